//! `ferrobot.World`, `ferrobot.Robot`, `ferrobot.Camera` and the
//! controllers (`JointPID`, `ResolvedRateController`).

use std::sync::{Arc, Mutex, MutexGuard};

use ferrobot_camera::Intrinsics;
use ferrobot_model::pose_to_matrix;
use ferrobot_model::{Hull, Mesh};
use ferrobot_sim::camera::{Camera, CameraMount};
use ferrobot_sim::{
    JointPid, ObjectDesc, ParallelGripper, ResolvedRate, RobotOptions, Shape, SimError, World,
    WorldConfig, execute_trajectory,
};
use nalgebra::{Isometry3, Point3, Vector3};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::arrays::{Finite, read_array, read_array_with, read_pose};
use crate::errors::{
    DuplicateNameError, InvalidArgumentError, NonFiniteError, ShapeError, SimulationDiverged,
    UnknownNameError, guard, model_err,
};
use crate::model::PyRobotModel;
use crate::planning::{PyJointTrajectory, PyPlanResult};
use ferrobot_model::ranges::sim::{
    COEFFICIENT, COORDINATE, EFFORT, GAIN, GRAVITY, MASS, MAX_FORCE, POSITION, VELOCITY, check_all,
    check_all_or_inf,
};

/// Converts a simulation error to the matching Python exception.
pub fn sim_err(e: SimError) -> PyErr {
    let msg = e.to_string();
    match e {
        SimError::InvalidArgument(_) => InvalidArgumentError::new_err(msg),
        SimError::UnknownName(_) => UnknownNameError::new_err(msg),
        SimError::Duplicate(_) => DuplicateNameError::new_err(msg),
        SimError::Shape { .. } => ShapeError::new_err(msg),
        SimError::NonFinite(_) => NonFiniteError::new_err(msg),
        SimError::Diverged(_) => SimulationDiverged::new_err(msg),
        SimError::Model(m) => model_err(m),
    }
}

pub(crate) type Shared = Arc<Mutex<World>>;
/// Two 3-vectors (linear, angular).
type VecPair<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>);
/// Points (N, 3) and their flat pixel indices (N,).
type PointsAndPixels<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<i64>>);

/// Locks the world. A panic while the lock was held (caught at the
/// boundary and reported) poisons it; the poison is cleared here so that
/// the world stays usable (`reset()` restores a consistent state).
pub(crate) fn lock(w: &Shared) -> PyResult<MutexGuard<'_, World>> {
    Ok(lock_world(w))
}

/// [`lock`] without the `PyResult` (for closures run without the GIL).
pub(crate) fn lock_world(w: &Shared) -> MutexGuard<'_, World> {
    w.lock().unwrap_or_else(|poisoned| {
        w.clear_poison();
        poisoned.into_inner()
    })
}

/// Runs physics steps (`f`) with the world locked, turning a panic inside
/// the physics engine into `SimulationDiverged` (the world stays usable:
/// `reset()` restores its initial state).
fn run_steps<T>(
    w: &Shared,
    f: impl FnOnce(&mut World) -> ferrobot_sim::Result<T>,
) -> Result<ferrobot_sim::Result<T>, String> {
    let mut guard = lock_world(w);
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&mut guard))).map_err(|p| {
        p.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into())
    })
}

fn sim_err_range(e: ferrobot_model::ranges::RangeError) -> PyErr {
    InvalidArgumentError::new_err(e.0)
}

fn diverged(what: String) -> PyErr {
    SimulationDiverged::new_err(format!(
        "the physics engine failed during the step ({what}); the world's state is undefined until reset()"
    ))
}

fn matrix<'py>(py: Python<'py>, pose: &Isometry3<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((4, 4), pose_to_matrix(pose).to_vec())
        .expect("4x4")
        .into_pyarray(py)
}

fn vec1<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    Array1::from_vec(v).into_pyarray(py)
}

fn vec_arg(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    Ok(read_array(obj, what, 1, &[None])?.data().to_vec())
}

/// A directional light from Python: (direction, color, intensity).
type LightArg<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, f64);

fn vec3_arg(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vector3<f64>> {
    let a = read_array(obj, what, 1, &[Some(3)])?;
    let d = a.data();
    Ok(Vector3::new(d[0], d[1], d[2]))
}

/// A pose as Isaac Sim returns it: position (3,), orientation (w, x, y, z).
fn pose_parts<'py>(py: Python<'py>, pose: &Isometry3<f64>) -> VecPair<'py> {
    let t = pose.translation.vector;
    let q = pose.rotation.quaternion();
    (
        vec1(py, vec![t.x, t.y, t.z]),
        vec1(py, vec![q.w, q.i, q.j, q.k]),
    )
}

/// Isaac Sim's `set_world_pose(position, orientation)`: each part optional
/// (kept from `current`); a whole pose (4x4 or 7-vector) as `position`.
fn compose_pose(
    current: &Isometry3<f64>,
    position: Option<&Bound<'_, PyAny>>,
    orientation: Option<&Bound<'_, PyAny>>,
) -> PyResult<Isometry3<f64>> {
    if let (Some(p), None) = (position, orientation) {
        let a = crate::arrays::read_array_any(p, "position")?;
        if matches!(a.shape.as_slice(), [7] | [4, 4]) {
            return read_pose(p, "position");
        }
    }
    let t = match position {
        Some(p) => {
            let v = vec3_arg(p, "position")?;
            if v.iter().any(|x| !x.is_finite()) {
                return Err(NonFiniteError::new_err("position: non-finite value"));
            }
            v
        }
        None => current.translation.vector,
    };
    let q = match orientation {
        Some(o) => {
            let a = read_array(o, "orientation", 1, &[Some(4)])?;
            let d = a.data();
            let v = [t.x, t.y, t.z, d[0], d[1], d[2], d[3]];
            let arr = Array1::from_vec(v.to_vec()).into_pyarray(o.py());
            read_pose(arr.as_any(), "orientation")?.rotation
        }
        None => current.rotation,
    };
    Ok(Isometry3::from_parts(t.into(), q))
}

/// Emits a `UserWarning` for an Isaac Sim setter ferrobot has no use for.
fn no_effect_warning(py: Python<'_>, msg: &str) -> PyResult<()> {
    let cat = py.get_type::<pyo3::exceptions::PyUserWarning>();
    let msg = std::ffi::CString::new(msg).unwrap_or_default();
    PyErr::warn(py, &cat, &msg, 1)
}

/// A physics world (Rapier): ground plane, rigid objects, robots, stepping,
/// reset. z is up; poses are 4x4 matrices or [x, y, z, qw, qx, qy, qz].
#[pyclass(name = "World", module = "ferrobot")]
pub struct PyWorld {
    inner: Shared,
}

/// The properties every `World.add_*` takes as keywords: `mass` (kg, in
/// [1e-6, 1e6]; ignored when fixed), `friction` and `restitution` (in
/// [0, 1000]), `fixed` (a static body; `static_` is its deprecated name)
/// and `color` (RGB in [0, 1]), read once, without a shape; None: not
/// given (the default of `ObjectDesc::new`). Checked on the finished
/// object by [`ObjectProps::desc`].
#[derive(Default)]
struct ObjectProps {
    mass: Option<f64>,
    friction: Option<f64>,
    restitution: Option<f64>,
    fixed: Option<bool>,
    color: Option<[f64; 3]>,
}

impl ObjectProps {
    /// Reads and checks the keyword properties.
    fn read(props: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut p = Self::default();
        let mut fixed_given = false;
        for (k, v) in props.into_iter().flat_map(|p| p.iter()) {
            let key = k.cast::<pyo3::types::PyString>()?.to_cow()?;
            let number = |what: &str| -> PyResult<f64> {
                if v.is_instance_of::<pyo3::types::PyBool>() {
                    return Err(InvalidArgumentError::new_err(format!(
                        "{what}: expected a number, got a bool"
                    )));
                }
                v.extract::<f64>().map_err(|_| {
                    InvalidArgumentError::new_err(format!("{what}: expected a number, got {v}"))
                })
            };
            let flag = |what: &str| -> PyResult<bool> {
                v.extract::<bool>().map_err(|_| {
                    InvalidArgumentError::new_err(format!("{what}: expected a bool, got {v}"))
                })
            };
            match key.as_ref() {
                "mass" => p.mass = Some(number("mass")?),
                "friction" => p.friction = Some(number("friction")?),
                "restitution" => p.restitution = Some(number("restitution")?),
                "fixed" | "static_" => {
                    if key == "static_" {
                        crate::planning::deprecated(
                            v.py(),
                            "World.add_*(static_=...) is deprecated: use fixed=",
                        )?;
                    }
                    if fixed_given {
                        return Err(InvalidArgumentError::new_err(
                            "give fixed, not both fixed and the deprecated static_",
                        ));
                    }
                    fixed_given = true;
                    p.fixed = Some(flag(&key)?);
                }
                "color" => {
                    if !v.is_none() {
                        let c = vec3_arg(&v, "color")?;
                        p.color = Some([c.x, c.y, c.z]);
                    }
                }
                other => {
                    return Err(InvalidArgumentError::new_err(format!(
                        "unknown object property '{other}'; known: mass, friction, restitution, fixed, color"
                    )));
                }
            }
        }
        Ok(p)
    }

    /// Whether the object is fixed (static).
    fn fixed(&self) -> bool {
        self.fixed == Some(true)
    }

    /// The object `name` of `shape` at `pose` (identity when None) with
    /// these properties.
    fn desc(
        &self,
        name: String,
        shape: Shape,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<ObjectDesc> {
        let pose = crate::arrays::read_pose_or_identity(pose, "pose")?;
        check_all(
            &COORDINATE,
            "pose translation",
            pose.translation.vector.as_slice(),
        )
        .map_err(sim_err)?;
        let mut d = ObjectDesc::new(name, shape, pose);
        d.mass = self.mass.unwrap_or(d.mass);
        d.friction = self.friction.unwrap_or(d.friction);
        d.restitution = self.restitution.unwrap_or(d.restitution);
        d.is_static = self.fixed.unwrap_or(d.is_static);
        d.color = self.color.unwrap_or(d.color);
        if !d.is_static {
            MASS.check(d.mass)
                .map_err(|e| InvalidArgumentError::new_err(e.0))?;
        }
        COEFFICIENT
            .check_as("friction", d.friction)
            .map_err(|e| InvalidArgumentError::new_err(e.0))?;
        COEFFICIENT
            .check_as("restitution", d.restitution)
            .map_err(|e| InvalidArgumentError::new_err(e.0))?;
        Ok(d)
    }
}

/// An object of `shape` with the keyword properties `props`
/// ([`ObjectProps`]).
fn object_desc(
    name: String,
    shape: Shape,
    pose: Option<&Bound<'_, PyAny>>,
    props: Option<&Bound<'_, PyDict>>,
) -> PyResult<ObjectDesc> {
    ObjectProps::read(props)?.desc(name, shape, pose)
}

impl PyWorld {
    /// The shared world (for bindings that read it, such as scene sync).
    pub(crate) fn shared(&self) -> Shared {
        self.inner.clone()
    }

    fn add(&self, desc: ObjectDesc) -> PyResult<String> {
        guard(|| {
            let name = desc.name.clone();
            lock(&self.inner)?.add_object(desc).map_err(sim_err)?;
            Ok(name)
        })
    }

    fn object(&self, w: &World, name: &str) -> PyResult<usize> {
        w.object_index(name).map_err(sim_err)
    }
}

#[pymethods]
impl PyWorld {
    /// A new world: time step `dt` (s), `gravity` (m/s², z up),
    /// `solver_iterations`, a ground plane at z = 0 when `ground`.
    #[new]
    #[pyo3(signature = (dt=1.0/240.0, gravity=None, solver_iterations=4, ground=true, ground_friction=0.8, *, contact_frequency=ferrobot_sim::world::CONTACT_FREQUENCY, allowed_penetration=ferrobot_sim::world::ALLOWED_PENETRATION, contact_damping_ratio=ferrobot_sim::world::CONTACT_DAMPING_RATIO, friction_in_stabilization=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        dt: f64,
        gravity: Option<&Bound<'_, PyAny>>,
        solver_iterations: usize,
        ground: bool,
        ground_friction: f64,
        contact_frequency: f64,
        allowed_penetration: f64,
        contact_damping_ratio: f64,
        friction_in_stabilization: bool,
    ) -> PyResult<Self> {
        guard(|| {
            let gravity = match gravity {
                Some(g) => {
                    let g = vec3_arg(g, "gravity")?;
                    check_all(&GRAVITY, "gravity", g.as_slice()).map_err(sim_err)?;
                    g
                }
                None => Vector3::new(0.0, 0.0, -9.81),
            };
            let w = World::new(WorldConfig {
                dt,
                gravity,
                solver_iterations,
                ground,
                ground_friction,
                contact_frequency,
                allowed_penetration,
                contact_damping_ratio,
                friction_in_stabilization,
            })
            .map_err(sim_err)?;
            Ok(Self {
                inner: Arc::new(Mutex::new(w)),
            })
        })
    }

    /// Time step (s).
    #[getter]
    fn dt(&self) -> PyResult<f64> {
        guard(|| Ok(lock(&self.inner)?.config().dt))
    }

    /// Simulated time (s) since creation or the last reset.
    #[getter]
    fn time(&self) -> PyResult<f64> {
        guard(|| Ok(lock(&self.inner)?.time()))
    }

    /// Steps taken since creation or the last reset.
    #[getter]
    fn num_steps(&self) -> PyResult<u64> {
        guard(|| Ok(lock(&self.inner)?.steps()))
    }

    /// Names of the objects, in the order added.
    #[getter]
    fn object_names(&self) -> PyResult<Vec<String>> {
        guard(|| {
            Ok(lock(&self.inner)?
                .objects()
                .iter()
                .map(|o| o.desc.name.clone())
                .collect())
        })
    }

    /// Segmentation ids to names: 0 background, 1 ground, objects, "robot/link".
    #[getter]
    fn segmentation_labels(&self) -> PyResult<std::collections::BTreeMap<u32, String>> {
        guard(|| {
            Ok(lock(&self.inner)?
                .labels()
                .iter()
                .map(|l| (l.id, l.name.clone()))
                .collect())
        })
    }

    /// Lighting of rendered RGB images (Lambert): `ambient` (r, g, b), each
    /// in [0, 1]; `headlight` in [0, 1] (a light at the camera); `lights`:
    /// directional lights, each `(direction, color, intensity)` with
    /// `direction` the (world-frame, non-zero) direction the light travels,
    /// `color` (r, g, b) each in [0, 1], `intensity` in [0, 10]; at most 8.
    /// A pixel of albedo `c`, unit normal `n`, unit view ray `r` is
    /// `255 * c * (ambient + headlight * |n·r| + sum(color * intensity * max(0, -n·l)))`,
    /// saturating at 255. Default: ambient 0.35, headlight 0.65, no lights.
    #[pyo3(signature = (ambient=None, headlight=0.65, lights=None))]
    fn set_lighting(
        &self,
        ambient: Option<&Bound<'_, PyAny>>,
        headlight: f64,
        lights: Option<Vec<LightArg<'_>>>,
    ) -> PyResult<()> {
        let ambient = match ambient {
            Some(a) => {
                let a = vec3_arg(a, "ambient")?;
                [a.x, a.y, a.z]
            }
            None => [0.35; 3],
        };
        let mut ls = Vec::new();
        for (i, (d, c, intensity)) in lights.unwrap_or_default().iter().enumerate() {
            let d = vec3_arg(d, &format!("lights[{i}] direction"))?;
            let c = vec3_arg(c, &format!("lights[{i}] color"))?;
            ls.push(ferrobot_sim::DirectionalLight {
                direction: [d.x, d.y, d.z],
                color: [c.x, c.y, c.z],
                intensity: *intensity,
            });
        }
        let lighting = ferrobot_sim::Lighting {
            ambient,
            headlight,
            lights: ls,
        };
        guard(|| lock(&self.inner)?.set_lighting(lighting).map_err(sim_err))
    }

    /// The lighting, a `Lighting` (`ambient` (r, g, b), `headlight`,
    /// `lights` [(direction, color, intensity), ...]; see `set_lighting`).
    #[getter]
    fn lighting(&self) -> PyResult<crate::results::PyLighting> {
        let l = guard(|| Ok(lock(&self.inner)?.lighting().clone()))?;
        Ok(crate::results::PyLighting {
            ambient: l.ambient.to_vec(),
            headlight: l.headlight,
            lights: l
                .lights
                .iter()
                .map(|x| (x.direction.to_vec(), x.color.to_vec(), x.intensity))
                .collect(),
        })
    }

    /// Adds a box of full edge lengths `size`.
    #[pyo3(signature = (name, size, pose=None, **props))]
    fn add_box(
        &self,
        name: String,
        size: &Bound<'_, PyAny>,
        pose: Option<&Bound<'_, PyAny>>,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        guard(|| {
            let s = vec3_arg(size, "size")?;
            let shape = Shape::cuboid_from_size(s);
            self.add(object_desc(name, shape, pose, props)?)
        })
    }

    /// Adds a sphere.
    #[pyo3(signature = (name, radius, pose=None, **props))]
    fn add_sphere(
        &self,
        name: String,
        radius: f64,
        pose: Option<&Bound<'_, PyAny>>,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        guard(|| {
            let shape = Shape::Sphere { radius };
            self.add(object_desc(name, shape, pose, props)?)
        })
    }

    /// Adds a cylinder along its z axis.
    #[pyo3(signature = (name, radius, length, pose=None, **props))]
    fn add_cylinder(
        &self,
        name: String,
        radius: f64,
        length: f64,
        pose: Option<&Bound<'_, PyAny>>,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        guard(|| {
            let shape = Shape::cylinder_from_length(radius, length);
            self.add(object_desc(name, shape, pose, props)?)
        })
    }

    /// Adds a capsule along its z axis (`length` of the cylindrical part).
    #[pyo3(signature = (name, radius, length, pose=None, **props))]
    fn add_capsule(
        &self,
        name: String,
        radius: f64,
        length: f64,
        pose: Option<&Bound<'_, PyAny>>,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        guard(|| {
            let shape = Shape::capsule_from_length(radius, length);
            self.add(object_desc(name, shape, pose, props)?)
        })
    }

    /// Adds a mesh (vertices (N, 3), faces (M, 3)) approximated as
    /// "convex_hull", "convex_decomposition" or "trimesh" (static only).
    #[pyo3(signature = (name, vertices, faces, pose=None, *, approximation="convex_hull", **props))]
    fn add_mesh(
        &self,
        name: String,
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        pose: Option<&Bound<'_, PyAny>>,
        approximation: &str,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        let py = vertices.py();
        let v = read_array(vertices, "vertices", 2, &[Some(3)])?;
        let pts: Vec<Point3<f64>> = v
            .data()
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        let f = read_array(faces, "faces", 2, &[Some(3)])?;
        let mut tris = Vec::with_capacity(f.shape[0]);
        for c in f.data().chunks_exact(3) {
            if c.iter()
                .any(|&i| i < 0.0 || i.fract() != 0.0 || i >= pts.len() as f64)
            {
                return Err(InvalidArgumentError::new_err(format!(
                    "faces: indices must be integers in [0, {}), got {c:?}",
                    pts.len()
                )));
            }
            tris.push([c[0] as u32, c[1] as u32, c[2] as u32]);
        }
        let geometry =
            |e| sim_err(ferrobot_sim::error::geometry_err(e).context(&format!("object '{name}'")));
        let shape = match approximation {
            "convex_hull" => Shape::ConvexHull(Arc::new(Hull::new(pts).map_err(geometry)?)),
            "convex_decomposition" => {
                Shape::ConvexDecomposition(Arc::new(Mesh::new(pts, tris).map_err(geometry)?))
            }
            "trimesh" => Shape::Mesh(Arc::new(Mesh::new(pts, tris).map_err(geometry)?)),
            other => {
                return Err(InvalidArgumentError::new_err(format!(
                    "approximation must be 'convex_hull', 'convex_decomposition' or 'trimesh', got '{other}'"
                )));
            }
        };
        let desc = object_desc(name, shape, pose, props)?;
        let inner = self.inner.clone();
        guard(|| {
            let name = desc.name.clone();
            py.detach(|| -> Result<(), SimError> {
                let mut w = lock_world(&inner);
                w.add_object(desc).map(|_| ())
            })
            .map_err(sim_err)?;
            Ok(name)
        })
    }

    /// Adds an object whose geometry is a mesh file (OBJ, STL, DAE) scaled
    /// by `scale` (one factor or three). `approximation`: None picks
    /// "trimesh" for a static object and "convex_decomposition" (V-HACD with
    /// `resolution`, `concavity`, `max_convex_hulls`, computed once per file,
    /// scale and parameters) for a dynamic one; "convex_hull" also works.
    /// Give `mass` (kg) or `density` (kg/m³, times the approximation's
    /// volume), not both; neither means 1 kg. Bad files raise `MeshError`
    /// naming the file.
    #[pyo3(signature = (name, path, pose=None, *, scale=None, approximation=None, density=None, resolution=64, concavity=0.01, max_convex_hulls=32, **props))]
    #[allow(clippy::too_many_arguments)]
    fn add_mesh_file(
        &self,
        py: Python<'_>,
        name: String,
        path: std::path::PathBuf,
        pose: Option<&Bound<'_, PyAny>>,
        scale: Option<&Bound<'_, PyAny>>,
        approximation: Option<&str>,
        density: Option<f64>,
        resolution: u32,
        concavity: f64,
        max_convex_hulls: u32,
        props: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        use crate::mesh_objects::{decomposition_params, object_mesh, scale_arg};
        guard(|| {
            let scale = scale_arg(scale)?;
            let params = decomposition_params(resolution, concavity, max_convex_hulls)?;
            // The shared properties (mass, friction, restitution, fixed,
            // color) are read once, before the shape: its default
            // approximation depends on `fixed`.
            let mut props = ObjectProps::read(props)?;
            let approximation = approximation.unwrap_or(if props.fixed() {
                "trimesh"
            } else {
                "convex_decomposition"
            });
            let decompose = approximation == "convex_decomposition";
            let mesh = object_mesh(py, &path, scale, params, decompose)?;
            let file_err = |e: ferrobot_geometry::GeometryError| {
                crate::errors::MeshError::new_err(format!("mesh file '{}': {e}", path.display()))
            };
            let shape = match approximation {
                "convex_decomposition" => Shape::ConvexDecomposition(mesh),
                "convex_hull" => Shape::ConvexHull(Arc::new(
                    Hull::new(mesh.vertices().collect()).map_err(file_err)?,
                )),
                "trimesh" => Shape::Mesh(mesh),
                other => {
                    return Err(InvalidArgumentError::new_err(format!(
                        "approximation must be 'convex_hull', 'convex_decomposition' or 'trimesh', got '{other}'"
                    )));
                }
            };
            if let Some(d) = density {
                if props.mass.is_some() {
                    return Err(InvalidArgumentError::new_err(
                        "give mass or density, not both",
                    ));
                }
                if !(d.is_finite() && d > 0.0 && d <= 1e5) {
                    return Err(InvalidArgumentError::new_err(format!(
                        "density must be in (0, 1e5] kg/m3, got {d}"
                    )));
                }
                let vol = shape.volume().ok_or_else(|| {
                    InvalidArgumentError::new_err(
                        "density needs a solid: use mass with approximation 'trimesh'",
                    )
                })?;
                let mass = d * vol;
                if !props.fixed() {
                    MASS.check(mass).map_err(|e| {
                        InvalidArgumentError::new_err(format!("mass from density: {}", e.0))
                    })?;
                }
                props.mass = Some(mass);
            }
            let desc = props.desc(name, shape, pose)?;
            let inner = self.inner.clone();
            let name = desc.name.clone();
            py.detach(|| -> Result<(), SimError> {
                let mut w = lock_world(&inner);
                w.add_object(desc).map(|_| ())
            })
            .map_err(sim_err)?;
            Ok(name)
        })
    }

    /// World pose (4x4) of an object.
    fn get_object_pose<'py>(
        &self,
        py: Python<'py>,
        name: &str,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let w = lock(&self.inner)?;
            let i = self.object(&w, name)?;
            Ok(matrix(py, &w.object_pose(i)))
        })
    }

    /// Teleports an object.
    fn set_object_pose(&self, name: &str, pose: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let p = read_pose(pose, "pose")?;
            let mut w = lock(&self.inner)?;
            let i = self.object(&w, name)?;
            w.set_object_pose(i, &p).map_err(sim_err)
        })
    }

    /// (linear (3,), angular (3,)) velocity of an object, world frame.
    fn get_object_velocity<'py>(&self, py: Python<'py>, name: &str) -> PyResult<VecPair<'py>> {
        guard(|| {
            let w = lock(&self.inner)?;
            let i = self.object(&w, name)?;
            let (l, a) = w.object_velocity(i);
            Ok((
                vec1(py, l.as_slice().to_vec()),
                vec1(py, a.as_slice().to_vec()),
            ))
        })
    }

    /// Sets an object's velocity (angular defaults to zero).
    #[pyo3(signature = (name, linear, angular=None))]
    fn set_object_velocity(
        &self,
        name: &str,
        linear: &Bound<'_, PyAny>,
        angular: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let l = vec3_arg(linear, "linear")?;
            let a = angular
                .map(|a| vec3_arg(a, "angular"))
                .transpose()?
                .unwrap_or_else(Vector3::zeros);
            check_all(&VELOCITY, "linear", l.as_slice()).map_err(sim_err)?;
            check_all(&VELOCITY, "angular", a.as_slice()).map_err(sim_err)?;
            let mut w = lock(&self.inner)?;
            let i = self.object(&w, name)?;
            w.set_object_velocity(i, &l, &a).map_err(sim_err)
        })
    }

    /// Adds a robot built from `model` with its base link at `pose`.
    #[pyo3(signature = (model, pose=None, *, name="robot".to_string(), q=None, gravity_compensation=true, solver_iterations=4, friction=1.0))]
    #[allow(clippy::too_many_arguments)]
    fn add_robot(
        &self,
        py: Python<'_>,
        model: &PyRobotModel,
        pose: Option<&Bound<'_, PyAny>>,
        name: String,
        q: Option<&Bound<'_, PyAny>>,
        gravity_compensation: bool,
        solver_iterations: usize,
        friction: f64,
    ) -> PyResult<PyRobot> {
        let mut opts = RobotOptions::new(name);
        opts.pose = crate::arrays::read_pose_or_identity(pose, "pose")?;
        opts.q = q
            .map(|q| {
                read_array(q, "q", 1, &[Some(model.inner.num_dof())]).map(|a| a.data().to_vec())
            })
            .transpose()?;
        opts.gravity_compensation = gravity_compensation;
        opts.solver_iterations = solver_iterations;
        opts.friction = friction;
        // Without an SRDF, the planner's automatic matrix (pairs overlapping
        // by design, cached on the model) filters the robot's self-contacts.
        // A robot with at most one link of collision geometry has no pair to
        // filter (and no sphere model to build).
        let collision_links = model
            .inner
            .links()
            .iter()
            .filter(|l| !l.collisions.is_empty())
            .count();
        if model.inner.srdf().is_none() && collision_links >= 2 {
            let checker = guard(|| crate::collision::build_checker(py, model, None, None, 0.0))?;
            opts.allowed_collisions = Some(checker.allowed_collisions().clone());
        }
        let inner = self.inner.clone();
        let m = model.inner.clone();
        guard(|| {
            let index = py
                .detach(|| lock_world(&inner).add_robot(m, &opts))
                .map_err(sim_err)?;
            Ok(PyRobot {
                world: self.inner.clone(),
                index,
                model: model.inner.clone(),
            })
        })
    }

    /// Advances the simulation by `n` steps; raises `SimulationDiverged`
    /// when it blows up. `render` and `step_sim` follow Isaac Sim's
    /// `World.step`: cameras render when asked (`Camera.render`), so
    /// `render` has nothing to do; `step_sim=False` does not step.
    #[pyo3(signature = (n=1, *, render=false, step_sim=true))]
    fn step(&self, py: Python<'_>, n: usize, render: bool, step_sim: bool) -> PyResult<()> {
        let _ = render;
        if !step_sim {
            return Ok(());
        }
        let inner = self.inner.clone();
        guard(|| {
            ferrobot_model::ranges::sim::steps_for("step(n)", n as f64, 1.0).map_err(sim_err)?;
            py.detach(|| run_steps(&inner, |w| w.step(n)))
                .map_err(diverged)?
                .map_err(sim_err)
        })
    }

    /// Returns to the initial state (the state at the first step after the
    /// last object or robot was added, or at `mark_initial_state()`).
    fn reset(&self) -> PyResult<()> {
        guard(|| {
            lock(&self.inner)?.reset();
            Ok(())
        })
    }

    /// Makes the current state the one `reset()` returns to.
    fn mark_initial_state(&self) -> PyResult<()> {
        guard(|| {
            lock(&self.inner)?.mark_initial_state();
            Ok(())
        })
    }
}

/// A robot simulated in a `World` (API after Isaac Sim's `Robot`). Joint
/// vectors are in `dof_names` order; `joint_indices` select DOFs.
#[pyclass(name = "Robot", module = "ferrobot", frozen)]
pub struct PyRobot {
    world: Shared,
    index: usize,
    model: Arc<ferrobot_model::RobotModel>,
}

fn indices_arg(ix: Option<Vec<i64>>) -> PyResult<Option<Vec<usize>>> {
    ix.map(|v| {
        v.into_iter()
            .map(|i| {
                usize::try_from(i).map_err(|_| {
                    UnknownNameError::new_err(format!("joint index {i} out of range (negative)"))
                })
            })
            .collect()
    })
    .transpose()
}

impl PyRobot {
    pub(crate) fn with_robot<T>(
        &self,
        f: impl FnOnce(
            &mut ferrobot_sim::Robot,
            &mut ferrobot_sim::state::PhysState,
        ) -> ferrobot_sim::Result<T>,
    ) -> PyResult<T> {
        self.with(f)
    }

    fn with<T>(
        &self,
        f: impl FnOnce(
            &mut ferrobot_sim::Robot,
            &mut ferrobot_sim::state::PhysState,
        ) -> ferrobot_sim::Result<T>,
    ) -> PyResult<T> {
        guard(|| {
            lock(&self.world)?
                .with_robot(self.index, f)
                .map_err(sim_err)
        })
    }

    fn read<T>(&self, f: impl FnOnce(&ferrobot_sim::Robot, &World) -> T) -> PyResult<T> {
        guard(|| {
            let w = lock(&self.world)?;
            let r = w.robot(self.index).map_err(sim_err)?;
            Ok(f(r, &w))
        })
    }

    /// The DOFs a call addresses: `joint_names` (the one spelling of a
    /// joint subset across the Python API, resolved by the model) or the
    /// deprecated `joint_indices` (DOF indices, Isaac Sim's spelling, kept
    /// for one release with a warning; `ferrobot.compat.isaac.Articulation`
    /// keeps it without one); all DOFs when neither is given.
    fn subset(
        &self,
        what: &str,
        joint_indices: Option<Vec<i64>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<Option<Vec<usize>>> {
        if joint_indices.is_some() && joint_names.is_none() {
            Python::attach(|py| {
                crate::planning::deprecated(
                    py,
                    &format!(
                        "Robot.{what}(joint_indices=...) is deprecated: use joint_names= \
                         (Isaac Sim code: ferrobot.compat.isaac.Articulation keeps joint_indices)"
                    ),
                )
            })?;
        }
        match (joint_indices, joint_names) {
            (Some(_), Some(_)) => Err(InvalidArgumentError::new_err(
                "give joint_names or joint_indices, not both",
            )),
            (None, Some(names)) => names
                .iter()
                .map(|n| self.model.dof(n).map_err(model_err))
                .collect::<PyResult<Vec<usize>>>()
                .map(Some),
            (ix, None) => indices_arg(ix),
        }
    }

    fn targets_len(&self, ix: &Option<Vec<usize>>) -> Option<usize> {
        ix.as_ref().map(|v| v.len()).or(Some(self.model.num_dof()))
    }
}

#[pymethods]
impl PyRobot {
    /// The robot's name in the world.
    #[getter]
    fn name(&self) -> PyResult<String> {
        guard(|| self.read(|r, _| r.name().to_string()))
    }

    /// The robot model.
    #[getter]
    fn model(&self) -> PyResult<PyRobotModel> {
        guard(|| Ok(PyRobotModel::from_arc(self.model.clone())))
    }

    /// Names of the DOFs (mimic joints excluded).
    #[getter]
    fn dof_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.model.dof_names().to_vec()))
    }

    /// Number of DOFs.
    #[getter]
    fn num_dof(&self) -> PyResult<usize> {
        guard(|| Ok(self.model.num_dof()))
    }

    /// Deprecated: read the `joint_positions` property instead.
    fn get_joint_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_joint_positions() is deprecated: read the property Robot.joint_positions",
        )?;
        self.read_joint_positions(py)
    }

    /// Deprecated: read the `joint_velocities` property instead.
    fn get_joint_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_joint_velocities() is deprecated: read the property Robot.joint_velocities",
        )?;
        self.read_joint_velocities(py)
    }

    /// Deprecated: read the `joint_position_targets` property instead.
    fn get_joint_position_targets<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_joint_position_targets() is deprecated: read the property Robot.joint_position_targets",
        )?;
        self.read_joint_position_targets(py)
    }

    /// Deprecated: read the `applied_joint_efforts` property instead.
    fn get_applied_joint_efforts<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_applied_joint_efforts() is deprecated: read the property Robot.applied_joint_efforts",
        )?;
        self.read_applied_joint_efforts(py)
    }

    /// Deprecated: read the `measured_joint_efforts` property instead.
    fn get_measured_joint_efforts<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_measured_joint_efforts() is deprecated: read the property Robot.measured_joint_efforts",
        )?;
        self.read_measured_joint_efforts(py)
    }

    /// Deprecated: read the `gripper_positions` property instead.
    fn get_gripper_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_gripper_positions() is deprecated: read the property Robot.gripper_positions",
        )?;
        self.read_gripper_positions(py)
    }

    /// Deprecated: read the `world_transform` property instead.
    fn get_world_transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::planning::deprecated(
            py,
            "Robot.get_world_transform() is deprecated: read the property Robot.world_transform",
        )?;
        self.read_world_transform(py)
    }

    /// Deprecated: read the `gripper_opening` property instead.
    fn get_gripper_opening<'py>(&self, py: Python<'py>) -> PyResult<f64> {
        crate::planning::deprecated(
            py,
            "Robot.get_gripper_opening() is deprecated: read the property Robot.gripper_opening",
        )?;
        self.read_gripper_opening()
    }

    /// Joint positions (num_dof,; rad or m), `dof_names` order.
    #[getter(joint_positions)]
    fn read_joint_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(vec1(py, self.read(|r, w| r.joint_positions(w.state()))?)))
    }

    /// Joint velocities (num_dof,; rad/s or m/s), `dof_names` order.
    #[getter(joint_velocities)]
    fn read_joint_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(vec1(py, self.read(|r, w| r.joint_velocities(w.state()))?)))
    }

    /// Joint-space mass matrix M(q) (num_dof, num_dof) at the current joint
    /// positions: the inertia the simulation uses (mimic joints held).
    fn mass_matrix<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let n = self.model.num_dof();
            let m = self.with(|r, s| Ok(r.mass_matrix(s)))?;
            Ok(Array2::from_shape_vec((n, n), m)
                .expect("num_dof x num_dof")
                .into_pyarray(py))
        })
    }

    /// Teleports the joints (zero velocity; mimic joints follow). Drive
    /// targets are unchanged, as in Isaac Sim.
    fn set_joint_positions(&self, q: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let q = read_array(q, "q", 1, &[Some(self.model.num_dof())])?
                .data()
                .to_vec();
            check_all(&POSITION, "q", &q).map_err(sim_err)?;
            self.with(|r, s| r.set_joint_positions(s, &q))
        })
    }

    /// Sets the joint velocities.
    fn set_joint_velocities(&self, qd: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let qd = read_array(qd, "qd", 1, &[Some(self.model.num_dof())])?
                .data()
                .to_vec();
            check_all(&VELOCITY, "qd", &qd).map_err(sim_err)?;
            self.with(|r, s| r.set_joint_velocities(s, &qd))
        })
    }

    /// Drive position targets for the DOFs `joint_names` or `joint_indices`
    /// (all DOFs when None).
    #[pyo3(signature = (targets, joint_indices=None, *, joint_names=None))]
    fn set_joint_position_targets(
        &self,
        targets: &Bound<'_, PyAny>,
        joint_indices: Option<Vec<i64>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let ix = self.subset("set_joint_position_targets", joint_indices, joint_names)?;
            let t = read_array(targets, "targets", 1, &[self.targets_len(&ix)])?
                .data()
                .to_vec();
            check_all(&POSITION, "targets", &t).map_err(sim_err)?;
            self.with(|r, s| r.set_position_targets(s, &t, ix.as_deref()))
        })
    }

    /// Drive velocity targets for the DOFs `joint_names` or `joint_indices`
    /// (all DOFs when None).
    #[pyo3(signature = (targets, joint_indices=None, *, joint_names=None))]
    fn set_joint_velocity_targets(
        &self,
        targets: &Bound<'_, PyAny>,
        joint_indices: Option<Vec<i64>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let ix = self.subset("set_joint_velocity_targets", joint_indices, joint_names)?;
            let t = read_array(targets, "targets", 1, &[self.targets_len(&ix)])?
                .data()
                .to_vec();
            check_all(&VELOCITY, "targets", &t).map_err(sim_err)?;
            self.with(|r, s| r.set_velocity_targets(s, &t, ix.as_deref()))
        })
    }

    /// Command latency (s): drive targets and efforts set at world time
    /// `t` take effect at the first step starting at or after `t + latency`
    /// (0 by default: at once).
    #[getter]
    fn command_latency(&self) -> PyResult<f64> {
        self.with(|r, _| Ok(r.command_latency()))
    }

    /// Sets the command latency (s, finite, in [0, 10]); commands already
    /// waiting keep their due times.
    #[setter(command_latency)]
    fn set_command_latency_value(&self, latency: f64) -> PyResult<()> {
        self.with(|r, _| r.set_command_latency(latency))
    }

    /// Deprecated: assign `command_latency` instead.
    fn set_command_latency(&self, py: Python<'_>, latency: f64) -> PyResult<()> {
        crate::planning::deprecated(
            py,
            "Robot.set_command_latency(s) is deprecated: assign Robot.command_latency = s",
        )?;
        self.set_command_latency_value(latency)
    }

    /// Commands waiting in the latency buffer.
    #[getter]
    fn pending_commands(&self) -> PyResult<usize> {
        self.with(|r, _| Ok(r.pending_commands()))
    }

    /// Efforts (N·m or N) applied every step on top of the drives.
    #[pyo3(signature = (efforts, joint_indices=None, *, joint_names=None))]
    fn set_joint_efforts(
        &self,
        efforts: &Bound<'_, PyAny>,
        joint_indices: Option<Vec<i64>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let ix = self.subset("set_joint_efforts", joint_indices, joint_names)?;
            let e = read_array(efforts, "efforts", 1, &[self.targets_len(&ix)])?
                .data()
                .to_vec();
            check_all(&EFFORT, "efforts", &e).map_err(sim_err)?;
            self.with(|r, _| r.set_efforts(&e, ix.as_deref()))
        })
    }

    /// Current drive position targets (num_dof,; rad or m).
    #[getter(joint_position_targets)]
    fn read_joint_position_targets<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| {
            Ok(vec1(
                py,
                self.read(|r, _| r.drives().iter().map(|d| d.target_position).collect())?,
            ))
        })
    }

    /// The drive gains: a `DriveGains` (stiffness, damping, max_force; each
    /// (num_dof,)).
    #[getter(drive_gains)]
    fn read_drive_gains(&self, py: Python<'_>) -> PyResult<crate::results::PyDriveGains> {
        use crate::results::arr1;
        guard(|| {
            let d = self.read(|r, _| r.drives().to_vec())?;
            Ok(crate::results::PyDriveGains {
                stiffness: arr1(py, d.iter().map(|d| d.stiffness).collect()),
                damping: arr1(py, d.iter().map(|d| d.damping).collect()),
                max_force: arr1(py, d.iter().map(|d| d.max_force).collect()),
            })
        })
    }

    /// Deprecated: read `drive_gains` (a `DriveGains`) instead.
    #[allow(clippy::type_complexity)]
    fn get_drive_gains<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
    )> {
        crate::planning::deprecated(
            py,
            "Robot.get_drive_gains() is deprecated: read Robot.drive_gains (.stiffness, .damping, .max_force)",
        )?;
        guard(|| {
            let d = self.read(|r, _| r.drives().to_vec())?;
            Ok((
                vec1(py, d.iter().map(|d| d.stiffness).collect()),
                vec1(py, d.iter().map(|d| d.damping).collect()),
                vec1(py, d.iter().map(|d| d.max_force).collect()),
            ))
        })
    }

    /// Drive gains and force limits (inf: unlimited) for `joint_names` or
    /// `joint_indices` (all DOFs when None).
    #[pyo3(signature = (stiffness, damping, max_force=None, joint_indices=None, *, joint_names=None))]
    fn set_drive_gains(
        &self,
        stiffness: &Bound<'_, PyAny>,
        damping: &Bound<'_, PyAny>,
        max_force: Option<&Bound<'_, PyAny>>,
        joint_indices: Option<Vec<i64>>,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<()> {
        guard(|| {
            let ix = self.subset("set_drive_gains", joint_indices, joint_names)?;
            let n = self.targets_len(&ix);
            let k = read_array(stiffness, "stiffness", 1, &[n])?.data().to_vec();
            let d = read_array(damping, "damping", 1, &[n])?.data().to_vec();
            let m = match max_force {
                None => None,
                Some(m) => Some(
                    read_array_with(m, "max_force", 1, &[n], Finite::NoNan)?
                        .data()
                        .to_vec(),
                ),
            };
            check_all(&GAIN, "stiffness", &k).map_err(sim_err)?;
            check_all(&GAIN, "damping", &d).map_err(sim_err)?;
            if let Some(m) = &m {
                check_all_or_inf(&MAX_FORCE, "max_force", m).map_err(sim_err)?;
            }
            self.with(|r, s| r.set_drive_gains(s, &k, &d, m.as_deref(), ix.as_deref()))
        })
    }

    /// Extra solver substeps for the robot's bodies, used while the robot
    /// touches something (grasps hold better; a free robot does not need them).
    fn set_solver_iterations(&self, n: usize) -> PyResult<()> {
        guard(|| self.with(|r, s| r.set_solver_iterations(s, n)))
    }

    // --- Isaac Sim shapes (issue 22): world pose as (position, wxyz),
    // joint states, articulation actions, solver setters, initialize. ---

    /// World pose of the base link as Isaac Sim returns it: position (3,)
    /// and orientation (4,) as (w, x, y, z). `get_world_transform()` gives
    /// the 4x4.
    fn get_world_pose<'py>(&self, py: Python<'py>) -> PyResult<VecPair<'py>> {
        Ok(pose_parts(py, &self.read(|r, _| r.world_pose())?))
    }

    /// World pose (4x4) of the base link.
    #[getter(world_transform)]
    fn read_world_transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(matrix(py, &self.read(|r, _| r.world_pose())?)))
    }

    /// Moves the fixed base: `position` (3,) and/or `orientation` (4,)
    /// (w, x, y, z), the other part kept (Isaac Sim's signature); or a whole
    /// pose (4x4 or 7-vector) as `position` with no `orientation`.
    #[pyo3(signature = (position=None, orientation=None))]
    fn set_world_pose(
        &self,
        position: Option<&Bound<'_, PyAny>>,
        orientation: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let current = self.read(|r, _| r.world_pose())?;
            let p = compose_pose(&current, position, orientation)?;
            self.with(|r, s| r.set_world_pose(s, p))
        })
    }

    /// Isaac Sim's `initialize()`: nothing to do (a ferrobot robot is ready
    /// when added); safe to call any number of times.
    #[pyo3(signature = (physics_sim_view=None))]
    fn initialize(&self, physics_sim_view: Option<&Bound<'_, PyAny>>) {
        let _ = physics_sim_view;
    }

    /// Isaac Sim's `get_joints_state()`: an object with `positions`,
    /// `velocities` and `efforts` (num_dof,), the efforts being those set
    /// with `set_joint_efforts` (Isaac's applied efforts, not drive forces).
    fn get_joints_state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (q, qd, e) = self.read(|r, w| {
            (
                r.joint_positions(w.state()),
                r.joint_velocities(w.state()),
                r.efforts().to_vec(),
            )
        })?;
        py.import("ferrobot.compat.isaac")?
            .getattr("JointsState")?
            .call1((vec1(py, q), vec1(py, qd), vec1(py, e)))
    }

    /// Efforts set with `set_joint_efforts` (num_dof,; N·m or N).
    #[getter(applied_joint_efforts)]
    fn read_applied_joint_efforts<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        Ok(vec1(py, self.read(|r, _| r.efforts().to_vec())?))
    }

    /// Isaac Sim's `apply_action(ArticulationAction)`: any object with
    /// `joint_positions` (drive position targets), `joint_velocities`
    /// (drive velocity targets), `joint_efforts` and `joint_indices`
    /// (all DOFs when None). A None entry leaves that DOF unchanged, as in
    /// Isaac Sim. Everything is checked before anything is applied.
    fn apply_action(&self, control_actions: &Bound<'_, PyAny>) -> PyResult<()> {
        let field = |name: &str| -> PyResult<Option<Vec<Option<f64>>>> {
            let v = control_actions.getattr(name).map_err(|_| {
                InvalidArgumentError::new_err(format!(
                    "control_actions: has no attribute '{name}' (expected an ArticulationAction)"
                ))
            })?;
            if v.is_none() {
                return Ok(None);
            }
            let v = if v.hasattr("tolist")? {
                v.call_method0("tolist")?
            } else {
                v
            };
            v.extract::<Vec<Option<f64>>>().map(Some).map_err(|_| {
                InvalidArgumentError::new_err(format!(
                    "control_actions.{name}: expected a 1-D sequence of numbers or None"
                ))
            })
        };
        let ix_obj = control_actions.getattr("joint_indices").map_err(|_| {
            InvalidArgumentError::new_err(
                "control_actions: has no attribute 'joint_indices' (expected an ArticulationAction)",
            )
        })?;
        let ix: Option<Vec<i64>> = if ix_obj.is_none() {
            None
        } else {
            let o = if ix_obj.hasattr("tolist")? {
                ix_obj.call_method0("tolist")?
            } else {
                ix_obj
            };
            Some(o.extract().map_err(|_| {
                InvalidArgumentError::new_err(
                    "control_actions.joint_indices: expected a sequence of integers",
                )
            })?)
        };
        let ix = indices_arg(ix)?;
        let n = self.model.num_dof();
        let all: Vec<usize> = match &ix {
            Some(v) => v.clone(),
            None => (0..n).collect(),
        };
        let mut parts: Vec<(&str, Vec<usize>, Vec<f64>)> = Vec::new();
        for name in ["joint_positions", "joint_velocities", "joint_efforts"] {
            let Some(vals) = field(name)? else { continue };
            if vals.len() != all.len() {
                return Err(ShapeError::new_err(format!(
                    "control_actions.{name}: expected {} values (one per joint index), got {}",
                    all.len(),
                    vals.len()
                )));
            }
            let (mut idx, mut v) = (Vec::new(), Vec::new());
            for (&i, x) in all.iter().zip(vals) {
                if let Some(x) = x {
                    if !x.is_finite() {
                        return Err(NonFiniteError::new_err(format!(
                            "control_actions.{name}: non-finite value for joint index {i}"
                        )));
                    }
                    idx.push(i);
                    v.push(x);
                }
            }
            parts.push((name, idx, v));
        }
        self.with(|r, s| {
            ferrobot_sim::drives::resolve_indices(r, Some(&all))?;
            for (name, idx, v) in &parts {
                match *name {
                    "joint_positions" => r.set_position_targets(s, v, Some(idx))?,
                    "joint_velocities" => r.set_velocity_targets(s, v, Some(idx))?,
                    _ => r.set_efforts(v, Some(idx))?,
                }
            }
            Ok(())
        })
    }

    /// Isaac Sim's position iteration count: ferrobot's extra solver
    /// substeps while the robot touches something (`set_solver_iterations`).
    fn set_solver_position_iteration_count(&self, count: usize) -> PyResult<()> {
        self.set_solver_iterations(count)
    }

    /// The extra solver substeps (see `set_solver_position_iteration_count`).
    fn get_solver_position_iteration_count(&self) -> PyResult<usize> {
        self.read(|r, _| r.solver_iterations())
    }

    /// Accepted for Isaac Sim scripts; has no effect, and says so with a
    /// `UserWarning`: Rapier's solver has no separate velocity iterations.
    fn set_solver_velocity_iteration_count(&self, py: Python<'_>, count: usize) -> PyResult<()> {
        no_effect_warning(
            py,
            &format!(
                "set_solver_velocity_iteration_count({count}) has no effect: Rapier's solver has no separate velocity iterations (use set_solver_position_iteration_count)"
            ),
        )
    }

    /// Accepted for Isaac Sim scripts (`threshold` finite, >= 0); has no
    /// effect, and says so with a `UserWarning`: ferrobot's robots never
    /// sleep and Rapier has no PhysX-style stabilisation damping.
    fn set_stabilization_threshold(&self, py: Python<'_>, threshold: f64) -> PyResult<()> {
        if !threshold.is_finite() || threshold < 0.0 {
            return Err(InvalidArgumentError::new_err(format!(
                "threshold: expected a finite value >= 0, got {threshold}"
            )));
        }
        no_effect_warning(
            py,
            &format!(
                "set_stabilization_threshold({threshold}) has no effect: ferrobot's robots never sleep and Rapier has no stabilisation damping"
            ),
        )
    }

    // --- end of the Isaac Sim shapes ---

    /// World pose (4x4) of a link (default: the end effector).
    #[pyo3(signature = (link=None))]
    fn get_link_pose<'py>(
        &self,
        py: Python<'py>,
        link: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let l = match link {
                Some(l) => self.model.link(l).map_err(model_err)?,
                None => self.model.ee_link(),
            };
            Ok(matrix(py, &self.read(|r, w| r.link_pose(w.state(), l))?))
        })
    }

    /// Opens the gripper (force limit default: the finger effort limits).
    #[pyo3(signature = (force=None))]
    fn open_gripper(&self, force: Option<f64>) -> PyResult<()> {
        guard(|| {
            if let Some(f) = force {
                MAX_FORCE.check_as("force", f).map_err(sim_err_range)?;
            }
            self.with(|r, s| r.open_gripper(s, force))
        })
    }

    /// Closes the gripper, squeezing with `force` N per finger.
    #[pyo3(signature = (force=None))]
    fn close_gripper(&self, force: Option<f64>) -> PyResult<()> {
        guard(|| {
            if let Some(f) = force {
                MAX_FORCE.check_as("force", f).map_err(sim_err_range)?;
            }
            self.with(|r, s| r.close_gripper(s, force))
        })
    }

    /// Describes a parallel gripper: finger DOF names with open and closed positions.
    fn set_gripper(
        &self,
        joint_names: Vec<String>,
        open: &Bound<'_, PyAny>,
        closed: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guard(|| {
            let o = vec_arg(open, "open")?;
            let c = vec_arg(closed, "closed")?;
            let g = ParallelGripper::new(&self.model, &joint_names, &o, &c).map_err(sim_err)?;
            self.with(|r, _| {
                r.set_gripper(g);
                Ok(())
            })
        })
    }

    /// Finger DOF positions of the gripper.
    #[getter(gripper_positions)]
    fn read_gripper_positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = guard(|| {
            let w = lock(&self.world)?;
            let r = w.robot(self.index).map_err(sim_err)?;
            r.gripper_positions(w.state()).map_err(sim_err)
        })?;
        Ok(vec1(py, v))
    }

    /// The gripper description the robot's gripper commands use (found in
    /// the model when added, or given with `use_gripper`), or None.
    #[getter]
    fn gripper_description(&self) -> PyResult<Option<crate::gripper::PyGripper>> {
        guard(|| {
            let w = lock(&self.world)?;
            let r = w.robot(self.index).map_err(sim_err)?;
            Ok(r.gripper()
                .and_then(|g| g.description.clone())
                .map(|inner| crate::gripper::PyGripper { inner }))
        })
    }

    /// Uses `gripper` (a `ferrobot.Gripper` this robot's model has) for the
    /// gripper commands: its driver is driven, its followers move through
    /// their mimic couplings only.
    fn use_gripper(&self, gripper: &crate::gripper::PyGripper) -> PyResult<()> {
        guard(|| {
            let g = ParallelGripper::from_gripper(&self.model, gripper.inner.clone())
                .map_err(sim_err)?;
            self.with(|r, _| {
                r.set_gripper(g);
                Ok(())
            })
        })
    }

    /// Drives the fingers to `opening` m between the pads (within the
    /// gripper's range), squeezing with at most `force` N per finger.
    #[pyo3(signature = (opening, force=None))]
    fn set_gripper_opening(&self, opening: f64, force: Option<f64>) -> PyResult<()> {
        guard(|| {
            if let Some(f) = force {
                MAX_FORCE.check_as("force", f).map_err(sim_err_range)?;
            }
            self.with(|r, s| r.set_gripper_opening(s, opening, force))
        })
    }

    /// Drives the gripper's driver joint to `position` (rad or m, between
    /// its open and closed positions), at most `force` N per finger.
    #[pyo3(signature = (position, force=None))]
    fn set_gripper_driver(&self, position: f64, force: Option<f64>) -> PyResult<()> {
        guard(|| {
            if let Some(f) = force {
                MAX_FORCE.check_as("force", f).map_err(sim_err_range)?;
            }
            self.with(|r, s| r.set_gripper_driver(s, position, force))
        })
    }

    /// Current opening (m) between the pads, from the driver's position.
    #[getter(gripper_opening)]
    fn read_gripper_opening(&self) -> PyResult<f64> {
        guard(|| {
            let w = lock(&self.world)?;
            let r = w.robot(self.index).map_err(sim_err)?;
            r.gripper_opening(w.state()).map_err(sim_err)
        })
    }

    /// Runs a joint trajectory sampled every `dt` s (positions (N, k) for
    /// the k `joint_indices`, all DOFs when None) through the drives, one
    /// target per physics step (linear interpolation, velocity
    /// feed-forward), then holds the last point for `settle_time` s.
    /// Returns a `TrackingReport` (times, desired, actual, max_error,
    /// rms_error, final_error).
    #[pyo3(signature = (positions, dt, velocities=None, joint_indices=None, settle_time=0.0, *, joint_names=None))]
    fn execute_trajectory<'py>(
        &self,
        positions: &Bound<'py, PyAny>,
        dt: f64,
        velocities: Option<&Bound<'py, PyAny>>,
        joint_indices: Option<Vec<i64>>,
        settle_time: f64,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<crate::results::PyTrackingReport> {
        guard(|| {
            let py = positions.py();
            let ix = self.subset("execute_trajectory", joint_indices, joint_names)?;
            let k = self.targets_len(&ix);
            let p = read_array(positions, "positions", 2, &[k])?.data().to_vec();
            let v = velocities
                .map(|v| read_array(v, "velocities", 2, &[k]).map(|a| a.data().to_vec()))
                .transpose()?;
            self.run_trajectory(py, p, v, dt, ix, settle_time)
        })
    }

    /// Executes a planned motion: a `JointTrajectory` (from
    /// `PlanResult.interpolated(dt)`) or a successful `PlanResult` (sampled
    /// at the world's time step), through the joint drives as
    /// `execute_trajectory` does. Joints are matched by name, so the
    /// planner's joint order needs no glue; mimic joints in the trajectory
    /// are skipped (the physics makes them follow their drivers); a name the
    /// robot does not have raises `UnknownNameError`. Returns the tracking
    /// report of `execute_trajectory`.
    #[pyo3(signature = (trajectory, settle_time=0.0))]
    fn execute<'py>(
        &self,
        py: Python<'py>,
        trajectory: &Bound<'py, PyAny>,
        settle_time: f64,
    ) -> PyResult<crate::results::PyTrackingReport> {
        guard(|| {
            let owned;
            let traj = if let Ok(t) = trajectory.cast::<PyJointTrajectory>() {
                t.get()
            } else if let Ok(r) = trajectory.cast::<PyPlanResult>() {
                let dt = lock(&self.world)?.config().dt;
                owned = r.borrow().interpolated(dt)?;
                &owned
            } else {
                return Err(InvalidArgumentError::new_err(format!(
                    "trajectory: expected a ferrobot.JointTrajectory or a ferrobot.PlanResult, got {}",
                    trajectory
                        .get_type()
                        .name()
                        .map(|n| n.to_string())
                        .unwrap_or_default()
                )));
            };
            let s = traj.samples();
            let width = s.names.len();
            let (cols, ix): (Vec<usize>, Vec<usize>) = self
                .model
                .dof_columns(s.names)
                .map_err(|e| {
                    UnknownNameError::new_err(format!(
                        "trajectory: {e} (not a joint of robot '{}')",
                        self.model.name()
                    ))
                })?
                .into_iter()
                .unzip();
            let pick = |src: &[f64]| -> Vec<f64> {
                src.chunks_exact(width.max(1))
                    .flat_map(|row| cols.iter().map(move |&c| row[c]))
                    .collect()
            };
            let (p, v) = (pick(s.positions), pick(s.velocities));
            let dt = s.dt;
            self.run_trajectory(py, p, Some(v), dt, Some(ix), settle_time)
        })
    }

    // Sim-to-real additions (bodies in sim2real.rs).

    /// Replaces `link`'s mass (kg, >= 0), centre of mass (3,) and inertia
    /// about it (3, 3; link axes) at run time; the next step uses them.
    fn set_link_inertial(
        &self,
        link: &str,
        mass: f64,
        com: &Bound<'_, PyAny>,
        inertia: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        crate::sim2real::set_link_inertial(self, link, mass, com, inertia)
    }

    /// `link`'s simulated mass properties in the link frame, a
    /// `LinkInertial` (mass, com, inertia).
    fn get_link_inertial(
        &self,
        py: Python<'_>,
        link: &str,
    ) -> PyResult<crate::results::PyLinkInertial> {
        crate::sim2real::get_link_inertial(py, self, link)
    }

    /// Sets a DOF's viscous damping (N·m·s/rad) and dry friction (N·m).
    fn set_joint_dynamics(&self, joint: &str, damping: f64, friction: f64) -> PyResult<()> {
        crate::sim2real::set_joint_dynamics(self, joint, damping, friction)
    }

    /// A DOF's (damping, friction).
    fn get_joint_dynamics(&self, joint: &str) -> PyResult<(f64, f64)> {
        crate::sim2real::get_joint_dynamics(self, joint)
    }

    /// Efforts the drives apply now (DOF order; plus `set_joint_efforts`).
    #[getter(measured_joint_efforts)]
    fn read_measured_joint_efforts<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        crate::sim2real::applied_efforts(py, self)
    }
}

impl PyRobot {
    /// Runs positions (rows of the `ix` joints) through the drives and
    /// returns the tracking report.
    fn run_trajectory(
        &self,
        py: Python<'_>,
        p: Vec<f64>,
        v: Option<Vec<f64>>,
        dt: f64,
        ix: Option<Vec<usize>>,
        settle_time: f64,
    ) -> PyResult<crate::results::PyTrackingReport> {
        let world = self.world.clone();
        let index = self.index;
        let rep = guard(|| {
            use ferrobot_model::ranges::sim::{
                POSITION, SETTLE_TIME, TRAJECTORY_DT, VELOCITY, check_all, steps_for,
            };
            TRAJECTORY_DT
                .check(dt)
                .map_err(|e| InvalidArgumentError::new_err(e.0))?;
            SETTLE_TIME
                .check(settle_time)
                .map_err(|e| InvalidArgumentError::new_err(e.0))?;
            check_all(&POSITION, "positions", &p).map_err(sim_err)?;
            if let Some(v) = &v {
                check_all(&VELOCITY, "velocities", v).map_err(sim_err)?;
            }
            let rows = p.len() / ix.as_ref().map_or(self.model.num_dof(), Vec::len).max(1);
            let h = lock(&world)?.config().dt;
            let duration = rows.saturating_sub(1) as f64 * dt + settle_time;
            steps_for("execute_trajectory (duration + settle_time)", duration, h)
                .map_err(sim_err)?;
            py.detach(|| {
                run_steps(&world, |w| {
                    execute_trajectory(w, index, &p, dt, v.as_deref(), ix.as_deref(), settle_time)
                })
            })
            .map_err(diverged)?
            .map_err(sim_err)
        })?;
        Ok(crate::results::PyTrackingReport::new(py, rep))
    }
}

/// A pinhole camera in a `World`, fixed to the world or to a robot link.
/// Its frame is OpenCV's (x right, y down, z forward).
#[pyclass(name = "Camera", module = "ferrobot")]
pub struct PyCamera {
    world: Shared,
    camera: Camera,
}

#[pymethods]
impl PyCamera {
    /// A camera of `width` x `height` pixels with focal lengths `fx`, `fy`
    /// and principal point `cx`, `cy` (defaults: the image centre); `pose`
    /// of the OpenCV camera frame in the world, or in `link` of `robot`.
    #[new]
    #[pyo3(signature = (world, width, height, fx, fy=None, cx=None, cy=None, pose=None, *, robot=None, link=None, near=0.01, far=100.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        world: &PyWorld,
        width: usize,
        height: usize,
        fx: f64,
        fy: Option<f64>,
        cx: Option<f64>,
        cy: Option<f64>,
        pose: Option<&Bound<'_, PyAny>>,
        robot: Option<&PyRobot>,
        link: Option<&str>,
        near: f64,
        far: f64,
    ) -> PyResult<Self> {
        guard(|| {
            let intrinsics = Intrinsics {
                width,
                height,
                fx,
                fy: fy.unwrap_or(fx),
                cx: cx.unwrap_or((width as f64 - 1.0) / 2.0),
                cy: cy.unwrap_or((height as f64 - 1.0) / 2.0),
                depth_scale: 1.0,
            };
            let mount = match (robot, link) {
                (None, None) => CameraMount::World,
                (Some(r), l) => {
                    if !Arc::ptr_eq(&r.world, &world.inner) {
                        return Err(InvalidArgumentError::new_err(
                            "robot: the robot belongs to another world",
                        ));
                    }
                    let link = match l {
                        Some(l) => r.model.link(l).map_err(model_err)?,
                        None => r.model.ee_link(),
                    };
                    CameraMount::Link {
                        robot: r.index,
                        link,
                    }
                }
                (None, Some(_)) => {
                    return Err(InvalidArgumentError::new_err(
                        "link: give the robot the link belongs to",
                    ));
                }
            };
            let camera = Camera {
                intrinsics,
                pose: crate::arrays::read_pose_or_identity(pose, "pose")?,
                mount,
                near,
                far,
            };
            camera.validate().map_err(sim_err)?;
            Ok(Self {
                world: world.inner.clone(),
                camera,
            })
        })
    }

    /// Image width.
    #[getter]
    fn width(&self) -> PyResult<usize> {
        guard(|| Ok(self.camera.intrinsics.width))
    }

    /// Image height.
    #[getter]
    fn height(&self) -> PyResult<usize> {
        guard(|| Ok(self.camera.intrinsics.height))
    }

    /// The 3x3 intrinsic matrix K.
    #[getter]
    fn intrinsic_matrix<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            Ok({
                let i = &self.camera.intrinsics;
                Array2::from_shape_vec(
                    (3, 3),
                    vec![i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0],
                )
                .expect("3x3")
                .into_pyarray(py)
            })
        })
    }

    /// Pose (4x4) of the camera relative to its mount (OpenCV frame);
    /// assignable (a 4x4 or [x, y, z, qw, qx, qy, qz]).
    #[getter(local_pose)]
    fn read_local_pose<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| Ok(matrix(py, &self.camera.pose)))
    }

    #[setter(local_pose)]
    fn assign_local_pose(&mut self, pose: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            self.camera.pose = read_pose(pose, "pose")?;
            Ok(())
        })
    }

    /// World pose (4x4) of the OpenCV camera frame.
    #[getter(world_transform)]
    fn read_world_transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = guard(|| {
            lock(&self.world)?
                .camera_pose(&self.camera)
                .map_err(sim_err)
        })?;
        Ok(matrix(py, &p))
    }

    /// Deprecated: read the `local_pose` property instead.
    fn get_local_pose<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::planning::deprecated(
            py,
            "Camera.get_local_pose() is deprecated: read the property Camera.local_pose",
        )?;
        self.read_local_pose(py)
    }

    /// Deprecated: assign the `local_pose` property instead.
    fn set_local_pose(&mut self, py: Python<'_>, pose: &Bound<'_, PyAny>) -> PyResult<()> {
        crate::planning::deprecated(
            py,
            "Camera.set_local_pose() is deprecated: assign Camera.local_pose",
        )?;
        self.assign_local_pose(pose)
    }

    /// Deprecated: read the `world_transform` property instead.
    fn get_world_transform<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        crate::planning::deprecated(
            py,
            "Camera.get_world_transform() is deprecated: read the property Camera.world_transform",
        )?;
        self.read_world_transform(py)
    }

    /// World pose as Isaac Sim's `Camera.get_world_pose(camera_axes)`:
    /// position (3,) and orientation (w, x, y, z) of the camera frame in
    /// the convention `camera_axes`: "world" (x forward, y left, z up; Isaac
    /// Sim's default), "ros" (OpenCV: x right, y down, z forward) or "usd"
    /// (OpenGL: x right, y up, -z forward).
    #[pyo3(signature = (camera_axes="world"))]
    fn get_world_pose<'py>(&self, py: Python<'py>, camera_axes: &str) -> PyResult<VecPair<'py>> {
        let p = guard(|| {
            lock(&self.world)?
                .camera_pose(&self.camera)
                .map_err(sim_err)
        })?;
        let p = match camera_axes {
            "ros" => p,
            "usd" => ferrobot_camera::opencv_to_opengl(&p),
            "world" => ferrobot_camera::convert_pose(
                &p,
                ferrobot_camera::Convention::OpenCv,
                ferrobot_camera::Convention::Ros,
            ),
            other => {
                return Err(InvalidArgumentError::new_err(format!(
                    "camera_axes: expected 'world', 'ros' or 'usd', got '{other}'"
                )));
            }
        };
        Ok(pose_parts(py, &p))
    }

    /// Renders the scene: a `RenderFrame` with `depth` (H, W) float32
    /// metres along the optical axis (inf: no hit), `segmentation` (H, W)
    /// int32 ids (see `World.segmentation_labels`) and, when `rgb`, `rgb`
    /// (H, W, 3) uint8 (else None).
    #[pyo3(signature = (rgb=true))]
    fn render(&self, py: Python<'_>, rgb: bool) -> PyResult<crate::results::PyRenderFrame> {
        let world = self.world.clone();
        let cam = self.camera.clone();
        let frame = guard(|| {
            py.detach(|| lock_world(&world).render(&cam, rgb))
                .map_err(sim_err)
        })?;
        let (h, w) = (frame.height, frame.width);
        let seg: Vec<i32> = frame.segmentation.iter().map(|&s| s as i32).collect();
        Ok(crate::results::PyRenderFrame {
            depth: Array2::from_shape_vec((h, w), frame.depth)
                .expect("h x w")
                .into_pyarray(py)
                .unbind(),
            segmentation: Array2::from_shape_vec((h, w), seg)
                .expect("h x w")
                .into_pyarray(py)
                .unbind(),
            rgb: frame.rgb.map(|c| {
                Array3::from_shape_vec((h, w, 3), c)
                    .expect("h x w x 3")
                    .into_pyarray(py)
                    .unbind()
            }),
        })
    }

    /// Back-projects a depth image (H, W) to camera-frame points (N, 3),
    /// skipping invalid pixels; returns (points, pixel indices (N,) flat).
    fn depth_to_points<'py>(
        &self,
        py: Python<'py>,
        depth: &Bound<'py, PyAny>,
    ) -> PyResult<PointsAndPixels<'py>> {
        guard(|| depth_to_points_impl(py, depth, &self.camera.intrinsics))
    }
}

fn depth_to_points_impl<'py>(
    py: Python<'py>,
    depth: &Bound<'py, PyAny>,
    intr: &Intrinsics,
) -> PyResult<PointsAndPixels<'py>> {
    // The one back-projection and missing-depth policy (ferrobot-camera):
    // 0 and +inf are missing; NaN, -inf and negative depths raise.
    crate::camera::backproject_flat(py, depth, intr)
}

/// Back-projects a depth image with intrinsics fx, fy, cx, cy.
#[pyfunction]
pub fn depth_to_points<'py>(
    py: Python<'py>,
    depth: &Bound<'py, PyAny>,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
) -> PyResult<PointsAndPixels<'py>> {
    guard(|| {
        let shape: Vec<usize> = depth
            .getattr("shape")
            .and_then(|s| s.extract())
            .map_err(|_| InvalidArgumentError::new_err("depth: expected a 2-D numpy array"))?;
        if shape.len() != 2 {
            return Err(ShapeError::new_err(format!(
                "depth: expected shape (H, W), got {shape:?}"
            )));
        }
        let intr = crate::camera::intrinsics(shape[1], shape[0], fx, fy, cx, cy, 1.0)?;
        depth_to_points_impl(py, depth, &intr)
    })
}

/// The OpenGL/USD camera pose (-z forward, y up) of an OpenCV camera pose.
#[pyfunction]
pub fn opencv_to_opengl<'py>(
    py: Python<'py>,
    pose: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        Ok(matrix(
            py,
            &ferrobot_camera::opencv_to_opengl(&read_pose(pose, "pose")?),
        ))
    })
}

/// The OpenCV camera pose (z forward, y down) of an OpenGL/USD camera pose.
#[pyfunction]
pub fn opengl_to_opencv<'py>(
    py: Python<'py>,
    pose: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        Ok(matrix(
            py,
            &ferrobot_camera::opengl_to_opencv(&read_pose(pose, "pose")?),
        ))
    })
}

/// The OpenCV camera pose at `eye` looking at `target` with `up` up.
#[pyfunction]
#[pyo3(signature = (eye, target, up=None))]
pub fn look_at<'py>(
    py: Python<'py>,
    eye: &Bound<'py, PyAny>,
    target: &Bound<'py, PyAny>,
    up: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    guard(|| {
        let e = vec3_arg(eye, "eye")?;
        let t = vec3_arg(target, "target")?;
        let u = up
            .map(|u| vec3_arg(u, "up"))
            .transpose()?
            .unwrap_or_else(Vector3::z);
        let p = ferrobot_camera::look_at(&e.into(), &t.into(), &u)
            .map_err(crate::camera::camera_err)?;
        Ok(matrix(py, &p))
    })
}

/// Joint-space PID with anti-windup (integral clamp + conditional integration).
#[pyclass(name = "JointPID", module = "ferrobot")]
pub struct PyJointPid {
    inner: JointPid,
}

fn broadcast(obj: &Bound<'_, PyAny>, what: &str, n: usize) -> PyResult<Vec<f64>> {
    if let Ok(v) = obj.extract::<f64>() {
        if v.is_nan() {
            return Err(NonFiniteError::new_err(format!("{what}: NaN")));
        }
        return Ok(vec![v; n]);
    }
    Ok(read_array_with(obj, what, 1, &[Some(n)], Finite::NoNan)?
        .data()
        .to_vec())
}

#[pymethods]
impl PyJointPid {
    /// Gains per joint (arrays of one length; ki, kd and limits may be scalars).
    #[new]
    #[pyo3(signature = (kp, ki, kd, integral_limit=None, output_limit=None))]
    fn new(
        kp: &Bound<'_, PyAny>,
        ki: &Bound<'_, PyAny>,
        kd: &Bound<'_, PyAny>,
        integral_limit: Option<&Bound<'_, PyAny>>,
        output_limit: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            let kp = vec_arg(kp, "kp")?;
            let n = kp.len();
            let ki = broadcast(ki, "ki", n)?;
            let kd = broadcast(kd, "kd", n)?;
            let il = integral_limit
                .map(|v| broadcast(v, "integral_limit", n))
                .transpose()?
                .unwrap_or(vec![f64::INFINITY; n]);
            let ol = output_limit
                .map(|v| broadcast(v, "output_limit", n))
                .transpose()?
                .unwrap_or(vec![f64::INFINITY; n]);
            Ok(Self {
                inner: JointPid::new(kp, ki, kd, il, ol).map_err(sim_err)?,
            })
        })
    }

    /// One update: efforts for q, qd towards target (target_velocity default 0).
    #[pyo3(signature = (q, qd, target, dt, target_velocity=None))]
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        qd: &Bound<'py, PyAny>,
        target: &Bound<'py, PyAny>,
        dt: f64,
        target_velocity: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| {
            let n = self.inner.kp.len();
            let q = read_array(q, "q", 1, &[Some(n)])?.data().to_vec();
            let qd = read_array(qd, "qd", 1, &[Some(n)])?.data().to_vec();
            let t = read_array(target, "target", 1, &[Some(n)])?.data().to_vec();
            let tv = match target_velocity {
                Some(v) => read_array(v, "target_velocity", 1, &[Some(n)])?
                    .data()
                    .to_vec(),
                None => vec![0.0; n],
            };
            Ok(vec1(
                py,
                self.inner.update(&q, &qd, &t, &tv, dt).map_err(sim_err)?,
            ))
        })
    }

    /// The integral state.
    #[getter]
    fn integral<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(vec1(py, self.inner.integral().to_vec())))
    }

    /// Clears the integral.
    fn reset(&mut self) -> PyResult<()> {
        guard(|| {
            self.inner.reset();
            Ok(())
        })
    }
}

/// Cartesian resolved-rate controller (damped Jacobian pseudo-inverse).
#[pyclass(name = "ResolvedRateController", module = "ferrobot", frozen)]
pub struct PyResolvedRate {
    model: Arc<ferrobot_model::RobotModel>,
    inner: ResolvedRate,
}

#[pymethods]
impl PyResolvedRate {
    /// Controls `link` (default: the end effector) with the DOFs
    /// `joint_names` (default: the planning group; `joint_indices` is its
    /// deprecated spelling).
    #[new]
    #[pyo3(signature = (model, link=None, joint_indices=None, linear_gain=5.0, angular_gain=5.0, damping=0.05, max_linear_speed=0.5, max_angular_speed=1.5, *, joint_names=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        model: &PyRobotModel,
        link: Option<&str>,
        joint_indices: Option<Vec<i64>>,
        linear_gain: f64,
        angular_gain: f64,
        damping: f64,
        max_linear_speed: f64,
        max_angular_speed: f64,
        joint_names: Option<Vec<String>>,
    ) -> PyResult<Self> {
        guard(|| {
            let m = model.inner.clone();
            let mut c = ResolvedRate::new(&m);
            if let Some(l) = link {
                c.link = m.link(l).map_err(model_err)?;
            }
            match (joint_indices, joint_names) {
                (Some(_), Some(_)) => {
                    return Err(InvalidArgumentError::new_err(
                        "give joint_names or joint_indices, not both",
                    ));
                }
                (None, Some(names)) => {
                    c.dofs = names
                        .iter()
                        .map(|n| m.dof(n).map_err(model_err))
                        .collect::<PyResult<_>>()?;
                }
                (Some(ix), None) => {
                    crate::planning::deprecated(
                        py,
                        "ResolvedRateController(joint_indices=...) is deprecated: use joint_names=",
                    )?;
                    if let Some(ix) = indices_arg(Some(ix))? {
                        c.dofs = ix;
                    }
                }
                (None, None) => {}
            }
            c.linear_gain = linear_gain;
            c.angular_gain = angular_gain;
            c.damping = damping;
            c.max_linear_speed = max_linear_speed;
            c.max_angular_speed = max_angular_speed;
            c.validate(&m).map_err(sim_err)?;
            Ok(Self { model: m, inner: c })
        })
    }

    /// Joint velocities (num_dof,) moving the link towards `target` (base frame).
    fn compute<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        target: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| {
            let q = read_array(q, "q", 1, &[Some(self.model.num_dof())])?
                .data()
                .to_vec();
            let t = read_pose(target, "target")?;
            Ok(vec1(
                py,
                self.inner.compute(&self.model, &q, &t).map_err(sim_err)?,
            ))
        })
    }
}
