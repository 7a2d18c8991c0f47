//! Documented valid ranges of the numeric parameters of ferrobot's public
//! API, shared by every crate and binding (the README's "Limits" section
//! lists the same table).
//!
//! A value outside its range is an error naming the parameter, the range
//! and the value: nothing is clamped. The ranges bound the work and memory
//! a call may take (a motion checked at a resolution of 1e-300 would need
//! more checks than fit in a `usize`; a trajectory sampled every 1e-9 s
//! needs gigabytes) while leaving every physically meaningful value valid.

use std::fmt;

/// A closed range `[min, max]` of valid values for a named parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// The parameter's name as the API spells it.
    pub name: &'static str,
    /// Smallest valid value.
    pub min: f64,
    /// Largest valid value.
    pub max: f64,
    /// Unit (SI) of the value, for messages.
    pub unit: &'static str,
}

/// A value outside its documented range (or a count over its limit).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RangeError(pub String);

impl fmt::Display for RangeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RangeError {}

impl Range {
    /// `value` if it is finite and inside the range, else an error naming
    /// the parameter (`what` overrides the range's own name when given).
    pub fn check(&self, value: f64) -> Result<f64, RangeError> {
        self.check_as(self.name, value)
    }

    /// [`Range::check`] naming the value `what`.
    pub fn check_as(&self, what: &str, value: f64) -> Result<f64, RangeError> {
        if value.is_finite() && value >= self.min && value <= self.max {
            Ok(value)
        } else {
            Err(RangeError(format!(
                "{what} must be in [{:e}, {:e}]{}, got {value:e}",
                self.min,
                self.max,
                if self.unit.is_empty() {
                    String::new()
                } else {
                    format!(" {}", self.unit)
                }
            )))
        }
    }
}

/// `n` if it lies in `[min, max]`, else an error naming `what`.
pub fn check_count(what: &str, n: usize, min: usize, max: usize) -> Result<usize, RangeError> {
    if (min..=max).contains(&n) {
        Ok(n)
    } else {
        Err(RangeError(format!(
            "{what} must be in [{min}, {max}], got {n}"
        )))
    }
}

/// The number of steps of size `step` needed to cover `span` (at least
/// 1), or an error if it exceeds `max` (computed in floating point first,
/// so that no step count overflows).
pub fn step_count(what: &str, span: f64, step: f64, max: usize) -> Result<usize, RangeError> {
    let steps = (span / step).ceil();
    if !(steps.is_finite() && steps <= max as f64) {
        return Err(RangeError(format!(
            "{what}: covering {span:e} in steps of {step:e} needs {steps:e} steps, more than the limit {max}; use a larger step"
        )));
    }
    Ok((steps as usize).max(1))
}

/// Motion-check resolution (rad or m between checked configurations):
/// finer than 1e-6 only multiplies work (below float32 kernel precision
/// over a joint range), coarser than 1 rad can step over whole obstacles.
pub const RESOLUTION: Range = Range {
    name: "resolution",
    min: 1e-6,
    max: 1.0,
    unit: "rad or m",
};

/// Largest number of configurations one motion check may test (about one
/// second of single-thread checking).
pub const MAX_MOTION_CHECKS: usize = 20_000_000;

/// Trajectory sampling period `dt` (s) of `interpolated`.
pub const SAMPLE_DT: Range = Range {
    name: "dt",
    min: 1e-6,
    max: 3600.0,
    unit: "s",
};

/// Largest number of samples of an interpolated trajectory (memory:
/// samples x DOFs x 3 arrays of float64).
pub const MAX_TRAJECTORY_SAMPLES: usize = 2_000_000;

/// Planning and IK time limits (s).
pub const TIME_LIMIT: Range = Range {
    name: "time_limit",
    min: 1e-6,
    max: 86_400.0,
    unit: "s",
};

/// RRT extension range (rad or m per tree step).
pub const RRT_RANGE: Range = Range {
    name: "range",
    min: 1e-4,
    max: 1e3,
    unit: "rad or m",
};

/// Largest number of RRT samples (each stored tree node costs memory).
pub const MAX_RRT_SAMPLES: usize = 5_000_000;

/// Coarse-to-fine resolution factor of the planner.
pub const COARSE_FACTOR: Range = Range {
    name: "coarse_factor",
    min: 1.0,
    max: 1e3,
    unit: "",
};

/// Largest number of goal IK solutions the planner keeps.
pub const MAX_GOAL_SOLUTIONS: usize = 10_000;

/// IK position tolerance (m).
pub const POSITION_TOLERANCE: Range = Range {
    name: "position_tolerance",
    min: 1e-12,
    max: 10.0,
    unit: "m",
};

/// IK rotation tolerance (rad).
pub const ROTATION_TOLERANCE: Range = Range {
    name: "rotation_tolerance",
    min: 1e-12,
    max: std::f64::consts::PI,
    unit: "rad",
};

/// Largest number of IK seeds per goal.
pub const MAX_IK_SEEDS: usize = 100_000;

/// Largest number of IK iterations per seed.
pub const MAX_IK_ITERATIONS: usize = 1_000_000;

/// Velocity and acceleration scales of time parametrisation (fractions of
/// the limits).
pub const SPEED_SCALE: Range = Range {
    name: "velocity_scale",
    min: 1e-6,
    max: 1.0,
    unit: "",
};

/// Collision margin (m) added to every robot sphere: negative values
/// shrink spheres, but never by more than 1 m.
pub const MARGIN: Range = Range {
    name: "margin",
    min: -1.0,
    max: 10.0,
    unit: "m",
};

/// Sizes, radii and lengths of world shapes (m).
pub const SHAPE_SIZE: Range = Range {
    name: "size",
    min: 1e-9,
    max: 1e4,
    unit: "m",
};

/// Coordinates of points and positions (m): |x| beyond 1e6 m is no robot
/// workspace and loses float32 precision in the kernels.
pub const COORDINATE: Range = Range {
    name: "coordinate",
    min: -1e6,
    max: 1e6,
    unit: "m",
};

/// Coverage tolerance of the automatic spherizer (m): finer tolerances
/// multiply the spheres and the work (the Panda: 3 s at 1 mm, over 200 s
/// at 0.5 mm; 1e-12 never finished).
pub const SPHERIZE_TOLERANCE: Range = Range {
    name: "tolerance",
    min: 1e-3,
    max: 1.0,
    unit: "m",
};

/// Largest sphere budget of the automatic spherizer (`total_budget`,
/// `max_per_link`): a budget of 1e12 never finished; real sphere models
/// have tens to hundreds of spheres.
pub const MAX_SPHERES: usize = 10_000;

/// Largest number of samples of collision-pair analysis.
pub const MAX_ANALYSIS_SAMPLES: usize = 10_000_000;

/// Largest nesting depth of an XML document (URDF, SRDF): real files nest
/// fewer than 10 levels; deeper documents are refused before parsing.
pub const MAX_XML_DEPTH: usize = 256;

/// Largest XML document (bytes) read as URDF or SRDF.
pub const MAX_XML_BYTES: usize = 256 << 20;

/// Ranges of the simulation's numeric inputs (`ferrobot-sim`), checked at
/// the API boundary before the world is touched.
///
/// Rapier computes in float32: values beyond its range overflow to
/// infinity or underflow to zero (a mass of 1e-45 kg becomes 0 and the body
/// freezes; gravity of 1e39 becomes infinite), and finite but huge efforts,
/// gains or velocities make a step blow up. The ranges below keep every
/// value representable in float32 with headroom for the solver, while
/// leaving every physically meaningful value for a manipulation scene
/// valid. The checks are generic over the caller's error type (any error
/// made from a [`RangeError`]).
pub mod sim {
    use super::{Range, RangeError};

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
    pub fn check_all<E: From<RangeError>>(
        range: &Range,
        what: &str,
        values: &[f64],
    ) -> Result<(), E> {
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
    pub fn check_all_or_inf<E: From<RangeError>>(
        range: &Range,
        what: &str,
        values: &[f64],
    ) -> Result<(), E> {
        for (i, &v) in values.iter().enumerate() {
            if v != f64::INFINITY {
                range.check_as(&format!("{what}[{i}]"), v)?;
            }
        }
        Ok(())
    }

    /// Steps needed to run `duration` seconds at time step `dt`, refused
    /// above [`MAX_STEPS_PER_CALL`].
    pub fn steps_for<E: From<RangeError>>(what: &str, duration: f64, dt: f64) -> Result<usize, E> {
        Ok(super::step_count(what, duration, dt, MAX_STEPS_PER_CALL)?)
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        #[test]
        fn ranges_refuse_float32_overflow_and_underflow() {
            assert!(check_all::<RangeError>(&MASS, "mass", &[1e-45]).is_err());
            assert!(check_all::<RangeError>(&MASS, "mass", &[1e39]).is_err());
            assert!(check_all::<RangeError>(&GRAVITY, "gravity", &[0.0, 0.0, 1e39]).is_err());
            assert!(check_all::<RangeError>(&VELOCITY, "qd", &[1e30]).is_err());
            assert!(check_all::<RangeError>(&EFFORT, "efforts", &[1e12]).is_err());
            assert!(check_all::<RangeError>(&EFFORT, "efforts", &[87.0, -12.0]).is_ok());
            assert!(
                check_all_or_inf::<RangeError>(&MAX_FORCE, "max_force", &[f64::INFINITY]).is_ok()
            );
            assert!(check_all_or_inf::<RangeError>(&MAX_FORCE, "max_force", &[f64::NAN]).is_err());
            assert!(steps_for::<RangeError>("settle_time", 1e12, 1.0 / 240.0).is_err());
            assert_eq!(steps_for::<RangeError>("t", 1.0, 0.25).unwrap(), 4);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_check_bounds_and_nan() {
        assert_eq!(RESOLUTION.check(0.005), Ok(0.005));
        assert!(RESOLUTION.check(1e-300).is_err());
        assert!(RESOLUTION.check(f64::NAN).is_err());
        assert!(RESOLUTION.check(2.0).is_err());
        let e = RESOLUTION.check(1e-12).unwrap_err().0;
        assert!(e.contains("resolution") && e.contains("1e-12"), "{e}");
    }

    #[test]
    fn step_counts_never_overflow() {
        assert_eq!(step_count("m", 1.0, 0.25, 10), Ok(4));
        assert_eq!(step_count("m", 0.0, 0.25, 10), Ok(1));
        assert!(step_count("m", 1.0, 5e-324, usize::MAX).is_err());
        assert!(step_count("m", 1.0, 1e-3, 10).is_err());
    }
}
