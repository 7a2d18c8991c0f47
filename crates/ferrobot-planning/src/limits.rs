//! Kinematic limits of the active DOFs: position, velocity, acceleration and
//! jerk, with defaults for arms whose data sheets give them.

use ferrobot_model::{JointKind, RobotModel};

use crate::error::{PlanningError, Result, check_positive};

/// Acceleration (rad/s²) and jerk (rad/s³) limits of the Franka Emika Panda
/// joints 1-7, from Franka's published robot specifications.
const PANDA_ACCELERATION: [f64; 7] = [15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0];
const PANDA_JERK: [f64; 7] = [7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0];

/// Default velocity where the URDF gives none (rad/s, or m/s for prismatic).
pub const DEFAULT_VELOCITY: [f64; 2] = [1.0, 0.2];
/// Default acceleration for joints without a known data sheet (rad/s², m/s²).
pub const DEFAULT_ACCELERATION: [f64; 2] = [10.0, 2.0];
/// Default jerk for joints without a known data sheet (rad/s³, m/s³).
pub const DEFAULT_JERK: [f64; 2] = [500.0, 100.0];

/// How far (rad, or m for prismatic joints) a start or goal configuration
/// may lie outside a position limit and still be planned for: such
/// excesses (benchmark start states a few µrad outside the URDF limits, as
/// recorded by real controllers) are clamped onto the limit before
/// planning, and the plan starts (or ends) at the clamped configuration.
/// Beyond it, the plan fails with `StartOutOfLimits` / `GoalOutOfLimits`.
pub const LIMIT_TOLERANCE: f64 = 1e-5;

/// Limits of the active DOFs, in active order.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicLimits {
    /// Lower position limits.
    pub lower: Vec<f64>,
    /// Upper position limits.
    pub upper: Vec<f64>,
    /// Velocity limits (positive).
    pub velocity: Vec<f64>,
    /// Acceleration limits (positive).
    pub acceleration: Vec<f64>,
    /// Jerk limits (positive).
    pub jerk: Vec<f64>,
}

impl KinematicLimits {
    /// Limits of `dofs` of `model`: positions and velocities from the URDF
    /// (the documented defaults where it has none), accelerations and jerks
    /// from the Panda's data sheet for `panda_joint1..7`, else the defaults.
    pub fn from_model(model: &RobotModel, dofs: &[usize]) -> Self {
        let (lo, hi, vel) = (
            model.lower_limits(),
            model.upper_limits(),
            model.velocity_limits(),
        );
        let mut out = Self {
            lower: Vec::new(),
            upper: Vec::new(),
            velocity: Vec::new(),
            acceleration: Vec::new(),
            jerk: Vec::new(),
        };
        for &d in dofs {
            let joint = &model.joints()[model.dof_joints()[d]];
            let k = usize::from(joint.kind == JointKind::Prismatic);
            let panda = joint
                .name
                .strip_prefix("panda_joint")
                .and_then(|n| n.parse::<usize>().ok())
                .filter(|n| (1..=7).contains(n));
            out.lower.push(lo[d]);
            out.upper.push(hi[d]);
            out.velocity.push(if vel[d].is_finite() && vel[d] > 0.0 {
                vel[d]
            } else {
                DEFAULT_VELOCITY[k]
            });
            out.acceleration
                .push(panda.map_or(DEFAULT_ACCELERATION[k], |n| PANDA_ACCELERATION[n - 1]));
            out.jerk
                .push(panda.map_or(DEFAULT_JERK[k], |n| PANDA_JERK[n - 1]));
        }
        out
    }

    /// Number of DOFs.
    pub fn len(&self) -> usize {
        self.lower.len()
    }

    /// Whether there are no DOFs.
    pub fn is_empty(&self) -> bool {
        self.lower.is_empty()
    }

    /// Velocity and acceleration limits scaled by factors in (0, 1] (jerk
    /// scales with the acceleration factor), as MoveIt's scaling factors.
    pub fn scaled(&self, velocity_scale: f64, acceleration_scale: f64) -> Result<Self> {
        for (what, s) in [
            ("velocity_scale", velocity_scale),
            ("acceleration_scale", acceleration_scale),
        ] {
            check_positive(what, s)?;
            if s > 1.0 {
                return Err(PlanningError::InvalidArgument(format!(
                    "{what} must be in (0, 1], got {s}"
                )));
            }
        }
        let mut out = self.clone();
        out.velocity.iter_mut().for_each(|v| *v *= velocity_scale);
        out.acceleration
            .iter_mut()
            .for_each(|a| *a *= acceleration_scale);
        out.jerk.iter_mut().for_each(|j| *j *= acceleration_scale);
        Ok(out)
    }

    /// Replaces the acceleration or jerk limits, checking length and sign.
    pub fn set(&mut self, what: &str, values: &[f64]) -> Result<()> {
        if values.len() != self.len() {
            return Err(PlanningError::InvalidArgument(format!(
                "{what} limits need {} values (active DOFs), got {}",
                self.len(),
                values.len()
            )));
        }
        for &v in values {
            check_positive(what, v)?;
        }
        let target = match what {
            "velocity" => &mut self.velocity,
            "acceleration" => &mut self.acceleration,
            "jerk" => &mut self.jerk,
            other => {
                return Err(PlanningError::InvalidArgument(format!(
                    "unknown limit kind '{other}' (velocity, acceleration, jerk)"
                )));
            }
        };
        target.copy_from_slice(values);
        Ok(())
    }

    /// Whether `q` lies within the position limits (with `tol` slack).
    pub fn contains(&self, q: &[f64], tol: f64) -> bool {
        q.iter()
            .zip(self.lower.iter().zip(&self.upper))
            .all(|(v, (lo, hi))| *v >= lo - tol && *v <= hi + tol)
    }

    /// `q` clamped into the limits when no value lies more than `tol`
    /// outside them, else `None`.
    pub fn clamp_within(&self, q: &[f64], tol: f64) -> Option<Vec<f64>> {
        self.contains(q, tol).then(|| {
            q.iter()
                .zip(self.lower.iter().zip(&self.upper))
                .map(|(v, (lo, hi))| v.max(*lo).min(*hi))
                .collect()
        })
    }
}
