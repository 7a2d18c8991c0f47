//! Typed result objects (issue 16): what used to be returned as plain dicts
//! (`PlanResult.times`, `Planner.limits`, `Planner.world_sync_stats`, the
//! tracking report of `Robot.execute` / `execute_trajectory`, a
//! controller's `last_step`, `Robot.drive_gains`) is a frozen class built
//! from the crate's struct, with one attribute per field, `to_dict()`, and,
//! for one release, dict-style access (`r["key"]`, `keys()`, `items()`,
//! `values()`, `get()`, `in`, iteration) that still works but emits a
//! `DeprecationWarning`.
//!
//! One macro makes every result class, so they all behave the same; a new
//! result type is one `result_class!` invocation (and its stub in
//! `_core.pyi`).

use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::IntoPyObjectExt;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Warns that dict-style access to a result object is deprecated;
/// `field`: the field asked for, when there is one.
fn dict_access(py: Python<'_>, class: &str, how: &str, field: Option<&str>) -> PyResult<()> {
    let instead = match field {
        Some(f) => format!("read the attribute {class}.{f}"),
        None => "read the attributes".to_string(),
    };
    crate::planning::deprecated(
        py,
        &format!(
            "{class}{how}: dict-style access to results is deprecated: {instead} or call to_dict()"
        ),
    )
}

/// A field's Python name: its Rust name without the `r#` of a raw
/// identifier (`r#type` is `type`).
fn unraw(name: &'static str) -> &'static str {
    name.strip_prefix("r#").unwrap_or(name)
}

macro_rules! result_class {
    (
        $(#[doc = $cdoc:literal])*
        $rust:ident, $pyname:literal {
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $ty:ty,
            )*
        }
    ) => {
        $(#[doc = $cdoc])*
        #[pyclass(name = $pyname, module = "ferrobot", frozen)]
        pub struct $rust {
            $(
                $(#[doc = $doc])*
                #[pyo3(get)]
                pub $field: $ty,
            )*
        }

        impl $rust {
            /// The field names (as Python spells them), in declaration order.
            pub(crate) fn fields() -> Vec<&'static str> {
                vec![$(unraw(stringify!($field))),*]
            }

            fn field<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Option<Bound<'py, PyAny>>> {
                $(if key == unraw(stringify!($field)) {
                    return Ok(Some((&self.$field).into_bound_py_any(py)?));
                })*
                Ok(None)
            }

            fn key_error(key: &Bound<'_, PyAny>) -> PyErr {
                pyo3::exceptions::PyKeyError::new_err(format!(
                    "{}: no field {}; fields: {}",
                    $pyname,
                    key.repr().map(|r| r.to_string()).unwrap_or_default(),
                    Self::fields().join(", ")
                ))
            }
        }

        #[pymethods]
        impl $rust {
            /// The fields as a dict (name: value).
            fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
                crate::errors::guard(|| {
                    let d = PyDict::new(py);
                    $(d.set_item(unraw(stringify!($field)), (&self.$field).into_bound_py_any(py)?)?;)*
                    Ok(d)
                })
            }

            /// Deprecated dict-style access: read the attribute instead.
            fn __getitem__<'py>(&self, py: Python<'py>, key: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
                let k: String = key.extract().map_err(|_| Self::key_error(key))?;
                dict_access(py, $pyname, &format!("[{k:?}]"), Some(&k))?;
                self.field(py, &k)?.ok_or_else(|| Self::key_error(key))
            }

            /// Deprecated dict-style access: `key in result`.
            fn __contains__(&self, py: Python<'_>, key: &Bound<'_, PyAny>) -> PyResult<bool> {
                dict_access(py, $pyname, ": `in`", None)?;
                Ok(key.extract::<String>().is_ok_and(|k| Self::fields().contains(&k.as_str())))
            }

            /// Deprecated dict-style access: iterates over the field names.
            fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
                dict_access(py, $pyname, ": iteration", None)?;
                Self::fields().into_bound_py_any(py)?.try_iter().map(|i| i.into_any())
            }

            /// Deprecated dict-style access: the field names.
            fn keys(&self, py: Python<'_>) -> PyResult<Vec<&'static str>> {
                dict_access(py, $pyname, ".keys()", None)?;
                Ok(Self::fields())
            }

            /// Deprecated dict-style access: the field values.
            fn values<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyAny>>> {
                dict_access(py, $pyname, ".values()", None)?;
                Ok(vec![$((&self.$field).into_bound_py_any(py)?),*])
            }

            /// Deprecated dict-style access: (name, value) pairs.
            fn items<'py>(&self, py: Python<'py>) -> PyResult<Vec<(&'static str, Bound<'py, PyAny>)>> {
                dict_access(py, $pyname, ".items()", None)?;
                Ok(vec![$((unraw(stringify!($field)), (&self.$field).into_bound_py_any(py)?)),*])
            }

            /// Deprecated dict-style access: the field `key`, or `default`.
            #[pyo3(signature = (key, default=None))]
            fn get<'py>(
                &self,
                py: Python<'py>,
                key: &Bound<'py, PyAny>,
                default: Option<Bound<'py, PyAny>>,
            ) -> PyResult<Option<Bound<'py, PyAny>>> {
                match key.extract::<String>() {
                    Ok(k) => {
                        dict_access(py, $pyname, ".get()", Some(&k))?;
                        Ok(self.field(py, &k)?.or(default))
                    }
                    Err(_) => {
                        dict_access(py, $pyname, ".get()", None)?;
                        Ok(default)
                    }
                }
            }

            fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
                let mut parts = Vec::new();
                $(parts.push(format!(
                    "{}={}",
                    unraw(stringify!($field)),
                    (&self.$field).into_bound_py_any(py)?.repr()?
                ));)*
                Ok(format!("{}({})", $pyname, parts.join(", ")))
            }
        }
    };
}

/// A float64 array (n,).
pub(crate) fn arr1(py: Python<'_>, v: Vec<f64>) -> Py<PyArray1<f64>> {
    Array1::from_vec(v).into_pyarray(py).unbind()
}

/// A float64 array (rows, cols) from row-major data.
pub(crate) fn arr2(py: Python<'_>, rows: usize, cols: usize, v: Vec<f64>) -> Py<PyArray2<f64>> {
    Array2::from_shape_vec((rows, cols), v)
        .expect("rows x cols")
        .into_pyarray(py)
        .unbind()
}

result_class! {
    /// Wall-clock time (s) of each stage of `Planner.plan`
    /// (`PlanResult.times`).
    PyPlanTimes, "PlanTimes" {
        /// IK of pose goals (s).
        ik: f64,
        /// RRT-Connect (s).
        planning: f64,
        /// Shortcutting (s).
        simplify: f64,
        /// Spline fitting, time scaling and the trajectory's re-check (s).
        trajectory: f64,
        /// Of `trajectory`: spline fits and time scaling (s).
        fit: f64,
        /// Of `trajectory`: collision re-checks of the fitted trajectory (s).
        recheck: f64,
        /// The whole call (s).
        total: f64,
    }
}

impl PyPlanTimes {
    /// From the planner's stage times.
    pub(crate) fn new(t: &ferrobot_planning::StageTimes) -> Self {
        Self {
            ik: t.ik,
            planning: t.planning,
            simplify: t.simplify,
            trajectory: t.trajectory,
            fit: t.fit,
            recheck: t.recheck,
            total: t.total,
        }
    }
}

result_class! {
    /// Limits of a planner's joints, arrays in `Planner.joint_names` order
    /// (`Planner.limits`).
    PyJointLimits, "JointLimits" {
        /// Lower position limits (rad or m).
        lower: Py<PyArray1<f64>>,
        /// Upper position limits (rad or m).
        upper: Py<PyArray1<f64>>,
        /// Velocity limits (rad/s or m/s).
        velocity: Py<PyArray1<f64>>,
        /// Acceleration limits (rad/s² or m/s²).
        acceleration: Py<PyArray1<f64>>,
        /// Jerk limits (rad/s³ or m/s³).
        jerk: Py<PyArray1<f64>>,
    }
}

result_class! {
    /// Counters of a planner's scene sync (`Planner.world_sync_stats`)
    /// since the planner was made.
    PyWorldSyncStats, "WorldSyncStats" {
        /// Syncs that built the world from scratch (the first of an episode).
        full_builds: u64,
        /// Syncs that updated the world in place.
        incremental: u64,
        /// Objects added to the planner's world.
        added: u64,
        /// Objects removed from the planner's world.
        removed: u64,
        /// Objects moved in place.
        moved: u64,
    }
}

impl PyWorldSyncStats {
    /// From the scene sync's counters.
    pub(crate) fn new(s: &ferrobot_pipeline::SyncStats) -> Self {
        Self {
            full_builds: s.full_builds,
            incremental: s.incremental,
            added: s.added,
            removed: s.removed,
            moved: s.moved,
        }
    }
}

result_class! {
    /// How the simulated robot tracked a trajectory (`Robot.execute`,
    /// `Robot.execute_trajectory`): M physics steps, k joints (the joints
    /// executed, in the order given).
    PyTrackingReport, "TrackingReport" {
        /// World time (s) after each physics step (M,).
        times: Py<PyArray1<f64>>,
        /// Commanded positions (rad or m) at each step (M, k).
        desired: Py<PyArray2<f64>>,
        /// Measured positions (rad or m) after each step (M, k).
        actual: Py<PyArray2<f64>>,
        /// Largest absolute tracking error per joint (k,).
        max_error: Py<PyArray1<f64>>,
        /// Root-mean-square tracking error per joint (k,).
        rms_error: Py<PyArray1<f64>>,
        /// Absolute error per joint after the last step (k,).
        final_error: Py<PyArray1<f64>>,
    }
}

impl PyTrackingReport {
    /// From the simulator's report.
    pub(crate) fn new(py: Python<'_>, rep: ferrobot_sim::TrackingReport) -> Self {
        let m = rep.times.len();
        let k = rep.num_joints;
        Self {
            times: arr1(py, rep.times),
            desired: arr2(py, m, k, rep.desired),
            actual: arr2(py, m, k, rep.actual),
            max_error: arr1(py, rep.max_error),
            rms_error: arr1(py, rep.rms_error),
            final_error: arr1(py, rep.final_error),
        }
    }
}

result_class! {
    /// Diagnostics of a controller's last step (`last_step` of
    /// `ReactiveController` / `PotentialFieldController`).
    PyControlStepInfo, "ControlStepInfo" {
        /// Smallest robot-sphere to world distance (m) within reach (inf beyond).
        world_clearance: f64,
        /// Smallest distance (m) between spheres of checked link pairs (inf beyond reach).
        self_clearance: f64,
        /// Avoidance terms active this step.
        active_avoidance: usize,
        /// End-effector distance to the target position (m; nan without a target).
        position_error: f64,
        /// End-effector angle to the target orientation (rad; nan without a target).
        rotation_error: f64,
        /// Factor (<= 1) the acceleration was scaled by.
        acceleration_scale: f64,
        /// Factor (<= 1) the velocity was scaled by.
        velocity_scale: f64,
        /// Whether a joint's velocity was cut so it can stop before its limit.
        limit_braked: bool,
        /// Whether the end effector made no progress for `stall_time`.
        stalled: bool,
        /// Waypoints of the global guidance still to pass.
        waypoints_remaining: usize,
        /// What global guidance is doing (its status name).
        guidance: String,
        /// Guidance plan attempts for the current target.
        guidance_plans: usize,
        /// Rows in the velocity filter this step (sphere pairs and exact link pairs, self and world).
        filtered: usize,
        /// Whether the velocity filter changed the commanded velocity this step (the arm held at a hold).
        filter_active: bool,
    }
}

impl PyControlStepInfo {
    /// From the controller's step info.
    pub(crate) fn new(info: &ferrobot_control::StepInfo) -> Self {
        Self {
            world_clearance: info.world_clearance,
            self_clearance: info.self_clearance,
            active_avoidance: info.active_avoidance,
            position_error: info.position_error,
            rotation_error: info.rotation_error,
            acceleration_scale: info.acceleration_scale,
            velocity_scale: info.velocity_scale,
            limit_braked: info.limit_braked,
            stalled: info.stalled,
            waypoints_remaining: info.waypoints_remaining,
            guidance: info.guidance.name().to_string(),
            guidance_plans: info.guidance_plans,
            filtered: info.filtered,
            filter_active: info.filter_active,
        }
    }
}

result_class! {
    /// Drive gains of a simulated robot, arrays (num_dof,) in `dof_names`
    /// order (`Robot.drive_gains`).
    PyDriveGains, "DriveGains" {
        /// Position gains (N·m/rad or N/m).
        stiffness: Py<PyArray1<f64>>,
        /// Velocity gains (N·m·s/rad or N·s/m).
        damping: Py<PyArray1<f64>>,
        /// Force limits (N·m or N; inf: unlimited).
        max_force: Py<PyArray1<f64>>,
    }
}

result_class! {
    /// One rendered camera frame (`Camera.render()`), H x W pixels.
    PyRenderFrame, "RenderFrame" {
        /// Depth (m) along the optical axis, float32 (H, W); inf: no hit.
        depth: Py<PyArray2<f32>>,
        /// Segmentation ids, int32 (H, W) (see `World.segmentation_labels`).
        segmentation: Py<PyArray2<i32>>,
        /// Colour, uint8 (H, W, 3), or None when rendered with `rgb=False`.
        rgb: Option<Py<PyArray3<u8>>>,
    }
}

result_class! {
    /// Signed distance of a configuration to the world and to itself, with
    /// its gradient (`CollisionChecker.distance`).
    PyCollisionDistance, "CollisionDistance" {
        /// The smaller of `world_distance` and `self_distance` (m; negative: penetration).
        distance: f64,
        /// Smallest signed robot-to-world distance (m; inf without a world).
        world_distance: f64,
        /// Smallest signed distance between checked link pairs (m).
        self_distance: f64,
        /// d distance / d q (num_dof,) (m/rad or m/m).
        gradient: Py<PyArray1<f64>>,
        /// (robot body, other body) of the closest pair, or None.
        closest: Option<(String, String)>,
    }
}

result_class! {
    /// One collision at a configuration (`CollisionChecker.contacts`).
    PyContact, "Contact" {
        /// The robot body (link or attached object).
        body: String,
        /// What it collides with (world object or link).
        other: String,
        /// Whether `other` is part of the robot.
        self_collision: bool,
        /// Penetration depth (m, > 0).
        depth: f64,
    }
}

result_class! {
    /// Counts of the self-collision analysis
    /// (`CollisionChecker.analyze_self_collisions`).
    PySelfCollisionAnalysis, "SelfCollisionAnalysis" {
        /// Configurations sampled.
        samples: usize,
        /// Link pairs never in contact (now excluded).
        never: usize,
        /// Link pairs always in contact (now excluded).
        always: usize,
        /// Link pairs sometimes in contact (still checked).
        sometimes: usize,
    }
}

result_class! {
    /// The automatic spherizer's report for one link (`SphereModel.report`).
    PySphereFit, "SphereFit" {
        /// The link's name.
        link: String,
        /// Spheres fitted.
        spheres: usize,
        /// Fraction (0..1) of the link's surface samples covered.
        coverage: f64,
        /// Mean distance (m) the spheres stick out of the geometry.
        mean_protrusion: f64,
        /// Largest distance (m) a sphere sticks out of the geometry.
        max_protrusion: f64,
    }
}

result_class! {
    /// Per robot sphere distances to the world at one configuration
    /// (`sphere_distances` of the reactive controllers), S spheres in the
    /// controller's sphere order.
    PySphereDistances, "SphereDistances" {
        /// Distance (m) of each sphere's surface to the nearest world shape (S,); inf beyond `reach`.
        distance: Py<PyArray1<f64>>,
        /// Unit direction of steepest distance increase (S, 3).
        direction: Py<PyArray2<f64>>,
        /// d distance / d q (S, num_dof) (m/rad or m/m).
        gradient: Py<PyArray2<f64>>,
        /// Sphere centres in the base frame (S, 3) (m).
        centers: Py<PyArray2<f64>>,
        /// Sphere radii (S,) (m).
        radii: Py<PyArray1<f64>>,
    }
}

result_class! {
    /// Exact clearance between collision geometries (`exact_clearance`,
    /// `exact_self_clearance` of the reactive controllers).
    PyClearance, "Clearance" {
        /// Smallest distance (m; 0 when touching).
        distance: f64,
        /// The closest pair: (link, object) or (link, link); None when nothing is in reach.
        closest: Option<(String, String)>,
    }
}

result_class! {
    /// The last global-guidance plan attempt (`ReactiveController.guidance_last_plan`).
    PyGuidancePlan, "GuidancePlan" {
        /// The planner's status name.
        status: String,
        /// The planner's message.
        message: String,
        /// Waypoints of the plan (0 on failure).
        waypoints: usize,
        /// Time the attempt took (s).
        seconds: f64,
    }
}

result_class! {
    /// A simulated link's mass properties in the link frame
    /// (`Robot.get_link_inertial`).
    PyLinkInertial, "LinkInertial" {
        /// Mass (kg).
        mass: f64,
        /// Centre of mass in the link frame (3,) (m).
        com: Py<PyArray1<f64>>,
        /// Inertia about the centre of mass, link-frame axes (3, 3) (kg·m²).
        inertia: Py<PyArray2<f64>>,
    }
}

result_class! {
    /// A link's URDF `<inertial>` (`RobotModel.inertial`).
    PyInertial, "Inertial" {
        /// Mass (kg).
        mass: f64,
        /// Pose (4x4) of the inertial frame in the link frame (m).
        origin: Py<PyArray2<f64>>,
        /// Inertia about the centre of mass, inertial-frame axes (3, 3) (kg·m²).
        inertia: Py<PyArray2<f64>>,
    }
}

result_class! {
    /// A joint's description (`RobotModel.joint_info`).
    PyJointInfo, "JointInfo" {
        /// The joint's name.
        name: String,
        /// "revolute", "continuous", "prismatic" or "fixed".
        r#type: String,
        /// Parent link.
        parent: String,
        /// Child link.
        child: String,
        /// Pose (4x4) of the joint frame in the parent link frame (m).
        origin: Py<PyArray2<f64>>,
        /// Unit axis (3,) in the joint frame.
        axis: Py<PyArray1<f64>>,
        /// Lower position limit (rad or m; -inf: none).
        lower: f64,
        /// Upper position limit (rad or m; inf: none).
        upper: f64,
        /// Velocity limit (rad/s or m/s).
        velocity: f64,
        /// Effort limit (N·m or N).
        effort: f64,
        /// Viscous damping (N·m·s/rad or N·s/m).
        damping: f64,
        /// Dry friction (N·m or N).
        friction: f64,
        /// (joint, multiplier, offset) when this joint mimics another, else None.
        mimic: Option<(String, f64, f64)>,
    }
}

result_class! {
    /// A world's lighting (`World.lighting`; see `World.set_lighting`).
    PyLighting, "Lighting" {
        /// Ambient colour [r, g, b], each in [0, 1].
        ambient: Vec<f64>,
        /// Intensity (>= 0) of the light at the camera.
        headlight: f64,
        /// Directional lights as (direction (3,), colour (r, g, b), intensity).
        lights: Vec<(Vec<f64>, Vec<f64>, f64)>,
    }
}

result_class! {
    /// A payload identified from static efforts (`_core.identify_payload`).
    PyPayloadFit, "PayloadFit" {
        /// Payload mass (kg).
        mass: f64,
        /// Payload centre of mass in the link frame (3,) (m).
        com: Py<PyArray1<f64>>,
        /// RMS of the fit's effort residuals (N·m or N).
        rms_residual: f64,
        /// Condition number of the regressor (dimensionless; large: poorly excited).
        condition: f64,
        /// Number of equations (effort samples) in the fit.
        equations: usize,
    }
}

result_class! {
    /// Link mass offsets identified from static efforts (`identify_link_masses`).
    PyLinkMassFit, "LinkMassFit" {
        /// Mass offset (kg) of each link, in the order the links were given (L,).
        offsets: Py<PyArray1<f64>>,
        /// RMS of the fit's effort residuals (N·m or N).
        rms_residual: f64,
        /// Condition number of the regressor (dimensionless; large: poorly excited).
        condition: f64,
        /// Number of equations (effort samples) in the fit.
        equations: usize,
    }
}

result_class! {
    /// Joint friction fitted as effort = coulomb·sign(v) + viscous·v (`_core.identify_friction`).
    PyFrictionFit, "FrictionFit" {
        /// Coulomb (dry) friction (N·m or N).
        coulomb: f64,
        /// Viscous coefficient (N·m·s/rad or N·s/m).
        viscous: f64,
        /// RMS of the fit's effort residuals (N·m or N).
        rms_residual: f64,
        /// Condition number of the regressor (dimensionless).
        condition: f64,
        /// Number of equations (samples with |v| > min_speed) in the fit.
        equations: usize,
    }
}

result_class! {
    /// One joint's command conflict resolved by an `Arbiter` (`Arbiter.conflicts`).
    PyArbiterConflict, "ArbiterConflict" {
        /// Time (s) of the conflict.
        t: f64,
        /// Joint index.
        joint: usize,
        /// The source whose command was applied.
        winner: String,
        /// The other sources with a fresh command for that joint.
        losers: Vec<String>,
    }
}

result_class! {
    /// One control tick of a `StreamGuard` (`StreamGuard.update`).
    PyStreamGuardStep, "StreamGuardStep" {
        /// The command to apply (n,) (rad or m).
        command: Py<PyArray1<f64>>,
        /// True while holding (no fresh command within the timeout; velocity targets should be 0).
        holding: bool,
        /// True while catching up with the stream after a hold (rate-limited).
        catching_up: bool,
        /// Largest |change| of the command from the previous tick (rad or m).
        step: f64,
    }
}

result_class! {
    /// A depth-noise model's parameters (`DepthNoise.params`).
    PyDepthNoiseParams, "DepthNoiseParams" {
        /// Axial standard deviation (m) at `z0`, >= 0.
        sigma0: f64,
        /// Quadratic growth of the standard deviation (1/m), >= 0.
        sigma2: f64,
        /// Depth (m) of the smallest noise.
        z0: f64,
        /// Probability (0..1) that any valid pixel is missing.
        dropout: f64,
        /// Depth jump (m) between 4-neighbours that makes a discontinuity, > 0.
        edge_threshold: f64,
        /// Extra probability (0..1) that a pixel on a discontinuity is missing.
        edge_dropout: f64,
        /// Value written into missing pixels (m, or inf/NaN).
        missing_value: f64,
    }
}

result_class! {
    /// One finding of the URDF checker (`UrdfCheckReport.findings`).
    PyUrdfFinding, "UrdfFinding" {
        /// "error", "warning" or "info".
        severity: String,
        /// Stable short code of the finding.
        code: String,
        /// 1-based line in the URDF, or None.
        line: Option<u32>,
        /// The element concerned (link, joint, ...).
        element: String,
        /// Human-readable explanation.
        message: String,
    }
}

result_class! {
    /// The URDF checker's report (`urdf_check`, `ferrobot check`).
    PyUrdfCheckReport, "UrdfCheckReport" {
        /// The robot's name.
        robot: String,
        /// The file checked.
        source: String,
        /// The kinematic tree as text.
        tree: String,
        /// Everything found, in file order within each check.
        findings: Vec<Py<PyUrdfFinding>>,
    }
}

result_class! {
    /// An object mesh, checked and decomposed into convex parts (`load_mesh`).
    PyLoadedMesh, "LoadedMesh" {
        /// Vertices of the scaled mesh (N, 3) (m).
        vertices: Py<PyArray2<f64>>,
        /// Triangles as vertex indices (M, 3).
        faces: Py<PyArray2<i64>>,
        /// Convex parts of the decomposition: (vertices (K, 3) (m), faces (L, 3)) each.
        parts: Vec<(Py<PyArray2<f64>>, Py<PyArray2<i64>>)>,
        /// Volume (m³) of the convex decomposition.
        volume: f64,
        /// True when every edge of the mesh is shared by two triangles.
        closed: bool,
    }
}

result_class! {
    /// A gripper's finger and palm geometry, metres (`Gripper.fingers`).
    PyFingerGeometry, "FingerGeometry" {
        /// Finger length along the approach axis (m).
        depth: f64,
        /// Finger thickness along the closing axis (m).
        thickness: f64,
        /// Finger size along the third axis (m).
        height: f64,
        /// Palm (housing) size along the closing axis (m).
        palm_width: f64,
        /// Palm size along the third axis (m).
        palm_height: f64,
        /// Palm size along the approach axis, behind the fingers (m).
        palm_depth: f64,
    }
}

impl PyFingerGeometry {
    /// From the model's finger geometry.
    pub(crate) fn new(f: &ferrobot_model::FingerGeometry) -> Self {
        Self {
            depth: f.depth,
            thickness: f.thickness,
            height: f.height,
            palm_width: f.palm_width,
            palm_height: f.palm_height,
            palm_depth: f.palm_depth,
        }
    }
}

result_class! {
    /// The grasp detector's hand geometry derived from a gripper
    /// (`Gripper.detection_options()`; the `DetectOptions` fields of the
    /// same names), metres.
    PyGripperDetection, "GripperDetection" {
        /// Largest opening between the fingers' inner faces (m).
        max_width: f64,
        /// Finger length along the approach axis the detector uses (m).
        finger_depth: f64,
        /// Finger thickness along the closing axis (m).
        finger_width: f64,
        /// Finger size along the third axis (m).
        height: f64,
        /// Hand housing size along the closing axis (m).
        palm_width: f64,
        /// Hand housing size along the third axis (m).
        palm_height: f64,
        /// Hand housing size along the approach axis (m).
        palm_depth: f64,
    }
}

impl PyGripperDetection {
    /// From the detector's gripper geometry.
    pub(crate) fn new(g: &ferrobot_grasp::GripperGeometry) -> Self {
        Self {
            max_width: g.max_width,
            finger_depth: g.finger_depth,
            finger_width: g.finger_width,
            height: g.height,
            palm_width: g.palm_width,
            palm_height: g.palm_height,
            palm_depth: g.palm_depth,
        }
    }
}

/// Registers the result classes.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyPlanTimes>()?;
    m.add_class::<PyJointLimits>()?;
    m.add_class::<PyWorldSyncStats>()?;
    m.add_class::<PyTrackingReport>()?;
    m.add_class::<PyControlStepInfo>()?;
    m.add_class::<PyDriveGains>()?;
    m.add_class::<PyRenderFrame>()?;
    m.add_class::<PyCollisionDistance>()?;
    m.add_class::<PyContact>()?;
    m.add_class::<PySelfCollisionAnalysis>()?;
    m.add_class::<PySphereFit>()?;
    m.add_class::<PySphereDistances>()?;
    m.add_class::<PyClearance>()?;
    m.add_class::<PyGuidancePlan>()?;
    m.add_class::<PyLinkInertial>()?;
    m.add_class::<PyInertial>()?;
    m.add_class::<PyJointInfo>()?;
    m.add_class::<PyLighting>()?;
    m.add_class::<PyPayloadFit>()?;
    m.add_class::<PyLinkMassFit>()?;
    m.add_class::<PyFrictionFit>()?;
    m.add_class::<PyArbiterConflict>()?;
    m.add_class::<PyStreamGuardStep>()?;
    m.add_class::<PyDepthNoiseParams>()?;
    m.add_class::<PyUrdfFinding>()?;
    m.add_class::<PyUrdfCheckReport>()?;
    m.add_class::<PyLoadedMesh>()?;
    m.add_class::<PyFingerGeometry>()?;
    m.add_class::<PyGripperDetection>()?;
    Ok(())
}
