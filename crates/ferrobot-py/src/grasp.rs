//! `ferrobot._core.grasp_*`: grasp detection bindings (used by the
//! `ferrobot.grasp` Python package).

use ferrobot_grasp::detect::detect_rgbd;
use ferrobot_grasp::frames::transform_group;
use ferrobot_grasp::grasp::GRASP_COLUMNS;
use ferrobot_grasp::{DetectOptions, GraspError, GraspGroup, Workspace, detect};
use nalgebra::{Isometry3, Point3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{read_array, read_pose};
use crate::errors::{InvalidArgumentError, NonFiniteError, ShapeError, guard};
use crate::gripper::PyGripper;
use crate::options::PyDetectOptions;

/// Converts a grasp error to the matching Python exception.
pub(crate) fn grasp_err(e: GraspError) -> PyErr {
    match e {
        GraspError::Shape(m) => ShapeError::new_err(m),
        GraspError::NonFinite(m) => NonFiniteError::new_err(m),
        GraspError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
    }
}

/// Detection options: `options` (or the defaults), made for `gripper`
/// when given (`DetectOptions::for_gripper`: its hand geometry and
/// pad-scaled depths), then `overrides`.
fn options(
    options: Option<&Bound<'_, PyDetectOptions>>,
    gripper: Option<&Bound<'_, PyGripper>>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<DetectOptions> {
    let Some(g) = gripper else {
        return PyDetectOptions::resolve(options, overrides);
    };
    let base = match options {
        Some(b) => b.borrow().inner.clone(),
        None => DetectOptions::default(),
    };
    let mut inner = base.for_gripper(&g.get().inner);
    match overrides {
        Some(o) => PyDetectOptions::apply(&mut inner, o)?,
        None => PyDetectOptions::check(&inner)?,
    }
    Ok(inner)
}

pub(crate) fn workspace(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Workspace>> {
    let Some(obj) = obj else { return Ok(None) };
    let a = read_array_inf(obj, "workspace")?;
    Ok(Some(Workspace(a)))
}

/// Workspace limits: 6 numbers, infinities allowed, NaN not.
fn read_array_inf(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<[f64; 6]> {
    let v: Vec<f64> = obj.extract().map_err(|_| {
        ShapeError::new_err(format!(
            "{what}: expected 6 numbers [xmin, xmax, ymin, ymax, zmin, zmax]"
        ))
    })?;
    let arr: [f64; 6] = v.try_into().map_err(|v: Vec<f64>| {
        ShapeError::new_err(format!(
            "{what}: expected 6 numbers [xmin, xmax, ymin, ymax, zmin, zmax], got {}",
            v.len()
        ))
    })?;
    Ok(arr)
}

fn to_py<'py>(py: Python<'py>, g: &GraspGroup) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let a = Array2::from_shape_vec((g.len(), GRASP_COLUMNS), g.to_array())
        .map_err(|e| InvalidArgumentError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

fn group(obj: &Bound<'_, PyAny>) -> PyResult<GraspGroup> {
    let a = read_array(obj, "grasp array", 2, &[Some(GRASP_COLUMNS)])?;
    GraspGroup::from_array(a.data()).map_err(grasp_err)
}

/// Detects grasps in a point cloud (N, 3); returns an (M, 17) array.
#[pyfunction]
#[pyo3(signature = (points, labels=None, seedable=None, options=None, gripper=None, **overrides))]
#[allow(clippy::too_many_arguments)]
pub fn grasp_detect<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    labels: Option<PyReadonlyArray1<'py, i32>>,
    seedable: Option<PyReadonlyArray1<'py, bool>>,
    options: Option<&Bound<'py, PyDetectOptions>>,
    gripper: Option<&Bound<'py, PyGripper>>,
    overrides: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let opts = self::options(options, gripper, overrides)?;
        let p = read_array(points, "points", 2, &[Some(3)])?;
        let pts: Vec<Point3<f64>> = p
            .data()
            .chunks(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        let labels = labels.map(|l| l.as_array().to_vec());
        let seedable = seedable.map(|s| s.as_array().to_vec());
        let g = py
            .detach(|| detect(&pts, labels.as_deref(), seedable.as_deref(), &opts))
            .map_err(grasp_err)?;
        to_py(py, &g)
    })
}

/// Detects grasps in a depth image (H, W); returns an (M, 17) array.
#[pyfunction]
#[pyo3(signature = (depth, fx, fy, cx, cy, scale, mask=None, object_id=None, workspace=None, options=None, gripper=None, **overrides))]
#[allow(clippy::too_many_arguments)]
pub fn grasp_detect_rgbd<'py>(
    py: Python<'py>,
    depth: &Bound<'py, PyAny>,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    scale: f64,
    mask: Option<PyReadonlyArray2<'py, i32>>,
    object_id: Option<i32>,
    workspace: Option<&Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDetectOptions>>,
    gripper: Option<&Bound<'py, PyGripper>>,
    overrides: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let d = crate::camera::read_depth(depth, [None, None])?;
        let (h, w) = (d.shape[0], d.shape[1]);
        let k = crate::camera::intrinsics(w, h, fx, fy, cx, cy, scale)?;
        let opts = self::options(options, gripper, overrides)?;
        let ws = self::workspace(workspace)?;
        let mask: Option<Vec<i32>> = match mask {
            None => None,
            Some(m) => {
                let m = m.as_array();
                if m.shape() != [h, w] {
                    return Err(ShapeError::new_err(format!(
                        "mask: expected shape ({h}, {w}) like the depth image, got {:?}",
                        m.shape()
                    )));
                }
                Some(m.iter().copied().collect())
            }
        };
        let data = d.data();
        let g = py
            .detach(|| detect_rgbd(data, &k, mask.as_deref(), object_id, ws.as_ref(), &opts))
            .map_err(grasp_err)?;
        to_py(py, &g)
    })
}

/// Indices kept by non-maximum suppression of an (N, 17) grasp array, best first.
#[pyfunction]
#[pyo3(signature = (grasps, translation=0.03, rotation=std::f64::consts::PI / 6.0))]
pub fn grasp_nms<'py>(
    py: Python<'py>,
    grasps: &Bound<'py, PyAny>,
    translation: f64,
    rotation: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    guard(|| {
        for (what, v) in [
            ("translation threshold", translation),
            ("rotation threshold", rotation),
        ] {
            if !v.is_finite() {
                return Err(NonFiniteError::new_err(format!(
                    "{what} must be finite, got {v}"
                )));
            }
            if v < 0.0 {
                return Err(InvalidArgumentError::new_err(format!(
                    "{what} must be >= 0, got {v}"
                )));
            }
        }
        let g = group(grasps)?;
        let kept = py.detach(|| ferrobot_grasp::nms::nms(&g.grasps, translation, rotation));
        Ok(Array1::from_vec(kept.into_iter().map(|i| i as i64).collect()).into_pyarray(py))
    })
}

/// Applies a pose (4x4 or 7-vector) to an (N, 17) grasp array.
#[pyfunction]
pub fn grasp_transform<'py>(
    py: Python<'py>,
    grasps: &Bound<'py, PyAny>,
    pose: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let t: Isometry3<f64> = read_pose(pose, "pose")?;
        let mut g = group(grasps)?;
        transform_group(&mut g, &t);
        to_py(py, &g)
    })
}

/// The 4x4 transform from OpenCV-optical camera coordinates to the world,
/// given the camera pose in the world in `convention`.
#[pyfunction]
#[pyo3(signature = (camera_pose, convention="opencv"))]
pub fn grasp_camera_to_world<'py>(
    py: Python<'py>,
    camera_pose: &Bound<'py, PyAny>,
    convention: &str,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let c =
            ferrobot_camera::Convention::parse(convention).map_err(crate::camera::camera_err)?;
        let t = ferrobot_camera::camera_to_world(&read_pose(camera_pose, "camera_pose")?, c);
        let m = t.to_homogeneous();
        Ok(Array2::from_shape_fn((4, 4), |(i, j)| m[(i, j)]).into_pyarray(py))
    })
}
