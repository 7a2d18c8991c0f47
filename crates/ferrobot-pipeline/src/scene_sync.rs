//! Scene sync: the planner's collision world built from a simulated world.
//!
//! As cuRobo's `get_obstacles_from_stage(ignore_substring=...)` does for an
//! Isaac Sim stage: every object of the simulation becomes an obstacle at its
//! current pose, expressed in the robot base frame, except objects whose
//! name contains one of the ignore substrings (the target being grasped, the
//! robot's own attachments). Robots are never obstacles (the planner models
//! its own robot). The ground plane becomes a thin slab under z = 0.
//!
//! [`collision_world_from_sim`] builds a new world; [`SceneSync`] keeps a
//! planner's world in sync with a simulation across an episode instead:
//! poses are updated in place, objects added or removed as the scene
//! changes, hulls and meshes shared with the simulation (the one [`Shape`],
//! whose meshes and hulls are `Arc`s: nothing is converted or rebuilt), and
//! ignored objects are
//! switched off by name in the checker (MoveIt's allowed-collision entries
//! for world objects) rather than left out of a rebuilt world.

use std::collections::{BTreeSet, HashSet};
use std::sync::Arc;

use ferrobot_collision::{CollisionChecker, CollisionError, CollisionWorld, Shape};
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

/// Counters of a [`SceneSync`] (since it was made).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SyncStats {
    /// Syncs that found none of the scene's objects in the planner's world
    /// and built it from scratch (the first sync of an episode).
    pub full_builds: u64,
    /// Syncs that updated an existing world in place.
    pub incremental: u64,
    /// Objects added to the planner's world.
    pub added: u64,
    /// Objects removed from the planner's world.
    pub removed: u64,
    /// Objects moved in place.
    pub moved: u64,
}

/// Whether world object parts are exactly `shape` at the object's origin:
/// the same shared mesh or cloud, or a primitive of the same kind and sizes
/// (compared exactly: they come from the same simulated shape).
fn same_parts(parts: &[(Shape, Isometry3<f64>)], shape: &Shape) -> bool {
    let [(have, local)] = parts else {
        return false;
    };
    if *local != Isometry3::identity() {
        return false;
    }
    use Shape as S;
    match (have, shape) {
        (S::ConvexHull(a), S::ConvexHull(b)) => Arc::ptr_eq(a, b),
        (S::Mesh(a), S::Mesh(b)) | (S::ConvexDecomposition(a), S::ConvexDecomposition(b)) => {
            Arc::ptr_eq(a, b)
        }
        (S::PointCloud(a), S::PointCloud(b)) => Arc::ptr_eq(a, b),
        (S::Box { half_extents: a }, S::Box { half_extents: b }) => a == b,
        (S::Sphere { radius: a }, S::Sphere { radius: b }) => a == b,
        (
            S::Cylinder {
                radius: r,
                half_height: h,
            },
            S::Cylinder {
                radius: r2,
                half_height: h2,
            },
        )
        | (
            S::Capsule {
                radius: r,
                half_height: h,
            },
            S::Capsule {
                radius: r2,
                half_height: h2,
            },
        ) => r == r2 && h == h2,
        _ => false,
    }
}

/// Keeps a planner's collision world in sync with a simulated world.
///
/// Each [`SceneSync::sync`] makes the checker's world hold the
/// simulation's objects at their current poses (base frame), adding,
/// removing and moving objects in place; objects named by the ignore
/// substrings stay in the world but are switched off in the checker, and
/// objects attached to the robot stay out. Hulls and meshes are the
/// simulation's own (shared, never rebuilt). The
/// checker recompiles its world once per sync, and only when a pose, an
/// object or the ignored set changed.
#[derive(Debug, Clone, Default)]
pub struct SceneSync {
    stats: SyncStats,
}

impl SceneSync {
    /// A sync with zeroed counters.
    pub fn new() -> Self {
        Self::default()
    }

    /// Counters since this sync was made.
    pub fn stats(&self) -> SyncStats {
        self.stats
    }

    /// Makes `checker`'s world the simulation's objects (see the type's
    /// documentation). Returns whether the checker's world changed. On an
    /// error (an invalid simulated shape) the checker is left unchanged.
    pub fn sync(
        &mut self,
        world: &World,
        options: &SyncOptions,
        checker: &mut CollisionChecker,
    ) -> Result<bool, CollisionError> {
        let to_base = options.base.inverse();
        let attached: HashSet<&str> = checker.attached().iter().map(|a| a.name.as_str()).collect();
        // The scene as it should be: (name, obstacle, pose in the base frame).
        let mut wanted: Vec<(String, Shape, Isometry3<f64>)> = Vec::new();
        if world.config().ground && !attached.contains(GROUND) {
            let [x, y, z] = GROUND_HALF_EXTENTS;
            let slab = Isometry3::from_parts(Translation3::new(0.0, 0.0, -z), Default::default());
            wanted.push((
                GROUND.to_string(),
                Shape::Box {
                    half_extents: Vector3::new(x, y, z),
                },
                to_base * slab,
            ));
        }
        for (i, obj) in world.objects().iter().enumerate() {
            let name = &obj.desc.name;
            if attached.contains(name.as_str()) {
                continue;
            }
            // The simulator's shape is the obstacle: an `Arc` clone.
            wanted.push((
                name.clone(),
                obj.desc.shape.clone(),
                to_base * world.object_pose(i),
            ));
        }
        let disabled: BTreeSet<String> = wanted
            .iter()
            .filter(|(n, _, _)| options.ignores(n))
            .map(|(n, _, _)| n.clone())
            .collect();
        // Whether each wanted object is in the world already, as it is.
        let kept: Vec<bool> = wanted
            .iter()
            .map(|(n, s, _)| {
                checker
                    .world()
                    .get(n)
                    .is_ok_and(|o| same_parts(&o.parts, s))
            })
            .collect();
        let reused = kept.iter().filter(|&&k| k).count();
        if reused == 0 && !wanted.is_empty() {
            self.stats.full_builds += 1;
        } else {
            self.stats.incremental += 1;
        }
        let wanted_names: HashSet<String> = wanted.iter().map(|(n, _, _)| n.clone()).collect();
        let mut stats = self.stats;
        // Checked before any change, so an error leaves the world as it was.
        for (n, _, p) in &wanted {
            check_pose(n, p)?;
        }
        let (_, changed) = checker.sync_world(disabled, |w| {
            let stale: Vec<String> = w
                .objects()
                .iter()
                .map(|o| o.name.clone())
                .filter(|n| !wanted_names.contains(n))
                .collect();
            for n in stale {
                w.remove(&n)?;
                stats.removed += 1;
            }
            for ((name, shape, pose), kept) in wanted.into_iter().zip(kept) {
                match w.get(&name) {
                    Ok(o) if kept => {
                        if o.pose != pose {
                            w.set_pose(&name, pose)?;
                            stats.moved += 1;
                        }
                    }
                    Ok(_) => {
                        w.remove(&name)?;
                        w.add_shape(&name, shape, pose)?;
                        stats.removed += 1;
                        stats.added += 1;
                    }
                    Err(_) => {
                        w.add_shape(&name, shape, pose)?;
                        stats.added += 1;
                    }
                }
            }
            Ok(())
        })?;
        self.stats = stats;
        Ok(changed)
    }
}

/// Checks a pose is finite (as the world would when the object is placed).
fn check_pose(name: &str, pose: &Isometry3<f64>) -> Result<(), CollisionError> {
    let finite = pose.translation.vector.iter().all(|v| v.is_finite())
        && pose.rotation.coords.iter().all(|v| v.is_finite());
    if finite {
        Ok(())
    } else {
        Err(CollisionError::InvalidShape(format!(
            "simulated object '{name}': pose is not finite"
        )))
    }
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

    /// The bundled Panda's checker in an empty world.
    fn panda_checker() -> CollisionChecker {
        use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
        use ferrobot_collision::{AllowedCollisions, RobotSpheres};
        let model = std::sync::Arc::new(ferrobot_model::robots::panda().unwrap());
        let options = SpherizeOptions {
            total_budget: Some(59),
            ..Default::default()
        };
        let (links, _) = spherize_robot(&model, &options).unwrap();
        let spheres = RobotSpheres::new(&model, links).unwrap();
        let acm = AllowedCollisions::from_model(&model);
        CollisionChecker::new(model, spheres, acm, CollisionWorld::new()).unwrap()
    }

    #[test]
    fn sync_is_incremental_and_ignores_by_name() {
        let mut w = world();
        let mut checker = panda_checker();
        let q = checker.model().named_state("ready", None).unwrap();
        // A block around the robot's base: the robot collides with it.
        let block = ObjectDesc::new(
            "block",
            Shape::Box {
                half_extents: Vector3::new(0.1, 0.1, 0.1),
            },
            Isometry3::translation(0.0, 0.0, 0.1),
        );
        w.add_object(block).unwrap();
        let mut sync = SceneSync::new();
        let opts = SyncOptions {
            ignore: vec![GROUND.into()],
            base: Isometry3::identity(),
        };
        assert!(sync.sync(&w, &opts, &mut checker).unwrap());
        let s = sync.stats();
        assert_eq!((s.full_builds, s.incremental), (1, 0));
        assert_eq!(s.added, 5); // ground, table, can, rock, block
        assert!(checker.in_collision(&q).unwrap());
        assert!(!checker.is_object_enabled(GROUND).unwrap());
        // The same scene again: nothing changes, nothing is recompiled.
        assert!(!sync.sync(&w, &opts, &mut checker).unwrap());
        // The rock moves; the block is ignored by name: in place, the hull
        // reused, the block still in the world but out of every query.
        let i = w.object_index("rock").unwrap();
        w.set_object_pose(i, &Isometry3::translation(0.0, 1.0, 0.5))
            .unwrap();
        let ignore_block = SyncOptions {
            ignore: vec!["block".into(), GROUND.into()],
            base: Isometry3::identity(),
        };
        assert!(sync.sync(&w, &ignore_block, &mut checker).unwrap());
        let s = sync.stats();
        assert_eq!((s.full_builds, s.incremental), (1, 2));
        // The rock's hull in the planner's world is the simulation's own.
        let (Shape::ConvexHull(sim_hull), Shape::ConvexHull(world_hull)) = (
            &w.objects()[i].desc.shape,
            &checker.world().get("rock").unwrap().parts[0].0,
        ) else {
            panic!("the rock is a hull");
        };
        assert!(Arc::ptr_eq(sim_hull, world_hull));
        assert_eq!((s.added, s.removed, s.moved), (5, 0, 1));
        assert!(checker.world().contains("block"));
        assert!(!checker.is_object_enabled("block").unwrap());
        assert!(
            !checker.in_collision(&q).unwrap(),
            "{:?}",
            checker.contacts(&q)
        );
        assert!(checker.contacts(&q).unwrap().is_empty());
        assert!(!checker.enabled_world().contains("block"));
        // Hand derivation: the hull vertex (0.05, 0, 0) moved with the rock
        // to (0.05, 1.0, 0.5) lies on its surface.
        let d = checker
            .world()
            .signed_distance(&Point3::new(0.05, 1.0, 0.5))
            .unwrap()
            .0;
        assert!(d.abs() < 1e-6, "{d}");
        // Enabled again by name, without a sync.
        checker.set_object_enabled("block", true).unwrap();
        assert!(checker.in_collision(&q).unwrap());
        assert!(checker.set_object_enabled("nothing", false).is_err());
        // A replaced world is rebuilt once, then synced in place.
        checker.set_world(CollisionWorld::new());
        sync.sync(&w, &opts, &mut checker).unwrap();
        sync.sync(&w, &opts, &mut checker).unwrap();
        let s = sync.stats();
        assert_eq!((s.full_builds, s.incremental), (2, 3));
        // A sync without "block" among the ignored enables it again.
        assert!(!checker.disabled_objects().any(|n| n == "block"));
        assert!(checker.in_collision(&q).unwrap());
        // Attached objects stay out of the synced world. The links that may
        // touch a held object by default: the hand and what hangs from it
        // in the URDF (its two fingers and the TCP frame).
        let hand = checker.model().link("panda_hand").unwrap();
        let mut touch = checker.default_touch_links(hand);
        touch.sort();
        assert_eq!(
            touch,
            [
                "panda_hand",
                "panda_hand_tcp",
                "panda_leftfinger",
                "panda_rightfinger"
            ]
        );
        let touch: Vec<&str> = touch.iter().map(String::as_str).collect();
        checker
            .attach_world_object("target_can", "panda_hand", &q, &touch)
            .unwrap();
        sync.sync(&w, &opts, &mut checker).unwrap();
        assert!(!checker.world().contains("target_can"));
        assert_eq!(sync.stats().removed, 0);
    }
}
