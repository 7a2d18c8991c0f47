//! Scene sync: the planner's collision world built from a simulated world.
//!
//! As cuRobo's `get_obstacles_from_stage(ignore_substring=...)` does for an
//! Isaac Sim stage: every object of the simulation becomes an obstacle at its
//! current pose, expressed in the robot base frame, except objects whose
//! name contains one of the ignore substrings (the target being grasped, the
//! robot's own attachments). Robots are never obstacles (the planner models
//! its own robot). The ground plane becomes a thin slab under z = 0.

use ferrobot_collision::{CollisionError, CollisionWorld, MeshShape, ObstacleShape};
use ferrobot_sim::{ObjectShape, World};
use nalgebra::{Isometry3, Point3, Translation3, Vector3};
use parry3d::math::Vector as PVec;

/// Name of the obstacle standing for the simulation's ground plane.
pub const GROUND: &str = "ground";

/// Half-extents (m) of the slab standing for the ground plane; its top face is z = 0.
pub const GROUND_HALF_EXTENTS: [f64; 3] = [5.0, 5.0, 0.05];

/// What to take from the simulated world.
#[derive(Debug, Clone)]
pub struct SyncOptions {
    /// Objects whose name contains any of these substrings are left out
    /// (the ground's name is [`GROUND`]).
    pub ignore: Vec<String>,
    /// Pose of the robot base in the simulated world: obstacles are
    /// expressed in this frame, the planner's.
    pub base: Isometry3<f64>,
}

impl Default for SyncOptions {
    fn default() -> Self {
        Self {
            ignore: Vec::new(),
            base: Isometry3::identity(),
        }
    }
}

impl SyncOptions {
    /// Whether `name` is left out.
    pub fn ignores(&self, name: &str) -> bool {
        self.ignore
            .iter()
            .any(|s| !s.is_empty() && name.contains(s.as_str()))
    }
}

/// The obstacle for a simulated object's shape.
fn obstacle(name: &str, shape: &ObjectShape) -> Result<ObstacleShape, CollisionError> {
    Ok(match shape {
        ObjectShape::Box { half_extents } => ObstacleShape::Box {
            half_extents: *half_extents,
        },
        ObjectShape::Sphere { radius } => ObstacleShape::Sphere { radius: *radius },
        ObjectShape::Cylinder { radius, length } => ObstacleShape::Cylinder {
            radius: *radius,
            half_length: length / 2.0,
        },
        ObjectShape::Capsule { radius, length } => ObstacleShape::Capsule {
            radius: *radius,
            half_length: length / 2.0,
        },
        ObjectShape::ConvexHull { points } => {
            let pts: Vec<PVec> = points
                .iter()
                .map(|p| PVec::new(p.x as f32, p.y as f32, p.z as f32))
                .collect();
            let (v, t) = parry3d::transformation::convex_hull(&pts);
            let v: Vec<Point3<f64>> = v
                .iter()
                .map(|p| Point3::new(p.x as f64, p.y as f64, p.z as f64))
                .collect();
            mesh(name, &v, &t)?
        }
        ObjectShape::ConvexDecomposition {
            vertices,
            triangles,
        }
        | ObjectShape::TriMesh {
            vertices,
            triangles,
        } => mesh(name, vertices, triangles)?,
    })
}

fn mesh(
    name: &str,
    vertices: &[Point3<f64>],
    triangles: &[[u32; 3]],
) -> Result<ObstacleShape, CollisionError> {
    MeshShape::new(vertices, triangles)
        .map(|m| ObstacleShape::Mesh(std::sync::Arc::new(m)))
        .map_err(|e| CollisionError::InvalidShape(format!("simulated object '{name}': {e}")))
}

/// The collision world of `world`'s objects at their current poses, in the
/// frame of `options.base`, without the ignored ones.
pub fn collision_world_from_sim(
    world: &World,
    options: &SyncOptions,
) -> Result<CollisionWorld, CollisionError> {
    let to_base = options.base.inverse();
    let mut out = CollisionWorld::new();
    if world.config().ground && !options.ignores(GROUND) {
        let [x, y, z] = GROUND_HALF_EXTENTS;
        let slab = Isometry3::from_parts(Translation3::new(0.0, 0.0, -z), Default::default());
        out.add_shape(
            GROUND,
            ObstacleShape::Box {
                half_extents: Vector3::new(x, y, z),
            },
            to_base * slab,
        )?;
    }
    for (i, obj) in world.objects().iter().enumerate() {
        let name = &obj.desc.name;
        if options.ignores(name) {
            continue;
        }
        let shape = obstacle(name, &obj.desc.shape)?;
        out.add_shape(name, shape, to_base * world.object_pose(i))?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ferrobot_sim::{ObjectDesc, WorldConfig};
    use nalgebra::UnitQuaternion;

    fn names(w: &CollisionWorld) -> Vec<&str> {
        w.objects().iter().map(|o| o.name.as_str()).collect()
    }

    fn world() -> World {
        let mut w = World::new(WorldConfig::default()).unwrap();
        let mut table = ObjectDesc::new(
            "table",
            ObjectShape::Box {
                half_extents: Vector3::new(0.4, 0.6, 0.2),
            },
            Isometry3::translation(0.6, 0.0, 0.2),
        );
        table.is_static = true;
        w.add_object(table).unwrap();
        let can = ObjectDesc::new(
            "target_can",
            ObjectShape::Cylinder {
                radius: 0.03,
                length: 0.12,
            },
            Isometry3::translation(0.5, 0.1, 0.46),
        );
        w.add_object(can).unwrap();
        let hull = ObjectDesc::new(
            "rock",
            ObjectShape::ConvexHull {
                points: vec![
                    Point3::new(0.0, 0.0, 0.0),
                    Point3::new(0.05, 0.0, 0.0),
                    Point3::new(0.0, 0.05, 0.0),
                    Point3::new(0.0, 0.0, 0.05),
                ],
            },
            Isometry3::translation(0.7, -0.2, 0.4),
        );
        w.add_object(hull).unwrap();
        w
    }

    #[test]
    fn objects_become_obstacles_in_the_base_frame() {
        let w = world();
        let base = Isometry3::from_parts(
            Translation3::new(0.1, -0.2, 0.0),
            UnitQuaternion::from_euler_angles(0.0, 0.0, 0.5),
        );
        let cw = collision_world_from_sim(
            &w,
            &SyncOptions {
                ignore: vec![],
                base,
            },
        )
        .unwrap();
        assert_eq!(names(&cw), vec!["ground", "table", "target_can", "rock"]);
        // A point 1 cm above the table top, known in the world frame, is 1 cm
        // from the table obstacle in the base frame.
        let p_world = Point3::new(0.6, 0.0, 0.41);
        let p_base = base.inverse() * p_world;
        let d = cw.signed_distance(&p_base).unwrap().0;
        assert!((d - 0.01).abs() < 1e-6, "{d}");
        // Inside the can's axis, 1 cm below its top: -1 cm (within its radius 3 cm).
        let inside = base.inverse() * Point3::new(0.5, 0.1, 0.51);
        assert!((cw.signed_distance(&inside).unwrap().0 + 0.01).abs() < 1e-6);
        // Under the ground, away from everything: negative.
        let below = base.inverse() * Point3::new(-2.0, 2.0, -0.01);
        assert!((cw.signed_distance(&below).unwrap().0 + 0.01).abs() < 1e-6);
    }

    #[test]
    fn ignore_substrings_and_moved_objects() {
        let mut w = world();
        let opts = SyncOptions {
            ignore: vec!["target".into(), GROUND.into(), String::new()],
            base: Isometry3::identity(),
        };
        let i = w.object_index("rock").unwrap();
        w.set_object_pose(i, &Isometry3::translation(0.0, 1.0, 0.5))
            .unwrap();
        let cw = collision_world_from_sim(&w, &opts).unwrap();
        assert_eq!(names(&cw), vec!["table", "rock"]);
        let pose = cw.get("rock").unwrap().pose;
        assert!((pose.translation.vector - Vector3::new(0.0, 1.0, 0.5)).norm() < 1e-6);
        // The hull's vertex (0.05, 0, 0) is on its surface.
        let d = cw.signed_distance(&Point3::new(0.05, 1.0, 0.5)).unwrap().0;
        assert!(d.abs() < 1e-6, "{d}");
    }
}
