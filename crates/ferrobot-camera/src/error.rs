//! Errors of the camera model.

/// What was wrong with a camera model or an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A parameter is out of range (e.g. a focal length <= 0).
    #[error("{0}")]
    InvalidArgument(String),
    /// A parameter is NaN or infinite.
    #[error("{0}")]
    NonFinite(String),
    /// An image has the wrong number of values.
    #[error("{0}")]
    Shape(String),
}
