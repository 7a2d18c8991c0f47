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

/// Every part of `world`'s objects as a parry shape at its world pose.
fn parry_parts(world: &CollisionWorld) -> Vec<(Box<dyn ParryShape>, Isometry3<f64>)> {
    let y_to_z = Isometry3::rotation(nalgebra::Vector3::x() * std::f64::consts::FRAC_PI_2);
    world
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
        .collect()
}

/// parry's distance from point `p` to each of `parts`.
fn parry_distances(parts: &[(Box<dyn ParryShape>, Isometry3<f64>)], p: &[f32; 3]) -> Vec<f32> {
    let point = Ball::new(1e-6);
    let at = Isometry3::translation(p[0] as f64, p[1] as f64, p[2] as f64);
    parts
        .iter()
        .map(|(s, pose)| {
            distance(&to_pose(&at), &point, &to_pose(pose), s.as_ref())
                .unwrap()
                .distance
        })
        .collect()
}

#[test]
fn grid_bounds_never_exceed_exact_distances() {
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(8);
    let mut positive = 0;
    for scene in [
        "bench/mbm/table_pick_panda/scene0004.yaml",
        "bench/mbm/bookshelf_small_panda/scene0007.yaml",
    ] {
        let world = CollisionWorld::from_moveit_scene(shared(scene)).unwrap();
        let parts = parry_parts(&world);
        let checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        let (robot, compiled) = checker.compiled();
        let grid = WorldGrid::for_robot(robot, compiled, 0.0).expect("a grid");
        for _ in 0..20_000 {
            let p = [
                rng.random_range(-1.3..1.3f32),
                rng.random_range(-1.3..1.3f32),
                rng.random_range(-0.9..1.6f32),
            ];
            let bound = grid.clearance(compiled, &p);
            let dists = parry_distances(&parts, &p);
            let exact = dists.iter().copied().fold(f32::INFINITY, f32::min);
            // Every obstacle within the lists' reach of `p` is a candidate
            // of `p`'s cell (one part per obstacle in these scenes), and
            // within the list's cut-off for a body of that reach at `p`
            // (so the early exit at the first farther entry never skips it);
            // also for a small body (reach 3 cm).
            if let Some(cell) = grid.list_cell(&p) {
                // The kernels' cell lookup gives the same cell and the
                // centre the lists were made from, bit for bit.
                let (at, centre) = grid.list_cell_centre(&p).unwrap();
                assert_eq!(at, cell);
                assert_eq!(
                    centre.map(f32::to_bits),
                    grid.list_centre(cell).map(f32::to_bits)
                );
                let list = grid.candidates(compiled, cell);
                assert!(list.windows(2).all(|w| w[0].distance <= w[1].distance));
                for reach in [grid.list_reach(), 0.03] {
                    let limit = grid.list_limit(cell, &p, reach);
                    for (oi, &d) in dists.iter().enumerate() {
                        if d < reach {
                            let c = list.iter().find(|c| c.obstacle == oi as u32);
                            assert!(
                                c.is_some_and(|c| c.distance <= limit),
                                "{scene} at {p:?}: obstacle {oi} at {d} m missing or cut ({c:?}, limit {limit})"
                            );
                        }
                    }
                }
            }
            assert!(
                bound <= exact + 1e-5,
                "{scene} at {p:?}: bound {bound} > exact {exact}"
            );
            if bound > 0.0 {
                positive += 1;
                // Not vacuous: within a cell's diagonal and two quanta of the
                // truth, or of the lists' reach where the truth is farther
                // (bounds are made from the candidate lists, so they stop
                // there; the kernels need no more).
                assert!(
                    exact.min(grid.list_reach()) - bound < 0.05 * 3f32.sqrt() + 0.009,
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

/// A cage of many small boxes around the arm's workspace plus clutter inside
/// it (hundreds of obstacles, many close to the arm).
fn cage_world(seed: u64, n: usize) -> CollisionWorld {
    common::scattered_world(seed, n, 0.9, -0.2..1.2, 0.01..0.06, 4)
}

#[test]
fn point_bounds_hold_near_obstacles_in_crowded_worlds() {
    // A cell stores its bound at its centre; a lookup deducts the point's
    // offset from the centre. Points drawn close to obstacles of crowded
    // worlds of rotated boxes, spheres, cylinders and capsules (where a
    // bound that is too large would hide a contact), against parry's exact
    // distances.
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(2311);
    let half_diagonal = 0.5 * 0.05 * 3f32.sqrt();
    for (seed, n, margin) in [(11, 250, 0.0), (12, 500, 0.02)] {
        let world = cage_world(seed, n);
        let parts = parry_parts(&world);
        let centres: Vec<[f64; 3]> = world
            .objects()
            .iter()
            .map(|o| o.pose.translation.vector.into())
            .collect();
        let checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        let (robot, compiled) = checker.compiled();
        let grid = WorldGrid::for_robot(robot, compiled, margin).expect("a grid");
        let mut positive = 0;
        for _ in 0..6_000 {
            let c = centres[rng.random_range(0..centres.len())];
            let p = [0, 1, 2].map(|a| (c[a] + rng.random_range(-0.2..0.2)) as f32);
            let bound = grid.clearance(compiled, &p);
            let exact = parry_distances(&parts, &p)
                .into_iter()
                .fold(f32::INFINITY, f32::min);
            assert!(
                bound <= exact + 1e-5,
                "{n} obstacles at {p:?}: bound {bound} > exact {exact}"
            );
            if bound > 0.0 {
                positive += 1;
                assert!(
                    exact.min(grid.list_reach()) - bound < 2.0 * half_diagonal + 0.009,
                    "{p:?}: {bound} {exact}"
                );
            }
        }
        assert!(positive > 1_000, "{n}: {positive}");
    }
}

#[test]
fn candidate_lists_never_hide_a_collision_in_crowded_worlds() {
    use ferrobot_collision::kernel::{self, Scratch};
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(23);
    for (seed, n, margin) in [(1, 300, 0.0), (2, 600, 0.02)] {
        let world = cage_world(seed, n);
        let mut checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        checker.set_margin(margin).unwrap();
        let qs: Vec<Vec<f64>> = (0..3000)
            .map(|_| common::random_q(&model, &mut rng))
            .collect();
        // The reference: the scalar lane against every obstacle, no grid.
        let (robot, compiled) = checker.compiled();
        let mut scratch = Scratch::<f32>::new(robot);
        let reference: Vec<bool> = qs
            .iter()
            .map(|q| {
                let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
                kernel::check(
                    robot,
                    compiled,
                    None,
                    &q32,
                    margin as f32,
                    1,
                    false,
                    &mut scratch,
                ) != 0
            })
            .collect();
        let hits = reference.iter().filter(|&&b| b).count();
        assert!(hits > 300 && hits < 2900, "{n} obstacles: {hits} colliding");
        let batch = checker.in_collision_batch(&qs.concat()).unwrap();
        assert!(checker.has_world_grid());
        assert_eq!(
            batch, reference,
            "{n} obstacles: batch with candidate lists"
        );
        // The same batch on the calling thread (the planner's re-check).
        let mut serial = vec![false; qs.len()];
        checker.in_collision_batch_serial_into(&qs.concat(), &mut serial);
        assert_eq!(
            serial, reference,
            "{n} obstacles: serial batch with candidate lists"
        );
        let single: Vec<bool> = qs
            .iter()
            .map(|q| checker.in_collision(q).unwrap())
            .collect();
        assert_eq!(
            single, reference,
            "{n} obstacles: single with candidate lists"
        );
        // Motions: a motion reported free has every checked configuration
        // free for the reference.
        for pair in qs.chunks(2).take(300) {
            let (a, b) = (&pair[0], &pair[1]);
            let b: Vec<f64> = a.iter().zip(b).map(|(x, y)| x + 0.15 * (y - x)).collect();
            if checker.motion_valid(a, &b, 0.01).unwrap() {
                let steps = a
                    .iter()
                    .zip(&b)
                    .map(|(x, y)| (y - x).abs())
                    .fold(0.0, f64::max)
                    / 0.01;
                let steps = (steps.ceil() as usize).max(1);
                for k in 0..=steps {
                    let t = k as f64 / steps as f64;
                    let q32: Vec<f32> = a
                        .iter()
                        .zip(&b)
                        .map(|(x, y)| (x + (y - x) * t) as f32)
                        .collect();
                    assert_eq!(
                        kernel::check(
                            robot,
                            compiled,
                            None,
                            &q32,
                            margin as f32,
                            1,
                            false,
                            &mut scratch
                        ),
                        0,
                        "a motion reported free collides at t = {t}"
                    );
                }
            }
        }
    }
}

#[test]
fn crowded_world_batches_agree_with_exact_f64_sphere_distances() {
    // The reference is independent of the kernel: the model's `f64`
    // kinematics, each robot sphere's signed distance to each obstacle's
    // exact shape (`CollisionChecker::distance`), and the sphere pairs of
    // the checked self pairs. With the exact self stage off the sphere model
    // decides, so away from a 0.1 mm band around the margin the batch (the
    // eight-lane kernel with candidate lists, one lane at a time where few
    // lanes share a list cell) must give the same answer; in particular it
    // never reports a configuration that touches an obstacle as free.
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(2323);
    for (seed, n, margin) in [(7, 250, 0.0), (8, 500, 0.015)] {
        let world = cage_world(seed, n);
        let mut checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        checker.set_margin(margin).unwrap();
        checker.set_exact_self_collision(false);
        let qs: Vec<Vec<f64>> = (0..2500)
            .map(|_| common::random_q(&model, &mut rng))
            .collect();
        let batch = checker.in_collision_batch(&qs.concat()).unwrap();
        assert!(checker.has_world_grid());
        let (mut world_hits, mut free, mut compared) = (0, 0, 0);
        for (q, &got) in qs.iter().zip(&batch) {
            // The single-configuration kernel (its own grid lookups and
            // candidate walk) answers the same.
            assert_eq!(
                checker.in_collision(q).unwrap(),
                got,
                "{n} obstacles: single vs batch at {q:?}"
            );
            let d = checker.distance(q).unwrap();
            let nearest = d.world_distance.min(d.self_distance);
            if d.world_distance < margin - 1e-4 {
                assert!(
                    got,
                    "{n} obstacles: touches the world by {} m, reported free",
                    margin - d.world_distance
                );
                world_hits += 1;
            }
            if (nearest - margin).abs() > 1e-4 {
                assert_eq!(got, nearest < margin, "{n} obstacles: q = {q:?}, {d:?}");
                compared += 1;
                free += usize::from(!got);
            }
        }
        assert!(
            world_hits > 300 && free > 300 && compared > 2400,
            "{n}: {world_hits} {free} {compared}"
        );
    }
}
