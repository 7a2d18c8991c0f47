//! Joint-space clearance maps against an independent reference: wherever a
//! map says a self pair is clear, the pair's spheres, placed by the model's
//! `f64` forward kinematics, are apart by more than the margin; wherever it
//! says the pair certainly collides, the spheres overlap and the links'
//! convex hulls (parry, `f64` poses) intersect; and the
//! single-configuration path that uses the maps answers exactly as the
//! batch kernel, which does not.

mod common;

use std::sync::Arc;

use common::{assert_single_matches_batch, hulls, mbm_panda, random_q, to_pose};

use ferrobot_collision::pair_map::PairMap;
use ferrobot_collision::{CollisionChecker, CollisionWorld};
use ferrobot_model::RobotModel;
use parry3d::query::intersection_test;
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Smallest surface distance between the spheres of links `la` and `lb`
/// at `q`, from the model's forward kinematics in `f64`.
fn clearance(checker: &CollisionChecker, q: &[f64], la: usize, lb: usize) -> f64 {
    let poses = checker.model().fk_all(q).unwrap();
    let s = &checker.spheres().links;
    let mut best = f64::INFINITY;
    for a in &s[la] {
        let ca = poses[la] * a.center;
        for b in &s[lb] {
            let cb = poses[lb] * b.center;
            best = best.min((ca - cb).norm() - a.radius - b.radius);
        }
    }
    best
}

/// The MotionBenchMaker Panda's checker with `margin`, empty world.
fn panda_checker(margin: f64) -> (Arc<RobotModel>, CollisionChecker) {
    let (model, spheres, acm) = mbm_panda();
    let mut checker =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).unwrap();
    checker.set_margin(margin).unwrap();
    (model, checker)
}

/// The self pairs with a map: (link, link, map).
fn mapped_pairs(checker: &CollisionChecker) -> Vec<(usize, usize, &PairMap)> {
    let (robot, _) = checker.compiled();
    robot
        .pairs
        .iter()
        .zip(&robot.pair_maps)
        .filter_map(|(&(a, b), m)| {
            m.as_deref()
                .map(|m| (robot.bodies[a].link, robot.bodies[b].link, m))
        })
        .collect()
}

/// A random configuration; half the time the map's two coordinates sit
/// within a thousandth of a cell of a cell edge, on either side.
fn sample(model: &RobotModel, map: &PairMap, rng: &mut StdRng) -> Vec<f64> {
    let mut q = random_q(model, rng);
    if rng.random_bool(0.5) {
        for d in map.dofs() {
            let (l, h) = (model.lower_limits()[d], model.upper_limits()[d]);
            let cell = (h - l) / 128.0;
            let k = rng.random_range(0..=128) as f64;
            q[d] = (l + cell * (k + rng.random_range(-1e-3..1e-3)))
                .min(h)
                .max(l);
        }
    }
    q
}

#[test]
fn clear_cells_are_clear_for_every_configuration_in_them() {
    let margin = 0.01;
    let (model, checker) = panda_checker(margin);
    let maps = mapped_pairs(&checker);
    // The Panda's wrist: link 5 against the hand and fingers (joints 6, 7).
    assert!(maps.len() >= 2, "{} maps", maps.len());
    // Link 7 sits within a centimetre of link 5 in every configuration, so
    // its map is empty at this margin; the hand and fingers are mostly clear.
    assert!(maps.iter().filter(|m| m.2.clear_fraction() > 0.5).count() >= 2);
    let mut rng = StdRng::seed_from_u64(3);
    let (mut clear, mut closest) = (0, f64::INFINITY);
    for (la, lb, map) in &maps {
        for _ in 0..3000 {
            let q = sample(&model, map, &mut rng);
            let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
            if map.clear(&q32, margin as f32) {
                let c = clearance(&checker, &q, *la, *lb);
                assert!(c > margin, "links {la}-{lb} at {q:?}: clearance {c}");
                clear += 1;
                closest = closest.min(c);
            }
            assert!(
                !map.clear(&q32, margin as f32 * 2.0),
                "built for a smaller margin"
            );
        }
    }
    assert!(clear > 2000, "{clear} samples in clear cells");
    // Not vacuous: the maps vouch for configurations close to contact.
    assert!(
        closest < margin + 0.02,
        "closest vouched clearance {closest}"
    );
}

#[test]
fn colliding_cells_collide_for_every_configuration_in_them() {
    let margin = 0.005;
    let (model, checker) = panda_checker(margin);
    let hulls = hulls(&model);
    let (robot, _) = checker.compiled();
    let maps = mapped_pairs(&checker);
    // The hand and link 5 collide over a band of wrist angles.
    assert!(maps.iter().any(|m| m.2.collide_fraction() > 0.02));
    // One map over joints 6 and 7 holds the colliding cells of all four.
    assert_eq!(robot.collide_maps.len(), 1);
    let mut rng = StdRng::seed_from_u64(8);
    let (mut colliding, mut shallowest) = (0, f64::INFINITY);
    for (la, lb, map) in &maps {
        for _ in 0..10_000 {
            let q = sample(&model, map, &mut rng);
            let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
            assert_eq!(
                robot.collide_maps[0].collides(&q32, margin as f32) && map.collides(&q32, 1.0),
                map.collides(&q32, margin as f32),
                "the union holds this map's cells"
            );
            if !map.collides(&q32, margin as f32) {
                continue;
            }
            colliding += 1;
            let c = clearance(&checker, &q, *la, *lb);
            assert!(c < margin, "links {la}-{lb} at {q:?}: clearance {c}");
            let poses = model.fk_all(&q).unwrap();
            let touch = hulls[*la].iter().any(|(oa, ha)| {
                hulls[*lb].iter().any(|(ob, hb)| {
                    let (pa, pb) = (to_pose(&(poses[*la] * oa)), to_pose(&(poses[*lb] * ob)));
                    intersection_test(&pa, ha, &pb, hb).unwrap().intersecting
                })
            });
            assert!(touch, "links {la}-{lb} hulls apart at {q:?}");
            assert!(checker.in_collision_batch(&q).unwrap()[0]);
            shallowest = shallowest.min(-c);
            assert!(
                !map.collides(&q32, margin as f32 - 0.001),
                "built for a larger margin"
            );
        }
    }
    assert!(colliding > 500, "{colliding} samples in colliding cells");
    // Not vacuous: the maps vouch for configurations close to the contact.
    assert!(shallowest < 0.02, "shallowest vouched overlap {shallowest}");
}

#[test]
fn single_path_with_maps_agrees_with_batch_kernel() {
    for (scene, margin) in [
        ("bench/mbm/table_pick_panda/scene0002.yaml", 0.0),
        ("bench/mbm/bookshelf_small_panda/scene0005.yaml", 0.02),
    ] {
        let (checker, _) = assert_single_matches_batch(scene, margin, 11, 4000, 1);
        assert!(checker.compiled().0.pair_maps.iter().any(|m| m.is_some()));
    }
}
