//! `ferrobot._core`: the Python bindings of ferrobot's Rust crates.
//!
//! Every entry point converts Rust errors to `ferrobot.errors` exceptions and
//! catches panics (`errors::guard`); heavy work releases the GIL.

mod arrays;
mod batch;
mod camera;
mod collision;
mod control;
mod errors;
mod faults;
mod grasp;
mod gripper;
mod mesh_objects;
mod model;
mod options;
mod planning;
mod results;
mod scene;
mod sim;
mod sim2real;

use pyo3::prelude::*;

/// Bundled robot descriptions by name: (URDF text, SRDF text, ee link).
#[pyfunction]
fn bundled_robot(name: &str) -> PyResult<(&'static str, &'static str, &'static str)> {
    errors::guard(|| {
        ferrobot_model::robots::bundled(name).ok_or_else(|| {
            errors::UnknownNameError::new_err(format!(
                "unknown bundled robot '{name}'; known: {}",
                ferrobot_model::robots::BUNDLED.join(", ")
            ))
        })
    })
}

/// The folder of ferrobot's disk cache for entries of `kind` (`"spheres"`,
/// `"objects"`): `$FERROBOT_CACHE_DIR/kind`, else
/// `$XDG_CACHE_HOME/ferrobot/kind`, else `~/.cache/ferrobot/kind`; `None`
/// when the disk cache is off (`FERROBOT_CACHE_DIR=off`, or no home). The
/// rule is `ferrobot_geometry::cache`'s; the folder is not created.
#[pyfunction]
fn cache_dir(kind: &str) -> PyResult<Option<std::path::PathBuf>> {
    errors::guard(|| {
        if kind.is_empty() || kind.contains(['/', '\\']) || kind == "." || kind == ".." {
            return Err(errors::InvalidArgumentError::new_err(format!(
                "kind must be one folder name (e.g. 'objects'), got {kind:?}"
            )));
        }
        Ok(ferrobot_geometry::cache::cache_dir(kind))
    })
}

/// The instruction-set levels of this process, for the Python loader that
/// picks one of a wheel's per-level builds (`python/ferrobot/_builds.py`):
/// (the best level this CPU and OS support, the level this module was
/// compiled for). Names as `FERROBOT_SIMD` takes them: `baseline`,
/// `x86-64-v2`, `x86-64-v3`, `x86-64-v4`.
#[pyfunction]
fn _simd_support() -> (&'static str, &'static str) {
    use ferrobot_collision::SimdLevel as L;
    let v2 = cfg!(all(
        target_feature = "sse3",
        target_feature = "ssse3",
        target_feature = "sse4.1",
        target_feature = "sse4.2",
        target_feature = "popcnt",
        target_feature = "cmpxchg16b"
    ));
    let v3 = v2
        && cfg!(all(
            target_feature = "avx",
            target_feature = "avx2",
            target_feature = "fma",
            target_feature = "bmi1",
            target_feature = "bmi2",
            target_feature = "lzcnt",
            target_feature = "movbe",
            target_feature = "f16c"
        ));
    let v4 = v3
        && cfg!(all(
            target_feature = "avx512f",
            target_feature = "avx512bw",
            target_feature = "avx512cd",
            target_feature = "avx512dq",
            target_feature = "avx512vl"
        ));
    let built = if v4 {
        L::X86V4
    } else if v3 {
        L::X86V3
    } else if v2 {
        L::X86V2
    } else {
        L::Baseline
    };
    (
        ferrobot_collision::dispatch::detected().name(),
        built.name(),
    )
}

/// The extension module.
/// The extension's allocator. Detection and collision queries allocate and
/// free buffers of several megabytes per call; with the system allocator
/// each such buffer came from a fresh `mmap` and was returned to the kernel
/// on free, so every call paid thousands of page faults (grasp detection on
/// a 640 x 480 evaluation frame: 31-32 ms median with the system allocator,
/// 25-26 ms with this one, on 2 cores). mimalloc keeps freed memory for
/// reuse. Only the Rust side's allocations use it. Built with the
/// local-dynamic TLS model: the initial-exec model used up the static TLS
/// that native libraries imported later need (`tests/test_import.py`).
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::PyRobotModel>()?;
    m.add_class::<gripper::PyGripper>()?;
    m.add_class::<collision::PyCollisionWorld>()?;
    m.add_class::<collision::PySphereModel>()?;
    m.add_class::<collision::PyCollisionChecker>()?;
    m.add_class::<planning::PyPlanner>()?;
    m.add_class::<planning::PyPlanResult>()?;
    m.add_class::<planning::PyIkResult>()?;
    m.add_class::<planning::PyJointTrajectory>()?;
    m.add_class::<sim::PyWorld>()?;
    m.add_class::<sim::PyRobot>()?;
    m.add_class::<sim::PyCamera>()?;
    m.add_class::<sim::PyJointPid>()?;
    m.add_class::<sim::PyResolvedRate>()?;
    m.add_function(wrap_pyfunction!(sim::depth_to_points, m)?)?;
    m.add_function(wrap_pyfunction!(sim::opencv_to_opengl, m)?)?;
    m.add_function(wrap_pyfunction!(sim::opengl_to_opencv, m)?)?;
    m.add_function(wrap_pyfunction!(sim::look_at, m)?)?;
    m.add_function(wrap_pyfunction!(camera::camera_check_intrinsics, m)?)?;
    m.add_function(wrap_pyfunction!(camera::camera_backproject, m)?)?;
    m.add_function(wrap_pyfunction!(camera::camera_convert_pose, m)?)?;
    m.add_function(wrap_pyfunction!(bundled_robot, m)?)?;
    m.add_function(wrap_pyfunction!(cache_dir, m)?)?;
    m.add_function(wrap_pyfunction!(_simd_support, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_objects::load_mesh, m)?)?;
    m.add_class::<control::PyReactiveController>()?;
    m.add_class::<control::PyPotentialFieldController>()?;
    m.add_function(wrap_pyfunction!(grasp::grasp_detect, m)?)?;
    m.add_function(wrap_pyfunction!(grasp::grasp_detect_rgbd, m)?)?;
    m.add_function(wrap_pyfunction!(grasp::grasp_nms, m)?)?;
    m.add_function(wrap_pyfunction!(grasp::grasp_transform, m)?)?;
    m.add_function(wrap_pyfunction!(grasp::grasp_camera_to_world, m)?)?;
    m.add_function(wrap_pyfunction!(batch::step_worlds, m)?)?;
    m.add_function(wrap_pyfunction!(batch::execute_trajectories, m)?)?;
    sim2real_register(m)?;
    faults::register(m)?;
    options_register(m)?;
    results::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// Registers the sim-to-real tools (`sim2real.rs`).
fn sim2real_register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<sim2real::PyCommandDelay>()?;
    m.add_class::<sim2real::PyLinearPredictor>()?;
    m.add_class::<sim2real::PyStreamGuard>()?;
    m.add_function(wrap_pyfunction!(sim2real::urdf_check, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::gravity_torques, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::payload_regressor, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::identify_payload, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::identify_link_masses, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::identify_friction, m)?)?;
    m.add_function(wrap_pyfunction!(sim2real::trajectory_sample, m)?)?;
    Ok(())
}

/// Registers the option classes (`options.rs`).
fn options_register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<options::PyPlanOptions>()?;
    m.add_class::<options::PyIkOptions>()?;
    m.add_class::<options::PyDetectOptions>()?;
    Ok(())
}
