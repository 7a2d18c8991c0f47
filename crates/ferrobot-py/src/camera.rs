//! Bindings of `ferrobot-camera` (the Python module `ferrobot.camera`):
//! conversion only; intrinsics validation, conventions and the
//! back-projection policy are the crate's.

use ferrobot_camera::{CameraError, Convention, Intrinsics, backproject, convert_pose};
use ferrobot_grasp::Workspace;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::{Finite, read_array_with, read_pose};
use crate::errors::{InvalidArgumentError, NonFiniteError, ShapeError, guard};

/// The Python exception for a camera error.
pub fn camera_err(e: CameraError) -> PyErr {
    match e {
        CameraError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
        CameraError::NonFinite(m) => NonFiniteError::new_err(m),
        CameraError::Shape(m) => ShapeError::new_err(m),
    }
}

/// Validated intrinsics (the one validation).
pub fn intrinsics(
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    depth_scale: f64,
) -> PyResult<Intrinsics> {
    let k = Intrinsics {
        width,
        height,
        fx,
        fy,
        cx,
        cy,
        depth_scale,
    };
    k.validate().map_err(camera_err)?;
    Ok(k)
}

/// A depth image (H, W) as float64, infinities allowed (+inf is missing
/// depth, -inf an error decided by the crate), NaN refused.
pub fn read_depth<'py>(
    depth: &Bound<'py, PyAny>,
    shape: [Option<usize>; 2],
) -> PyResult<crate::arrays::Array<'py>> {
    read_array_with(depth, "depth", 2, &shape, Finite::NoNan)
}

/// Checks intrinsics; raises the matching `ferrobot.errors` class.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn camera_check_intrinsics(
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    depth_scale: f64,
) -> PyResult<()> {
    guard(|| intrinsics(width, height, fx, fy, cx, cy, depth_scale).map(|_| ()))
}

/// Back-projected points (N, 3) and their pixels (N, 2) as (row, column).
type PointsAndRowCols<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<i64>>);

/// Back-projects a depth image (H, W): (points (N, 3), pixels (N, 2) rows
/// and columns). Missing depth (0, +inf) is skipped.
#[pyfunction]
#[pyo3(signature = (depth, width, height, fx, fy, cx, cy, depth_scale, workspace=None))]
#[allow(clippy::too_many_arguments)]
pub fn camera_backproject<'py>(
    py: Python<'py>,
    depth: &Bound<'py, PyAny>,
    width: usize,
    height: usize,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    depth_scale: f64,
    workspace: Option<&Bound<'py, PyAny>>,
) -> PyResult<PointsAndRowCols<'py>> {
    guard(|| {
        let k = intrinsics(width, height, fx, fy, cx, cy, depth_scale)?;
        let ws: Option<Workspace> = crate::grasp::workspace(workspace)?;
        if let Some(w) = &ws {
            w.validate().map_err(crate::grasp::grasp_err)?;
        }
        let d = read_depth(depth, [Some(height), Some(width)])?;
        let data = d.data();
        let bp = py
            .detach(|| backproject(data, &k, |p| ws.as_ref().is_none_or(|w| w.contains(p))))
            .map_err(camera_err)?;
        let n = bp.points.len();
        let pts = Array2::from_shape_vec(
            (n, 3),
            bp.points.iter().flat_map(|p| [p.x, p.y, p.z]).collect(),
        )
        .expect("n x 3");
        let pix = Array2::from_shape_vec(
            (n, 2),
            bp.pixels
                .iter()
                .flat_map(|&(r, c)| [r as i64, c as i64])
                .collect(),
        )
        .expect("n x 2");
        Ok((pts.into_pyarray(py), pix.into_pyarray(py)))
    })
}

/// Back-projected points (N, 3) and their flat pixel indices (N,).
pub type PointsAndPixels<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<i64>>);

/// [`backproject`] with flat row-major pixel indices (the sim camera's
/// `depth_to_points` and the deprecated `ferrobot.depth_to_points`).
pub fn backproject_flat<'py>(
    py: Python<'py>,
    depth: &Bound<'py, PyAny>,
    k: &Intrinsics,
) -> PyResult<PointsAndPixels<'py>> {
    let d = read_depth(depth, [Some(k.height), Some(k.width)])?;
    let data = d.data();
    let bp = py
        .detach(|| backproject(data, k, |_| true))
        .map_err(camera_err)?;
    let n = bp.points.len();
    Ok((
        Array2::from_shape_vec(
            (n, 3),
            bp.points.iter().flat_map(|p| [p.x, p.y, p.z]).collect(),
        )
        .expect("n x 3")
        .into_pyarray(py),
        Array1::from_vec(
            bp.flat_pixels(k.width)
                .into_iter()
                .map(|i| i as i64)
                .collect(),
        )
        .into_pyarray(py),
    ))
}

/// The pose (4x4) in convention `to` of a camera whose pose in convention
/// `from_` is `pose`.
#[pyfunction]
#[pyo3(signature = (pose, from_, to))]
pub fn camera_convert_pose<'py>(
    py: Python<'py>,
    pose: &Bound<'py, PyAny>,
    from_: &str,
    to: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let from = Convention::parse(from_).map_err(camera_err)?;
        let to = Convention::parse(to).map_err(camera_err)?;
        let p = convert_pose(&read_pose(pose, "pose")?, from, to);
        let m = p.to_homogeneous();
        Ok(Array2::from_shape_fn((4, 4), |(i, j)| m[(i, j)]).into_pyarray(py))
    })
}
