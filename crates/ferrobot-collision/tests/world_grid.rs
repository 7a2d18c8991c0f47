//! The world grid's distance bounds against parry's exact distances, and the
//! single-configuration path that uses the grid against the batch kernel,
//! which does not.

mod common;

use common::{assert_single_matches_batch, mbm_panda, shared, to_pose};

use ferrobot_collision::world_grid::WorldGrid;
use ferrobot_collision::{CollisionChecker, CollisionWorld, Shape};
use nalgebra::Isometry3;
use parry3d::math::Vector;
use parry3d::query::distance;
use parry3d::shape::{Ball, Capsule, Cuboid, Cylinder, Shape as ParryShape};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Parry's shape of a primitive (all the MotionBenchMaker scenes use).
fn parry_shape(shape: &Shape) -> Box<dyn ParryShape> {
    match shape {
        Shape::Box { half_extents: h } => {
            Box::new(Cuboid::new(Vector::new(h.x as f32, h.y as f32, h.z as f32)))
        }
        Shape::Sphere { radius } => Box::new(Ball::new(*radius as f32)),
        Shape::Cylinder {
            radius,
            half_height,
        } => {
            // parry's cylinders run along y, ferrobot's along z.
            Box::new(Cylinder::new(*half_height as f32, *radius as f32))
        }
        Shape::Capsule {
            radius,
            half_height,
        } => Box::new(Capsule::new_z(*half_height as f32, *radius as f32)),
        other => panic!("no parry shape for {other:?} in this test"),
    }
}

#[test]
fn grid_bounds_never_exceed_exact_distances() {
    let (model, spheres, acm) = mbm_panda();
    let y_to_z = Isometry3::rotation(nalgebra::Vector3::x() * std::f64::consts::FRAC_PI_2);
    let mut rng = StdRng::seed_from_u64(8);
    let mut positive = 0;
    for scene in [
        "bench/mbm/table_pick_panda/scene0004.yaml",
        "bench/mbm/bookshelf_small_panda/scene0007.yaml",
    ] {
        let world = CollisionWorld::from_moveit_scene(shared(scene)).unwrap();
        let parts: Vec<(Box<dyn ParryShape>, Isometry3<f64>)> = world
            .objects()
            .iter()
            .flat_map(|o| {
                o.parts.iter().map(move |(s, local)| {
                    let pose = o.pose * local;
                    let pose = match s {
                        Shape::Cylinder { .. } => pose * y_to_z,
                        _ => pose,
                    };
                    (parry_shape(s), pose)
                })
            })
            .collect();
        let checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        let (robot, compiled) = checker.compiled();
        let grid = WorldGrid::for_robot(robot, compiled).expect("a grid");
        let point = Ball::new(1e-6);
        for _ in 0..20_000 {
            let p = [
                rng.random_range(-1.3..1.3f32),
                rng.random_range(-1.3..1.3f32),
                rng.random_range(-0.9..1.6f32),
            ];
            let bound = grid.clearance(compiled, &p);
            let at = Isometry3::translation(p[0] as f64, p[1] as f64, p[2] as f64);
            let exact = parts
                .iter()
                .map(|(s, pose)| {
                    distance(&to_pose(&at), &point, &to_pose(pose), s.as_ref())
                        .unwrap()
                        .distance
                })
                .fold(f32::INFINITY, f32::min);
            assert!(
                bound <= exact + 1e-5,
                "{scene} at {p:?}: bound {bound} > exact {exact}"
            );
            if bound > 0.0 {
                positive += 1;
                // Not vacuous: within a cell's diagonal and two quanta of the
                // truth (bounds are stored up to about 1 m).
                assert!(
                    bound > 1.0 || exact - bound < 0.05 * 3f32.sqrt() + 0.009,
                    "{p:?}: {bound} {exact}"
                );
            }
        }
    }
    assert!(positive > 10_000, "{positive}");
}

#[test]
fn single_path_with_grid_agrees_with_batch_kernel_in_every_dev_scene_kind() {
    for (scene, margin) in [
        ("bench/mbm/table_pick_panda/scene0009.yaml", 0.0),
        ("bench/mbm/bookshelf_small_panda/scene0010.yaml", 0.03),
    ] {
        // Twice: with the grid being made and its cells filled, then filled.
        let (checker, batch) = assert_single_matches_batch(scene, margin, 12, 4000, 2);
        assert!(checker.has_world_grid(), "{scene}: the grid was never made");
        assert!(batch.iter().filter(|&&b| b).count() > 200);
    }
}
