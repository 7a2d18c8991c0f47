//! A larger margin never frees a configuration: whatever collides at margin
//! 0 collides at every margin > 0. Tested where it is easiest to get wrong,
//! at the self-collision boundary: configurations found by bisection on
//! random motions from a free to a self-colliding configuration, just
//! inside the boundary (colliding at margin 0 by a hair), in an empty world,
//! where the exact self stage decides every pair (at margin 0 by an
//! intersection test, at a positive margin by a distance).

mod common;

use common::{mbm_panda, random_q};
use ferrobot_collision::{CollisionChecker, CollisionWorld};
use rand::{SeedableRng, rngs::StdRng};

#[test]
fn a_larger_margin_never_frees_a_self_collision() {
    let (model, spheres, acm) = mbm_panda();
    let base = CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).unwrap();
    let margins = [0.0005, 0.001, 0.0023, 0.005, 0.01];
    let grown: Vec<CollisionChecker> = margins
        .iter()
        .map(|&m| {
            let mut c = base.clone();
            c.set_margin(m).unwrap();
            c
        })
        .collect();
    let mut rng = StdRng::seed_from_u64(7);
    let (mut boundary, mut tries) = (0, 0);
    while boundary < 400 && tries < 40_000 {
        tries += 1;
        let a = random_q(&model, &mut rng);
        let mut b = random_q(&model, &mut rng);
        // Elbow folded so that the hand and links 5-7 reach links 0-4.
        b[3] = -3.0 + 0.3 * (tries % 5) as f64 / 5.0;
        if base.in_collision(&a).unwrap() || !base.in_collision(&b).unwrap() {
            continue;
        }
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            let q: Vec<f64> = a.iter().zip(&b).map(|(x, y)| x + mid * (y - x)).collect();
            if base.in_collision(&q).unwrap() {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        boundary += 1;
        // Just inside (colliding at margin 0) and a little further in.
        for t in [hi, hi + 1e-4, hi + 1e-3] {
            let q: Vec<f64> = a
                .iter()
                .zip(&b)
                .map(|(x, y)| x + t.min(1.0) * (y - x))
                .collect();
            if !base.in_collision(&q).unwrap() {
                continue;
            }
            for (c, m) in grown.iter().zip(margins) {
                assert!(
                    c.in_collision(&q).unwrap(),
                    "colliding at margin 0, free at margin {m}: {q:?}"
                );
                let batch = c.in_collision_batch(&q).unwrap();
                assert!(batch[0], "batch frees it at margin {m}: {q:?}");
            }
        }
    }
    assert!(
        boundary >= 100,
        "only {boundary} boundary crossings in {tries} motions"
    );
}
