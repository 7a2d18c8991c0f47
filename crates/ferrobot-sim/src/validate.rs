//! Valid ranges of the simulation's numeric inputs, checked at the API
//! boundary (the Python bindings call these before touching the world).
//!
//! Rapier computes in float32: values beyond its range overflow to
//! infinity or underflow to zero (a mass of 1e-45 kg becomes 0 and the body
//! freezes; gravity of 1e39 becomes infinite), and finite but huge efforts,
//! gains or velocities make a step blow up. The ranges below keep every
//! value representable in float32 with headroom for the solver, while
//! leaving every physically meaningful value for a manipulation scene
//! valid. Nothing is clamped: a value outside its range is an error naming
//! the argument.

use ferrobot_model::ranges::{Range, RangeError};

use crate::error::SimError;

impl From<RangeError> for SimError {
    fn from(e: RangeError) -> Self {
        SimError::InvalidArgument(e.0)
    }
}

/// The world's solver substeps per step (`WorldConfig::solver_iterations`):
/// each is a full constraint solve, so a step's cost grows linearly with
/// it; 4 is the default and 256 is far beyond what a manipulation scene
/// needs (a larger count only makes a step take minutes).
pub const WORLD_SOLVER_ITERATIONS: Range = Range {
    name: "solver_iterations",
    min: 1.0,
    max: 256.0,
    unit: "substeps",
};

/// A robot's extra solver substeps while it touches something
/// (`RobotOptions::solver_iterations`, `Robot::set_solver_iterations`): 0
/// to 256, for the same reason as [`WORLD_SOLVER_ITERATIONS`].
pub const ROBOT_SOLVER_ITERATIONS: Range = Range {
    name: "solver_iterations",
    min: 0.0,
    max: 256.0,
    unit: "substeps",
};

/// Joint efforts (N·m or N), per joint, either sign.
pub const EFFORT: Range = Range {
    name: "efforts",
    min: -1e6,
    max: 1e6,
    unit: "N·m or N",
};

/// Joint and body velocities (rad/s or m/s), per component, either sign:
/// representable in float32 with headroom. Bodies faster than
/// `world::DIVERGENCE_SPEED` are reported by the step as `Diverged`.
pub const VELOCITY: Range = Range {
    name: "velocity",
    min: -1e6,
    max: 1e6,
    unit: "rad/s or m/s",
};

/// Joint position targets and positions (rad or m).
pub const POSITION: Range = Range {
    name: "position",
    min: -1e4,
    max: 1e4,
    unit: "rad or m",
};

/// Drive stiffness (N·m/rad or N/m) and damping (N·m·s/rad or N·s/m).
pub const GAIN: Range = Range {
    name: "gain",
    min: 0.0,
    max: 1e9,
    unit: "",
};

/// Drive and gripper force limits (N·m or N); `inf` means unlimited.
pub const MAX_FORCE: Range = Range {
    name: "max_force",
    min: 0.0,
    max: 1e9,
    unit: "N·m or N",
};

/// Body masses (kg).
pub const MASS: Range = Range {
    name: "mass",
    min: 1e-6,
    max: 1e6,
    unit: "kg",
};

/// Gravity, per component (m/s²).
pub const GRAVITY: Range = Range {
    name: "gravity",
    min: -1e3,
    max: 1e3,
    unit: "m/s²",
};

/// Friction and restitution coefficients.
pub const COEFFICIENT: Range = Range {
    name: "friction",
    min: 0.0,
    max: 1e3,
    unit: "",
};

/// Object positions (m) per component.
pub const COORDINATE: Range = Range {
    name: "position",
    min: -1e6,
    max: 1e6,
    unit: "m",
};

/// Sampling period of a trajectory given to `execute_trajectory` (s).
pub const TRAJECTORY_DT: Range = Range {
    name: "dt",
    min: 1e-6,
    max: 3600.0,
    unit: "s",
};

/// Time held at the last point of an executed trajectory (s).
pub const SETTLE_TIME: Range = Range {
    name: "settle_time",
    min: 0.0,
    max: 3600.0,
    unit: "s",
};

/// Largest number of physics steps one call may run (`step(n)`, a
/// trajectory execution): about an hour of simulated time at 240 Hz, and
/// the size of the per-step report buffers.
pub const MAX_STEPS_PER_CALL: usize = 1_000_000;

/// Checks every value of `values` against `range`, naming `what[i]`.
pub fn check_all(range: &Range, what: &str, values: &[f64]) -> Result<(), SimError> {
    for (i, &v) in values.iter().enumerate() {
        if values.len() == 1 {
            range.check_as(what, v)?;
        } else {
            range.check_as(&format!("{what}[{i}]"), v)?;
        }
    }
    Ok(())
}

/// Like [`check_all`] but `+inf` passes (an unlimited force).
pub fn check_all_or_inf(range: &Range, what: &str, values: &[f64]) -> Result<(), SimError> {
    for (i, &v) in values.iter().enumerate() {
        if v != f64::INFINITY {
            range.check_as(&format!("{what}[{i}]"), v)?;
        }
    }
    Ok(())
}

/// Steps needed to run `duration` seconds at time step `dt`, refused
/// above [`MAX_STEPS_PER_CALL`].
pub fn steps_for(what: &str, duration: f64, dt: f64) -> Result<usize, SimError> {
    Ok(ferrobot_model::ranges::step_count(
        what,
        duration,
        dt,
        MAX_STEPS_PER_CALL,
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_refuse_float32_overflow_and_underflow() {
        assert!(check_all(&MASS, "mass", &[1e-45]).is_err());
        assert!(check_all(&MASS, "mass", &[1e39]).is_err());
        assert!(check_all(&GRAVITY, "gravity", &[0.0, 0.0, 1e39]).is_err());
        assert!(check_all(&VELOCITY, "qd", &[1e30]).is_err());
        assert!(check_all(&EFFORT, "efforts", &[1e12]).is_err());
        assert!(check_all(&EFFORT, "efforts", &[87.0, -12.0]).is_ok());
        assert!(check_all_or_inf(&MAX_FORCE, "max_force", &[f64::INFINITY]).is_ok());
        assert!(check_all_or_inf(&MAX_FORCE, "max_force", &[f64::NAN]).is_err());
        assert!(steps_for("settle_time", 1e12, 1.0 / 240.0).is_err());
        assert_eq!(steps_for("t", 1.0, 0.25).unwrap(), 4);
    }
}
