//! Errors of the simulation crate.

use ferrobot_model::ModelError;

/// What can go wrong building or running a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// An invalid argument (negative mass, zero time step, bad shape, ...).
    #[error("{0}")]
    InvalidArgument(String),
    /// An unknown object, robot, joint or link name or index.
    #[error("{0}")]
    UnknownName(String),
    /// A name that is taken already.
    #[error("{0}")]
    Duplicate(String),
    /// An array of the wrong length.
    #[error("{what}: expected {expected}, got {got}")]
    Shape {
        /// The argument.
        what: String,
        /// The expected length or shape.
        expected: String,
        /// What was given.
        got: String,
    },
    /// A NaN or infinite input.
    #[error("{0}")]
    NonFinite(String),
    /// The simulation produced non-finite or runaway states.
    #[error("{0}")]
    Diverged(String),
    /// An error of the robot model.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// Result alias of the simulation crate.
pub type Result<T> = std::result::Result<T, SimError>;

/// Checks that every value of `v` is finite.
pub fn check_finite(what: &str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(SimError::NonFinite(format!(
            "{what}: non-finite value {} at index {i}",
            v[i]
        ))),
        None => Ok(()),
    }
}

/// Checks that `v` has `n` values, all finite.
pub fn check_len(what: &str, v: &[f64], n: usize) -> Result<()> {
    if v.len() != n {
        return Err(SimError::Shape {
            what: what.into(),
            expected: format!("{n} values"),
            got: format!("{} values", v.len()),
        });
    }
    check_finite(what, v)
}

/// The simulator's error for a shape the geometry crate rejects.
pub fn geometry_err(e: ferrobot_geometry::GeometryError) -> SimError {
    match e {
        ferrobot_geometry::GeometryError::InvalidShape(m) => SimError::InvalidArgument(m),
        ferrobot_geometry::GeometryError::NonFinite(m) => SimError::NonFinite(m),
    }
}

impl SimError {
    /// The same error with its message prefixed by `what` (an object name).
    pub fn context(self, what: &str) -> Self {
        match self {
            SimError::InvalidArgument(m) => SimError::InvalidArgument(format!("{what}: {m}")),
            SimError::NonFinite(m) => SimError::NonFinite(format!("{what}: {m}")),
            other => other,
        }
    }
}

impl From<ferrobot_camera::CameraError> for SimError {
    fn from(e: ferrobot_camera::CameraError) -> Self {
        match e {
            ferrobot_camera::CameraError::InvalidArgument(m) => SimError::InvalidArgument(m),
            ferrobot_camera::CameraError::NonFinite(m) => SimError::NonFinite(m),
            ferrobot_camera::CameraError::Shape(m) => SimError::InvalidArgument(m),
        }
    }
}

/// A value outside its range (`ferrobot_model::ranges`, the simulation's
/// float32 ranges in `ranges::sim`) is an invalid argument.
impl From<ferrobot_model::ranges::RangeError> for SimError {
    fn from(e: ferrobot_model::ranges::RangeError) -> Self {
        SimError::InvalidArgument(e.0)
    }
}
