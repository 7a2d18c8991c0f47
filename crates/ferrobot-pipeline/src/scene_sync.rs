//! Scene sync: the planner's collision world built from a simulated world.
//!
//! As cuRobo's `get_obstacles_from_stage(ignore_substring=...)` does for an
//! Isaac Sim stage: every object of the simulation becomes an obstacle at its
//! current pose, expressed in the robot base frame, except objects whose
//! name contains one of the ignore substrings (the target being grasped, the
//! robot's own attachments). Robots are never obstacles (the planner models
//! its own robot). The ground plane becomes a thin slab under z = 0.

use ferrobot_collision::{CollisionError, CollisionWorld, Shape};
use ferrobot_sim::World;
use nalgebra::{Isometry3, Translation3, Vector3};

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
            Shape::Box {
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
        // The simulator's shape is the obstacle (one vocabulary): meshes and
        // hulls are shared, their BVH built once across syncs.
        out.add_shape(name, obj.desc.shape.clone(), to_base * world.object_pose(i))
            .map_err(|e| match e {
                CollisionError::InvalidShape(m) => {
                    CollisionError::InvalidShape(format!("simulated object '{name}': {m}"))
                }
                other => other,
            })?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ferrobot_sim::{ObjectDesc, WorldConfig};
    use nalgebra::{Point3, UnitQuaternion};

    fn names(w: &CollisionWorld) -> Vec<&str> {
        w.objects().iter().map(|o| o.name.as_str()).collect()
    }

    fn world() -> World {
        let mut w = World::new(WorldConfig::default()).unwrap();
        let mut table = ObjectDesc::new(
            "table",
            Shape::Box {
                half_extents: Vector3::new(0.4, 0.6, 0.2),
            },
            Isometry3::translation(0.6, 0.0, 0.2),
        );
        table.is_static = true;
        w.add_object(table).unwrap();
        let can = ObjectDesc::new(
            "target_can",
            Shape::Cylinder {
                radius: 0.03,
                half_height: 0.06,
            },
            Isometry3::translation(0.5, 0.1, 0.46),
        );
        w.add_object(can).unwrap();
        let hull = ObjectDesc::new(
            "rock",
            Shape::ConvexHull(std::sync::Arc::new(
                ferrobot_geometry::Hull::new(vec![
                    Point3::new(0.0, 0.0, 0.0),
                    Point3::new(0.05, 0.0, 0.0),
                    Point3::new(0.0, 0.05, 0.0),
                    Point3::new(0.0, 0.0, 0.05),
                ])
                .unwrap(),
            )),
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
