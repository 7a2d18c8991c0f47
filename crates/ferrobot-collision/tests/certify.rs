//! Continuous certification of motions (`CollisionChecker::curve_certified_until`,
//! issue 23 item 5): a motion checked at samples can graze an obstacle
//! between them; a certified motion cannot. The reference is dense
//! sampling (100 µrad) of the same motions and configurations constructed
//! on the boundary of a collision.

mod common;

use common::{mbm_panda, random_q, scattered_world};
use ferrobot_collision::{CollisionChecker, CollisionWorld};
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Many small obstacles around the arm (as in the scene classes' clutter).
fn crowded_world(seed: u64, n: usize) -> CollisionWorld {
    scattered_world(seed, n, 0.8, -0.1..1.1, 0.01..0.04, 3)
}

fn certify(checker: &CollisionChecker, a: &[f64], b: &[f64], resolution: f64) -> bool {
    let delta: Vec<f64> = a.iter().zip(b).map(|(x, y)| (y - x).abs()).collect();
    let span = delta.iter().copied().fold(0.0, f64::max);
    let steps = ((span / resolution).ceil() as usize).max(1);
    let mut point = |u: f64, q: &mut [f64]| {
        for ((o, x), y) in q.iter_mut().zip(a).zip(b) {
            *o = x + (y - x) * u;
        }
    };
    checker
        .curve_certified_until(&mut point, &delta, steps, 0.0, None, &mut 0)
        .expect("no deadline")
}

fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + (y - x) * t).collect()
}

#[test]
fn grazes_between_samples_are_not_certified() {
    let (model, spheres, acm) = mbm_panda();
    let checker =
        CollisionChecker::new(model.clone(), spheres, acm, crowded_world(5, 120)).unwrap();
    let mut rng = StdRng::seed_from_u64(7);
    let arm: Vec<usize> = (0..7).collect();
    let mut grazes = 0;
    for _ in 0..600 {
        let (f, c) = (random_q(&model, &mut rng), random_q(&model, &mut rng));
        if checker.in_collision(&f).unwrap() || !checker.in_collision(&c).unwrap() {
            continue;
        }
        // The first collision along f -> c, to within 1e-12 of the segment.
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..45 {
            let mid = 0.5 * (lo + hi);
            if checker.in_collision(&lerp(&f, &c, mid)).unwrap() {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let touch = lerp(&f, &c, hi);
        // A 4 mrad motion through the touching configuration, tangent to
        // the collision's boundary there (a random direction of the arm's
        // joints without its part along the distance gradient): at a 5 mrad
        // resolution only its end points are checked, and they are free.
        let g = checker.distance(&touch).unwrap().gradient;
        let mut v: Vec<f64> = (0..touch.len())
            .map(|d| {
                if arm.contains(&d) {
                    rng.random_range(-1.0..1.0)
                } else {
                    0.0
                }
            })
            .collect();
        let gg: f64 = g.iter().map(|x| x * x).sum();
        if gg > 0.0 {
            let k = v.iter().zip(&g).map(|(x, y)| x * y).sum::<f64>() / gg;
            for (x, y) in v.iter_mut().zip(&g) {
                *x -= k * y;
            }
        }
        let top = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if top == 0.0 {
            continue;
        }
        let a: Vec<f64> = touch
            .iter()
            .zip(&v)
            .map(|(t, x)| t - 0.002 * x / top)
            .collect();
        let b: Vec<f64> = touch
            .iter()
            .zip(&v)
            .map(|(t, x)| t + 0.002 * x / top)
            .collect();
        if checker.in_collision(&a).unwrap() || checker.in_collision(&b).unwrap() {
            continue;
        }
        if !checker.in_collision(&lerp(&a, &b, 0.5)).unwrap() {
            continue; // rounding moved the midpoint off the boundary
        }
        // The sampled check cannot see it; the certification must.
        assert!(checker.motion_valid(&a, &b, 0.005).unwrap());
        assert!(
            !certify(&checker, &a, &b, 0.005),
            "a motion through a colliding configuration was certified free"
        );
        grazes += 1;
    }
    assert!(grazes >= 20, "only {grazes} grazing motions made");
}

#[test]
fn certified_motions_are_free_at_every_dense_sample() {
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(11);
    for (seed, margin) in [(1, 0.0), (2, 0.01)] {
        let mut checker = CollisionChecker::new(
            model.clone(),
            spheres.clone(),
            acm.clone(),
            crowded_world(seed, 150),
        )
        .unwrap();
        checker.set_margin(margin).unwrap();
        let (mut sampled_free, mut certified) = (0, 0);
        let mut tried = 0;
        while tried < 300 {
            let a = random_q(&model, &mut rng);
            if checker.in_collision(&a).unwrap() {
                continue;
            }
            tried += 1;
            let far = random_q(&model, &mut rng);
            let b = lerp(&a, &far, 0.08);
            let sampled = checker.motion_valid(&a, &b, 0.005).unwrap();
            sampled_free += usize::from(sampled);
            if !certify(&checker, &a, &b, 0.005) {
                continue;
            }
            certified += 1;
            // Every configuration 100 µrad apart along it is free.
            let span = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (y - x).abs())
                .fold(0.0, f64::max);
            let n = (span / 1e-4).ceil() as usize;
            let dense: Vec<f64> = (0..=n)
                .flat_map(|k| lerp(&a, &b, k as f64 / n as f64))
                .collect();
            let flags = checker.in_collision_batch(&dense).unwrap();
            assert!(
                !flags.iter().any(|&f| f),
                "margin {margin}: a certified motion collides at a dense sample"
            );
        }
        // The certificate is not vacuous: most motions free at their samples
        // are certified (the others pass within millimetres of an obstacle).
        assert!(
            certified * 10 >= sampled_free * 8 && certified > 100,
            "margin {margin}: {certified} certified of {sampled_free} free at samples"
        );
    }
}

#[test]
fn one_pass_certification_equals_two_passes() {
    // `curve_certified_until` tests self pairs at the margin and the world
    // at the grown margin in one kernel pass; the reference runs the two
    // passes of the scheme before it (the whole robot at the margin, then
    // the world alone at the grown margin). Same answers on random motions
    // of every kind: free, grazing, through obstacles, self-colliding.
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(23);
    let mut answers = [0usize; 2];
    let mut self_only = 0;
    for (seed, margin, tube, exact) in [
        (3, 0.0, 0.0, true),
        (4, 0.01, 0.0, true),
        (5, 0.0, 0.002, true),
        (6, 0.005, 0.001, false),
    ] {
        let world = crowded_world(seed, 150);
        let mut checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        checker.set_margin(margin).unwrap();
        checker.set_exact_self_collision(exact);
        let empty = {
            let mut c = CollisionChecker::new(
                model.clone(),
                spheres.clone(),
                acm.clone(),
                CollisionWorld::new(),
            )
            .unwrap();
            c.set_margin(margin).unwrap();
            c.set_exact_self_collision(exact);
            c
        };
        for k in 0..200 {
            let a = random_q(&model, &mut rng);
            let far = random_q(&model, &mut rng);
            let b = lerp(&a, &far, [0.02, 0.08, 0.3, 1.0][k % 4]);
            let delta: Vec<f64> = a.iter().zip(&b).map(|(x, y)| (y - x).abs()).collect();
            let span = delta.iter().copied().fold(0.0, f64::max);
            let steps = ((span / 0.01).ceil() as usize).max(1);
            let mut point = |u: f64, q: &mut [f64]| {
                for ((o, x), y) in q.iter_mut().zip(&a).zip(&b) {
                    *o = x + (y - x) * u;
                }
            };
            let one = checker
                .curve_certified_until(&mut point, &delta, steps, tube, None, &mut 0)
                .expect("no deadline");
            let two = checker
                .curve_certified_two_pass_until(&mut point, &delta, steps, tube, None, &mut 0)
                .expect("no deadline");
            assert_eq!(
                one, two,
                "world {seed}, margin {margin}, tube {tube}, exact {exact}: motion {k} \
                 one pass says {one}, two passes {two}"
            );
            answers[usize::from(one)] += 1;
            // Motions that collide only with themselves (free of the
            // world: the same answer in an empty world).
            let alone = empty
                .curve_certified_until(&mut point, &delta, steps, tube, None, &mut 0)
                .expect("no deadline");
            self_only += usize::from(!alone);
        }
    }
    // Not vacuous: both answers and self-collisions occur.
    assert!(
        answers[0] >= 100 && answers[1] >= 100 && self_only >= 20,
        "colliding {}, free {}, self-colliding {self_only}",
        answers[0],
        answers[1]
    );
}
