//! Mapping Rust errors and panics to the `ferrobot.errors` exceptions.

use std::panic::{AssertUnwindSafe, catch_unwind};

use ferrobot_model::ModelError;
use pyo3::prelude::*;

pyo3::import_exception!(ferrobot.errors, UrdfError);
pyo3::import_exception!(ferrobot.errors, SrdfError);
pyo3::import_exception!(ferrobot.errors, MeshError);
pyo3::import_exception!(ferrobot.errors, UnknownNameError);
pyo3::import_exception!(ferrobot.errors, ShapeError);
pyo3::import_exception!(ferrobot.errors, NonFiniteError);
pyo3::import_exception!(ferrobot.errors, InvalidArgumentError);
pyo3::import_exception!(ferrobot.errors, InternalError);
pyo3::import_exception!(ferrobot.errors, FileFormatError);
pyo3::import_exception!(ferrobot.errors, DuplicateNameError);
pyo3::import_exception!(ferrobot.errors, SimulationDiverged);

/// Converts a collision error to the matching Python exception.
pub fn collision_err(e: ferrobot_collision::CollisionError) -> PyErr {
    use ferrobot_collision::CollisionError as C;
    match e {
        C::Model(m) => model_err(m),
        C::InvalidShape(m) | C::InvalidArgument(m) => InvalidArgumentError::new_err(m),
        C::Name(m) => UnknownNameError::new_err(m),
        C::Duplicate(m) => DuplicateNameError::new_err(m),
        e @ C::File { .. } => FileFormatError::new_err(e.to_string()),
    }
}

/// Converts a model error to the matching Python exception.
pub fn model_err(e: ModelError) -> PyErr {
    let msg = e.to_string();
    match e {
        ModelError::Urdf { .. } => UrdfError::new_err(msg),
        ModelError::Srdf { .. } => SrdfError::new_err(msg),
        ModelError::Mesh { .. } => MeshError::new_err(msg),
        ModelError::UnknownName { .. } => UnknownNameError::new_err(msg),
        ModelError::Shape { .. } => ShapeError::new_err(msg),
        ModelError::NonFinite { .. } => NonFiniteError::new_err(msg),
        ModelError::InvalidArgument(_) => InvalidArgumentError::new_err(msg),
    }
}

/// Runs `f`, turning a Rust panic into `ferrobot.errors.InternalError` so
/// that no panic ever reaches Python.
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(InternalError::new_err(format!(
                "internal error in ferrobot (please report it): {what}"
            )))
        }
    }
}
