//! `ferrobot.Gripper`: the one gripper description (`ferrobot_model::Gripper`).

use ferrobot_model::{FingerGeometry, Gripper, OpeningMap, pose_to_matrix};
use nalgebra::{Unit, Vector3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::{InvalidArgumentError, guard, model_err};
use crate::model::PyRobotModel;
use crate::results::{PyFingerGeometry, PyGripperDetection};

/// A parallel-jaw gripper: hand link, TCP, approach and closing axes (hand
/// frame), driver joint and mimic followers, the driver-to-opening map and
/// the finger geometry grasp detection uses.
#[pyclass(name = "Gripper", module = "ferrobot", frozen)]
#[derive(Clone)]
pub struct PyGripper {
    pub inner: Gripper,
}

fn vec3(v: &[f64], what: &str) -> PyResult<Vector3<f64>> {
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        return Err(InvalidArgumentError::new_err(format!(
            "{what}: expected 3 finite numbers, got {v:?}"
        )));
    }
    Ok(Vector3::new(v[0], v[1], v[2]))
}

fn unit(v: &[f64], what: &str) -> PyResult<Unit<Vector3<f64>>> {
    let v = vec3(v, what)?;
    if v.norm() < 1e-9 {
        return Err(InvalidArgumentError::new_err(format!(
            "{what}: must not be zero"
        )));
    }
    Ok(Unit::new_normalize(v))
}

/// `fingers` argument: a `FingerGeometry` or a dict with exactly its six
/// fields (m).
fn finger_geometry(fingers: &Bound<'_, PyAny>) -> PyResult<FingerGeometry> {
    if let Ok(f) = fingers.cast::<PyFingerGeometry>() {
        let f = f.get();
        return Ok(FingerGeometry {
            depth: f.depth,
            thickness: f.thickness,
            height: f.height,
            palm_width: f.palm_width,
            palm_height: f.palm_height,
            palm_depth: f.palm_depth,
        });
    }
    let Ok(d) = fingers.cast::<PyDict>() else {
        return Err(InvalidArgumentError::new_err(format!(
            "fingers: expected a FingerGeometry or a dict, got {}",
            fingers.get_type().name()?
        )));
    };
    let known = PyFingerGeometry::fields();
    for k in d.keys() {
        let k: String = k.extract()?;
        if !known.contains(&k.as_str()) {
            return Err(InvalidArgumentError::new_err(format!(
                "fingers: unknown key '{k}'; known: {known:?}"
            )));
        }
    }
    let get = |k: &str| -> PyResult<f64> {
        d.get_item(k)?
            .ok_or_else(|| InvalidArgumentError::new_err(format!("fingers: missing '{k}'")))?
            .extract()
            .map_err(|_| InvalidArgumentError::new_err(format!("fingers: '{k}' must be a number")))
    };
    Ok(FingerGeometry {
        depth: get("depth")?,
        thickness: get("thickness")?,
        height: get("height")?,
        palm_width: get("palm_width")?,
        palm_height: get("palm_height")?,
        palm_depth: get("palm_depth")?,
    })
}

#[pymethods]
impl PyGripper {
    /// An explicit gripper. `opening_map` is ("linear", scale, offset),
    /// ("four_bar", offset, radius, phase) or ("table", q list, opening list);
    /// `fingers` a `FingerGeometry` (e.g. another gripper's `fingers`) or a
    /// dict of depth, thickness, height, palm_width, palm_height, palm_depth
    /// (m). Validated (see `Gripper.validate`).
    #[new]
    #[pyo3(signature = (name, hand_link, tcp, approach, closing, driver, followers, open_position, closed_position, opening_map, fingers))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        name: String,
        hand_link: String,
        tcp: Vec<f64>,
        approach: Vec<f64>,
        closing: Vec<f64>,
        driver: String,
        followers: Vec<String>,
        open_position: f64,
        closed_position: f64,
        opening_map: &Bound<'_, PyAny>,
        fingers: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        guard(|| {
            let kind: String = opening_map.get_item(0)?.extract()?;
            let map = match kind.as_str() {
                "linear" => OpeningMap::Linear {
                    scale: opening_map.get_item(1)?.extract()?,
                    offset: opening_map.get_item(2)?.extract()?,
                },
                "four_bar" => OpeningMap::FourBar {
                    offset: opening_map.get_item(1)?.extract()?,
                    radius: opening_map.get_item(2)?.extract()?,
                    phase: opening_map.get_item(3)?.extract()?,
                },
                "table" => OpeningMap::Table {
                    q: opening_map.get_item(1)?.extract()?,
                    opening: opening_map.get_item(2)?.extract()?,
                },
                other => {
                    return Err(InvalidArgumentError::new_err(format!(
                        "opening_map: unknown kind '{other}' (linear, four_bar, table)"
                    )));
                }
            };
            let fingers = finger_geometry(fingers)?;
            let g = Gripper {
                name,
                hand_link,
                tcp: vec3(&tcp, "tcp")?,
                approach: unit(&approach, "approach")?,
                closing: unit(&closing, "closing")?,
                driver,
                followers,
                open_position,
                closed_position,
                map,
                fingers,
            };
            g.validate().map_err(model_err)?;
            Ok(Self { inner: g })
        })
    }

    /// The Franka hand of the bundled Panda.
    #[staticmethod]
    fn panda_hand() -> Self {
        Self {
            inner: Gripper::panda_hand(),
        }
    }

    /// The Robotiq 2F-85 of the bundled UR5e.
    #[staticmethod]
    fn robotiq_2f85() -> Self {
        Self {
            inner: Gripper::robotiq_2f85(),
        }
    }

    /// The gripper of `model`: a shipped one whose links and joints it has,
    /// else one built from its SRDF end effector and finger geometry (its
    /// detection boxes the description's; `covering` grows them to the
    /// model's collision geometry).
    #[staticmethod]
    fn from_model(model: &PyRobotModel) -> PyResult<Self> {
        guard(|| {
            Ok(Self {
                inner: Gripper::from_model(&model.inner).map_err(model_err)?,
            })
        })
    }

    /// This gripper with its finger and housing boxes grown to cover `model`'s
    /// own collision geometry of the hand and finger links (every opening
    /// from closed to open): what grasp detection keeps out of the cloud is
    /// then what the planner and simulator collide with. Raises unless
    /// `model` has this gripper.
    fn covering(&self, model: &PyRobotModel) -> PyResult<Self> {
        guard(|| {
            Ok(Self {
                inner: self.inner.covering(&model.inner).map_err(model_err)?,
            })
        })
    }

    /// How far `model`'s collision geometry of this gripper reaches in the
    /// grasp frame (m, a dict): thickness and height of the fingers (from the
    /// pads' inner faces), palm_width, palm_height, palm_depth of the rest,
    /// tip (finger geometry beyond the TCP) and palm_front (hand geometry in
    /// front of the fingers' base), which the detector's boxes do not model.
    fn model_extents<'py>(
        &self,
        py: Python<'py>,
        model: &PyRobotModel,
    ) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        guard(|| {
            let e = self.inner.model_extents(&model.inner).map_err(model_err)?;
            let d = pyo3::types::PyDict::new(py);
            for (k, v) in [
                ("thickness", e.thickness),
                ("height", e.height),
                ("palm_width", e.palm_width),
                ("palm_height", e.palm_height),
                ("palm_depth", e.palm_depth),
                ("tip", e.tip),
                ("palm_front", e.palm_front),
            ] {
                d.set_item(k, v)?;
            }
            Ok(d)
        })
    }

    /// Raises unless `model` has this gripper's hand link, driver and followers.
    fn check_model(&self, model: &PyRobotModel) -> PyResult<()> {
        guard(|| self.inner.check_model(&model.inner).map_err(model_err))
    }

    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }
    #[getter]
    fn hand_link(&self) -> String {
        self.inner.hand_link.clone()
    }
    /// TCP position (3,) in the hand link frame.
    #[getter]
    fn tcp<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.inner.tcp.as_slice().to_vec()).into_pyarray(py)
    }
    /// Approach direction (3,) in the hand link frame.
    #[getter]
    fn approach<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.inner.approach.as_slice().to_vec()).into_pyarray(py)
    }
    /// Closing axis (3,) in the hand link frame.
    #[getter]
    fn closing<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(self.inner.closing.as_slice().to_vec()).into_pyarray(py)
    }
    #[getter]
    fn driver(&self) -> String {
        self.inner.driver.clone()
    }
    #[getter]
    fn followers(&self) -> Vec<String> {
        self.inner.followers.clone()
    }
    #[getter]
    fn open_position(&self) -> f64 {
        self.inner.open_position
    }
    #[getter]
    fn closed_position(&self) -> f64 {
        self.inner.closed_position
    }
    /// Largest opening (m).
    #[getter]
    fn max_opening(&self) -> f64 {
        self.inner.max_opening()
    }
    /// Opening (m) closed on nothing.
    #[getter]
    fn min_opening(&self) -> f64 {
        self.inner.min_opening()
    }
    /// Finger geometry (a `FingerGeometry`: depth, thickness, height,
    /// palm_width, palm_height, palm_depth, m).
    #[getter]
    fn fingers(&self) -> PyFingerGeometry {
        PyFingerGeometry::new(&self.inner.fingers)
    }
    /// The opening map's kind: "linear", "four_bar" or "table".
    #[getter]
    fn opening_map_kind(&self) -> &'static str {
        match self.inner.map {
            OpeningMap::Linear { .. } => "linear",
            OpeningMap::FourBar { .. } => "four_bar",
            OpeningMap::Table { .. } => "table",
        }
    }

    /// Opening (m) at driver position `q` (rad or m).
    fn opening(&self, q: f64) -> PyResult<f64> {
        if !q.is_finite() {
            return Err(InvalidArgumentError::new_err(format!(
                "q must be finite, got {q}"
            )));
        }
        Ok(self.inner.opening(q))
    }

    /// Driver position for `opening` (m, within [min_opening, max_opening]).
    fn driver_position(&self, opening: f64) -> PyResult<f64> {
        guard(|| self.inner.driver_position(opening).map_err(model_err))
    }

    /// 4x4 pose of the hand link in the grasp frame (x approach, y closing,
    /// origin at the TCP): a grasp at pose G puts the hand at G @ this.
    fn grasp_to_hand<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        Array2::from_shape_vec((4, 4), pose_to_matrix(&self.inner.grasp_to_hand()).to_vec())
            .expect("4x4")
            .into_pyarray(py)
    }

    /// The grasp detector's hand geometry for this gripper (a
    /// `GripperDetection`: max_width, finger_depth, finger_width, height,
    /// palm_width, palm_height, palm_depth, m; the `DetectOptions` fields of
    /// the same names), derived in `ferrobot_grasp::GripperGeometry::from_gripper`.
    fn detection_options(&self) -> PyGripperDetection {
        PyGripperDetection::new(&ferrobot_grasp::GripperGeometry::from_gripper(&self.inner))
    }

    fn __repr__(&self) -> String {
        format!(
            "Gripper('{}', hand '{}', driver '{}' + {} followers, opening {:.4}-{:.4} m)",
            self.inner.name,
            self.inner.hand_link,
            self.inner.driver,
            self.inner.followers.len(),
            self.inner.min_opening(),
            self.inner.max_opening()
        )
    }
}
