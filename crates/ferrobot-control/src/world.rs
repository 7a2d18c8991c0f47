//! The world as a controller sees it: the collision world's shapes posed in
//! the base frame, each object's velocity (for obstacles that move), and
//! optionally a voxelised distance field per shape.

use std::sync::Arc;

use ferrobot_collision::{CollisionWorld, Shape};
use nalgebra::{Isometry3, Point3, Vector3};

use crate::error::{ControlError, Result, check_finite};
use crate::field::VoxelField;

/// One shape of a world object, posed in the base frame.
#[derive(Debug, Clone)]
pub struct Part {
    /// Index of its object in the world.
    pub object: usize,
    /// The shape.
    pub shape: Shape,
    /// Pose of the shape in the object frame.
    pub local: Isometry3<f64>,
    /// Pose of the shape in the base frame.
    pub pose: Isometry3<f64>,
    /// Radius of a ball about the shape origin holding the shape.
    pub bound: f64,
    /// Its voxelised distance field (in the shape frame), when built.
    pub field: Option<Arc<VoxelField>>,
}

/// The obstacles of a controller.
#[derive(Debug, Clone, Default)]
pub struct ControlWorld {
    world: CollisionWorld,
    parts: Vec<Part>,
    /// Per object: linear velocity of its frame origin (m/s) and angular
    /// velocity (rad/s), base frame.
    velocities: Vec<(Vector3<f64>, Vector3<f64>)>,
}

impl ControlWorld {
    /// The shapes of `world`, all at rest.
    pub fn new(world: CollisionWorld) -> Self {
        let mut parts = Vec::new();
        for (i, obj) in world.objects().iter().enumerate() {
            for (shape, local) in &obj.parts {
                parts.push(Part {
                    object: i,
                    shape: shape.clone(),
                    local: *local,
                    pose: obj.pose * local,
                    bound: shape.bounding_radius(),
                    field: None,
                });
            }
        }
        let velocities = vec![(Vector3::zeros(), Vector3::zeros()); world.len()];
        Self {
            world,
            parts,
            velocities,
        }
    }

    /// Builds a voxel field per shape (in the shape's frame, so moving an
    /// object keeps its field valid).
    pub fn build_fields(&mut self, resolution: f64, padding: f64) -> Result<()> {
        for part in &mut self.parts {
            part.field = Some(Arc::new(VoxelField::build(
                &part.shape,
                resolution,
                padding,
            )?));
        }
        Ok(())
    }

    /// The collision world (object poses kept current).
    pub fn world(&self) -> &CollisionWorld {
        &self.world
    }

    /// The posed shapes.
    pub fn parts(&self) -> &[Part] {
        &self.parts
    }

    /// Moves object `name` to `pose` with `velocity` (linear m/s, then
    /// angular rad/s, base frame; `None`: at rest). Fields are not rebuilt:
    /// they live in the shape frames.
    pub fn set_pose(
        &mut self,
        name: &str,
        pose: Isometry3<f64>,
        velocity: Option<[f64; 6]>,
    ) -> Result<()> {
        if let Some(v) = &velocity {
            check_finite("velocity", v)?;
        }
        self.world.set_pose(name, pose).map_err(|e| match e {
            ferrobot_collision::CollisionError::Name(m) => ControlError::UnknownName(m),
            other => other.into(),
        })?;
        let i = self
            .world
            .objects()
            .iter()
            .position(|o| o.name == name)
            .expect("object exists: set_pose succeeded");
        for part in self.parts.iter_mut().filter(|p| p.object == i) {
            part.pose = pose * part.local;
        }
        let v = velocity.unwrap_or([0.0; 6]);
        self.velocities[i] = (
            Vector3::new(v[0], v[1], v[2]),
            Vector3::new(v[3], v[4], v[5]),
        );
        Ok(())
    }

    /// Velocity (m/s) of the point `p` (base frame) moving with `object`.
    #[inline]
    pub fn point_velocity(&self, object: usize, p: &Point3<f64>) -> Vector3<f64> {
        let (v, w) = &self.velocities[object];
        if w.x == 0.0 && w.y == 0.0 && w.z == 0.0 {
            return *v;
        }
        let o = self.world.objects()[object].pose.translation.vector;
        v + w.cross(&(p.coords - o))
    }

    /// Whether a ball at `c` of radius `r` may come within `reach` of `part`.
    #[inline]
    pub fn near(part: &Part, c: &Point3<f64>, r: f64, reach: f64) -> bool {
        let lim = part.bound + r + reach;
        (c.coords - part.pose.translation.vector).norm_squared() < lim * lim
    }

    /// Exact signed distance from `p` (base frame) to `part` and its
    /// gradient (unit, base frame).
    #[inline]
    pub fn exact_distance(part: &Part, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        let lp = part.pose.inverse_transform_point(p);
        let (d, g) = part.shape.signed_distance(&lp);
        (d, part.pose.rotation * g)
    }

    /// Signed distance from `p` to `part` read from its voxel field and the
    /// field's gradient (base frame), or `None` outside the field.
    #[inline]
    pub fn field_distance(part: &Part, p: &Point3<f64>) -> Option<(f64, Vector3<f64>)> {
        let field = part.field.as_ref()?;
        let lp = part.pose.inverse_transform_point(p);
        field.lookup(&lp).map(|(d, g)| (d, part.pose.rotation * g))
    }
}
