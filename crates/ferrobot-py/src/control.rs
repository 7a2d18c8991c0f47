//! `ferrobot.ReactiveController` and `ferrobot.PotentialFieldController`:
//! reactive joint-space control towards an end-effector target around
//! (moving) obstacles, one `step(q, qd, dt)` per control cycle.

use ferrobot_collision::{AllowedCollisions, AnalyzeCollisions};
use ferrobot_control::{
    ControlError, ControllerCore, LinkClearance, PotentialFieldConfig, PotentialFieldController,
    ReactiveConfig, ReactiveController, StepInfo,
};
use numpy::ndarray::Array1;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{read_array, read_pose};
use crate::collision::{PyCollisionWorld, PySphereModel, build_checker};
use crate::errors::{
    InvalidArgumentError, NonFiniteError, UnknownNameError, collision_err, guard, model_err,
};
use crate::model::PyRobotModel;

/// Converts a control error to the matching `ferrobot.errors` exception.
pub(crate) fn control_err(e: ControlError) -> PyErr {
    match e {
        ControlError::Model(m) => model_err(m),
        ControlError::Collision(c) => collision_err(c),
        ControlError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
        ControlError::NonFinite(m) => NonFiniteError::new_err(m),
        ControlError::UnknownName(m) => UnknownNameError::new_err(m),
    }
}

/// Permutation from a caller's joint order to `dof_names` order:
/// `perm[i]` is the DOF index of the caller's joint `i`.
fn joint_order(model: &ferrobot_model::RobotModel, names: &[String]) -> PyResult<Vec<usize>> {
    let n = model.num_dof();
    let mut perm = Vec::with_capacity(names.len());
    let mut seen = vec![false; n];
    for name in names {
        let d = model.dof(name).map_err(model_err)?;
        if seen[d] {
            return Err(InvalidArgumentError::new_err(format!(
                "joint_names: '{name}' appears twice"
            )));
        }
        seen[d] = true;
        perm.push(d);
    }
    if perm.len() != n {
        let missing: Vec<&str> = (0..n)
            .filter(|&d| !seen[d])
            .map(|d| model.dof_names()[d].as_str())
            .collect();
        return Err(InvalidArgumentError::new_err(format!(
            "joint_names: every joint of dof_names is needed; missing {}",
            missing.join(", ")
        )));
    }
    Ok(perm)
}

macro_rules! controller_class {
    ($py_name:literal, $ty:ident, $ctl:ty, $cfg:ty, $doc:literal $(, { $($extra:tt)* })?) => {
        #[doc = $doc]
        #[pyclass(name = $py_name, module = "ferrobot")]
        pub struct $ty {
            inner: $ctl,
            last: Option<StepInfo>,
            clearance: std::sync::OnceLock<LinkClearance>,
        }

        impl $ty {
            fn q(&self, q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
                let n = self.inner.model().num_dof();
                Ok(read_array(q, what, 1, &[Some(n)])?.data().to_vec())
            }
        }

        #[pymethods]
        impl $ty {
            /// A controller for `model` among the obstacles of `world`
            /// (default: none), steering by the robot's `spheres` (default:
            /// the automatic sphere model) towards targets for `ee_link`
            /// (default: the model's end effector). It drives the model's
            /// planning group; other DOFs are held at the posture. `config`
            /// overrides gains by name (see `config_ranges()`). Self-collision
            /// pairs are the checker's, minus link pairs never or always in
            /// contact over `self_collision_samples` random configurations
            /// (0 skips that analysis).
            #[new]
            #[pyo3(signature = (model, world=None, spheres=None, *, ee_link=None, config=None, self_collision_samples=2000))]
            fn new(
                py: Python<'_>,
                model: &PyRobotModel,
                world: Option<&PyCollisionWorld>,
                spheres: Option<&PySphereModel>,
                ee_link: Option<String>,
                config: Option<&Bound<'_, PyDict>>,
                self_collision_samples: usize,
            ) -> PyResult<Self> {
                guard(|| {
                    let mut cfg = <$cfg>::default();
                    if let Some(c) = config {
                        for (k, v) in c.iter() {
                            let name: String = k.extract().map_err(|_| {
                                InvalidArgumentError::new_err("config: keys must be strings")
                            })?;
                            let value: f64 = v.extract().map_err(|_| {
                                InvalidArgumentError::new_err(format!(
                                    "config '{name}': expected a number"
                                ))
                            })?;
                            cfg.set(&name, value).map_err(control_err)?;
                        }
                    }
                    let mut checker = build_checker(py, model, world, spheres, 0.0)?;
                    let inner = py.detach(|| -> Result<$ctl, ControlError> {
                        if self_collision_samples > 0 {
                            let mut acm: AllowedCollisions = checker.allowed_collisions().clone();
                            acm.analyze(
                                checker.model(),
                                checker.spheres(),
                                self_collision_samples,
                                0,
                            )?;
                            checker.set_allowed_collisions(acm);
                        }
                        <$ctl>::new(&checker, ee_link.as_deref(), cfg)
                    });
                    Ok(Self {
                        inner: inner.map_err(control_err)?,
                        last: None,
                        clearance: std::sync::OnceLock::new(),
                    })
                })
            }

            /// Every gain's accepted range: {name: (low, high)} (inclusive).
            #[staticmethod]
            fn config_ranges() -> std::collections::BTreeMap<&'static str, (f64, f64)> {
                <$cfg>::FIELDS
                    .iter()
                    .map(|&(n, lo, hi)| (n, (lo, hi)))
                    .collect()
            }

            /// The gains as {name: value}.
            #[getter]
            fn config(&self) -> std::collections::BTreeMap<&'static str, f64> {
                <$cfg>::FIELDS
                    .iter()
                    .map(|&(n, _, _)| (n, self.inner.config().get(n).expect("known name")))
                    .collect()
            }

            /// Changes some gains ({name: value}); all are checked before any changes.
            fn set_config(&mut self, py: Python<'_>, config: &Bound<'_, PyDict>) -> PyResult<()> {
                guard(|| {
                    let mut cfg = self.inner.config().clone();
                    for (k, v) in config.iter() {
                        let name: String = k.extract().map_err(|_| {
                            InvalidArgumentError::new_err("config: keys must be strings")
                        })?;
                        let value: f64 = v.extract().map_err(|_| {
                            InvalidArgumentError::new_err(format!("config '{name}': expected a number"))
                        })?;
                        cfg.set(&name, value).map_err(control_err)?;
                    }
                    py.detach(|| self.inner.set_config(cfg)).map_err(control_err)
                })
            }

            /// Names of all DOFs (the order of `q`, `qd` and the outputs).
            #[getter]
            fn dof_names(&self) -> Vec<String> {
                self.inner.model().dof_names().to_vec()
            }

            /// Names of the DOFs the controller moves (the planning group).
            #[getter]
            fn active_joints(&self) -> Vec<String> {
                let names = self.inner.model().dof_names();
                self.inner.core().active_dofs().iter().map(|&d| names[d].clone()).collect()
            }

            /// Number of robot spheres steered by.
            #[getter]
            fn num_spheres(&self) -> usize {
                self.inner.core().num_spheres()
            }

            /// Number of sphere pairs watched for self-collision.
            #[getter]
            fn num_self_pairs(&self) -> usize {
                self.inner.core().num_self_pairs()
            }

            /// Sets the end-effector target: a 4x4 pose or [x, y, z, qw, qx, qy, qz]
            /// in the base frame; `orientation=False` controls the position only.
            #[pyo3(signature = (pose, orientation=true))]
            fn set_target(&mut self, pose: &Bound<'_, PyAny>, orientation: bool) -> PyResult<()> {
                guard(|| {
                    let pose = read_pose(pose, "pose")?;
                    self.inner
                        .core_mut()
                        .set_target(pose, orientation)
                        .map_err(control_err)
                })
            }

            /// Removes the target (the controller then holds its posture).
            fn clear_target(&mut self) {
                self.inner.core_mut().clear_target();
            }

            /// The target as [x, y, z, qw, qx, qy, qz], or None.
            #[getter]
            fn target<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
                self.inner.core().target().map(|t| {
                    Array1::from_vec(ferrobot_model::pose_to_array(&t.pose).to_vec())
                        .into_pyarray(py)
                })
            }

            /// Sets the posture (num_dof,) the c-space policy pulls towards;
            /// by default the first `q` given to `step`.
            fn set_posture(&mut self, q: &Bound<'_, PyAny>) -> PyResult<()> {
                guard(|| {
                    let q = self.q(q, "q")?;
                    self.inner.core_mut().set_posture(&q).map_err(control_err)
                })
            }

            /// Replaces the obstacles (a copy of `world`, objects at rest).
            fn update_world(&mut self, py: Python<'_>, world: &PyCollisionWorld) -> PyResult<()> {
                guard(|| {
                    let w = world.inner.clone();
                    py.detach(|| self.inner.set_world(w)).map_err(control_err)
                })
            }

            /// Moves world object `name` to `pose` with `velocity`: (3,)
            /// linear (m/s) or (6,) linear then angular (rad/s) about the
            /// object's origin, base frame; None: at rest.
            #[pyo3(signature = (name, pose, velocity=None))]
            fn set_obstacle_pose(
                &mut self,
                name: &str,
                pose: &Bound<'_, PyAny>,
                velocity: Option<&Bound<'_, PyAny>>,
            ) -> PyResult<()> {
                guard(|| {
                    let pose = read_pose(pose, "pose")?;
                    let v = match velocity {
                        None => None,
                        Some(v) => {
                            let a = read_array(v, "velocity", 1, &[None])?;
                            let d = a.data();
                            match d.len() {
                                3 => Some([d[0], d[1], d[2], 0.0, 0.0, 0.0]),
                                6 => Some([d[0], d[1], d[2], d[3], d[4], d[5]]),
                                n => {
                                    return Err(crate::errors::ShapeError::new_err(format!(
                                        "velocity: expected shape (3,) or (6,), got ({n},)"
                                    )));
                                }
                            }
                        }
                    };
                    self.inner
                        .set_obstacle_pose(name, pose, v)
                        .map_err(control_err)
                })
            }

            /// One control step from the measured joint positions `q` and
            /// velocities `qd` over `dt` seconds (0 < dt <= 1): returns
            /// `(q_target, qd_target, qdd)`, to send as position (and
            /// velocity) targets. Arrays are in `dof_names` order, or in the
            /// order of `joint_names` (all DOFs, e.g. a robot driver's order)
            /// when given. GIL released.
            #[pyo3(signature = (q, qd, dt, joint_names=None))]
            #[allow(clippy::type_complexity)]
            fn step<'py>(
                &mut self,
                py: Python<'py>,
                q: &Bound<'py, PyAny>,
                qd: &Bound<'py, PyAny>,
                dt: f64,
                joint_names: Option<Vec<String>>,
            ) -> PyResult<(
                Bound<'py, PyArray1<f64>>,
                Bound<'py, PyArray1<f64>>,
                Bound<'py, PyArray1<f64>>,
            )> {
                guard(|| {
                    let (mut q, mut qd) = (self.q(q, "q")?, self.q(qd, "qd")?);
                    let perm = match &joint_names {
                        Some(names) => {
                            let p = joint_order(self.inner.model(), names)?;
                            let (q0, qd0) = (q.clone(), qd.clone());
                            for (i, &d) in p.iter().enumerate() {
                                q[d] = q0[i];
                                qd[d] = qd0[i];
                            }
                            Some(p)
                        }
                        None => None,
                    };
                    let out = py
                        .detach(|| self.inner.step(&q, &qd, dt))
                        .map_err(control_err)?;
                    self.last = Some(out.info.clone());
                    let order = |v: Vec<f64>| match &perm {
                        None => v,
                        Some(p) => p.iter().map(|&d| v[d]).collect(),
                    };
                    Ok((
                        Array1::from_vec(order(out.q_target)).into_pyarray(py),
                        Array1::from_vec(order(out.qd_target)).into_pyarray(py),
                        Array1::from_vec(order(out.qdd)).into_pyarray(py),
                    ))
                })
            }

            /// Diagnostics of the last step, a `ControlStepInfo`
            /// (clearances, active avoidance terms, target errors, limit
            /// scaling), or None before the first.
            #[getter]
            fn last_step(&self) -> Option<crate::results::PyControlStepInfo> {
                self.last.as_ref().map(crate::results::PyControlStepInfo::new)
            }

            /// Per robot sphere at `q`, a `SphereDistances`: `distance` (S,) to the nearest world
            /// shape (exact geometry, minus the sphere radius; inf beyond
            /// `reach` m), its unit `direction` (S, 3) of steepest increase,
            /// `gradient` (S, num_dof) with respect to q, `centers` (S, 3)
            /// and `radii` (S,), in the controller's sphere order.
            #[pyo3(signature = (q, reach=1.0))]
            fn sphere_distances<'py>(
                &self,
                py: Python<'py>,
                q: &Bound<'py, PyAny>,
                reach: f64,
            ) -> PyResult<crate::results::PySphereDistances> {
                guard(|| {
                    let q = self.q(q, "q")?;
                    if !(reach.is_finite() && reach > 0.0) {
                        return Err(InvalidArgumentError::new_err(format!(
                            "reach: must be positive and finite, got {reach}"
                        )));
                    }
                    let mut core = self.inner.core().clone();
                    let (dist, dirs, grads, centers) = py
                        .detach(|| core.sphere_distances(&q, reach))
                        .map_err(control_err)?;
                    let s = dist.len();
                    let n = q.len();
                    let flat = |v: Vec<[f64; 3]>| crate::results::arr2(py, s, 3, v.concat());
                    Ok(crate::results::PySphereDistances {
                        distance: crate::results::arr1(py, dist),
                        direction: flat(dirs.iter().map(|d| [d.x, d.y, d.z]).collect()),
                        gradient: crate::results::arr2(py, s, n, grads.concat()),
                        centers: flat(centers.iter().map(|c| [c.x, c.y, c.z]).collect()),
                        radii: crate::results::arr1(py, core.sphere_radii()),
                    })
                })
            }

            /// Exact clearance (m) at `q` between the links' collision
            /// geometry (meshes as convex hulls) and the current obstacles
            /// (boxes, spheres, cylinders, capsules), with parry: a `Clearance`
            /// with `distance` (0 when touching) and `closest` (link, object) or None.
            fn exact_clearance<'py>(
                &self,
                py: Python<'py>,
                q: &Bound<'py, PyAny>,
            ) -> PyResult<crate::results::PyClearance> {
                guard(|| {
                    let q = self.q(q, "q")?;
                    if self.clearance.get().is_none() {
                        let c = LinkClearance::new(self.inner.model().clone()).map_err(control_err)?;
                        let _ = self.clearance.set(c);
                    }
                    let lc = self.clearance.get().expect("set above");
                    let world = self.inner.core().world().world();
                    let c = py.detach(|| lc.clearance(&q, world)).map_err(control_err)?;
                    Ok(crate::results::PyClearance {
                        distance: c.distance,
                        closest: c.closest,
                    })
                })
            }

            /// Exact self-clearance (m) at `q`: the smallest distance
            /// between the collision geometry (meshes as convex hulls, with
            /// parry) of the link pairs the controller checks for
            /// self-collision (`self_link_pairs`): a `Clearance` with `distance`
            /// (0 when touching) and `closest` (link, link) or None.
            fn exact_self_clearance<'py>(
                &self,
                py: Python<'py>,
                q: &Bound<'py, PyAny>,
            ) -> PyResult<crate::results::PyClearance> {
                guard(|| {
                    let q = self.q(q, "q")?;
                    if self.clearance.get().is_none() {
                        let c = LinkClearance::new(self.inner.model().clone()).map_err(control_err)?;
                        let _ = self.clearance.set(c);
                    }
                    let lc = self.clearance.get().expect("set above");
                    let pairs = self.inner.core().self_link_pairs();
                    let c = py.detach(|| lc.self_clearance(&q, pairs)).map_err(control_err)?;
                    Ok(crate::results::PyClearance {
                        distance: c.distance,
                        closest: c.closest,
                    })
                })
            }

            /// Link pairs checked for self-collision, as (link, link) names.
            #[getter]
            fn self_link_pairs(&self) -> Vec<(String, String)> {
                let links = self.inner.model().links();
                self.inner
                    .core()
                    .self_link_pairs()
                    .iter()
                    .map(|&(a, b)| (links[a].name.clone(), links[b].name.clone()))
                    .collect()
            }

            fn __repr__(&self) -> String {
                format!(
                    "{}({} spheres, {} self pairs, {} obstacles)",
                    $py_name,
                    self.inner.core().num_spheres(),
                    self.inner.core().num_self_pairs(),
                    self.inner.core().world().world().len()
                )
            }

            $($($extra)*)?
        }
    };
}

controller_class!(
    "ReactiveController",
    PyReactiveController,
    ReactiveController,
    ReactiveConfig,
    "Reactive (RMPflow-style) control towards an end-effector target around obstacles.",
    {
        /// Global guidance: joint-space waypoints, an (N, num_dof) or
        /// (N, len(active_joints)) array (the other DOFs from the
        /// posture), followed with every avoidance policy active before
        /// the controller hands back to the end-effector target (e.g. a
        /// planner's path to an IK solution when `last_step["stalled"]`).
        /// An empty array clears them.
        fn set_waypoints(&mut self, waypoints: &Bound<'_, PyAny>) -> PyResult<()> {
            guard(|| {
                let a = read_array(waypoints, "waypoints", 2, &[None, None])?;
                let cols = a.shape[1];
                let rows: Vec<Vec<f64>> = if cols == 0 {
                    Vec::new()
                } else {
                    a.data().chunks(cols).map(|r| r.to_vec()).collect()
                };
                self.inner.set_waypoints(&rows).map_err(control_err)
            })
        }

        /// Drops the waypoints.
        fn clear_waypoints(&mut self) {
            self.inner.clear_waypoints();
        }

        /// Waypoints still to pass.
        #[getter]
        fn waypoints_remaining(&self) -> usize {
            self.inner.waypoints_remaining()
        }

        /// The last global-guidance plan attempt, a `GuidancePlan`
        /// (status, message, waypoints, seconds), or None before the first one.
        #[getter]
        fn guidance_last_plan(&self) -> Option<crate::results::PyGuidancePlan> {
            self.inner
                .guidance_last_plan()
                .map(|a| crate::results::PyGuidancePlan {
                    status: a.status.clone(),
                    message: a.message.clone(),
                    waypoints: a.waypoints,
                    seconds: a.seconds,
                })
        }

        /// Why global guidance is unavailable for this robot (no planner
        /// for its group and end effector), or None when it is available.
        #[getter]
        fn guidance_error(&self) -> Option<String> {
            self.inner.guidance_error().map(str::to_string)
        }
    }
);

controller_class!(
    "PotentialFieldController",
    PyPotentialFieldController,
    PotentialFieldController,
    PotentialFieldConfig,
    "Potential-field control over voxelised distance fields of the obstacles."
);
