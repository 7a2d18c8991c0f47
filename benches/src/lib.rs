//! Fixtures shared by ferrobot's benchmarks (see `benches/benches` and
//! `benches/examples`): the MotionBenchMaker Panda from `../shared`, its
//! collision checker in a scene, random configurations, and the simulated
//! table scene.

pub mod scenes;

use std::path::PathBuf;
use std::sync::Arc;

use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
use ferrobot_sim::{ObjectDesc, RobotOptions, Shape, World, WorldConfig};
use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// A path inside `../shared` beside the checkout.
pub fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared")
        .join(rel)
}

/// The MotionBenchMaker Panda with its SRDF, end effector `panda_hand`.
pub fn mbm_panda() -> RobotModel {
    RobotModel::from_urdf_file(
        shared("robots/panda/panda.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("robots/panda/panda.srdf"))),
            ee_link: Some("panda_hand".into()),
            ..Default::default()
        },
    )
    .expect("load the shared Panda")
}

/// A checker for the MotionBenchMaker Panda (spherized model, 59 spheres)
/// in scene `scene` (a path below `bench/mbm`, e.g. `table_pick_panda/scene0001.yaml`).
pub fn mbm_checker(scene: &str) -> CollisionChecker {
    let model = mbm_panda();
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .expect("spherized Panda");
    let acm = AllowedCollisions::from_model(&model);
    let world =
        CollisionWorld::from_moveit_scene(shared(&format!("bench/mbm/{scene}"))).expect("scene");
    CollisionChecker::new(Arc::new(model), spheres, acm, world).expect("checker")
}

/// `n` configurations uniform within the joint limits, row-major, seeded.
pub fn random_configurations(model: &RobotModel, n: usize, seed: u64) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (lo, hi) = (model.lower_limits(), model.upper_limits());
    (0..n)
        .flat_map(|_| {
            (0..lo.len())
                .map(|i| rng.random_range(lo[i]..hi[i]))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// A MotionBenchMaker problem: scene file (below `bench/mbm`) and the start
/// and goal configurations in `panda_joint1..7` order.
#[derive(Debug, Clone)]
pub struct MbmProblem {
    /// Scene path below `bench/mbm`.
    pub scene: String,
    /// Start configuration (7 arm joints).
    pub start: Vec<f64>,
    /// Goal configuration (7 arm joints).
    pub goal: Vec<f64>,
}

/// The problems of one MotionBenchMaker folder (e.g. `table_pick_panda`).
pub fn mbm_problems(folder: &str) -> Vec<MbmProblem> {
    let dir = shared(&format!("bench/mbm/{folder}"));
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .expect("problem folder")
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("request") && n.ends_with(".yaml"))
        .collect();
    names.sort();
    let arm = |name: &str| {
        name.strip_prefix("panda_joint")
            .and_then(|n| n.parse::<usize>().ok())
    };
    names
        .into_iter()
        .map(|n| {
            let text = std::fs::read_to_string(dir.join(&n)).expect("request");
            let v: serde_yaml::Value = serde_yaml::from_str(&text).expect("request yaml");
            let js = &v["start_state"]["joint_state"];
            let mut start = vec![0.0; 7];
            for (name, pos) in js["name"]
                .as_sequence()
                .unwrap()
                .iter()
                .zip(js["position"].as_sequence().unwrap())
            {
                if let Some(k) = arm(name.as_str().unwrap()) {
                    start[k - 1] = pos.as_f64().unwrap();
                }
            }
            let mut goal = vec![0.0; 7];
            for c in v["goal_constraints"][0]["joint_constraints"]
                .as_sequence()
                .unwrap()
            {
                if let Some(k) = arm(c["joint_name"].as_str().unwrap()) {
                    goal[k - 1] = c["position"].as_f64().unwrap();
                }
            }
            MbmProblem {
                scene: format!("{folder}/{}", n.replace("request", "scene")),
                start,
                goal,
            }
        })
        .collect()
}

/// Joint targets of the simulated Panda in [`sim_table_scene`] (7 arm
/// joints, then the finger).
pub const SIM_Q0: [f64; 8] = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];

/// The simulation benchmarks' scene, settled for one second: the bundled
/// Panda holding [`SIM_Q0`] with its position drives, and with `objects` a
/// static 0.8 x 1.2 x 0.4 m table with a 5 cm box, a can and a ball resting
/// on it.
pub fn sim_table_scene(objects: bool) -> World {
    let mut w = World::new(WorldConfig::default()).expect("world");
    let model = Arc::new(ferrobot_model::robots::panda().expect("bundled Panda"));
    let mut opts = RobotOptions::new("panda");
    opts.q = Some(SIM_Q0.to_vec());
    let r = w.add_robot(model, &opts).expect("robot");
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &SIM_Q0, None))
        .expect("targets");
    if objects {
        let mut add = |name: &str, shape, pose, is_static| {
            let mut d = ObjectDesc::new(name, shape, pose);
            d.is_static = is_static;
            w.add_object(d).expect("object");
        };
        add(
            "table",
            Shape::Box {
                half_extents: Vector3::new(0.4, 0.6, 0.2),
            },
            Isometry3::translation(0.6, 0.0, 0.2),
            true,
        );
        add(
            "box",
            Shape::Box {
                half_extents: Vector3::new(0.025, 0.025, 0.025),
            },
            Isometry3::translation(0.5, 0.0, 0.425),
            false,
        );
        add(
            "can",
            Shape::Cylinder {
                radius: 0.03,
                half_height: 0.06,
            },
            Isometry3::translation(0.6, 0.25, 0.46),
            false,
        );
        add(
            "ball",
            Shape::Sphere { radius: 0.04 },
            Isometry3::translation(0.7, -0.25, 0.44),
            false,
        );
    }
    w.step(240).expect("settle");
    w
}
