//! Option classes: `ferrobot.PlanOptions`, `ferrobot.IkOptions` and
//! `ferrobot.DetectOptions`.
//!
//! Each wraps its crate's options struct: the defaults are the struct's
//! `Default`, the checks its `validate`, so neither is written here. One
//! field table per class (the `options_class!` invocation) gives the Python
//! name, the Python type and the Rust field of each option; the macro makes
//! the typed properties, the `**overrides` of the constructor, of
//! `replace` and of the calls that take options (`Planner.plan`,
//! `Planner.ik`, `ferrobot.grasp.detect`, ...) from it.

use std::time::Duration;

use nalgebra::{Point3, Vector3};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::InvalidArgumentError;

/// How a Python option value becomes its Rust field and back.
pub(crate) trait Conv<R>: Sized {
    /// The field's value (`name` for the error of a value out of range).
    fn to_rust(self, name: &str) -> PyResult<R>;
    /// The Python value of the field.
    fn from_rust(r: &R) -> Self;
}

impl<T: Clone> Conv<T> for T {
    fn to_rust(self, _: &str) -> PyResult<T> {
        Ok(self)
    }
    fn from_rust(r: &T) -> Self {
        r.clone()
    }
}

/// Seconds as a `Duration` (within `ferrobot_model::ranges::TIME_LIMIT`,
/// checked before the conversion, which would panic on NaN or overflow).
impl Conv<Duration> for f64 {
    fn to_rust(self, name: &str) -> PyResult<Duration> {
        ferrobot_model::ranges::TIME_LIMIT
            .check_as(name, self)
            .map_err(|e| InvalidArgumentError::new_err(e.0))?;
        Ok(Duration::from_secs_f64(self))
    }
    fn from_rust(r: &Duration) -> Self {
        r.as_secs_f64()
    }
}

impl Conv<Vector3<f64>> for [f64; 3] {
    fn to_rust(self, _: &str) -> PyResult<Vector3<f64>> {
        Ok(Vector3::from(self))
    }
    fn from_rust(r: &Vector3<f64>) -> Self {
        [r.x, r.y, r.z]
    }
}

impl Conv<Point3<f64>> for [f64; 3] {
    fn to_rust(self, _: &str) -> PyResult<Point3<f64>> {
        Ok(Point3::from(self))
    }
    fn from_rust(r: &Point3<f64>) -> Self {
        [r.x, r.y, r.z]
    }
}

/// Extracts an option's value, the error naming the option and its type.
pub(crate) fn extract<'py, T: pyo3::conversion::FromPyObjectOwned<'py>>(
    v: &Bound<'py, PyAny>,
    class: &str,
    key: &str,
    ty: &str,
) -> PyResult<T> {
    // A bool is an int to Python; an integer option given True is a mistake.
    if ty != "bool" && v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(InvalidArgumentError::new_err(format!(
            "{class}.{key}: expected {ty}, got a bool"
        )));
    }
    v.extract::<T>().map_err(|_| {
        let got = v
            .get_type()
            .name()
            .map(|n| n.to_string())
            .unwrap_or_else(|_| "?".into());
        InvalidArgumentError::new_err(format!("{class}.{key}: expected {ty}, got {got} {v}"))
    })
}

/// The error of an unknown option name.
pub(crate) fn unknown(class: &str, key: &str, fields: &[&str]) -> PyErr {
    let what = match class {
        "DetectOptions" => "grasp",
        "PlanOptions" => "plan",
        _ => "IK",
    };
    InvalidArgumentError::new_err(format!(
        "unknown {what} option '{key}' ({class}); known: {}",
        fields.join(", ")
    ))
}

/// Emits a `DeprecationWarning` for an old option name.
fn deprecated_name(class: &str, old: &str, new: &str) -> PyResult<()> {
    Python::attach(|py| {
        crate::planning::deprecated(
            py,
            &format!("{class} option '{old}' is deprecated: use '{new}'"),
        )
    })
}

macro_rules! options_class {
    (
        $(#[doc = $cdoc:literal])*
        $py:ident($rust:ty, $pyname:literal, validate = $validate:expr, aliases = [$($old:literal => $new:literal),* $(,)?]) {
            $(
                $(#[doc = $doc:literal])*
                $name:ident / $setter:ident : $ty:ty [$tyname:literal] => $($path:ident).+;
            )*
        }
    ) => {
        $(#[doc = $cdoc])*
        #[pyclass(name = $pyname, module = "ferrobot")]
        #[derive(Clone)]
        pub struct $py {
            pub(crate) inner: $rust,
        }

        impl $py {
            /// The Python names of the options.
            pub(crate) const FIELDS: &'static [&'static str] = &[$(stringify!($name)),*];

            /// Sets option `key` of `inner` (checked by `validate` later).
            pub(crate) fn set_field(inner: &mut $rust, key: &str, v: &Bound<'_, PyAny>) -> PyResult<()> {
                match key {
                    $(
                        stringify!($name) => {
                            let x: $ty = extract(v, $pyname, key, $tyname)?;
                            inner.$($path).+ = Conv::to_rust(x, key)?;
                        }
                    )*
                    $(
                        $old => {
                            deprecated_name($pyname, $old, $new)?;
                            return Self::set_field(inner, $new, v);
                        }
                    )*
                    other => return Err(unknown($pyname, other, Self::FIELDS)),
                }
                Ok(())
            }

            /// Checks `inner` with its crate's `validate`.
            pub(crate) fn check(inner: &$rust) -> PyResult<()> {
                let f: fn(&$rust) -> PyResult<()> = $validate;
                f(inner)
            }

            /// `base` (the defaults when None) with `overrides` applied,
            /// validated.
            pub(crate) fn resolve(
                base: Option<&Bound<'_, Self>>,
                overrides: Option<&Bound<'_, PyDict>>,
            ) -> PyResult<$rust> {
                let mut inner = match base {
                    Some(b) => b.borrow().inner.clone(),
                    None => <$rust>::default(),
                };
                let Some(o) = overrides else {
                    if base.is_none() {
                        return Ok(inner);
                    }
                    Self::check(&inner)?;
                    return Ok(inner);
                };
                Self::apply(&mut inner, o)?;
                Ok(inner)
            }

            /// `overrides` applied to `inner`, then checked.
            pub(crate) fn apply(inner: &mut $rust, overrides: &Bound<'_, PyDict>) -> PyResult<()> {
                for (k, v) in overrides.iter() {
                    let key = k.cast::<pyo3::types::PyString>()?.to_cow()?;
                    Self::set_field(inner, &key, &v)?;
                }
                Self::check(inner)
            }
        }

        #[pymethods]
        impl $py {
            /// The defaults with `overrides` applied (unknown names and
            /// values out of range raise `InvalidArgumentError`).
            #[new]
            #[pyo3(signature = (**overrides))]
            fn new(overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
                crate::errors::guard(|| Ok(Self { inner: Self::resolve(None, overrides)? }))
            }

            /// A copy with `overrides` applied.
            #[pyo3(signature = (**overrides))]
            fn replace(slf: &Bound<'_, Self>, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
                crate::errors::guard(|| Ok(Self { inner: Self::resolve(Some(slf), overrides)? }))
            }

            /// The options as a dict (name: value).
            fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
                crate::errors::guard(|| {
                    let d = PyDict::new(py);
                    $(
                        let v: $ty = Conv::from_rust(&self.inner.$($path).+);
                        d.set_item(stringify!($name), v)?;
                    )*
                    Ok(d)
                })
            }

            fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
                crate::errors::guard(|| {
                    let Ok(o) = other.cast::<Self>() else { return Ok(false) };
                    self.to_dict(py)?.eq(o.borrow().to_dict(py)?)
                })
            }

            fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
                crate::errors::guard(|| {
                    let d = self.to_dict(py)?;
                    let mut parts = Vec::new();
                    for (k, v) in d.iter() {
                        parts.push(format!("{}={}", k, v.repr()?));
                    }
                    Ok(format!("{}({})", $pyname, parts.join(", ")))
                })
            }

            $(
                $(#[doc = $doc])*
                #[getter]
                fn $name(&self) -> $ty {
                    Conv::from_rust(&self.inner.$($path).+)
                }

                #[setter]
                fn $setter(&mut self, value: &Bound<'_, PyAny>) -> PyResult<()> {
                    crate::errors::guard(|| {
                        let mut next = self.inner.clone();
                        Self::set_field(&mut next, stringify!($name), value)?;
                        Self::check(&next)?;
                        self.inner = next;
                        Ok(())
                    })
                }
            )*
        }
    };
}

options_class! {
    /// Options of `Planner.plan` (ferrobot-planning's `PlanOptions`; its
    /// `Default` gives the defaults, its `validate` the checks). Every
    /// option is also a keyword of `plan`.
    PyPlanOptions(ferrobot_planning::PlanOptions, "PlanOptions",
        validate = |o| o.validate().map_err(crate::planning::planning_err),
        aliases = []) {
        /// Wall-clock limit of the whole plan, seconds, in [1e-6, 86400]
        /// (default 1).
        time_limit / set_time_limit: f64 ["float"] => rrt.time_limit;
        /// RRT-Connect samples at most, in [1, 5e6] (default 100000).
        max_samples / set_max_samples: usize ["int"] => rrt.max_samples;
        /// Motion-check resolution: the largest joint step between checked
        /// configurations (rad or m), in [1e-6, 1] (default 0.005);
        /// `resolution * coarse_factor` stays within it too.
        resolution / set_resolution: f64 ["float"] => rrt.resolution;
        /// Longest RRT-Connect edge (joint-space distance), in [1e-4, 1000]
        /// (default 1).
        range / set_range: f64 ["float"] => rrt.range;
        /// Random seed, in [0, 2^64 - 1] (same inputs and seed, same path;
        /// default 0).
        seed / set_seed: u64 ["int"] => rrt.seed;
        /// Velocity limit factor in [1e-6, 1] (default 1).
        velocity_scale / set_velocity_scale: f64 ["float"] => velocity_scale;
        /// Acceleration and jerk limit factor in [1e-6, 1] (default 1).
        acceleration_scale / set_acceleration_scale: f64 ["float"] => acceleration_scale;
        /// Shortcut the path (default True).
        simplify / set_simplify: bool ["bool"] => simplify_path;
        /// Build the time-parametrised trajectory (default True).
        trajectory / set_trajectory: bool ["bool"] => trajectory;
        /// IK solutions used as goal configurations of a pose goal, in
        /// [1, 10000] (default 4).
        goal_solutions / set_goal_solutions: usize ["int"] => goal_solutions;
        /// The search and shortcutting check motions at `resolution` times
        /// this factor; the final path and trajectory are then certified
        /// free at every configuration (not only at samples) from intervals
        /// of `resolution`; in [1, 1000] (default 4).
        coarse_factor / set_coarse_factor: f64 ["float"] => coarse_factor;
        /// Times the smooth trajectory is refined where it collided before
        /// stopping at every waypoint, in [0, 64] (default 4).
        refinements / set_refinements: usize ["int"] => refinements;
        /// Shortcutting: a random shortcut that would shorten the path by
        /// less than this fraction of its length is not checked and counts
        /// as a failed attempt; in [0, 0.5] (default 0.01; 0 checks every
        /// candidate: slightly shorter paths, slower on crowded scenes;
        /// larger values give up more shortcuts: faster, longer paths).
        min_gain / set_min_gain: f64 ["float"] => simplify.min_gain;
        /// Shortcutting: random shortcut attempts at most, in [0, 100000]
        /// (default 40; 0 keeps only the vertex reduction, which connects
        /// each kept waypoint to the farthest later one it sees).
        max_shortcuts / set_max_shortcuts: usize ["int"] => simplify.max_shortcuts;
        /// Shortcutting stops after this many failed attempts in a row, in
        /// [1, 100000] (default 10).
        max_shortcut_failures / set_max_shortcut_failures: usize ["int"] => simplify.max_failures;
    }
}

options_class! {
    /// Options of `Planner.ik`, `ik_goalset` and `ik_batch`
    /// (ferrobot-planning's `IkOptions`: its `Default` and `validate`).
    /// Every option is also a keyword of those calls.
    PyIkOptions(ferrobot_planning::IkOptions, "IkOptions",
        validate = |o| o.validate().map_err(crate::planning::planning_err),
        aliases = []) {
        /// Position tolerance, metres, in [1e-12, 10] (default 1e-3).
        position_tolerance / set_position_tolerance: f64 ["float"] => position_tolerance;
        /// Rotation tolerance, radians, in [1e-12, pi] (default 0.01).
        rotation_tolerance / set_rotation_tolerance: f64 ["float"] => rotation_tolerance;
        /// Starts tried at most (a given start counts), in [1, 100000]
        /// (default 200).
        num_seeds / set_num_seeds: usize ["int"] => num_seeds;
        /// Iterations per start at most, in [1, 10^6] (default 60).
        max_iterations / set_max_iterations: usize ["int"] => max_iterations;
        /// Reject solutions in collision (default False).
        collision_free / set_collision_free: bool ["bool"] => collision_free;
        /// Random seed of the random starts, in [0, 2^64 - 1] (default 0).
        seed / set_seed: u64 ["int"] => seed;
    }
}

options_class! {
    /// Options of grasp detection (`ferrobot.grasp.detect`,
    /// `detect_from_rgbd`; ferrobot-grasp's `DetectOptions` with its
    /// gripper geometry: its `Default` and `validate`). Every option is also
    /// a keyword of those calls. `rng_seed` is a deprecated name of `seed`.
    PyDetectOptions(ferrobot_grasp::DetectOptions, "DetectOptions",
        validate = |o| o.validate().map_err(crate::grasp::grasp_err),
        aliases = ["rng_seed" => "seed"]) {
        /// Voxel size of the downsampling, metres, > 0 (default 0.005).
        voxel_size / set_voxel_size: f64 ["float"] => voxel_size;
        /// Neighbourhood radius of the normals, metres, > 0 (default 0.015).
        normal_radius / set_normal_radius: f64 ["float"] => normal_radius;
        /// Seed points sampled, >= 0 (default 128).
        num_seeds / set_num_seeds: usize ["int"] => num_seeds;
        /// Seeds kept at least this far apart while possible, metres, >= 0
        /// (default 0: a plain random sample).
        seed_spacing / set_seed_spacing: f64 ["float"] => seed_spacing;
        /// Closing-axis rotations over a half turn, >= 1 (default 8).
        num_rotations / set_num_rotations: usize ["int"] => num_rotations;
        /// Approach tilts about the closing axis, radians, each in
        /// (-pi/2, pi/2), at least one (default 0, -0.4, 0.4).
        approach_tilts / set_approach_tilts: Vec<f64> ["a list of floats"] => approach_tilts;
        /// Fingertip depths beyond the surface, deepest first, metres, each
        /// in [0, finger_depth), at least one (default 0.04, 0.03, 0.02;
        /// a hand must engage the pad's width of the object, shallower
        /// hands only where the support plane limits the depth, ranked
        /// below).
        depths / set_depths: Vec<f64> ["a list of floats"] => depths;
        /// Friction coefficient the grasp must close at, > 0 (default 1).
        friction / set_friction: f64 ["float"] => friction;
        /// Camera position in the cloud's frame, for orienting normals,
        /// finite (default the origin).
        viewpoint / set_viewpoint: [f64; 3] ["3 floats"] => viewpoint;
        /// Preferred approach direction, finite and non-zero (default +z).
        approach_direction / set_approach_direction: [f64; 3] ["3 floats"] => approach_direction;
        /// NMS translation threshold, metres, > 0 (default 0.03).
        nms_translation / set_nms_translation: f64 ["float"] => nms_translation;
        /// NMS rotation threshold, radians, > 0 (default pi/6).
        nms_rotation / set_nms_rotation: f64 ["float"] => nms_rotation;
        /// Keep at most this many grasps after NMS, >= 0 (0: all; default 0).
        max_grasps / set_max_grasps: usize ["int"] => max_grasps;
        /// Seed of the random seed-point and plane sampling, in
        /// [0, 2^64 - 1] (default 0).
        seed / set_seed: u64 ["int"] => rng_seed;
        /// Find the support plane (a table) by RANSAC (default True).
        support_plane / set_support_plane: bool ["bool"] => support_plane;
        /// Inlier distance of the support plane, metres, > 0 (default 0.005).
        plane_threshold / set_plane_threshold: f64 ["float"] => plane_threshold;
        /// Lever-arm scale of the centre-of-mass score, metres, >= 0
        /// (0 disables; default 0.01).
        torque_scale / set_torque_scale: f64 ["float"] => torque_scale;
        /// Check the hand's body against every point of the cloud, not only
        /// the support plane (default True).
        body_collision / set_body_collision: bool ["bool"] => body_collision;
        /// With labels, reject hands closing on another object's points
        /// (default True).
        single_object / set_single_object: bool ["bool"] => single_object;
        /// With an RGB-D frame and a mask, reject fingers or palm in space
        /// hidden behind another object (default True).
        occlusion / set_occlusion: bool ["bool"] => occlusion;
        /// Where a hand's housing along the preferred approach would meet
        /// another object (bin walls, neighbours), also search approaches
        /// chosen to keep it clear: straight or tilted away, the closing
        /// axis turned to fit (default True).
        wall_approaches / set_wall_approaches: bool ["bool"] => wall_approaches;
        /// Largest opening between the fingers, metres, > 0 (default 0.08).
        max_width / set_max_width: f64 ["float"] => gripper.max_width;
        /// Finger length along the approach, metres, > 0 (default 0.05).
        finger_depth / set_finger_depth: f64 ["float"] => gripper.finger_depth;
        /// Finger thickness along the closing axis, metres, > 0
        /// (default 0.01).
        finger_width / set_finger_width: f64 ["float"] => gripper.finger_width;
        /// Finger size across approach and closing, metres, > 0
        /// (default 0.02).
        height / set_height: f64 ["float"] => gripper.height;
        /// Free corridor behind the palm, metres, >= 0 (default 0.03).
        approach_distance / set_approach_distance: f64 ["float"] => gripper.approach_distance;
        /// Free space between object and each open finger, metres, >= 0
        /// (default 0.002).
        clearance / set_clearance: f64 ["float"] => gripper.clearance;
        /// Hand housing along the closing axis, metres, > 0 (default 0.208).
        palm_width / set_palm_width: f64 ["float"] => gripper.palm_width;
        /// Hand housing across approach and closing, metres, > 0
        /// (default 0.063).
        palm_height / set_palm_height: f64 ["float"] => gripper.palm_height;
        /// Hand housing along the approach, metres, > 0 (default 0.092).
        palm_depth / set_palm_depth: f64 ["float"] => gripper.palm_depth;
    }
}
