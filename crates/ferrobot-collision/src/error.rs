//! The error type of the collision crate.

use ferrobot_model::ModelError;

/// What can go wrong building sphere models, worlds or running queries.
#[derive(Debug, Clone, thiserror::Error)]
pub enum CollisionError {
    /// A problem from the robot model (unknown link, bad configuration, ...).
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A shape with invalid parameters (negative size, non-finite pose, ...).
    #[error("{0}")]
    InvalidShape(String),
    /// A world or attached object name that does not exist.
    #[error("{0}")]
    Name(String),
    /// A world or attached object name that exists already.
    #[error("{0}")]
    Duplicate(String),
    /// A file (scene YAML, sphere YAML, spherized URDF) that cannot be read.
    #[error("{location}: {message}")]
    File {
        /// File (and element or line where known).
        location: String,
        /// What is wrong.
        message: String,
    },
    /// Any other invalid argument.
    #[error("{0}")]
    InvalidArgument(String),
}

impl From<ferrobot_geometry::GeometryError> for CollisionError {
    fn from(e: ferrobot_geometry::GeometryError) -> Self {
        CollisionError::InvalidShape(e.to_string())
    }
}

impl From<ferrobot_model::ranges::RangeError> for CollisionError {
    fn from(e: ferrobot_model::ranges::RangeError) -> Self {
        CollisionError::InvalidArgument(e.0)
    }
}

/// Result alias of the collision crate.
pub type Result<T, E = CollisionError> = std::result::Result<T, E>;
