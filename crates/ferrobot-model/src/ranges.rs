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
