//! The certification of a plan's final path (issue 23 item 5): one kernel
//! pass per interval (self pairs at the interval midpoints, the world
//! continuously) with no separate motion check at samples. Judge: dense
//! sampling (0.25 mrad) of the same motions with the same checker, on the
//! MotionBenchMaker Panda in crowded worlds; a motion certified free must
//! be free at every dense sample, self-collisions included.

use std::path::PathBuf;
use std::sync::Arc;

use ferrobot_collision::{
    AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres, Shape,
};
use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
use ferrobot_planning::Planner;
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

fn shared(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared")
        .join(rel)
}

fn panda(world: CollisionWorld) -> Planner {
    let model = RobotModel::from_urdf_file(
        shared("robots/panda/panda.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("robots/panda/panda.srdf"))),
            ee_link: Some("panda_hand".into()),
            ..Default::default()
        },
    )
    .unwrap();
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .unwrap();
    let acm = AllowedCollisions::from_model(&model);
    let checker = CollisionChecker::new(Arc::new(model), spheres, acm, world).unwrap();
    Planner::new(checker, None).unwrap()
}

/// `n` small boxes and spheres around the arm (as the scene classes' clutter).
fn crowded(seed: u64, n: usize) -> CollisionWorld {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut world = CollisionWorld::new();
    for i in 0..n {
        let (x, y) = loop {
            let (x, y): (f64, f64) = (rng.random_range(-0.8..0.8), rng.random_range(-0.8..0.8));
            if x.hypot(y) > 0.3 {
                break (x, y);
            }
        };
        let pose = Isometry3::from_parts(
            Translation3::new(x, y, rng.random_range(-0.1..1.1)),
            UnitQuaternion::from_euler_angles(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            ),
        );
        let shape = if i % 2 == 0 {
            Shape::Box {
                half_extents: Vector3::new(
                    rng.random_range(0.01..0.04),
                    rng.random_range(0.01..0.04),
                    rng.random_range(0.01..0.04),
                ),
            }
        } else {
            Shape::Sphere {
                radius: rng.random_range(0.01..0.04),
            }
        };
        world.add_shape(&format!("o{i}"), shape, pose).unwrap();
    }
    world
}

fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + (y - x) * t).collect()
}

#[test]
fn certified_final_edges_are_free_at_every_dense_sample() {
    let resolution = 0.005;
    let (mut free, mut colliding, mut selfish, mut missed_by_samples) = (0, 0, 0, 0);
    for (seed, n) in [(1u64, 150usize), (2, 150), (3, 60)] {
        let planner = panda(crowded(seed, n));
        // The same robot without obstacles tells self-collisions apart.
        let alone = panda(CollisionWorld::new());
        let space = planner.space().clone();
        let (lo, hi) = (
            planner.limits().lower.clone(),
            planner.limits().upper.clone(),
        );
        let mut rng = SmallRng::seed_from_u64(seed + 100);
        let collides = |p: &Planner, q: &[f64]| p.checker().in_collision(&space.expand(q)).unwrap();
        let mut tried = 0;
        while tried < 200 {
            let a: Vec<f64> = lo
                .iter()
                .zip(&hi)
                .map(|(l, h)| rng.random_range(*l..*h))
                .collect();
            if collides(&planner, &a) {
                continue;
            }
            let c: Vec<f64> = lo
                .iter()
                .zip(&hi)
                .map(|(l, h)| rng.random_range(*l..*h))
                .collect();
            let frac = [0.03, 0.1, 0.3, 0.6][tried % 4];
            let b = lerp(&a, &c, frac);
            if collides(&planner, &b) {
                // A path's vertices are free.
                continue;
            }
            tried += 1;
            let span = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (y - x).abs())
                .fold(0.0, f64::max);
            let dense = ((span / 2.5e-4).ceil() as usize).max(1);
            let hit =
                (0..=dense).find(|&k| collides(&planner, &lerp(&a, &b, k as f64 / dense as f64)));
            let certified = planner
                .path_certified(&[a.clone(), b.clone()], resolution)
                .unwrap();
            match hit {
                None => free += 1,
                Some(k) => {
                    colliding += 1;
                    let q = lerp(&a, &b, k as f64 / dense as f64);
                    if collides(&alone, &q) {
                        selfish += 1;
                    }
                    // A graze: the shortest motion around the colliding
                    // stretch that starts at the dense sample before it and
                    // ends at the first free one after it. When it spans
                    // less than 4 x the resolution, the search's check at
                    // samples (its end points) misses it; the certification
                    // must not.
                    if let Some(out) = (k..=dense)
                        .find(|&j| !collides(&planner, &lerp(&a, &b, j as f64 / dense as f64)))
                    {
                        let (ga, gb) = (
                            lerp(&a, &b, (k - 1) as f64 / dense as f64),
                            lerp(&a, &b, out as f64 / dense as f64),
                        );
                        let gspan = ga
                            .iter()
                            .zip(&gb)
                            .map(|(x, y)| (y - x).abs())
                            .fold(0.0, f64::max);
                        if gspan < 4.0 * resolution && !collides(&alone, &q) {
                            missed_by_samples += 1;
                            assert!(
                                !planner.path_certified(&[ga, gb], resolution).unwrap(),
                                "seed {seed}: a graze of the world {} mrad long was certified free",
                                gspan * 1e3
                            );
                        }
                    }
                    assert!(
                        !certified,
                        "seed {seed}: a motion colliding at u = {} ({} of the dense samples) was certified free",
                        k as f64 / dense as f64,
                        if collides(&alone, &q) {
                            "self"
                        } else {
                            "world"
                        }
                    );
                }
            }
        }
    }
    // Motions through a self-collision: from a free configuration towards a
    // self-colliding one, to the first free configuration beyond the
    // collision (both end points free, the middle not). Before this test
    // the tube was certified first, with the self pairs at the margin grown
    // by it, where the checker missed crossings 10 mrad long.
    let alone = panda(CollisionWorld::new());
    let space = alone.space().clone();
    let (lo, hi) = (alone.limits().lower.clone(), alone.limits().upper.clone());
    let collides = |q: &[f64]| alone.checker().in_collision(&space.expand(q)).unwrap();
    let mut rng = SmallRng::seed_from_u64(7);
    let mut through = 0;
    for _ in 0..20_000 {
        if through >= 40 {
            break;
        }
        let a: Vec<f64> = lo
            .iter()
            .zip(&hi)
            .map(|(l, h)| rng.random_range(*l..*h))
            .collect();
        let c: Vec<f64> = lo
            .iter()
            .zip(&hi)
            .map(|(l, h)| rng.random_range(*l..*h))
            .collect();
        if collides(&a) || !collides(&c) {
            continue;
        }
        let span = a
            .iter()
            .zip(&c)
            .map(|(x, y)| (y - x).abs())
            .fold(0.0, f64::max);
        let n = ((span / 1e-3).ceil() as usize).max(1);
        let Some(enter) = (0..=n).find(|&k| collides(&lerp(&a, &c, k as f64 / n as f64))) else {
            continue;
        };
        let Some(exit) = (enter..=n).find(|&k| !collides(&lerp(&a, &c, k as f64 / n as f64)))
        else {
            continue;
        };
        // Self-collisions are certified absent at samples no more than the
        // resolution apart: a crossing surely longer than that is found.
        let step = span / n as f64;
        if (exit - enter - 1) as f64 * step <= resolution {
            continue;
        }
        let b = lerp(&a, &c, exit as f64 / n as f64);
        through += 1;
        selfish += 1;
        assert!(
            !alone.path_certified(&[a, b], resolution).unwrap(),
            "a motion through a self-collision ({} mrad long) was certified free",
            (exit - enter) as f64 * step * 1e3
        );
    }
    eprintln!(
        "free {free}, colliding {colliding} (self {selfish}, through a self-collision {through}), \
         missed by coarse samples {missed_by_samples}"
    );
    assert!(
        free >= 100 && colliding >= 100,
        "free {free}, colliding {colliding}"
    );
    assert!(
        through >= 20 && selfish >= 20,
        "only {selfish} self-colliding motions"
    );
    assert!(
        missed_by_samples >= 1,
        "no motion grazed between coarse samples"
    );
}
