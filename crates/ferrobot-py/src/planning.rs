//! Python bindings of the planning crate: `ferrobot.Planner`, its IK and
//! plan results, and the interpolated joint trajectory.

use std::sync::Arc;

use ferrobot_planning::{
    ActiveSpace, Configuration, Goal, IkOptions, IkSolution, JointOrder, PlanRequest, PlanResult,
    Planner, PlanningError, Trajectory,
};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{read_array, read_poses};
use crate::collision::{PyCollisionWorld, PySphereModel, build_checker};
use crate::errors::{InvalidArgumentError, ShapeError, collision_err, guard, model_err};
use crate::model::PyRobotModel;
use crate::options::{PyIkOptions, PyPlanOptions};

/// Emits a `DeprecationWarning` (an old spelling kept for one release).
pub(crate) fn deprecated(py: Python<'_>, msg: &str) -> PyResult<()> {
    let cat = py.get_type::<pyo3::exceptions::PyDeprecationWarning>();
    let msg = std::ffi::CString::new(msg).unwrap_or_default();
    PyErr::warn(py, &cat, &msg, 1)
}

/// The IK start configuration and random seed from `start`, `seed` and the
/// deprecated spellings: `seed` given a configuration (the old meaning)
/// is the start; `random_seed` is the seed. Each old spelling warns.
fn seed_args<'py>(
    py: Python<'py>,
    what: &str,
    start_name: &str,
    start: Option<&Bound<'py, PyAny>>,
    seed: Option<&Bound<'py, PyAny>>,
    random_seed: Option<u64>,
) -> PyResult<(Option<Bound<'py, PyAny>>, Option<u64>)> {
    let mut start = start.cloned();
    let mut rng: Option<u64> = None;
    if let Some(s) = seed {
        let is_int = s.is_instance_of::<pyo3::types::PyInt>()
            || s.hasattr("__index__")? && !s.hasattr("__len__")?;
        if is_int {
            rng = Some(s.extract::<u64>().map_err(|_| {
                InvalidArgumentError::new_err(format!(
                    "{what}: seed must be an integer in [0, 2^64 - 1] (the random seed)"
                ))
            })?);
        } else {
            deprecated(
                py,
                &format!(
                    "{what}(seed=<configuration>) is deprecated: the start configuration is `{start_name}`; `seed` is the random seed"
                ),
            )?;
            if start.is_some() {
                return Err(InvalidArgumentError::new_err(format!(
                    "{what}: give {start_name}, not both {start_name} and a configuration as seed"
                )));
            }
            start = Some(s.clone());
        }
    }
    if let Some(r) = random_seed {
        deprecated(
            py,
            &format!("{what}(random_seed=...) is deprecated: use seed="),
        )?;
        if rng.is_some_and(|x| x != r) {
            return Err(InvalidArgumentError::new_err(format!(
                "{what}: give seed, not both seed and the deprecated random_seed"
            )));
        }
        rng = Some(r);
    }
    Ok((start, rng))
}

/// IK options: `options` (or the defaults) with `overrides`, the random
/// seed from the call's `seed` keyword when given.
fn ik_options(
    options: Option<&Bound<'_, PyIkOptions>>,
    overrides: Option<&Bound<'_, PyDict>>,
    seed: Option<u64>,
) -> PyResult<IkOptions> {
    let mut o = PyIkOptions::resolve(options, overrides)?;
    if let Some(s) = seed {
        o.seed = s;
    }
    Ok(o)
}

/// Converts a planning error to the matching Python exception.
pub fn planning_err(e: PlanningError) -> PyErr {
    match e {
        PlanningError::Model(m) => model_err(m),
        PlanningError::Collision(c) => collision_err(c),
        PlanningError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
    }
}

fn rows<'py>(py: Python<'py>, data: Vec<f64>, cols: usize) -> Bound<'py, PyArray2<f64>> {
    let n = data.len().checked_div(cols).unwrap_or(0);
    Array2::from_shape_vec((n, cols), data)
        .expect("rows x cols")
        .into_pyarray(py)
}

fn vec1<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(v).into_pyarray(py)
}

/// The output order of a result: a user's joint order, or the planner's.
#[derive(Clone)]
struct Output {
    space: ActiveSpace,
    order: Option<JointOrder>,
}

impl Output {
    fn names(&self) -> Vec<String> {
        match &self.order {
            Some(o) => o.names().to_vec(),
            None => self.space.names.clone(),
        }
    }

    fn positions(&self, q: &[f64]) -> Vec<f64> {
        match &self.order {
            Some(o) => o.from_active(&self.space, q),
            None => q.to_vec(),
        }
    }

    fn derivatives(&self, dq: &[f64]) -> Vec<f64> {
        match &self.order {
            Some(o) => o.derivative_from_active(&self.space, dq),
            None => dq.to_vec(),
        }
    }

    fn width(&self) -> usize {
        self.order.as_ref().map_or(self.space.len(), |o| o.len())
    }
}

/// A trajectory sampled at a fixed time step.
/// A trajectory's samples, for bindings that run it (`Robot.execute`):
/// joint names, time step, positions and velocities (rows of `names.len()`).
pub(crate) struct TrajectorySamples<'a> {
    pub names: &'a [String],
    pub dt: f64,
    pub positions: &'a [f64],
    pub velocities: &'a [f64],
}

#[pyclass(name = "JointTrajectory", module = "ferrobot", frozen)]
pub struct PyJointTrajectory {
    #[pyo3(get)]
    dt: f64,
    #[pyo3(get)]
    joint_names: Vec<String>,
    times: Vec<f64>,
    positions: Vec<f64>,
    velocities: Vec<f64>,
    accelerations: Vec<f64>,
    width: usize,
}

impl PyJointTrajectory {
    /// Its samples.
    pub(crate) fn samples(&self) -> TrajectorySamples<'_> {
        TrajectorySamples {
            names: &self.joint_names,
            dt: self.dt,
            positions: &self.positions,
            velocities: &self.velocities,
        }
    }
}

#[pymethods]
impl PyJointTrajectory {
    /// Sample times (s), shape (T,); the last is the trajectory's end.
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(vec1(py, self.times.clone())))
    }

    /// Positions, shape (T, len(joint_names)).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(rows(py, self.positions.clone(), self.width)))
    }

    /// Velocities, shape (T, len(joint_names)).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(rows(py, self.velocities.clone(), self.width)))
    }

    /// Accelerations, shape (T, len(joint_names)).
    #[getter]
    fn accelerations<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(rows(py, self.accelerations.clone(), self.width)))
    }

    fn __len__(&self) -> PyResult<usize> {
        guard(|| Ok(self.times.len()))
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                format!(
                    "JointTrajectory({} samples, dt={}, {:.3} s)",
                    self.times.len(),
                    self.dt,
                    self.times.last().copied().unwrap_or(0.0)
                )
            })
        })
    }
}

/// The result of `Planner.plan`: status, path, trajectory, stage times.
#[pyclass(name = "PlanResult", module = "ferrobot", frozen)]
pub struct PyPlanResult {
    inner: PlanResult,
    out: Output,
}

#[pymethods]
impl PyPlanResult {
    /// Whether a collision-free path was found.
    #[getter]
    fn success(&self) -> PyResult<bool> {
        guard(|| Ok(self.inner.success()))
    }

    /// "solved", "start_in_collision", "goal_in_collision",
    /// "start_out_of_limits", "goal_out_of_limits", "ik_failed", "timeout"
    /// or "sample_limit".
    #[getter]
    fn status(&self) -> PyResult<&'static str> {
        guard(|| Ok(self.inner.status.name()))
    }

    /// Why the plan failed (empty when solved).
    #[getter]
    fn message(&self) -> PyResult<&str> {
        guard(|| Ok(self.inner.message.as_str()))
    }

    /// Joint order of `path`, `goal` and the interpolated trajectory.
    #[getter]
    fn joint_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.out.names()))
    }

    /// The geometric path, shape (K, len(joint_names)); empty if failed.
    #[getter]
    fn path<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            Ok({
                let data: Vec<f64> = self
                    .inner
                    .path
                    .iter()
                    .flat_map(|q| self.out.positions(q))
                    .collect();
                rows(py, data, self.out.width())
            })
        })
    }

    /// The goal configuration reached (the IK solution for pose goals).
    #[getter]
    fn goal<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<f64>>>> {
        guard(|| {
            Ok({
                self.inner
                    .goal
                    .as_ref()
                    .map(|g| vec1(py, self.out.positions(g)))
            })
        })
    }

    /// Stage wall-clock times (s): a `PlanTimes` (ik, planning, simplify,
    /// trajectory, total).
    #[getter]
    fn times(&self) -> crate::results::PyPlanTimes {
        crate::results::PyPlanTimes::new(&self.inner.times)
    }

    /// RRT-Connect samples drawn.
    #[getter]
    fn samples(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.samples))
    }

    /// True when the smooth spline kept colliding and the trajectory stops
    /// at every waypoint instead (it then follows the checked path exactly).
    #[getter]
    fn stops_at_waypoints(&self) -> PyResult<bool> {
        guard(|| Ok(self.inner.stops_at_waypoints))
    }

    /// Configurations the trajectory's collision re-checks tested.
    #[getter]
    fn recheck_samples(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.recheck_samples))
    }

    /// Waypoints added to the smooth trajectory where it collided.
    #[getter]
    fn refinements(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.refinements))
    }

    /// Length of the path in joint space (Euclidean over planned joints).
    #[getter]
    fn path_length(&self) -> PyResult<f64> {
        guard(|| Ok(self.inner.path_length()))
    }

    /// Duration of the trajectory (s), or None.
    #[getter]
    fn duration(&self) -> PyResult<Option<f64>> {
        guard(|| Ok(self.inner.trajectory.as_ref().map(Trajectory::duration)))
    }

    /// The trajectory sampled every `dt` seconds (the last sample at its
    /// end): positions, velocities and accelerations.
    #[pyo3(signature = (dt=0.01))]
    pub(crate) fn interpolated(&self, dt: f64) -> PyResult<PyJointTrajectory> {
        guard(|| {
            use ferrobot_model::ranges::{MAX_TRAJECTORY_SAMPLES, SAMPLE_DT, step_count};
            SAMPLE_DT
                .check(dt)
                .map_err(|e| InvalidArgumentError::new_err(e.0))?;
            let traj = self.inner.trajectory.as_ref().ok_or_else(|| {
                InvalidArgumentError::new_err(format!(
                    "no trajectory: the plan's status is '{}'{}",
                    self.inner.status.name(),
                    if self.inner.success() {
                        " (planned with trajectory=False)"
                    } else {
                        ""
                    }
                ))
            })?;
            let k = traj.dim();
            step_count("interpolated", traj.duration(), dt, MAX_TRAJECTORY_SAMPLES)
                .map_err(|e| InvalidArgumentError::new_err(e.0))?;
            let (times, q, v, a) = traj.interpolated(dt);
            let map = |src: &[f64], f: &dyn Fn(&[f64]) -> Vec<f64>| -> Vec<f64> {
                src.chunks_exact(k).flat_map(f).collect()
            };
            Ok(PyJointTrajectory {
                dt,
                joint_names: self.out.names(),
                positions: map(&q, &|r| self.out.positions(r)),
                velocities: map(&v, &|r| self.out.derivatives(r)),
                accelerations: map(&a, &|r| self.out.derivatives(r)),
                times,
                width: self.out.width(),
            })
        })
    }

    fn __bool__(&self) -> PyResult<bool> {
        guard(|| Ok(self.inner.success()))
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                let t = self.inner.times;
                format!(
                    "PlanResult(status='{}', waypoints={}, total={:.3} ms{})",
                    self.inner.status.name(),
                    self.inner.path.len(),
                    t.total * 1e3,
                    if self.inner.message.is_empty() {
                        String::new()
                    } else {
                        format!(", message={:?}", self.inner.message)
                    }
                )
            })
        })
    }
}

/// IK results: one solve (scalars and 1-D arrays) or a batch (arrays).
#[pyclass(name = "IkResult", module = "ferrobot", frozen)]
pub struct PyIkResult {
    solutions: Vec<IkSolution>,
    out: Output,
    batched: bool,
}

#[pymethods]
impl PyIkResult {
    /// Success flag(s).
    #[getter]
    fn success<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            if self.batched {
                let v: Vec<bool> = self.solutions.iter().map(|s| s.success).collect();
                Ok(Array1::from_vec(v).into_pyarray(py).into_any())
            } else {
                Ok(pyo3::types::PyBool::new(py, self.solutions[0].success)
                    .to_owned()
                    .into_any())
            }
        })
    }

    /// Solution(s) (or best attempts where `success` is false), shape
    /// (len(joint_names),) or (N, len(joint_names)).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            Ok({
                let data: Vec<f64> = self
                    .solutions
                    .iter()
                    .flat_map(|s| self.out.positions(&s.q))
                    .collect();
                if self.batched {
                    rows(py, data, self.out.width()).into_any()
                } else {
                    vec1(py, data).into_any()
                }
            })
        })
    }

    /// Position error(s) (m).
    #[getter]
    fn position_error<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| self.scalars(py, |s| s.position_error))
    }

    /// Rotation error(s) (rad).
    #[getter]
    fn rotation_error<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| self.scalars(py, |s| s.rotation_error))
    }

    /// Index of the goal reached in a goal set (0 for single goals).
    #[getter]
    fn goal_index<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            self.scalars(py, |s| s.goal_index as f64).and_then(|v| {
                if self.batched {
                    v.call_method1("astype", ("int64",))
                } else {
                    v.call_method0("__int__")
                }
            })
        })
    }

    /// Seeds tried (per solve).
    #[getter]
    fn seeds_tried<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            self.scalars(py, |s| s.seeds_tried as f64).and_then(|v| {
                if self.batched {
                    v.call_method1("astype", ("int64",))
                } else {
                    v.call_method0("__int__")
                }
            })
        })
    }

    /// Joint order of `q`.
    #[getter]
    fn joint_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.out.names()))
    }

    fn __len__(&self) -> PyResult<usize> {
        guard(|| Ok(self.solutions.len()))
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                let ok = self.solutions.iter().filter(|s| s.success).count();
                format!("IkResult({ok}/{} solved)", self.solutions.len())
            })
        })
    }
}

impl PyIkResult {
    fn scalars<'py>(
        &self,
        py: Python<'py>,
        f: impl Fn(&IkSolution) -> f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<f64> = self.solutions.iter().map(f).collect();
        if self.batched {
            Ok(vec1(py, v).into_any())
        } else {
            Ok(pyo3::types::PyFloat::new(py, v[0]).into_any())
        }
    }
}

/// Motion planner: multi-seed IK, RRT-Connect with vectorised motion
/// checks, shortcutting and smooth time-parametrised trajectories.
#[pyclass(name = "Planner", module = "ferrobot")]
pub struct PyPlanner {
    /// The planner, swapped atomically: a plan works on a snapshot (an
    /// `Arc` clone) with the lock released, and a change (`update_world`,
    /// `attach_world_object`, ...) edits a copy when a plan holds the
    /// current one, so concurrent plans always see one consistent world.
    inner: std::sync::RwLock<Arc<Planner>>,
    /// Keeps the planner's world in sync with a simulated world
    /// (`update_world(sim, ...)`): hulls cached, poses moved in place.
    sync: std::sync::Mutex<ferrobot_pipeline::SceneSync>,
    /// The links' exact geometry for `exact_clearance`, made on first use.
    exact: std::sync::OnceLock<ferrobot_control::LinkClearance>,
}

impl PyPlanner {
    /// The current planner (a snapshot unaffected by later changes).
    fn snap(&self) -> Arc<Planner> {
        self.inner
            .read()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone()
    }

    /// Applies `f` to the planner (copy-on-write if a plan holds it).
    fn edit<T>(&self, f: impl FnOnce(&mut Planner) -> PyResult<T>) -> PyResult<T> {
        let mut g = self
            .inner
            .write()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        // In place when no plan holds the planner, else on a copy.
        f(Arc::make_mut(&mut g))
    }

    fn order(&self, joint_names: Option<Vec<String>>) -> PyResult<Option<JointOrder>> {
        let inner = self.snap();
        joint_names
            .map(|n| JointOrder::new(inner.model(), inner.space(), &n))
            .transpose()
            .map_err(planning_err)
    }

    /// A full configuration (`dof_names` order) from a configuration in
    /// any accepted order (locked joints at their locked values).
    fn full_config(
        &self,
        q: &Bound<'_, PyAny>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<Vec<f64>> {
        let inner = self.snap();
        let order = self.order(joint_names)?;
        Ok(self
            .config(q, "q", order.as_ref())?
            .into_full(inner.space()))
    }

    /// Reads a configuration (`Configuration::read` of the planning crate
    /// decides the order and the locked-joint overrides).
    fn config(
        &self,
        obj: &Bound<'_, PyAny>,
        what: &str,
        order: Option<&JointOrder>,
    ) -> PyResult<Configuration> {
        let inner = self.snap();
        let arr = read_array(obj, what, 1, &[None])?;
        Configuration::read(inner.model(), inner.space(), order, what, arr.data())
            .map_err(planning_err)
    }

    fn output(&self, order: Option<JointOrder>, space: &ActiveSpace) -> Output {
        Output {
            space: space.clone(),
            order,
        }
    }

    fn link(&self, link: Option<&str>) -> PyResult<Option<usize>> {
        let inner = self.snap();
        link.map(|l| inner.model().link(l).map_err(model_err))
            .transpose()
    }
}

#[pymethods]
impl PyPlanner {
    /// A planner for `model` (its planning group: the SRDF group chosen at
    /// load, or the chain from the base to the end effector) in `world`
    /// (robot base frame; default empty), with `spheres` (default: the
    /// automatic sphere model) and IK for `ee_link` (default: the model's
    /// end effector).
    #[new]
    #[pyo3(signature = (model, world=None, spheres=None, *, margin=0.0, ee_link=None))]
    fn new(
        py: Python<'_>,
        model: &PyRobotModel,
        world: Option<&PyCollisionWorld>,
        spheres: Option<&PySphereModel>,
        margin: f64,
        ee_link: Option<&str>,
    ) -> PyResult<Self> {
        guard(|| {
            let checker = build_checker(py, model, world, spheres, margin)?;
            let link = ee_link
                .map(|l| model.inner.link(l).map_err(model_err))
                .transpose()?;
            Ok(Self {
                inner: std::sync::RwLock::new(Arc::new(
                    Planner::new(checker, link).map_err(planning_err)?,
                )),
                sync: Default::default(),
                exact: Default::default(),
            })
        })
    }

    /// The planned joints, in the planner's own order (a subset of
    /// `dof_names`, in the same order).
    #[getter]
    fn joint_names(&self) -> PyResult<Vec<String>> {
        let inner = self.snap();
        guard(|| Ok(inner.space().names.clone()))
    }

    /// All DOF names of the model.
    #[getter]
    fn dof_names(&self) -> PyResult<Vec<String>> {
        let inner = self.snap();
        guard(|| Ok(inner.model().dof_names().to_vec()))
    }

    /// The IK link's name.
    #[getter]
    fn ee_link(&self) -> PyResult<String> {
        guard(|| {
            let inner = self.snap();
            Ok(inner.model().links()[inner.ik_link()].name.clone())
        })
    }

    /// Values of the joints the planner does not move, `dof_names` order.
    #[getter]
    fn locked_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let inner = self.snap();
        guard(|| Ok(vec1(py, inner.space().locked.clone())))
    }

    /// Sets the joints the planner does not move (fingers, say) from a full
    /// configuration in `dof_names` order.
    #[setter(locked_positions)]
    fn set_locked_positions_value(&self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let n = self.snap().model().num_dof();
            let arr = read_array(q, "q", 1, &[Some(n)])?;
            self.edit(|p| p.set_locked(arr.data()).map_err(planning_err))
        })
    }

    /// Deprecated: assign `locked_positions` instead.
    fn set_locked_positions(&self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        deprecated(
            q.py(),
            "Planner.set_locked_positions(q) is deprecated: assign Planner.locked_positions = q",
        )?;
        self.set_locked_positions_value(q)
    }

    /// Limits of the planned joints: a `JointLimits` (lower, upper,
    /// velocity, acceleration, jerk; arrays in `joint_names` order).
    #[getter]
    fn limits(&self, py: Python<'_>) -> PyResult<crate::results::PyJointLimits> {
        use crate::results::arr1;
        guard(|| {
            let inner = self.snap();
            let l = inner.limits();
            Ok(crate::results::PyJointLimits {
                lower: arr1(py, l.lower.clone()),
                upper: arr1(py, l.upper.clone()),
                velocity: arr1(py, l.velocity.clone()),
                acceleration: arr1(py, l.acceleration.clone()),
                jerk: arr1(py, l.jerk.clone()),
            })
        })
    }

    /// Replaces velocity, acceleration and/or jerk limits (positive, one per
    /// planned joint).
    #[pyo3(signature = (*, velocity=None, acceleration=None, jerk=None))]
    fn set_limits(
        &self,
        velocity: Option<&Bound<'_, PyAny>>,
        acceleration: Option<&Bound<'_, PyAny>>,
        jerk: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let inner = self.snap();
            let k = inner.space().len();
            let mut next = inner.limits().clone();
            for (what, v) in [
                ("velocity", velocity),
                ("acceleration", acceleration),
                ("jerk", jerk),
            ] {
                if let Some(v) = v {
                    let arr = read_array(v, what, 1, &[Some(k)])?;
                    next.set(what, arr.data()).map_err(planning_err)?;
                }
            }
            self.edit(|p| {
                *p.limits_mut() = next;
                Ok(())
            })
        })
    }

    /// Sets the planner's world. `world` is a `CollisionWorld` (robot base
    /// frame; a copy replaces the planner's world, without the objects
    /// whose name contains one of the `ignore` substrings) or a simulated
    /// `World`, whose objects are taken at their current poses and expressed
    /// in the frame of `base_pose` (the robot base's pose in the simulation;
    /// identity by default), with its ground plane as a slab named "ground".
    /// A simulated world is synced incrementally: objects are moved in
    /// place, added or removed as the simulation changed, hulls made once
    /// per object, and the objects matching `ignore` stay in the world but
    /// are ignored by every query until a later sync enables them (see
    /// `set_object_enabled`). Objects attached to the robot stay out.
    #[pyo3(signature = (world, ignore=None, base_pose=None))]
    fn update_world(
        &self,
        world: &Bound<'_, PyAny>,
        ignore: Option<&Bound<'_, PyAny>>,
        base_pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let ignore = crate::scene::ignore_list(ignore)?;
            if let Ok(sim) = world.cast::<crate::sim::PyWorld>() {
                let base = match base_pose {
                    Some(p) => crate::arrays::read_pose(p, "base_pose")?,
                    None => nalgebra::Isometry3::identity(),
                };
                let opts = ferrobot_pipeline::SyncOptions { ignore, base };
                let shared = sim.borrow().shared();
                let w = crate::sim::lock(&shared)?;
                let mut sync = self
                    .sync
                    .lock()
                    .unwrap_or_else(|poisoned| poisoned.into_inner());
                return self.edit(|p| {
                    sync.sync(&w, &opts, p.checker_mut())
                        .map(|_| ())
                        .map_err(collision_err)
                });
            }
            let attached: Vec<String> = self
                .snap()
                .checker()
                .attached()
                .iter()
                .map(|a| a.name.clone())
                .collect();
            let w = crate::scene::world_from_any(world, ignore, base_pose, &attached)?;
            self.edit(|p| {
                p.update_world(w);
                Ok(())
            })
        })
    }

    /// Ignores (`enabled=False`) or enables world object `name` for every
    /// query without rebuilding the world (MoveIt's allowed-collision
    /// entry for a world object). Raises `UnknownNameError` for a name not
    /// in the world.
    #[pyo3(signature = (name, enabled))]
    fn set_object_enabled(&self, name: &str, enabled: bool) -> PyResult<()> {
        guard(|| {
            self.edit(|p| {
                p.checker_mut()
                    .set_object_enabled(name, enabled)
                    .map_err(collision_err)
            })
        })
    }

    /// Names of the world objects the planner ignores (sorted).
    #[getter]
    fn ignored_objects(&self) -> PyResult<Vec<String>> {
        guard(|| {
            Ok(self
                .snap()
                .checker()
                .disabled_objects()
                .map(String::from)
                .collect())
        })
    }

    /// Counters of the scene sync (`update_world` with a simulated world)
    /// since the planner was made: a `WorldSyncStats` (`full_builds`: syncs
    /// that built the world from scratch, `incremental`: syncs that updated
    /// it in place, `added`, `removed`, `moved`: objects).
    #[getter]
    fn world_sync_stats(&self) -> PyResult<crate::results::PyWorldSyncStats> {
        guard(|| {
            let s = self
                .sync
                .lock()
                .unwrap_or_else(|poisoned| poisoned.into_inner())
                .stats();
            Ok(crate::results::PyWorldSyncStats::new(&s))
        })
    }

    /// Attaches world object `name` to `link` (default: the planner's
    /// end-effector link) at configuration `q`, keeping its pose relative to
    /// the link: it leaves the world, is covered by spheres and moves with
    /// the link (a grasped object). `touch_links` may touch it (default:
    /// `link` and every link below it, e.g. the fingers).
    #[pyo3(signature = (name, q, link=None, touch_links=None, joint_names=None))]
    fn attach_world_object(
        &self,
        name: &str,
        q: &Bound<'_, PyAny>,
        link: Option<&str>,
        touch_links: Option<Vec<String>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let full = self.full_config(q, joint_names)?;
            let inner = self.snap();
            let model = inner.model().clone();
            let li = match link {
                Some(l) => model.link(l).map_err(model_err)?,
                None => inner.ik_link(),
            };
            let touch = match touch_links {
                Some(t) => t,
                None => inner.checker().default_touch_links(li),
            };
            let touch: Vec<&str> = touch.iter().map(String::as_str).collect();
            let link_name = model.links()[li].name.clone();
            self.edit(|p| {
                p.checker_mut()
                    .attach_world_object(name, &link_name, &full, &touch)
                    .map_err(collision_err)
            })
        })
    }

    /// Detaches `name`; with `q` it returns to the world at its pose at `q`,
    /// without it is dropped.
    #[pyo3(signature = (name, q=None, joint_names=None))]
    fn detach(
        &self,
        name: &str,
        q: Option<&Bound<'_, PyAny>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let full = q.map(|q| self.full_config(q, joint_names)).transpose()?;
            self.edit(|p| {
                p.checker_mut()
                    .detach(name, full.as_deref())
                    .map(|_| ())
                    .map_err(collision_err)
            })
        })
    }

    /// The robot's sphere model used by this planner (automatic unless one
    /// was given); its `report` is empty.
    #[getter]
    fn sphere_model(&self) -> PyResult<PySphereModel> {
        guard(|| {
            let inner = self.snap();
            Ok({
                let c = inner.checker();
                PySphereModel {
                    model: c.model().clone(),
                    inner: c.spheres().clone(),
                    report: Vec::new(),
                }
            })
        })
    }

    /// Names of the objects attached to the robot.
    #[getter]
    fn attached(&self) -> PyResult<Vec<String>> {
        guard(|| {
            let inner = self.snap();
            Ok({
                inner
                    .checker()
                    .attached()
                    .iter()
                    .map(|a| a.name.clone())
                    .collect()
            })
        })
    }

    /// A copy of the planner's world: the objects it collides with (the
    /// ignored ones left out).
    #[getter]
    fn world(&self) -> PyResult<PyCollisionWorld> {
        guard(|| {
            let inner = self.snap();
            Ok(PyCollisionWorld {
                inner: inner.checker().enabled_world(),
            })
        })
    }

    /// Exact clearance at `q` of each object of the planner's world (the
    /// ignored ones left out; every object, or those named in `objects`):
    /// a dict from object name to `Clearance` (`distance` in m, 0 when
    /// touching or overlapping; `closest` = (link, object)). Measured with
    /// parry on the links' collision geometry (meshes as their convex
    /// hulls) and the objects' shapes, not the sphere model: it tells the
    /// contacts the spheres report (they reach a few millimetres beyond the
    /// links) from real ones. Point clouds raise `InvalidArgumentError`;
    /// unknown names `UnknownNameError`.
    #[pyo3(signature = (q, objects=None, joint_names=None))]
    fn exact_clearance(
        &self,
        py: Python<'_>,
        q: &Bound<'_, PyAny>,
        objects: Option<Vec<String>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<std::collections::HashMap<String, crate::results::PyClearance>> {
        guard(|| {
            let inner = self.snap();
            let full = self.full_config(q, joint_names)?;
            if self.exact.get().is_none() {
                let lc = ferrobot_control::LinkClearance::new(inner.model().clone())
                    .map_err(crate::control::control_err)?;
                let _ = self.exact.set(lc);
            }
            let lc = self.exact.get().expect("set above");
            let world = inner.checker().enabled_world();
            let found = py
                .detach(|| lc.object_clearances(&full, &world, objects.as_deref()))
                .map_err(crate::control::control_err)?;
            Ok(found
                .into_iter()
                .map(|o| {
                    let closest = o.link.map(|l| (l, o.object.clone()));
                    (
                        o.object,
                        crate::results::PyClearance {
                            distance: o.distance,
                            closest,
                        },
                    )
                })
                .collect())
        })
    }

    /// Whether configuration `q` collides (world or self).
    #[pyo3(signature = (q, joint_names=None))]
    fn in_collision(
        &self,
        q: &Bound<'_, PyAny>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<bool> {
        guard(|| {
            let full = self.full_config(q, joint_names)?;
            Ok(self.snap().checker().in_collision_unchecked(&full))
        })
    }

    /// IK for one pose (base frame; 4x4 or [x, y, z, qw, qx, qy, qz]):
    /// the `start` configuration first, then random starts drawn with the
    /// random seed `seed`. Options: `options` (an `IkOptions`, default
    /// `IkOptions()`) with `**overrides` (any `IkOptions` field, e.g.
    /// `collision_free=True`); with `collision_free`, solutions in collision
    /// are rejected. (Deprecated: `seed=<configuration>` for `start`, and
    /// `random_seed` for `seed`.)
    #[pyo3(signature = (goal_pose, start=None, *, link=None, joint_names=None,
        options=None, seed=None, random_seed=None, **overrides))]
    #[allow(clippy::too_many_arguments)]
    fn ik(
        &self,
        py: Python<'_>,
        goal_pose: &Bound<'_, PyAny>,
        start: Option<&Bound<'_, PyAny>>,
        link: Option<&str>,
        joint_names: Option<Vec<String>>,
        options: Option<&Bound<'_, PyIkOptions>>,
        seed: Option<&Bound<'_, PyAny>>,
        random_seed: Option<u64>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyIkResult> {
        guard(|| {
            let (start, rng) = seed_args(py, "ik", "start", start, seed, random_seed)?;
            let opts = ik_options(options, overrides, rng)?;
            let goals = read_poses(goal_pose, "goal_pose")?;
            if goals.len() != 1 {
                return Err(ShapeError::new_err(
                    "goal_pose: one pose expected (use ik_goalset or ik_batch for several)",
                ));
            }
            self.goalset(py, goals, start.as_ref(), link, joint_names, opts)
        })
    }

    /// IK for a goal set: any of the poses (N, 7) or (N, 4, 4) will do
    /// (grasp candidates, say); `goal_index` tells which was reached.
    /// `start`, `seed`, `options` and `**overrides` as in `ik`.
    #[pyo3(signature = (goal_poses, start=None, *, link=None, joint_names=None,
        options=None, seed=None, random_seed=None, **overrides))]
    #[allow(clippy::too_many_arguments)]
    fn ik_goalset(
        &self,
        py: Python<'_>,
        goal_poses: &Bound<'_, PyAny>,
        start: Option<&Bound<'_, PyAny>>,
        link: Option<&str>,
        joint_names: Option<Vec<String>>,
        options: Option<&Bound<'_, PyIkOptions>>,
        seed: Option<&Bound<'_, PyAny>>,
        random_seed: Option<u64>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyIkResult> {
        guard(|| {
            let (start, rng) = seed_args(py, "ik_goalset", "start", start, seed, random_seed)?;
            let opts = ik_options(options, overrides, rng)?;
            let goals = read_poses(goal_poses, "goal_poses")?;
            self.goalset(py, goals, start.as_ref(), link, joint_names, opts)
        })
    }

    /// IK for each of N poses independently, in parallel; `starts` (N, k)
    /// optional start configurations, `seed` the random seed, `options`
    /// and `**overrides` as in `ik`. Results are arrays over the batch.
    /// Without `starts`, a batch of 64 or more poses starts each pose from
    /// the nearest-pose entry of a 512-configuration random library (made
    /// from `seed`; it counts as one of the seeds tried).
    /// (Deprecated: `seeds` for `starts`, `random_seed` for `seed`.)
    #[pyo3(signature = (goal_poses, starts=None, *, link=None, joint_names=None,
        options=None, seed=None, seeds=None, random_seed=None, **overrides))]
    #[allow(clippy::too_many_arguments)]
    fn ik_batch(
        &self,
        py: Python<'_>,
        goal_poses: &Bound<'_, PyAny>,
        starts: Option<&Bound<'_, PyAny>>,
        link: Option<&str>,
        joint_names: Option<Vec<String>>,
        options: Option<&Bound<'_, PyIkOptions>>,
        seed: Option<u64>,
        seeds: Option<&Bound<'_, PyAny>>,
        random_seed: Option<u64>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyIkResult> {
        guard(|| {
            let starts = match (starts, seeds) {
                (Some(_), Some(_)) => {
                    return Err(InvalidArgumentError::new_err(
                        "ik_batch: give starts, not both starts and the deprecated seeds",
                    ));
                }
                (None, Some(s)) => {
                    deprecated(
                        py,
                        "ik_batch(seeds=...) is deprecated: the start configurations are `starts`",
                    )?;
                    Some(s)
                }
                (s, None) => s,
            };
            let rng = match random_seed {
                Some(r) => {
                    deprecated(py, "ik_batch(random_seed=...) is deprecated: use seed=")?;
                    if seed.is_some_and(|s| s != r) {
                        return Err(InvalidArgumentError::new_err(
                            "ik_batch: give seed, not both seed and the deprecated random_seed",
                        ));
                    }
                    Some(r)
                }
                None => seed,
            };
            let inner = self.snap();
            let opts = ik_options(options, overrides, rng)?;
            let goals = read_poses(goal_poses, "goal_poses")?;
            let order = self.order(joint_names)?;
            let starts: Option<Vec<Vec<f64>>> = match starts {
                None => None,
                Some(s) => {
                    let arr = read_array(s, "starts", 2, &[None])?;
                    let w = arr.shape[1];
                    if arr.shape[0] != goals.len() {
                        return Err(ShapeError::new_err(format!(
                            "starts: {} rows for {} goal poses",
                            arr.shape[0],
                            goals.len()
                        )));
                    }
                    let mut out = Vec::with_capacity(goals.len());
                    for row in arr.data().chunks_exact(w.max(1)) {
                        let list = pyo3::types::PyList::new(py, row)?;
                        out.push(
                            self.config(list.as_any(), "starts row", order.as_ref())?
                                .active,
                        );
                    }
                    Some(out)
                }
            };
            let link = self.link(link)?;
            let solver = inner.ik_solver(link).map_err(planning_err)?;
            let solutions = py
                .detach(|| solver.solve_batch(&goals, starts.as_deref(), &opts))
                .map_err(planning_err)?;
            Ok(PyIkResult {
                solutions,
                out: self.output(order, inner.space()),
                batched: true,
            })
        })
    }

    /// Plans from `start` to `goal_q` (a configuration) or `goal_pose` (a
    /// pose of the IK link in the base frame, or a goal set (N, 7) /
    /// (N, 4, 4), reached through collision-free IK). Configurations are in
    /// `joint_names` order if given, else full `dof_names` vectors or the
    /// planner's `joint_names`. Options: `options` (a `PlanOptions`, default
    /// `PlanOptions()`) with `**overrides` (any `PlanOptions` field, e.g.
    /// `time_limit=2.0, seed=3`). Failures are reported in the result's
    /// `status`, not raised.
    #[pyo3(signature = (start, goal_q=None, goal_pose=None, joint_names=None, *,
        options=None, **overrides))]
    fn plan(
        &self,
        start: &Bound<'_, PyAny>,
        goal_q: Option<&Bound<'_, PyAny>>,
        goal_pose: Option<&Bound<'_, PyAny>>,
        joint_names: Option<Vec<String>>,
        options: Option<&Bound<'_, PyPlanOptions>>,
        overrides: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<PyPlanResult> {
        guard(|| {
            let py = start.py();
            let inner = self.snap();
            let opts = PyPlanOptions::resolve(options, overrides)?;
            inner
                .limits()
                .scaled(opts.velocity_scale, opts.acceleration_scale)
                .map_err(planning_err)?;
            let order = self.order(joint_names)?;
            let start = self.config(start, "start", order.as_ref())?;
            // A full start sets the locked joints for this plan (the request
            // carries them: the planner is shared, not copied).
            let locked = start.locked_override(inner.space());
            let start = start.active;
            let goal = match (goal_q, goal_pose) {
                (Some(g), None) => {
                    Goal::Configuration(self.config(g, "goal_q", order.as_ref())?.active)
                }
                (None, Some(p)) => Goal::Poses(read_poses(p, "goal_pose")?),
                _ => {
                    return Err(InvalidArgumentError::new_err(
                        "give exactly one of goal_q and goal_pose",
                    ));
                }
            };
            let mut space = inner.space().clone();
            if let Some(f) = &locked {
                space.lock_from(f);
            }
            let request = PlanRequest {
                start,
                goal,
                locked,
                options: opts,
            };
            let result = py.detach(|| inner.solve(&request)).map_err(planning_err)?;
            Ok(PyPlanResult {
                inner: result,
                out: self.output(order, &space),
            })
        })
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            let inner = self.snap();
            Ok({
                format!(
                    "Planner(robot='{}', joints={:?}, ee_link='{}')",
                    inner.model().name(),
                    inner.space().names,
                    self.ee_link()?
                )
            })
        })
    }
}

impl PyPlanner {
    fn goalset(
        &self,
        py: Python<'_>,
        goals: Vec<nalgebra::Isometry3<f64>>,
        start: Option<&Bound<'_, PyAny>>,
        link: Option<&str>,
        joint_names: Option<Vec<String>>,
        opts: IkOptions,
    ) -> PyResult<PyIkResult> {
        let inner = self.snap();
        let order = self.order(joint_names)?;
        let seeds = match start {
            Some(s) => vec![self.config(s, "start", order.as_ref())?.active],
            None => Vec::new(),
        };
        let link = self.link(link)?;
        let solver = inner.ik_solver(link).map_err(planning_err)?;
        let solution = py
            .detach(|| solver.solve(&goals, &seeds, &opts))
            .map_err(planning_err)?;
        Ok(PyIkResult {
            solutions: vec![solution],
            out: self.output(order, inner.space()),
            batched: false,
        })
    }
}
