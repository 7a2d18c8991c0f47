//! Which configurations of a smooth trajectory the planner re-checks for
//! collision, and in which order.
//!
//! The trajectory ([`crate::spline::Trajectory`]) is cut into *pieces*
//! (sub-intervals of its spline intervals). On each piece two exact bounds
//! are computed from the cubic polynomials:
//!
//! - the largest joint speed (the velocity of a cubic is a quadratic: its
//!   largest magnitude on a range is at an end or where the acceleration
//!   crosses zero), which gives the fewest uniformly spaced samples such that
//!   no joint moves more than the resolution between consecutive samples
//!   (`|q(t2) - q(t1)| <= max|v| * (t2 - t1)`);
//! - the largest distance (max norm over joints) from the piece to the
//!   straight waypoint segment it belongs to (see
//!   [`deviation_bound`]): every edge of the planner's path was checked free
//!   at the resolution before the trajectory is made, so a piece within
//!   [`SKIP_DEVIATION`] x resolution of its segment lies on the verified
//!   path (to that tolerance) and is not sampled again.
//!
//! The pieces left are checked in order of decreasing deviation (the parts
//! furthest from the verified path first), in chunks, stopping at the first
//! collision: a trajectory that needs refining is found out after a few
//! hundred configurations, not after all of them. A rest-to-rest trajectory
//! through two waypoints is the straight segment itself (every joint follows
//! the same normalised profile), so it needs no re-check at all.

use crate::spline::Trajectory;

/// Pieces within this fraction of the resolution (max norm over joints,
/// rad or m) of their verified waypoint segment are not sampled again:
/// every configuration on them lies within `0.1 * resolution` of the path
/// checked at the resolution.
pub const SKIP_DEVIATION: f64 = 0.1;

/// Added to every deviation bound for rounding (rad or m).
const ROUNDING: f64 = 1e-10;

/// Pieces whose deviation bound is at most this (rad or m) lie on their
/// waypoint segment up to rounding (rest-to-rest pieces, straight spline
/// intervals): a segment certified free (with no tube) covers them, since
/// the certificates' slack (`ferrobot_collision::certify::CERTIFY_SLACK`,
/// 2 µm) is far above this times any robot's lever (m per rad).
pub const ON_SEGMENT: f64 = 1e-9;

/// Samples per piece aimed at (pieces are shorter where the trajectory
/// bends, so the deviation bound stays tight).
const SAMPLES_PER_PIECE: f64 = 8.0;

/// Most pieces per spline interval.
const MAX_PIECES: usize = 256;

/// A sub-interval of one spline interval and what checking it takes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Spline interval.
    pub interval: usize,
    /// Start, as time since the interval's start (s).
    pub s0: f64,
    /// End, as time since the interval's start (s).
    pub s1: f64,
    /// Uniform steps over the piece such that no joint moves more than the
    /// resolution between consecutive samples (at least 1).
    pub steps: usize,
    /// Bound on the max-norm distance from the piece to its waypoint
    /// segment (infinite when no waypoints were given).
    pub deviation: f64,
}

/// Coefficients `[c0, c1, c2, c3]` of joint `d` on interval `i` as a
/// polynomial in the time `s` since the interval's start.
fn cubic(traj: &Trajectory, i: usize, d: usize) -> [f64; 4] {
    let h = traj.times[i + 1] - traj.times[i];
    let (y0, y1) = (traj.positions[i][d], traj.positions[i + 1][d]);
    let (m0, m1) = (traj.accelerations[i][d], traj.accelerations[i + 1][d]);
    let v0 = -m0 * h / 2.0 + (y1 - y0) / h - (m1 - m0) * h / 6.0;
    [y0, v0, m0 / 2.0, (m1 - m0) / (6.0 * h)]
}

fn poly(c: &[f64; 4], s: f64) -> f64 {
    ((c[3] * s + c[2]) * s + c[1]) * s + c[0]
}

/// Smallest and largest value of the cubic `c` on `[s0, s1]` (at the ends
/// or where its derivative vanishes inside).
fn cubic_range(c: &[f64; 4], s0: f64, s1: f64) -> (f64, f64) {
    let (mut lo, mut hi) = {
        let (a, b) = (poly(c, s0), poly(c, s1));
        (a.min(b), a.max(b))
    };
    // Derivative 3 c3 s^2 + 2 c2 s + c1.
    let (a, b, k) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut visit = |s: f64| {
        if s > s0 && s < s1 {
            let v = poly(c, s);
            lo = lo.min(v);
            hi = hi.max(v);
        }
    };
    if a != 0.0 {
        let disc = b * b - 4.0 * a * k;
        if disc >= 0.0 {
            let r = disc.sqrt();
            visit((-b - r) / (2.0 * a));
            visit((-b + r) / (2.0 * a));
        }
    } else if b != 0.0 {
        visit(-k / b);
    }
    (lo, hi)
}

/// Largest |value| of the quadratic `q0 + q1 s + q2 s^2` on `[s0, s1]`.
fn quadratic_max_abs(q: [f64; 3], s0: f64, s1: f64) -> f64 {
    let f = |s: f64| (q[2] * s + q[1]) * s + q[0];
    let mut best = f(s0).abs().max(f(s1).abs());
    if q[2] != 0.0 {
        let s = -q[1] / (2.0 * q[2]);
        if s > s0 && s < s1 {
            best = best.max(f(s).abs());
        }
    }
    best
}

/// Largest |velocity| of each joint on `[s0, s1]` of interval `i`.
pub fn joint_speeds(traj: &Trajectory, i: usize, s0: f64, s1: f64) -> Vec<f64> {
    (0..traj.dim())
        .map(|d| {
            let c = cubic(traj, i, d);
            quadratic_max_abs([c[1], 2.0 * c[2], 3.0 * c[3]], s0, s1)
        })
        .collect()
}

/// Largest joint speed (max over joints of |velocity|) on `[s0, s1]` of
/// interval `i`.
pub fn max_speed(traj: &Trajectory, i: usize, s0: f64, s1: f64) -> f64 {
    (0..traj.dim())
        .map(|d| {
            let c = cubic(traj, i, d);
            quadratic_max_abs([c[1], 2.0 * c[2], 3.0 * c[3]], s0, s1)
        })
        .fold(0.0, f64::max)
}

/// A bound on the largest max-norm distance from the trajectory on
/// `[s0, s1]` of interval `i` to the straight segment from `a` to `b`.
///
/// With `r` the joint that moves most from `a` to `b` (`delta = b - a`),
/// every configuration `q(s)` is written as `a + u(s) delta + e(s)` where
/// `u(s) = (q_r(s) - a_r) / delta_r`; `u` and each residual `e_d` are cubics
/// whose ranges are exact. The point `a + clamp(u, 0, 1) delta` lies on the
/// segment and differs from `q(s)` by at most
/// `|e_d(s)| + dist(u(s), [0, 1]) |delta_d|` in joint `d`.
pub fn deviation_bound(traj: &Trajectory, i: usize, s0: f64, s1: f64, a: &[f64], b: &[f64]) -> f64 {
    let dim = traj.dim();
    let delta = |d: usize| b[d] - a[d];
    let r = (0..dim)
        .max_by(|&x, &y| delta(x).abs().total_cmp(&delta(y).abs()))
        .expect("at least one joint");
    let dr = delta(r);
    // u(s) as a cubic (0 for a segment of zero length).
    let u = if dr != 0.0 {
        let c = cubic(traj, i, r);
        [(c[0] - a[r]) / dr, c[1] / dr, c[2] / dr, c[3] / dr]
    } else {
        [0.0; 4]
    };
    let (ulo, uhi) = cubic_range(&u, s0, s1);
    let out = (-ulo).max(uhi - 1.0).max(0.0);
    let mut worst = 0.0f64;
    for (d, ad) in a.iter().enumerate().take(dim) {
        let (c, dd) = (cubic(traj, i, d), delta(d));
        let e = [
            c[0] - ad - u[0] * dd,
            c[1] - u[1] * dd,
            c[2] - u[2] * dd,
            c[3] - u[3] * dd,
        ];
        let (lo, hi) = cubic_range(&e, s0, s1);
        worst = worst.max(lo.abs().max(hi.abs()) + out * dd.abs());
    }
    // A rounding allowance (positions are O(1) rad or m, so rounding is
    // O(1e-15)): the residual of a joint that follows the reference joint
    // exactly is a difference of nearly equal terms.
    worst + ROUNDING
}

/// The pieces of `traj` for a re-check at `resolution` (max-norm joint step
/// between samples), with their deviation from the waypoint segments of
/// `waypoints` (the path the trajectory was fitted through, every segment
/// checked free at `resolution`), or without skipping when `None`.
pub fn pieces(traj: &Trajectory, resolution: f64, waypoints: Option<&[Vec<f64>]>) -> Vec<Piece> {
    let mut out = Vec::new();
    for i in 0..traj.times.len() - 1 {
        let h = traj.times[i + 1] - traj.times[i];
        // A whole interval within the tolerance is skipped without cutting
        // it (a sub-range's bound is never above the whole range's).
        let segment = waypoints.map(|w| (&w[traj.segment_of[i]], &w[traj.segment_of[i] + 1]));
        if let Some((a, b)) = segment {
            let whole = deviation_bound(traj, i, 0.0, h, a, b);
            if whole <= SKIP_DEVIATION * resolution {
                out.push(Piece {
                    interval: i,
                    s0: 0.0,
                    s1: h,
                    steps: (((h * max_speed(traj, i, 0.0, h)) / resolution).ceil() as usize).max(1),
                    deviation: whole,
                });
                continue;
            }
        }
        // Pieces of about SAMPLES_PER_PIECE samples at the interval's top speed.
        let top = max_speed(traj, i, 0.0, h);
        let k = ((h * top / resolution / SAMPLES_PER_PIECE).ceil() as usize).clamp(1, MAX_PIECES);
        for p in 0..k {
            let (s0, s1) = (h * p as f64 / k as f64, h * (p + 1) as f64 / k as f64);
            let speed = max_speed(traj, i, s0, s1);
            // `as` saturates; callers bound the resolution and the duration.
            let steps = (((s1 - s0) * speed / resolution).ceil() as usize).max(1);
            let deviation = match segment {
                Some((a, b)) => deviation_bound(traj, i, s0, s1, a, b),
                None => f64::INFINITY,
            };
            out.push(Piece {
                interval: i,
                s0,
                s1,
                steps,
                deviation,
            });
        }
    }
    out
}

/// The pieces to sample (deviation above `SKIP_DEVIATION * resolution`), in
/// the order to check them: furthest from the verified path first.
pub fn to_check(pieces: &[Piece], resolution: f64) -> Vec<Piece> {
    let mut out: Vec<Piece> = pieces
        .iter()
        .filter(|p| p.deviation > SKIP_DEVIATION * resolution)
        .copied()
        .collect();
    out.sort_by(|x, y| y.deviation.total_cmp(&x.deviation));
    out
}

/// The sample times of `piece` (time since its interval's start, s): both
/// ends and `steps - 1` uniformly spaced inside.
pub fn sample_times(piece: &Piece) -> impl Iterator<Item = f64> {
    let (s0, s1, steps) = (piece.s0, piece.s1, piece.steps);
    (0..=steps).map(move |k| {
        if k == steps {
            s1
        } else {
            s0 + (s1 - s0) * k as f64 / steps as f64
        }
    })
}
