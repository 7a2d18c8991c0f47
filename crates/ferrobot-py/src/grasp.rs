//! `ferrobot._core.grasp_*`: grasp detection bindings (used by the
//! `ferrobot.grasp` Python package).

use ferrobot_grasp::detect::detect_rgbd;
use ferrobot_grasp::frames::transform_group;
use ferrobot_grasp::grasp::GRASP_COLUMNS;
use ferrobot_grasp::{DetectOptions, GraspError, GraspGroup, Workspace, detect};
use nalgebra::{Isometry3, Point3, Vector3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{read_array, read_pose};
use crate::errors::{InvalidArgumentError, NonFiniteError, ShapeError, guard};

/// Converts a grasp error to the matching Python exception.
pub(crate) fn grasp_err(e: GraspError) -> PyErr {
    match e {
        GraspError::Shape(m) => ShapeError::new_err(m),
        GraspError::NonFinite(m) => NonFiniteError::new_err(m),
        GraspError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
    }
}

fn vec3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vector3<f64>> {
    let a = read_array(obj, what, 1, &[Some(3)])?;
    let d = a.data();
    Ok(Vector3::new(d[0], d[1], d[2]))
}

/// Detection options from a dict of keyword options (unknown keys raise).
fn options(opts: Option<&Bound<'_, PyDict>>) -> PyResult<DetectOptions> {
    let mut o = DetectOptions::default();
    let Some(opts) = opts else { return Ok(o) };
    for (k, v) in opts.iter() {
        let key: String = k.extract()?;
        let f = |v: &Bound<'_, PyAny>| -> PyResult<f64> {
            v.extract::<f64>().map_err(|_| {
                InvalidArgumentError::new_err(format!("option {key}: expected a number"))
            })
        };
        let n = |v: &Bound<'_, PyAny>| -> PyResult<usize> {
            v.extract::<usize>().map_err(|_| {
                InvalidArgumentError::new_err(format!(
                    "option {key}: expected a non-negative integer"
                ))
            })
        };
        let list = |v: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
            let a = read_array(v, &format!("option {key}"), 1, &[None])?;
            Ok(a.data().to_vec())
        };
        match key.as_str() {
            "voxel_size" => o.voxel_size = f(&v)?,
            "normal_radius" => o.normal_radius = f(&v)?,
            "num_seeds" => o.num_seeds = n(&v)?,
            "seed_spacing" => o.seed_spacing = f(&v)?,
            "num_rotations" => o.num_rotations = n(&v)?,
            "approach_tilts" => o.approach_tilts = list(&v)?,
            "depths" => o.depths = list(&v)?,
            "friction" => o.friction = f(&v)?,
            "viewpoint" => o.viewpoint = Point3::from(vec3(&v, "option viewpoint")?),
            "approach_direction" => o.approach_direction = vec3(&v, "option approach_direction")?,
            "nms_translation" => o.nms_translation = f(&v)?,
            "nms_rotation" => o.nms_rotation = f(&v)?,
            "max_grasps" => o.max_grasps = n(&v)?,
            "rng_seed" => o.rng_seed = n(&v)? as u64,
            "support_plane" => {
                o.support_plane = v.extract::<bool>().map_err(|_| {
                    InvalidArgumentError::new_err(format!("option {key}: expected a bool"))
                })?
            }
            "body_collision" | "single_object" | "occlusion" => {
                let b = v.extract::<bool>().map_err(|_| {
                    InvalidArgumentError::new_err(format!("option {key}: expected a bool"))
                })?;
                match key.as_str() {
                    "body_collision" => o.body_collision = b,
                    "single_object" => o.single_object = b,
                    _ => o.occlusion = b,
                }
            }
            "plane_threshold" => o.plane_threshold = f(&v)?,
            "torque_scale" => o.torque_scale = f(&v)?,
            "max_width" => o.gripper.max_width = f(&v)?,
            "finger_depth" => o.gripper.finger_depth = f(&v)?,
            "finger_width" => o.gripper.finger_width = f(&v)?,
            "height" => o.gripper.height = f(&v)?,
            "approach_distance" => o.gripper.approach_distance = f(&v)?,
            "clearance" => o.gripper.clearance = f(&v)?,
            "palm_width" => o.gripper.palm_width = f(&v)?,
            "palm_height" => o.gripper.palm_height = f(&v)?,
            "palm_depth" => o.gripper.palm_depth = f(&v)?,
            other => {
                return Err(InvalidArgumentError::new_err(format!(
                    "unknown grasp option '{other}'"
                )));
            }
        }
    }
    o.validate().map_err(grasp_err)?;
    Ok(o)
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
#[pyo3(signature = (points, labels=None, seedable=None, options=None))]
pub fn grasp_detect<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    labels: Option<PyReadonlyArray1<'py, i32>>,
    seedable: Option<PyReadonlyArray1<'py, bool>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let opts = self::options(options)?;
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
#[pyo3(signature = (depth, fx, fy, cx, cy, scale, mask=None, object_id=None, workspace=None, options=None))]
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
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let d = crate::camera::read_depth(depth, [None, None])?;
        let (h, w) = (d.shape[0], d.shape[1]);
        let k = crate::camera::intrinsics(w, h, fx, fy, cx, cy, scale)?;
        let opts = self::options(options)?;
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
