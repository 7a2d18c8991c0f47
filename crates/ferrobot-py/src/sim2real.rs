//! Bindings of the sim-to-real tools: `ferrobot check` (URDF checking),
//! calibration (gravity torques, payload, link masses, friction), run-time
//! inertial and joint-friction changes of a simulated robot, applied drive
//! efforts, and command latency / stream-fault helpers.

use std::path::PathBuf;

use ferrobot_collision::urdf_check::{CheckOptions, check_urdf_file};
use ferrobot_model::{Inertial, RobotModel};
use ferrobot_sim::calibration;
use ferrobot_sim::latency::{self, CommandDelay, LinearPredictor, StreamGuard};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::read_array;
use crate::errors::{FileFormatError, guard, model_err};
use crate::model::PyRobotModel;
use crate::results::{
    PyFrictionFit, PyLinkMassFit, PyPayloadFit, PyStreamGuardStep, PyUrdfCheckReport, PyUrdfFinding,
};
use crate::sim::{PyRobot, sim_err};

fn vec1<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(v).into_pyarray(py)
}

fn vec3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vector3<f64>> {
    let a = read_array(obj, what, 1, &[Some(3)])?;
    let d = a.data();
    Ok(Vector3::new(d[0], d[1], d[2]))
}

/// Checks a URDF file (see `ferrobot check`): returns a `UrdfCheckReport`
/// (`robot`, `source`, `tree` (text) and `findings`, `UrdfFinding`s with
/// `severity` ("error", "warning", "info"), `code`, `line` (or None),
/// `element` and `message`).
#[pyfunction]
#[pyo3(signature = (path, srdf=None, package_dirs=None, skip_coverage=false))]
pub fn urdf_check<'py>(
    py: Python<'py>,
    path: PathBuf,
    srdf: Option<PathBuf>,
    package_dirs: Option<Vec<PathBuf>>,
    skip_coverage: bool,
) -> PyResult<PyUrdfCheckReport> {
    let options = CheckOptions {
        srdf,
        package_dirs: package_dirs.unwrap_or_default(),
        skip_coverage,
    };
    let report = guard(|| {
        py.detach(|| check_urdf_file(&path, &options)).map_err(|e| {
            FileFormatError::new_err(format!("path: cannot read '{}': {e}", path.display()))
        })
    })?;
    let findings = report
        .findings
        .iter()
        .map(|f| {
            Py::new(
                py,
                PyUrdfFinding {
                    severity: f.severity.as_str().to_string(),
                    code: f.code.to_string(),
                    line: f.line,
                    element: f.element.clone(),
                    message: f.message.clone(),
                },
            )
        })
        .collect::<PyResult<_>>()?;
    Ok(PyUrdfCheckReport {
        robot: report.robot,
        source: report.source,
        tree: report.tree,
        findings,
    })
}

fn link_index(model: &RobotModel, link: &str) -> PyResult<usize> {
    model.link(link).map_err(model_err)
}

/// Joint efforts holding `model` still at `q` against `gravity` (base
/// frame, m/s²): Pinocchio's generalized gravity.
#[pyfunction]
pub fn gravity_torques<'py>(
    py: Python<'py>,
    model: &PyRobotModel,
    q: &Bound<'py, PyAny>,
    gravity: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n = model.inner.num_dof();
    let q = read_array(q, "q", 1, &[Some(n)])?.data().to_vec();
    let g = vec3(gravity, "gravity")?;
    let tau = guard(|| calibration::gravity_torques(&model.inner, &q, &g).map_err(sim_err))?;
    Ok(vec1(py, tau))
}

/// The (num_dof, 4) payload regressor of `link` at `q`.
#[pyfunction]
pub fn payload_regressor<'py>(
    py: Python<'py>,
    model: &PyRobotModel,
    q: &Bound<'py, PyAny>,
    link: &str,
    gravity: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = model.inner.num_dof();
    let q = read_array(q, "q", 1, &[Some(n)])?.data().to_vec();
    let g = vec3(gravity, "gravity")?;
    let l = link_index(&model.inner, link)?;
    let y = guard(|| calibration::payload_regressor(&model.inner, &q, l, &g).map_err(sim_err))?;
    Ok(Array2::from_shape_vec((n, 4), y)
        .expect("n x 4")
        .into_pyarray(py))
}

/// Identifies a payload on `link` from static efforts (see the Rust docs
/// of `identify_payload`). Returns a `PayloadFit`: mass, com, rms_residual,
/// condition, equations.
#[pyfunction]
#[pyo3(signature = (model, link, qs, efforts, gravity, dofs=None))]
pub fn identify_payload<'py>(
    py: Python<'py>,
    model: &PyRobotModel,
    link: &str,
    qs: &Bound<'py, PyAny>,
    efforts: &Bound<'py, PyAny>,
    gravity: &Bound<'py, PyAny>,
    dofs: Option<Vec<usize>>,
) -> PyResult<PyPayloadFit> {
    let n = model.inner.num_dof();
    let q = read_array(qs, "qs", 2, &[Some(n)])?;
    let e = read_array(efforts, "efforts", 2, &[Some(n)])?;
    if q.shape != e.shape {
        return Err(crate::errors::ShapeError::new_err(format!(
            "efforts: expected shape {:?} like qs, got {:?}",
            q.shape, e.shape
        )));
    }
    let g = vec3(gravity, "gravity")?;
    let l = link_index(&model.inner, link)?;
    let (qv, ev) = (q.data().to_vec(), e.data().to_vec());
    let p = guard(|| {
        py.detach(|| calibration::identify_payload(&model.inner, l, &qv, &ev, &g, dofs.as_deref()))
            .map_err(sim_err)
    })?;
    Ok(PyPayloadFit {
        mass: p.mass,
        com: vec1(py, p.com.iter().copied().collect()).unbind(),
        rms_residual: p.fit.rms_residual,
        condition: p.fit.condition,
        equations: p.fit.equations,
    })
}

/// Identifies mass offsets (kg) of `links` from static efforts. Returns a
/// `LinkMassFit`: offsets (array in `links` order), rms_residual,
/// condition, equations.
#[pyfunction]
pub fn identify_link_masses<'py>(
    py: Python<'py>,
    model: &PyRobotModel,
    links: Vec<String>,
    qs: &Bound<'py, PyAny>,
    efforts: &Bound<'py, PyAny>,
    gravity: &Bound<'py, PyAny>,
) -> PyResult<PyLinkMassFit> {
    let n = model.inner.num_dof();
    let q = read_array(qs, "qs", 2, &[Some(n)])?;
    let e = read_array(efforts, "efforts", 2, &[Some(n)])?;
    if q.shape != e.shape {
        return Err(crate::errors::ShapeError::new_err(format!(
            "efforts: expected shape {:?} like qs, got {:?}",
            q.shape, e.shape
        )));
    }
    let g = vec3(gravity, "gravity")?;
    let ls: Vec<usize> = links
        .iter()
        .map(|l| link_index(&model.inner, l))
        .collect::<PyResult<_>>()?;
    let (qv, ev) = (q.data().to_vec(), e.data().to_vec());
    let (x, fit) = guard(|| {
        py.detach(|| calibration::identify_link_masses(&model.inner, &ls, &qv, &ev, &g))
            .map_err(sim_err)
    })?;
    Ok(PyLinkMassFit {
        offsets: vec1(py, x).unbind(),
        rms_residual: fit.rms_residual,
        condition: fit.condition,
        equations: fit.equations,
    })
}

/// Fits effort = coulomb·sign(v) + viscous·v. Returns a `FrictionFit`:
/// coulomb, viscous, rms_residual, condition, equations.
#[pyfunction]
#[pyo3(signature = (velocities, efforts, min_speed=1e-3))]
pub fn identify_friction<'py>(
    py: Python<'py>,
    velocities: &Bound<'py, PyAny>,
    efforts: &Bound<'py, PyAny>,
    min_speed: f64,
) -> PyResult<PyFrictionFit> {
    let v = read_array(velocities, "velocities", 1, &[None])?
        .data()
        .to_vec();
    let e = read_array(efforts, "efforts", 1, &[None])?.data().to_vec();
    let (c, vis, fit) =
        guard(|| calibration::identify_friction(&v, &e, min_speed).map_err(sim_err))?;
    let _ = py;
    Ok(PyFrictionFit {
        coulomb: c,
        viscous: vis,
        rms_residual: fit.rms_residual,
        condition: fit.condition,
        equations: fit.equations,
    })
}

/// `PyRobot.set_link_inertial`.
pub(crate) fn set_link_inertial(
    robot: &PyRobot,
    link: &str,
    mass: f64,
    com: &Bound<'_, PyAny>,
    inertia: &Bound<'_, PyAny>,
) -> PyResult<()> {
    let com = vec3(com, "com")?;
    let i = read_array(inertia, "inertia", 2, &[Some(3), Some(3)])?;
    if i.shape[0] != 3 {
        return Err(crate::errors::ShapeError::new_err(format!(
            "inertia: expected shape (3, 3), got {:?}",
            i.shape
        )));
    }
    let d = i.data();
    if !mass.is_finite() {
        return Err(crate::errors::NonFiniteError::new_err(format!(
            "mass: non-finite value {mass}"
        )));
    }
    let inertial = Inertial {
        origin: Isometry3::from_parts(Translation3::from(com), UnitQuaternion::identity()),
        mass,
        inertia: [[d[0], d[1], d[2]], [d[3], d[4], d[5]], [d[6], d[7], d[8]]],
    };
    robot.with_robot(|r, s| {
        let l = r.model().link(link)?;
        r.set_link_inertial(s, l, inertial)
    })
}

/// `PyRobot.get_link_inertial`: (mass, com (3,), inertia (3, 3)) in the
/// link frame (the inertia rotated from the inertial frame).
pub(crate) fn get_link_inertial(
    py: Python<'_>,
    robot: &PyRobot,
    link: &str,
) -> PyResult<crate::results::PyLinkInertial> {
    let inertial = robot.with_robot(|r, _| {
        let l = r.model().link(link)?;
        Ok(r.link_inertial(l)?.clone())
    })?;
    let rot = inertial.origin.rotation.to_rotation_matrix();
    let m = nalgebra::Matrix3::from_fn(|r, c| inertial.inertia[r][c]);
    let in_link = rot.matrix() * m * rot.matrix().transpose();
    Ok(crate::results::PyLinkInertial {
        mass: inertial.mass,
        com: crate::results::arr1(
            py,
            inertial.origin.translation.vector.iter().copied().collect(),
        ),
        inertia: Array2::from_shape_fn((3, 3), |(r, c)| in_link[(r, c)])
            .into_pyarray(py)
            .unbind(),
    })
}

/// `PyRobot.set_joint_dynamics`.
pub(crate) fn set_joint_dynamics(
    robot: &PyRobot,
    joint: &str,
    damping: f64,
    friction: f64,
) -> PyResult<()> {
    robot.with_robot(|r, s| {
        let dof = r.model().dof(joint)?;
        r.set_joint_dynamics(s, dof, damping, friction)
    })
}

/// `PyRobot.get_joint_dynamics`.
pub(crate) fn get_joint_dynamics(robot: &PyRobot, joint: &str) -> PyResult<(f64, f64)> {
    robot.with_robot(|r, s| {
        let dof = r.model().dof(joint)?;
        r.joint_dynamics(s, dof)
    })
}

/// `PyRobot.get_measured_joint_efforts`.
pub(crate) fn applied_efforts<'py>(
    py: Python<'py>,
    robot: &PyRobot,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let e = robot.with_robot(|r, s| Ok(r.applied_efforts(s)))?;
    Ok(vec1(py, e))
}

/// Commands delayed by a constant latency: `push(t, command)` issues,
/// `pop_due(t)` returns the newest command issued at or before `t - delay`
/// (None when none became due since the last call).
#[pyclass(name = "CommandDelay", module = "ferrobot")]
pub struct PyCommandDelay {
    inner: CommandDelay,
}

#[pymethods]
impl PyCommandDelay {
    /// A buffer of commands of `width` values delayed by `delay` s (>= 0).
    #[new]
    fn new(delay: f64, width: usize) -> PyResult<Self> {
        Ok(Self {
            inner: CommandDelay::new(delay, width).map_err(sim_err)?,
        })
    }

    /// The latency (s).
    #[getter]
    fn delay(&self) -> f64 {
        self.inner.delay()
    }

    /// Commands waiting.
    #[getter]
    fn pending(&self) -> usize {
        self.inner.pending()
    }

    /// Issues `command` at time `t` (times must not decrease).
    fn push(&mut self, t: f64, command: &Bound<'_, PyAny>) -> PyResult<()> {
        let c = read_array(command, "command", 1, &[None])?.data().to_vec();
        self.inner.push(t, &c).map_err(sim_err)
    }

    /// The newest command due by `t`, or None.
    fn pop_due<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
    ) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        Ok(self.inner.pop_due(t).map_err(sim_err)?.map(|c| vec1(py, c)))
    }

    /// Drops pending commands.
    fn clear(&mut self) {
        self.inner.clear();
    }
}

/// Linear extrapolation of a command stream by `horizon` s.
#[pyclass(name = "LinearPredictor", module = "ferrobot")]
pub struct PyLinearPredictor {
    inner: LinearPredictor,
}

#[pymethods]
impl PyLinearPredictor {
    /// A predictor looking `horizon` s (>= 0) ahead.
    #[new]
    fn new(horizon: f64) -> PyResult<Self> {
        Ok(Self {
            inner: LinearPredictor::new(horizon).map_err(sim_err)?,
        })
    }

    /// Feeds command `c` at time `t` (increasing); returns the prediction.
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        c: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let c = read_array(c, "command", 1, &[None])?.data().to_vec();
        Ok(vec1(py, self.inner.update(t, &c).map_err(sim_err)?))
    }
}

/// Holds on a command dropout (no command for `timeout` s) and rate-limits
/// every output to `max_velocity · dt` per joint, so the stream resumes
/// without a jump. `update(t, command_or_None, current)` returns a dict:
/// command, holding, catching_up, step.
#[pyclass(name = "StreamGuard", module = "ferrobot")]
pub struct PyStreamGuard {
    inner: StreamGuard,
}

#[pymethods]
impl PyStreamGuard {
    /// A guard with `timeout` (s, > 0) and per-joint `max_velocity` (> 0).
    #[new]
    fn new(timeout: f64, max_velocity: &Bound<'_, PyAny>) -> PyResult<Self> {
        let v = read_array(max_velocity, "max_velocity", 1, &[None])?
            .data()
            .to_vec();
        Ok(Self {
            inner: StreamGuard::new(timeout, &v).map_err(sim_err)?,
        })
    }

    /// One control tick: a `StreamGuardStep`.
    #[pyo3(signature = (t, command, current))]
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
        command: Option<&Bound<'py, PyAny>>,
        current: &Bound<'py, PyAny>,
    ) -> PyResult<PyStreamGuardStep> {
        let c = command
            .map(|c| read_array(c, "command", 1, &[None]).map(|a| a.data().to_vec()))
            .transpose()?;
        let cur = read_array(current, "current", 1, &[None])?.data().to_vec();
        let out = self.inner.update(t, c.as_deref(), &cur).map_err(sim_err)?;
        Ok(PyStreamGuardStep {
            command: vec1(py, out.command).unbind(),
            holding: out.holding,
            catching_up: out.catching_up,
            step: out.step,
        })
    }
}

/// The trajectory `positions` (N, n) sampled every `dt` at time `t`
/// (linear interpolation, held at the ends).
#[pyfunction]
pub fn trajectory_sample<'py>(
    py: Python<'py>,
    positions: &Bound<'py, PyAny>,
    dt: f64,
    t: f64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let p = read_array(positions, "positions", 2, &[None])?;
    let n = p.shape[1];
    let s = latency::trajectory_sample(p.data(), n, dt, t).map_err(sim_err)?;
    Ok(vec1(py, s))
}
