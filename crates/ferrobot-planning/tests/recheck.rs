//! The trajectory re-check's bounds against brute force: the deviation
//! bound is never below the true distance from the trajectory to its
//! waypoint segment (measured by dense sampling and an exact 1-D convex
//! minimisation), the sample spacing never lets a joint move more than the
//! resolution, and a two-waypoint trajectory is its straight segment (so it
//! is skipped whole). The planner-level safety of skipping is tested on the
//! toy wall in `reference.rs`.

use ferrobot_planning::KinematicLimits;
use ferrobot_planning::Trajectory;
use ferrobot_planning::recheck::{
    SKIP_DEVIATION, deviation_bound, max_speed, pieces, sample_times, to_check,
};
use ferrobot_planning::timing::parametrize;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

fn panda_like_limits(dim: usize) -> KinematicLimits {
    let v = [2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61];
    let a = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0];
    let j = [7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0];
    KinematicLimits {
        lower: vec![-3.0; dim],
        upper: vec![3.0; dim],
        velocity: (0..dim).map(|d| v[d % 7]).collect(),
        acceleration: (0..dim).map(|d| a[d % 7]).collect(),
        jerk: (0..dim).map(|d| j[d % 7]).collect(),
    }
}

fn random_path(rng: &mut SmallRng, n: usize, dim: usize, spread: f64) -> Vec<Vec<f64>> {
    let mut out = vec![
        (0..dim)
            .map(|_| rng.random_range(-1.5..1.5))
            .collect::<Vec<f64>>(),
    ];
    for _ in 1..n {
        let prev = out.last().unwrap().clone();
        // Mostly moving, sometimes a nearly collinear or a repeated waypoint.
        let next = match rng.random_range(0..6) {
            0 => prev.clone(),
            1 if out.len() >= 2 => {
                let before = &out[out.len() - 2];
                prev.iter()
                    .zip(before)
                    .map(|(p, b)| p + (p - b) * 0.7 + rng.random_range(-1e-4..1e-4))
                    .collect()
            }
            _ => prev
                .iter()
                .map(|p| p + rng.random_range(-spread..spread))
                .collect(),
        };
        out.push(next);
    }
    out
}

fn position(traj: &Trajectory, i: usize, s: f64) -> Vec<f64> {
    let mut q = vec![0.0; traj.dim()];
    traj.position_on(i, s, &mut q);
    q
}

/// Max-norm distance from `q` to the segment `a`-`b`: the max over joints
/// of |q - a - u (b - a)| is convex in u, minimised over [0, 1] by golden
/// section to 1e-13.
fn distance_to_segment(q: &[f64], a: &[f64], b: &[f64]) -> f64 {
    let f = |u: f64| {
        q.iter()
            .zip(a.iter().zip(b))
            .map(|(q, (a, b))| (q - a - u * (b - a)).abs())
            .fold(0.0, f64::max)
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    while hi - lo > 1e-13 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if f(x1) <= f(x2) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    f(lo).min(f(hi)).min(f(0.0)).min(f(1.0))
}

/// On random multi-waypoint trajectories (2-7 joints, 2-8 waypoints, with
/// repeated and nearly collinear waypoints), for every interval and random
/// sub-ranges of it, the bound is at least the largest distance found by
/// 200 samples, and tight within a factor on smooth pieces (not vacuous).
#[test]
fn deviation_bound_is_never_below_the_sampled_distance() {
    let mut rng = SmallRng::seed_from_u64(7);
    let mut checked = 0;
    let mut tight = 0;
    for case in 0..300 {
        let dim = 2 + case % 6;
        let n = 2 + case % 7;
        let path = random_path(&mut rng, n, dim, 0.8);
        let traj = parametrize(&path, &panda_like_limits(dim));
        for i in 0..traj.times.len() - 1 {
            let h = traj.times[i + 1] - traj.times[i];
            let seg = traj.segment_of[i];
            for r in 0..4 {
                let (s0, s1) = if r == 0 {
                    (0.0, h)
                } else {
                    let x = rng.random_range(0.0..h);
                    let y = rng.random_range(0.0..h);
                    (x.min(y), x.max(y))
                };
                let bound = deviation_bound(&traj, i, s0, s1, &path[seg], &path[seg + 1]);
                let mut worst = 0.0f64;
                for k in 0..=200 {
                    let s = s0 + (s1 - s0) * k as f64 / 200.0;
                    let q = position(&traj, i, s);
                    worst = worst.max(distance_to_segment(&q, &path[seg], &path[seg + 1]));
                }
                assert!(
                    worst <= bound + 1e-12,
                    "case {case} interval {i} [{s0}, {s1}]: distance {worst} > bound {bound}"
                );
                checked += 1;
                if bound <= 4.0 * worst + 1e-9 {
                    tight += 1;
                }
            }
        }
    }
    assert!(checked > 3000, "{checked}");
    // The bound is useful, not only safe: mostly within 4x of the truth.
    assert!(tight * 10 >= checked * 8, "{tight} of {checked} within 4x");
}

/// A rest-to-rest trajectory through two waypoints is the straight segment
/// (every joint follows one normalised profile): its bound is at rounding
/// level, so none of it is re-checked, while the same trajectory offset by
/// 1 mrad in one joint is checked whole.
#[test]
fn two_waypoint_trajectory_is_skipped_and_an_offset_one_is_not() {
    let mut rng = SmallRng::seed_from_u64(3);
    let res = 0.005;
    for _ in 0..50 {
        let path = random_path(&mut rng, 2, 7, 1.5);
        if path[0] == path[1] {
            continue;
        }
        let traj = parametrize(&path, &panda_like_limits(7));
        let all = pieces(&traj, res, Some(&path));
        assert!(all.iter().all(|p| p.deviation < 1e-9), "{all:?}");
        assert!(to_check(&all, res).is_empty());
        // The verified segment moved by 1 mrad (> SKIP_DEVIATION * res) in
        // joint 3: no piece may be skipped.
        let mut moved = path.clone();
        moved[0][3] += 1e-3;
        moved[1][3] += 1e-3;
        assert!(1e-3 > SKIP_DEVIATION * res);
        let all = pieces(&traj, res, Some(&moved));
        assert_eq!(to_check(&all, res).len(), all.len());
    }
}

/// Consecutive samples of every piece, and of consecutive pieces, are at
/// most the resolution apart in every joint (checked between the samples by
/// 20 sub-samples each, and against the exact speed bound), the pieces
/// tile the whole trajectory, and the count is no more than 1.5x the
/// minimum (the trajectory's max-norm arc length over the resolution) plus
/// one per piece (rounding up).
#[test]
fn samples_are_never_further_apart_than_the_resolution() {
    let mut rng = SmallRng::seed_from_u64(11);
    for case in 0..60 {
        let dim = 2 + case % 6;
        let path = random_path(&mut rng, 2 + case % 5, dim, 0.9);
        let traj = parametrize(&path, &panda_like_limits(dim));
        let res = [0.005, 0.02, 0.001][case % 3];
        let all = pieces(&traj, res, None);
        let mut t_end = 0.0;
        let mut prev: Option<Vec<f64>> = None;
        let mut count = 0usize;
        let mut arc = 0.0;
        for p in &all {
            // Tiling: each piece starts where the last ended.
            let t0 = traj.times[p.interval];
            assert!((t0 + p.s0 - t_end).abs() < 1e-12);
            t_end = t0 + p.s1;
            assert!(
                max_speed(&traj, p.interval, p.s0, p.s1) * (p.s1 - p.s0) / p.steps as f64
                    <= res * (1.0 + 1e-12)
            );
            let times: Vec<f64> = sample_times(p).collect();
            assert_eq!(times.len(), p.steps + 1);
            count += p.steps;
            for w in times.windows(2) {
                let a = position(&traj, p.interval, w[0]);
                for k in 1..=20 {
                    let b = position(&traj, p.interval, w[0] + (w[1] - w[0]) * k as f64 / 20.0);
                    let step = a
                        .iter()
                        .zip(&b)
                        .map(|(x, y)| (x - y).abs())
                        .fold(0.0, f64::max);
                    assert!(
                        step <= res * (1.0 + 1e-9),
                        "case {case}: step {step} > {res}"
                    );
                }
            }
            let first = position(&traj, p.interval, p.s0);
            if let Some(q) = &prev {
                let gap = q
                    .iter()
                    .zip(&first)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(gap < 1e-9, "pieces do not meet: {gap}");
            }
            prev = Some(position(&traj, p.interval, p.s1));
            // Max-norm arc length by fine sampling.
            let m = 200;
            for k in 0..m {
                let a = position(
                    &traj,
                    p.interval,
                    p.s0 + (p.s1 - p.s0) * k as f64 / m as f64,
                );
                let b = position(
                    &traj,
                    p.interval,
                    p.s0 + (p.s1 - p.s0) * (k + 1) as f64 / m as f64,
                );
                arc += a
                    .iter()
                    .zip(&b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
            }
        }
        assert!((t_end - traj.duration()).abs() < 1e-12);
        assert!(
            count as f64 <= 1.5 * arc / res + all.len() as f64,
            "case {case}: {count} samples for arc {arc} at {res} ({} pieces)",
            all.len()
        );
    }
}
