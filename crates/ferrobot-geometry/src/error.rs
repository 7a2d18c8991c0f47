//! The one error of the geometry crate.

/// A shape that cannot be built or used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A size, index or topology that does not make a shape.
    #[error("{0}")]
    InvalidShape(String),
    /// A NaN or infinite coordinate.
    #[error("{0}")]
    NonFinite(String),
}

/// Result with [`GeometryError`].
pub type Result<T> = std::result::Result<T, GeometryError>;
