//! The smooth trajectory: a C2 cubic spline through the waypoints that
//! starts and ends at rest (zero velocity and acceleration).
//!
//! Among all C2 functions through given knots at given times, the cubic
//! spline minimises the integral of the squared acceleration, so fitting it
//! is the exact solution of the minimum-acceleration trajectory problem for
//! those knots. Zero end accelerations need two more degrees of freedom than
//! a clamped spline has: two *free knots* are inserted in the first and last
//! segments and their positions solved for together with the knot
//! accelerations (one linear system shared by every joint). A two-waypoint
//! spline is a straight line in joint space (every joint follows the same
//! normalised profile), so concatenating rest-to-rest pieces follows the
//! waypoint polyline exactly.

use nalgebra::DMatrix;

/// A piecewise-cubic trajectory in the active space.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Trajectory {
    /// Knot times, starting at 0, increasing.
    pub times: Vec<f64>,
    /// Knot positions (one row per knot).
    pub positions: Vec<Vec<f64>>,
    /// Knot accelerations (the spline's moments).
    pub accelerations: Vec<Vec<f64>>,
    /// For each interval, the waypoint segment it belongs to.
    pub segment_of: Vec<usize>,
}

/// Position, velocity and acceleration of one joint on one interval.
#[inline]
fn eval(h: f64, y0: f64, y1: f64, m0: f64, m1: f64, s: f64) -> (f64, f64, f64) {
    // s: time since the interval's start; r: time to its end.
    let r = h - s;
    let q = m0 * r * r * r / (6.0 * h)
        + m1 * s * s * s / (6.0 * h)
        + (y0 / h - m0 * h / 6.0) * r
        + (y1 / h - m1 * h / 6.0) * s;
    let v = -m0 * r * r / (2.0 * h) + m1 * s * s / (2.0 * h) + (y1 - y0) / h - (m1 - m0) * h / 6.0;
    let a = (m0 * r + m1 * s) / h;
    (q, v, a)
}

impl Trajectory {
    /// Fits the rest-to-rest C2 spline through `waypoints` (at least two),
    /// spending `durations[s]` (positive) on waypoint segment `s`.
    pub fn fit(waypoints: &[Vec<f64>], durations: &[f64]) -> Self {
        let m = waypoints.len() - 1;
        assert!(m >= 1 && durations.len() == m, "fit needs >= 2 waypoints");
        let dim = waypoints[0].len();
        // Knots: (time, Some(waypoint) or None for a free knot, segment).
        let mut knots: Vec<(f64, Option<usize>)> = Vec::with_capacity(m + 3);
        let mut segment_of = Vec::with_capacity(m + 2);
        let mut t = 0.0;
        knots.push((0.0, Some(0)));
        for (s, &d) in durations.iter().enumerate() {
            let free: &[f64] = if m == 1 {
                &[1.0 / 3.0, 2.0 / 3.0]
            } else if s == 0 || s == m - 1 {
                &[0.5]
            } else {
                &[]
            };
            for &f in free {
                knots.push((t + d * f, None));
                segment_of.push(s);
            }
            t += d;
            knots.push((t, Some(s + 1)));
            segment_of.push(s);
        }
        let n = knots.len() - 1; // intervals
        let h: Vec<f64> = knots.windows(2).map(|w| w[1].0 - w[0].0).collect();
        let free_index: Vec<Option<usize>> = {
            let mut k = 0;
            knots
                .iter()
                .map(|(_, w)| {
                    if w.is_none() {
                        k += 1;
                        Some(n + k)
                    } else {
                        None
                    }
                })
                .collect()
        };
        let size = n + 3;
        let mut a = DMatrix::<f64>::zeros(size, size);
        let mut b = DMatrix::<f64>::zeros(size, dim);
        // Adds `coef * y_knot` to row `row` (matrix if free, else RHS).
        let add_y = |a: &mut DMatrix<f64>,
                     b: &mut DMatrix<f64>,
                     row: usize,
                     knot: usize,
                     coef: f64| {
            match (knots[knot].1, free_index[knot]) {
                (Some(w), _) => {
                    for d in 0..dim {
                        b[(row, d)] -= coef * waypoints[w][d];
                    }
                }
                (None, Some(col)) => a[(row, col)] += coef,
                (None, None) => unreachable!(),
            }
        };
        // Zero accelerations at both ends.
        a[(0, 0)] = 1.0;
        a[(1, n)] = 1.0;
        // Zero velocity at the start: (y1 - y0)/h0 - h0 (2 M0 + M1)/6 = 0.
        add_y(&mut a, &mut b, 2, 1, 1.0 / h[0]);
        add_y(&mut a, &mut b, 2, 0, -1.0 / h[0]);
        a[(2, 0)] -= h[0] / 3.0;
        a[(2, 1)] -= h[0] / 6.0;
        // Zero velocity at the end: (yN - yN-1)/h + h (MN-1 + 2 MN)/6 = 0.
        let hl = h[n - 1];
        add_y(&mut a, &mut b, 3, n, 1.0 / hl);
        add_y(&mut a, &mut b, 3, n - 1, -1.0 / hl);
        a[(3, n - 1)] += hl / 6.0;
        a[(3, n)] += hl / 3.0;
        // Continuity of the acceleration's slope at interior knots.
        for i in 1..n {
            let row = 3 + i;
            a[(row, i - 1)] += h[i - 1];
            a[(row, i)] += 2.0 * (h[i - 1] + h[i]);
            a[(row, i + 1)] += h[i];
            add_y(&mut a, &mut b, row, i + 1, -6.0 / h[i]);
            add_y(&mut a, &mut b, row, i, 6.0 / h[i] + 6.0 / h[i - 1]);
            add_y(&mut a, &mut b, row, i - 1, -6.0 / h[i - 1]);
        }
        let x = a
            .lu()
            .solve(&b)
            .expect("the spline system is non-singular for positive durations");
        let positions = knots
            .iter()
            .enumerate()
            .map(|(k, (_, w))| match w {
                Some(w) => waypoints[*w].clone(),
                None => (0..dim).map(|d| x[(free_index[k].unwrap(), d)]).collect(),
            })
            .collect();
        let accelerations = (0..=n)
            .map(|i| (0..dim).map(|d| x[(i, d)]).collect())
            .collect();
        Self {
            times: knots.iter().map(|k| k.0).collect(),
            positions,
            accelerations,
            segment_of,
        }
    }

    /// Number of joints.
    pub fn dim(&self) -> usize {
        self.positions[0].len()
    }

    /// Total duration (s).
    pub fn duration(&self) -> f64 {
        *self.times.last().expect("non-empty")
    }

    /// Interval holding time `t` (clamped to the trajectory).
    fn interval(&self, t: f64) -> usize {
        let n = self.times.len() - 1;
        self.times.partition_point(|&x| x <= t).clamp(1, n) - 1
    }

    /// Position, velocity and acceleration at time `t` (clamped to
    /// `[0, duration]`), written into the three slices.
    pub fn sample_into(&self, t: f64, q: &mut [f64], v: &mut [f64], a: &mut [f64]) {
        let t = t.clamp(0.0, self.duration());
        let i = self.interval(t);
        let h = self.times[i + 1] - self.times[i];
        let s = t - self.times[i];
        for d in 0..self.dim() {
            let (qq, vv, aa) = eval(
                h,
                self.positions[i][d],
                self.positions[i + 1][d],
                self.accelerations[i][d],
                self.accelerations[i + 1][d],
                s,
            );
            q[d] = qq;
            v[d] = vv;
            a[d] = aa;
        }
    }

    /// Position at time `s` since the start of interval `i` (`0 <= s <=`
    /// the interval's length), written into `q`.
    pub fn position_on(&self, i: usize, s: f64, q: &mut [f64]) {
        let h = self.times[i + 1] - self.times[i];
        for (d, out) in q.iter_mut().enumerate().take(self.dim()) {
            *out = eval(
                h,
                self.positions[i][d],
                self.positions[i + 1][d],
                self.accelerations[i][d],
                self.accelerations[i + 1][d],
                s,
            )
            .0;
        }
    }

    /// Samples every `dt` from 0, the last sample at the end exactly:
    /// (times, positions, velocities, accelerations), row-major.
    pub fn interpolated(&self, dt: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let dim = self.dim();
        let total = self.duration();
        // `as` saturates; callers bound the count (ranges::SAMPLE_DT and
        // ranges::MAX_TRAJECTORY_SAMPLES) before sampling.
        let steps = ((total / dt) - 1e-9).ceil().max(0.0) as usize;
        let mut times: Vec<f64> = (0..steps).map(|k| k as f64 * dt).collect();
        times.push(total);
        let mut q = vec![0.0; times.len() * dim];
        let mut v = q.clone();
        let mut a = q.clone();
        for (k, &t) in times.iter().enumerate() {
            let r = k * dim..(k + 1) * dim;
            self.sample_into(t, &mut q[r.clone()], &mut v[r.clone()], &mut a[r]);
        }
        (times, q, v, a)
    }

    /// Largest |velocity| of joint `d` on interval `i`.
    pub fn max_speed(&self, i: usize, d: usize) -> f64 {
        let h = self.times[i + 1] - self.times[i];
        let (y0, y1) = (self.positions[i][d], self.positions[i + 1][d]);
        let (m0, m1) = (self.accelerations[i][d], self.accelerations[i + 1][d]);
        let mut best = eval(h, y0, y1, m0, m1, 0.0)
            .1
            .abs()
            .max(eval(h, y0, y1, m0, m1, h).1.abs());
        // Inside the interval the velocity peaks where the acceleration
        // (linear in time) crosses zero.
        if m0 * m1 < 0.0 {
            let s = h * m0 / (m0 - m1);
            best = best.max(eval(h, y0, y1, m0, m1, s).1.abs());
        }
        best
    }

    /// Largest |acceleration| of joint `d` on interval `i`.
    pub fn max_acceleration(&self, i: usize, d: usize) -> f64 {
        self.accelerations[i][d]
            .abs()
            .max(self.accelerations[i + 1][d].abs())
    }

    /// |jerk| of joint `d` on interval `i` (constant on an interval).
    pub fn jerk(&self, i: usize, d: usize) -> f64 {
        (self.accelerations[i + 1][d] - self.accelerations[i][d]).abs()
            / (self.times[i + 1] - self.times[i])
    }

    /// Appends `other`, which must start where this ends, at rest.
    pub fn append(&mut self, other: &Trajectory) {
        let t0 = self.duration();
        let seg0 = self.segment_of.last().map_or(0, |s| s + 1);
        self.times.extend(other.times[1..].iter().map(|t| t + t0));
        self.positions.extend_from_slice(&other.positions[1..]);
        self.accelerations
            .extend_from_slice(&other.accelerations[1..]);
        self.segment_of
            .extend(other.segment_of.iter().map(|s| s + seg0));
    }
}
