//! The lane kernel against an independent f64 reference (exact sphere to
//! primitive distances), and the batched/SIMD paths against the scalar path.

mod common;

use common::{mbm_panda, random_q, shared};

use ferrobot_collision::{CollisionChecker, CollisionWorld};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Reference: every sphere against every object part with exact f64
/// distances, and every checked pair of bodies.
fn reference(checker: &CollisionChecker, q: &[f64]) -> f64 {
    checker.distance(q).unwrap().distance
}

#[test]
fn scenes_parse_and_kernel_agrees_with_exact_reference() {
    let (model, spheres, acm) = mbm_panda();
    assert_eq!(spheres.count(), 59);
    let mut rng = StdRng::seed_from_u64(5);
    let mut checked = 0;
    let (mut hits, mut free) = (0, 0);
    for scene in ["table_pick_panda", "bookshelf_small_panda"] {
        for id in (1..=100).step_by(9) {
            let path = shared(&format!("bench/mbm/{scene}/scene{id:04}.yaml"));
            let world = CollisionWorld::from_moveit_scene(&path).unwrap();
            assert!(!world.is_empty(), "{}", path.display());
            let mut checker =
                CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
            // The reference measures spheres only, self pairs included.
            checker.set_exact_self_collision(false);
            for _ in 0..200 {
                let q = random_q(&model, &mut rng);
                let d = reference(&checker, &q);
                let got = checker.in_collision(&q).unwrap();
                // f32 kernel: only configurations within 0.1 mm of contact may differ.
                if d.abs() > 1e-4 {
                    assert_eq!(got, d < 0.0, "{scene} {id} q={q:?} d={d}");
                    checked += 1;
                }
                if got { hits += 1 } else { free += 1 }
            }
        }
    }
    assert!(
        checked > 4000 && hits > 200 && free > 200,
        "{checked} {hits} {free}"
    );
}

#[test]
fn batch_and_simd_agree_exactly_with_scalar() {
    let (model, spheres, acm) = mbm_panda();
    let world =
        CollisionWorld::from_moveit_scene(shared("bench/mbm/bookshelf_small_panda/scene0003.yaml"))
            .unwrap();
    let checker = CollisionChecker::new(model.clone(), spheres, acm, world).unwrap();
    let mut rng = StdRng::seed_from_u64(9);
    let n = 2003; // not a multiple of 8
    let qs: Vec<f64> = (0..n).flat_map(|_| random_q(&model, &mut rng)).collect();
    let batch = checker.in_collision_batch(&qs).unwrap();
    let scalar: Vec<bool> = qs
        .chunks(7)
        .map(|q| checker.in_collision(q).unwrap())
        .collect();
    assert_eq!(batch, scalar);
    assert!(batch.iter().any(|&b| b) && batch.iter().any(|&b| !b));
}

#[test]
fn motion_check_matches_dense_scalar_checks() {
    let (model, spheres, acm) = mbm_panda();
    let world =
        CollisionWorld::from_moveit_scene(shared("bench/mbm/table_pick_panda/scene0001.yaml"))
            .unwrap();
    let checker = CollisionChecker::new(model.clone(), spheres, acm, world).unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    let (mut valid, mut invalid) = (0, 0);
    for _ in 0..300 {
        let a = random_q(&model, &mut rng);
        let b: Vec<f64> = a.iter().map(|x| x + rng.random_range(-0.4..0.4)).collect();
        let res = 0.01;
        let got = checker.motion_valid(&a, &b, res).unwrap();
        let span = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (y - x).abs())
            .fold(0.0, f64::max);
        let steps = ((span / res).ceil() as usize).max(1);
        let dense = (0..=steps).all(|k| {
            let t = k as f64 / steps as f64;
            let q: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x + (y - x) * t).collect();
            !checker.in_collision(&q).unwrap()
        });
        assert_eq!(got, dense);
        if got { valid += 1 } else { invalid += 1 }
    }
    assert!(valid > 20 && invalid > 20, "{valid} {invalid}");
}

#[test]
fn column_kinematics_of_one_configuration_is_bit_identical() {
    use ferrobot_collision::compiled::CompiledRobot;
    use ferrobot_collision::kernel::{Scratch, forward, forward_one};
    use ferrobot_model::{LoadOptions, RobotModel, SrdfSource, robots};
    // The bundled Panda has a prismatic finger with a mimic twin; the
    // MotionBenchMaker one has joint frames turned by 90 degrees.
    let bundled = RobotModel::from_urdf_str(
        robots::PANDA_URDF,
        &LoadOptions {
            srdf: Some(SrdfSource::Text(robots::PANDA_SRDF.into())),
            ..Default::default()
        },
    )
    .unwrap();
    let (mbm, _, _) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(4);
    for model in [&bundled, mbm.as_ref()] {
        let robot = CompiledRobot::new(model, &[], &[], &[], |_, _| false);
        assert!(robot.steps.iter().any(|s| s.perm.is_some()));
        let (mut a, mut b) = (Scratch::<f32>::new(&robot), Scratch::<f32>::new(&robot));
        for _ in 0..500 {
            let q: Vec<f32> = random_q(model, &mut rng)
                .iter()
                .map(|&v| v as f32 * rng.random_range(0.5..2.0f32))
                .collect();
            forward(&robot, &q, &mut a);
            forward_one(&robot, &q, &mut b);
            for (fa, fb) in a.frames().iter().zip(b.frames()) {
                assert_eq!(fa.map(f32::to_bits), fb.map(f32::to_bits), "{q:?}");
            }
        }
    }
}
