//! The error type of the grasp crate.

/// What can go wrong detecting grasps.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GraspError {
    /// An array with the wrong shape or length.
    #[error("{0}")]
    Shape(String),
    /// A NaN or infinite value where a finite number is required.
    #[error("{0}")]
    NonFinite(String),
    /// Any other invalid argument (bad intrinsics, negative size, ...).
    #[error("{0}")]
    InvalidArgument(String),
}

/// Result alias of the grasp crate.
pub type Result<T, E = GraspError> = std::result::Result<T, E>;

/// Checks that `v` is finite and strictly positive.
pub(crate) fn positive(what: &str, v: f64) -> Result<f64> {
    if !v.is_finite() {
        return Err(GraspError::NonFinite(format!(
            "{what} must be finite, got {v}"
        )));
    }
    if v <= 0.0 {
        return Err(GraspError::InvalidArgument(format!(
            "{what} must be positive, got {v}"
        )));
    }
    Ok(v)
}
