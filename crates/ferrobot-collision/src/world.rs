//! The collision world: named objects, each one or more shapes posed in the
//! object's frame, the object posed in the world (robot base) frame.

use std::collections::HashMap;

use nalgebra::{Isometry3, Point3, Vector3};

use crate::error::{CollisionError, Result};
use ferrobot_geometry::Shape;

/// One named object of the world.
#[derive(Debug, Clone)]
pub struct WorldObject {
    /// Unique name.
    pub name: String,
    /// Pose of the object frame in the world frame.
    pub pose: Isometry3<f64>,
    /// Shapes and their poses in the object frame.
    pub parts: Vec<(Shape, Isometry3<f64>)>,
}

/// A set of named obstacles.
#[derive(Debug, Clone, Default)]
pub struct CollisionWorld {
    objects: Vec<WorldObject>,
    index: HashMap<String, usize>,
    revision: u64,
}

fn check_pose(what: &str, pose: &Isometry3<f64>) -> Result<()> {
    use ferrobot_model::ranges::COORDINATE;
    let finite = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if !finite {
        return Err(CollisionError::InvalidShape(format!(
            "{what}: pose is not finite"
        )));
    }
    for v in pose.translation.vector.iter() {
        COORDINATE.check_as(&format!("{what}: position"), *v)?;
    }
    Ok(())
}

/// Checks a shape's parameters: sizes (and radii, lengths) in
/// [`ferrobot_model::ranges::SHAPE_SIZE`] (positive, finite, at most 10 km:
/// the kernels compute in float32), then [`Shape::validate`], and builds a
/// mesh's BVH now, so that a mesh parry rejects is an error when it is added
/// rather than an obstacle that is never hit.
pub fn check_shape(what: &str, shape: &Shape) -> Result<()> {
    use ferrobot_model::ranges::SHAPE_SIZE;
    let positive = |name: &str, v: f64| -> Result<()> {
        if (SHAPE_SIZE.min..=SHAPE_SIZE.max).contains(&v) {
            Ok(())
        } else {
            Err(CollisionError::InvalidShape(format!(
                "{what}: {name} must be positive and finite, in [{:e}, {:e}] m, got {v}",
                SHAPE_SIZE.min, SHAPE_SIZE.max
            )))
        }
    };
    match shape {
        Shape::Box { half_extents } => half_extents
            .iter()
            .try_for_each(|&h| positive("box size", 2.0 * h))?,
        Shape::Sphere { radius } => positive("sphere radius", *radius)?,
        Shape::Cylinder {
            radius,
            half_height,
        } => {
            positive("cylinder radius", *radius)?;
            positive("cylinder length", 2.0 * half_height)?;
        }
        Shape::Capsule {
            radius,
            half_height,
        } => {
            positive("capsule radius", *radius)?;
            if *half_height != 0.0 {
                positive("capsule length", 2.0 * half_height)?;
            }
        }
        _ => {}
    }
    shape.validate(what)?;
    if let Shape::Mesh(m) | Shape::ConvexDecomposition(m) = shape {
        m.query_ready()
            .map_err(|e| CollisionError::InvalidShape(format!("{what}: {e}")))?;
    }
    Ok(())
}

impl CollisionWorld {
    /// An empty world.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an object made of `parts` at `pose`; the name must be new.
    pub fn add(
        &mut self,
        name: &str,
        pose: Isometry3<f64>,
        parts: Vec<(Shape, Isometry3<f64>)>,
    ) -> Result<()> {
        if self.index.contains_key(name) {
            return Err(CollisionError::Duplicate(format!(
                "world object '{name}' exists already; remove it first or use set_pose"
            )));
        }
        if parts.is_empty() {
            return Err(CollisionError::InvalidShape(format!(
                "world object '{name}': no shapes"
            )));
        }
        check_pose(&format!("world object '{name}'"), &pose)?;
        for (k, (shape, local)) in parts.iter().enumerate() {
            let what = format!("world object '{name}' shape {k} ({})", shape.kind());
            check_shape(&what, shape)?;
            check_pose(&what, local)?;
        }
        self.index.insert(name.to_string(), self.objects.len());
        self.objects.push(WorldObject {
            name: name.to_string(),
            pose,
            parts,
        });
        self.revision += 1;
        Ok(())
    }

    /// Adds a single shape at `pose`.
    pub fn add_shape(&mut self, name: &str, shape: Shape, pose: Isometry3<f64>) -> Result<()> {
        self.add(name, pose, vec![(shape, Isometry3::identity())])
    }

    /// Removes and returns the object `name`.
    pub fn remove(&mut self, name: &str) -> Result<WorldObject> {
        let i = self.position(name)?;
        let obj = self.objects.remove(i);
        self.reindex();
        self.revision += 1;
        Ok(obj)
    }

    /// Moves object `name` to `pose`.
    pub fn set_pose(&mut self, name: &str, pose: Isometry3<f64>) -> Result<()> {
        check_pose(&format!("world object '{name}'"), &pose)?;
        let i = self.position(name)?;
        self.objects[i].pose = pose;
        self.revision += 1;
        Ok(())
    }

    /// The object `name`.
    pub fn get(&self, name: &str) -> Result<&WorldObject> {
        Ok(&self.objects[self.position(name)?])
    }

    /// Whether an object `name` exists.
    pub fn contains(&self, name: &str) -> bool {
        self.index.contains_key(name)
    }

    /// All objects, in insertion order.
    pub fn objects(&self) -> &[WorldObject] {
        &self.objects
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether there are no objects.
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Increases on every change (for caches of compiled worlds).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Removes every object.
    pub fn clear(&mut self) {
        self.objects.clear();
        self.index.clear();
        self.revision += 1;
    }

    /// Signed distance from world point `p` to the nearest object, the
    /// direction it grows fastest and the object's index (None if empty).
    pub fn signed_distance(&self, p: &Point3<f64>) -> Option<(f64, Vector3<f64>, usize)> {
        self.signed_distance_where(p, |_| true)
    }

    /// [`CollisionWorld::signed_distance`] over the objects for which
    /// `enabled(object index)` holds.
    pub fn signed_distance_where(
        &self,
        p: &Point3<f64>,
        enabled: impl Fn(usize) -> bool,
    ) -> Option<(f64, Vector3<f64>, usize)> {
        let mut best: Option<(f64, Vector3<f64>, usize)> = None;
        for (i, obj) in self.objects.iter().enumerate() {
            if !enabled(i) {
                continue;
            }
            for (shape, local) in &obj.parts {
                let pose = obj.pose * local;
                let lp = pose.inverse_transform_point(p);
                let (d, g) = shape.signed_distance(&lp);
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, pose.rotation * g, i));
                }
            }
        }
        best
    }

    fn position(&self, name: &str) -> Result<usize> {
        self.index.get(name).copied().ok_or_else(|| {
            let known: Vec<&str> = self
                .objects
                .iter()
                .take(12)
                .map(|o| o.name.as_str())
                .collect();
            CollisionError::Name(format!(
                "unknown world object '{name}'; known: {}",
                known.join(", ")
            ))
        })
    }

    fn reindex(&mut self) {
        self.index = self
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| (o.name.clone(), i))
            .collect();
    }
}
