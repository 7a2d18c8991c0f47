//! Fixtures shared by ferrobot's benchmarks (see `benches/benches` and
//! `benches/examples`): the MotionBenchMaker Panda from `../shared`, its
//! collision checker in a scene, and random configurations.

use std::path::PathBuf;
use std::sync::Arc;

use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
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
