//! Executing a planned joint trajectory: positions sampled at `dt` become
//! drive targets at every physics step (linear interpolation between
//! samples, velocities as feed-forward), and the tracking error is
//! recorded.

use crate::drives::resolve_indices;
use crate::error::{Result, SimError, check_finite};
use crate::world::World;

/// What happened while executing a trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackingReport {
    /// Number of joints tracked (columns).
    pub num_joints: usize,
    /// Time after each physics step, from the start (s).
    pub times: Vec<f64>,
    /// Desired positions at those times (row-major, steps x joints).
    pub desired: Vec<f64>,
    /// Measured positions after each step (row-major, steps x joints).
    pub actual: Vec<f64>,
    /// Largest |actual − desired| per joint.
    pub max_error: Vec<f64>,
    /// Root-mean-square error per joint.
    pub rms_error: Vec<f64>,
    /// |actual − desired| per joint after the last step.
    pub final_error: Vec<f64>,
}

/// Runs `positions` (row-major, `N x k` for the `k` joints `joint_indices`,
/// all DOFs when `None`) sampled every `dt` seconds on robot `robot`:
/// each physics step sets the position target to the trajectory
/// interpolated at the end of the step and the velocity target to its
/// slope (or to `velocities` interpolated when given), steps once and
/// records the error. After the last sample the final point is held for
/// `settle_time` seconds.
pub fn execute_trajectory(
    world: &mut World,
    robot: usize,
    positions: &[f64],
    dt: f64,
    velocities: Option<&[f64]>,
    joint_indices: Option<&[usize]>,
    settle_time: f64,
) -> Result<TrackingReport> {
    let ix = resolve_indices(world.robot(robot)?, joint_indices)?;
    let k = ix.len();
    if k == 0 || positions.is_empty() || !positions.len().is_multiple_of(k) {
        return Err(SimError::Shape {
            what: "positions".into(),
            expected: format!("(N, {k}) with N >= 1"),
            got: format!("{} values", positions.len()),
        });
    }
    check_finite("positions", positions)?;
    if let Some(v) = velocities {
        if v.len() != positions.len() {
            return Err(SimError::Shape {
                what: "velocities".into(),
                expected: format!("the shape of positions ({} values)", positions.len()),
                got: format!("{} values", v.len()),
            });
        }
        check_finite("velocities", v)?;
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SimError::InvalidArgument(format!(
            "dt must be > 0, got {dt}"
        )));
    }
    if !(settle_time.is_finite() && settle_time >= 0.0) {
        return Err(SimError::InvalidArgument(format!(
            "settle_time must be >= 0, got {settle_time}"
        )));
    }
    let n = positions.len() / k;
    let h = world.config().dt;
    let duration = (n - 1) as f64 * dt;
    let steps = ((duration + settle_time) / h - 1e-9).ceil().max(1.0) as usize;
    let sample = |t: f64| -> (Vec<f64>, Vec<f64>) {
        let s = (t / dt).clamp(0.0, (n - 1) as f64);
        let i = (s.floor() as usize).min(n.saturating_sub(2));
        let a = if n == 1 { 0.0 } else { s - i as f64 };
        let row = |r: usize| &positions[r * k..(r + 1) * k];
        if n == 1 {
            return (row(0).to_vec(), vec![0.0; k]);
        }
        let (p0, p1) = (row(i), row(i + 1));
        let p: Vec<f64> = (0..k).map(|j| p0[j] + a * (p1[j] - p0[j])).collect();
        let v: Vec<f64> = if t > duration {
            vec![0.0; k]
        } else if let Some(vel) = velocities {
            let (v0, v1) = (&vel[i * k..(i + 1) * k], &vel[(i + 1) * k..(i + 2) * k]);
            (0..k).map(|j| v0[j] + a * (v1[j] - v0[j])).collect()
        } else {
            (0..k).map(|j| (p1[j] - p0[j]) / dt).collect()
        };
        (p, v)
    };
    let mut report = TrackingReport {
        num_joints: k,
        times: Vec::with_capacity(steps),
        desired: Vec::with_capacity(steps * k),
        actual: Vec::with_capacity(steps * k),
        max_error: vec![0.0; k],
        rms_error: vec![0.0; k],
        final_error: vec![0.0; k],
    };
    for s in 0..steps {
        let t = (s + 1) as f64 * h;
        let (p, v) = sample(t);
        world.with_robot(robot, |r, state| {
            r.set_position_targets(state, &p, Some(&ix))?;
            r.set_velocity_targets(state, &v, Some(&ix))
        })?;
        world.step(1)?;
        let q = world.robot(robot)?.joint_positions(world.state());
        report.times.push(t);
        for (j, &d) in ix.iter().enumerate() {
            let e = (q[d] - p[j]).abs();
            report.max_error[j] = report.max_error[j].max(e);
            report.rms_error[j] += e * e;
            report.final_error[j] = e;
            report.desired.push(p[j]);
            report.actual.push(q[d]);
        }
    }
    for r in &mut report.rms_error {
        *r = (*r / steps as f64).sqrt();
    }
    Ok(report)
}
