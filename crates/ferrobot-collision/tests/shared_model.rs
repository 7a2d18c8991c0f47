//! Several scenes over one shared robot collision model: the robot's
//! compiled data is not copied, and each scene answers as a checker built
//! on its own would.

mod common;

use std::sync::Arc;

use common::{mbm_panda, random_q, shared};
use ferrobot_collision::{CollisionChecker, CollisionWorld, RobotCollisionModel, Shape};
use nalgebra::Isometry3;
use rand::{SeedableRng, rngs::StdRng};

#[test]
fn scenes_share_one_robot_model_and_answer_like_separate_checkers() {
    let (model, spheres, acm) = mbm_panda();
    let robot =
        Arc::new(RobotCollisionModel::new(model.clone(), spheres.clone(), acm.clone()).unwrap());
    let worlds: Vec<CollisionWorld> = [
        "bench/mbm/table_pick_panda/scene0003.yaml",
        "bench/mbm/bookshelf_small_panda/scene0005.yaml",
    ]
    .iter()
    .map(|s| CollisionWorld::from_moveit_scene(shared(s)).unwrap())
    .collect();
    let mut scenes: Vec<CollisionChecker> = worlds
        .iter()
        .map(|w| CollisionChecker::with_model(robot.clone(), w.clone()))
        .collect();
    // One compiled robot for both scenes (no copy).
    assert!(std::ptr::eq(scenes[0].compiled().0, scenes[1].compiled().0));
    assert!(Arc::ptr_eq(
        scenes[0].robot_model(),
        scenes[1].robot_model()
    ));
    // An attachment in one scene leaves the other (and the shared model) as is.
    scenes[1]
        .attach(
            "tool",
            "panda_hand",
            Isometry3::translation(0.0, 0.0, 0.2),
            vec![(
                Shape::Box {
                    half_extents: nalgebra::Vector3::new(0.02, 0.02, 0.03),
                },
                Isometry3::identity(),
            )],
            &["panda_hand", "panda_leftfinger", "panda_rightfinger"],
        )
        .unwrap();
    assert!(!std::ptr::eq(
        scenes[0].compiled().0,
        scenes[1].compiled().0
    ));
    assert_eq!(scenes[0].attached().len(), 0);
    let mut rng = StdRng::seed_from_u64(5);
    let qs: Vec<Vec<f64>> = (0..2000).map(|_| random_q(&model, &mut rng)).collect();
    for (k, w) in worlds.iter().enumerate() {
        let mut alone =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), w.clone()).unwrap();
        if k == 1 {
            let parts = scenes[1].attached()[0].parts.clone();
            alone
                .attach(
                    "tool",
                    "panda_hand",
                    Isometry3::translation(0.0, 0.0, 0.2),
                    parts,
                    &["panda_hand", "panda_leftfinger", "panda_rightfinger"],
                )
                .unwrap();
        }
        let flat = qs.concat();
        let expected = alone.in_collision_batch(&flat).unwrap();
        let hits = expected.iter().filter(|&&b| b).count();
        assert!(
            hits > 0 && hits < expected.len(),
            "scene {k}: {hits} colliding"
        );
        assert_eq!(scenes[k].in_collision_batch(&flat).unwrap(), expected);
        let single: Vec<bool> = qs
            .iter()
            .map(|q| scenes[k].in_collision(q).unwrap())
            .collect();
        assert_eq!(single, expected);
    }
}
