//! The error type of the control crate.

use ferrobot_collision::CollisionError;
use ferrobot_model::ModelError;

/// What can go wrong configuring or stepping a controller.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ControlError {
    /// A problem from the robot model (bad configuration vector, ...).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A problem from the collision crate (world, spheres, ...).
    #[error(transparent)]
    Collision(#[from] CollisionError),
    /// A parameter out of its documented range, a wrong length, ...
    #[error("{0}")]
    InvalidArgument(String),
    /// A non-finite input value.
    #[error("{0}")]
    NonFinite(String),
    /// An unknown configuration key, joint or world object.
    #[error("{0}")]
    UnknownName(String),
}

/// Result alias of the control crate.
pub type Result<T, E = ControlError> = std::result::Result<T, E>;

/// Checks that every value of `v` is finite.
pub fn check_finite(what: &str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(ControlError::NonFinite(format!(
            "{what}: non-finite value {} at index {i}",
            v[i]
        ))),
    }
}
