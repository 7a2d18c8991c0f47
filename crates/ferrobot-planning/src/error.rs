//! Errors of the planning crate. Failures to *plan* are not errors: they are
//! reported by [`crate::PlanStatus`]; errors are invalid calls.

use ferrobot_collision::CollisionError;
use ferrobot_model::ModelError;

/// An invalid call to the planner.
#[derive(Debug, thiserror::Error)]
pub enum PlanningError {
    /// From the robot model (wrong length, NaN, unknown name, ...).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// From the collision crate.
    #[error(transparent)]
    Collision(#[from] CollisionError),
    /// Any other invalid argument (negative tolerance, empty goal set, ...).
    #[error("{0}")]
    InvalidArgument(String),
}

impl From<ferrobot_model::ranges::RangeError> for PlanningError {
    fn from(e: ferrobot_model::ranges::RangeError) -> Self {
        PlanningError::InvalidArgument(e.0)
    }
}

/// Result alias of the planning crate.
pub type Result<T, E = PlanningError> = std::result::Result<T, E>;

/// Error unless every value is finite.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<()> {
    ferrobot_model::error::check_finite(what, values).map_err(Into::into)
}

/// Error unless `value` is finite and positive.
pub(crate) fn check_positive(what: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(PlanningError::InvalidArgument(format!(
            "{what} must be a positive finite number, got {value}"
        )))
    }
}
