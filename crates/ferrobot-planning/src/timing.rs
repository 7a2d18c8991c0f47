//! Time parametrisation: durations of the waypoint segments such that the
//! spline ([`crate::spline::Trajectory`]) respects velocity, acceleration
//! and jerk limits.
//!
//! Segment durations start from the time each segment needs at the
//! velocity and acceleration limits, then each segment is stretched or
//! shrunk by its own limit ratio for a few rounds (segments that are far
//! from their limits get faster, offending ones slower). A final uniform
//! time scaling by the largest ratio makes the limits hold exactly:
//! stretching time by `k` divides velocities by `k`, accelerations by `k^2`
//! and jerks by `k^3` without changing the path.

use crate::limits::KinematicLimits;
use crate::spline::Trajectory;

/// Rounds of per-segment adjustment.
const ROUNDS: usize = 6;

/// Per-interval limit ratio: max over joints of
/// `max(v / vmax, sqrt(a / amax), cbrt(j / jmax))` (<= 1 means within limits).
pub fn interval_ratios(traj: &Trajectory, limits: &KinematicLimits) -> Vec<f64> {
    (0..traj.times.len() - 1)
        .map(|i| {
            (0..traj.dim())
                .map(|d| {
                    (traj.max_speed(i, d) / limits.velocity[d])
                        .max((traj.max_acceleration(i, d) / limits.acceleration[d]).sqrt())
                        .max((traj.jerk(i, d) / limits.jerk[d]).cbrt())
                })
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Time a rest-to-rest move over `delta` needs at the velocity and
/// acceleration limits (the slowest joint decides).
fn segment_time(a: &[f64], b: &[f64], limits: &KinematicLimits) -> f64 {
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(d, (x, y))| {
            let delta = (y - x).abs();
            (1.5 * delta / limits.velocity[d]).max(2.0 * (delta / limits.acceleration[d]).sqrt())
        })
        .fold(1e-3, f64::max)
}

/// The time-parametrised smooth trajectory through `waypoints` (at least
/// two, consecutive ones distinct or not) within `limits`.
pub fn parametrize(waypoints: &[Vec<f64>], limits: &KinematicLimits) -> Trajectory {
    let mut durations: Vec<f64> = waypoints
        .windows(2)
        .map(|w| segment_time(&w[0], &w[1], limits))
        .collect();
    let mut traj = Trajectory::fit(waypoints, &durations);
    for _ in 0..ROUNDS {
        let ratios = interval_ratios(&traj, limits);
        let mut seg = vec![0.0f64; durations.len()];
        for (i, r) in ratios.iter().enumerate() {
            let s = traj.segment_of[i];
            seg[s] = seg[s].max(*r);
        }
        if seg.iter().all(|r| (0.95..=1.0).contains(r)) {
            break;
        }
        for (d, r) in durations.iter_mut().zip(&seg) {
            *d *= r.clamp(0.5, 2.0);
        }
        traj = Trajectory::fit(waypoints, &durations);
    }
    let worst = interval_ratios(&traj, limits)
        .into_iter()
        .fold(0.0, f64::max);
    if worst > 1.0 {
        // Uniform scaling keeps the shape and meets every limit.
        durations
            .iter_mut()
            .for_each(|d| *d *= worst * (1.0 + 1e-9));
        traj = Trajectory::fit(waypoints, &durations);
    }
    traj
}

/// Rest-to-rest pieces through each waypoint segment, joined: follows the
/// waypoint polyline exactly (stopping at each waypoint).
pub fn parametrize_polyline(waypoints: &[Vec<f64>], limits: &KinematicLimits) -> Trajectory {
    let mut out = parametrize(&waypoints[..2], limits);
    for w in waypoints.windows(2).skip(1) {
        out.append(&parametrize(w, limits));
    }
    out
}
