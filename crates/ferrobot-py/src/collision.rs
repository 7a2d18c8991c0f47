//! `ferrobot.CollisionWorld`, `ferrobot.SphereModel` and
//! `ferrobot.CollisionChecker`.

use std::sync::Arc;

use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{
    AllowedCollisions, AnalyzeCollisions, CollisionChecker, CollisionWorld, Mesh, PointCloud,
    RobotCollisionModel, RobotSpheres, Shape,
};
use nalgebra::{Isometry3, Point3, Vector3};
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::arrays::{read_array, read_pose, read_pose_or_identity};
use crate::errors::{InvalidArgumentError, collision_err, guard};
use crate::model::PyRobotModel;

fn positive(what: &str, v: f64) -> PyResult<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(InvalidArgumentError::new_err(format!(
            "{what} must be positive and finite, got {v}"
        )))
    }
}

/// Builds a shape from `(kind, dims...)` as used by `attach`: ("box", [sx, sy, sz]),
/// ("sphere", r), ("cylinder", r, length), ("capsule", r, length).
fn shape_from_tuple(shape: &Bound<'_, PyAny>) -> PyResult<Shape> {
    shape_parts(shape).map_err(|e| {
        if e.is_instance_of::<InvalidArgumentError>(shape.py()) {
            e
        } else {
            InvalidArgumentError::new_err(format!(
                "shape: expected (\"box\", [sx, sy, sz]), (\"sphere\", r), (\"cylinder\", r, length) or (\"capsule\", r, length): {e}"
            ))
        }
    })
}

fn shape_parts(shape: &Bound<'_, PyAny>) -> PyResult<Shape> {
    let kind: String = shape.get_item(0)?.extract()?;
    Ok(match kind.as_str() {
        "box" => {
            let size = read_array(&shape.get_item(1)?, "box size", 1, &[Some(3)])?;
            let s = size.data();
            Shape::cuboid_from_size(Vector3::new(
                positive("box size", s[0])?,
                positive("box size", s[1])?,
                positive("box size", s[2])?,
            ))
        }
        "sphere" => Shape::Sphere {
            radius: positive("sphere radius", shape.get_item(1)?.extract()?)?,
        },
        "cylinder" | "capsule" => {
            let r = positive("radius", shape.get_item(1)?.extract()?)?;
            let l = positive("length", shape.get_item(2)?.extract()?)?;
            if kind == "cylinder" {
                Shape::cylinder_from_length(r, l)
            } else {
                Shape::capsule_from_length(r, l)
            }
        }
        other => {
            return Err(InvalidArgumentError::new_err(format!(
                "unknown shape type '{other}' (known: box, sphere, cylinder, capsule)"
            )));
        }
    })
}

/// Named obstacles: boxes, spheres, cylinders, capsules, meshes and point
/// clouds, each posed in the world (robot base) frame.
#[pyclass(name = "CollisionWorld", module = "ferrobot")]
#[derive(Clone, Default)]
pub struct PyCollisionWorld {
    /// The world.
    pub inner: CollisionWorld,
}

impl PyCollisionWorld {
    fn add(&mut self, name: &str, shape: Shape, pose: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let pose = read_pose_or_identity(pose, "pose")?;
        self.inner
            .add_shape(name, shape, pose)
            .map_err(collision_err)
    }
}

#[pymethods]
impl PyCollisionWorld {
    /// An empty world.
    #[new]
    fn new() -> PyResult<Self> {
        guard(|| Ok(Self::default()))
    }

    /// The obstacles of a simulated `World` at their current poses, in the
    /// frame of `base_pose` (a robot base's pose in the simulation; identity
    /// by default); the ground plane becomes a slab named "ground"; objects
    /// whose name contains one of the `ignore` substrings are left out.
    #[staticmethod]
    #[pyo3(signature = (world, ignore=None, base_pose=None))]
    fn from_sim(
        world: &Bound<'_, PyAny>,
        ignore: Option<&Bound<'_, PyAny>>,
        base_pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            if world.cast::<crate::sim::PyWorld>().is_err() {
                return Err(crate::errors::InvalidArgumentError::new_err(
                    "world: expected a simulated ferrobot.World",
                ));
            }
            let ignore = crate::scene::ignore_list(ignore)?;
            Ok(Self {
                inner: crate::scene::world_from_any(world, ignore, base_pose, &[])?,
            })
        })
    }

    /// Reads a MoveIt planning-scene YAML file (quaternions x, y, z, w in that format).
    #[staticmethod]
    fn from_moveit_scene(path: std::path::PathBuf) -> PyResult<Self> {
        guard(|| {
            Ok(Self {
                inner: CollisionWorld::from_moveit_scene(&path).map_err(collision_err)?,
            })
        })
    }

    /// Adds a box of full edge lengths `size` (3,) at `pose` (4x4 or 7-vector).
    #[pyo3(signature = (name, size, pose=None))]
    fn add_box(
        &mut self,
        name: &str,
        size: &Bound<'_, PyAny>,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let s = read_array(size, "size", 1, &[Some(3)])?;
            let s = s.data();
            self.add(
                name,
                Shape::cuboid_from_size(Vector3::new(s[0], s[1], s[2])),
                pose,
            )
        })
    }

    /// Adds a sphere.
    #[pyo3(signature = (name, radius, pose=None))]
    fn add_sphere(
        &mut self,
        name: &str,
        radius: f64,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.add(name, Shape::Sphere { radius }, pose))
    }

    /// Adds a cylinder along the pose's z axis.
    #[pyo3(signature = (name, radius, length, pose=None))]
    fn add_cylinder(
        &mut self,
        name: &str,
        radius: f64,
        length: f64,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.add(name, Shape::cylinder_from_length(radius, length), pose))
    }

    /// Adds a capsule along the pose's z axis (`length` of the cylindrical part).
    #[pyo3(signature = (name, radius, length, pose=None))]
    fn add_capsule(
        &mut self,
        name: &str,
        radius: f64,
        length: f64,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| self.add(name, Shape::capsule_from_length(radius, length), pose))
    }

    /// Adds a triangle mesh: `vertices` (N, 3) and `faces` (M, 3) vertex indices.
    #[pyo3(signature = (name, vertices, faces, pose=None))]
    fn add_mesh(
        &mut self,
        name: &str,
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let v = read_array(vertices, "vertices", 2, &[Some(3)])?;
            let f = read_array(faces, "faces", 2, &[Some(3)])?;
            let verts: Vec<Point3<f64>> = v
                .data()
                .chunks(3)
                .map(|c| Point3::new(c[0], c[1], c[2]))
                .collect();
            let mut tris = Vec::with_capacity(f.shape[0]);
            for t in f.data().chunks(3) {
                if t.iter()
                    .any(|&i| i < 0.0 || i.fract() != 0.0 || i >= verts.len() as f64)
                {
                    return Err(InvalidArgumentError::new_err(format!(
                        "faces: {t:?} are not vertex indices below {}",
                        verts.len()
                    )));
                }
                tris.push([t[0] as u32, t[1] as u32, t[2] as u32]);
            }
            let mesh = Mesh::new(verts, tris).map_err(|e| collision_err(e.into()))?;
            self.add(name, Shape::Mesh(Arc::new(mesh)), pose)
        })
    }

    /// Adds a point cloud (N, 3) whose points are balls of `radius`.
    #[pyo3(signature = (name, points, radius=0.005, pose=None))]
    fn add_pointcloud(
        &mut self,
        name: &str,
        points: &Bound<'_, PyAny>,
        radius: f64,
        pose: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        guard(|| {
            let p = read_array(points, "points", 2, &[Some(3)])?;
            let pts = p
                .data()
                .chunks(3)
                .map(|c| Point3::new(c[0], c[1], c[2]))
                .collect();
            let cloud = PointCloud::new(pts, radius).map_err(|e| collision_err(e.into()))?;
            self.add(name, Shape::PointCloud(Arc::new(cloud)), pose)
        })
    }

    /// Removes object `name`.
    fn remove(&mut self, name: &str) -> PyResult<()> {
        guard(|| self.inner.remove(name).map(|_| ()).map_err(collision_err))
    }

    /// Moves object `name` to `pose`.
    fn set_pose(&mut self, name: &str, pose: &Bound<'_, PyAny>) -> PyResult<()> {
        guard(|| {
            let pose = read_pose(pose, "pose")?;
            self.inner.set_pose(name, pose).map_err(collision_err)
        })
    }

    /// Pose (4x4) of object `name`.
    fn get_pose<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let obj = self.inner.get(name).map_err(collision_err)?;
            let m = ferrobot_model::pose_to_matrix(&obj.pose);
            Ok(Array2::from_shape_vec((4, 4), m.to_vec())
                .expect("4x4")
                .into_pyarray(py))
        })
    }

    /// Object names in insertion order.
    #[getter]
    fn names(&self) -> PyResult<Vec<String>> {
        guard(|| {
            Ok({
                self.inner
                    .objects()
                    .iter()
                    .map(|o| o.name.clone())
                    .collect()
            })
        })
    }

    /// Shape kinds of object `name` (one per part).
    fn kinds(&self, name: &str) -> PyResult<Vec<String>> {
        guard(|| {
            let obj = self.inner.get(name).map_err(collision_err)?;
            Ok(obj
                .parts
                .iter()
                .map(|(s, _)| s.kind().to_string())
                .collect())
        })
    }

    /// Signed distance (m) from each point (N, 3) to the nearest object (inf if empty).
    fn signed_distance<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| {
            let p = read_array(points, "points", 2, &[Some(3)])?;
            let d: Vec<f64> = p
                .data()
                .chunks(3)
                .map(|c| {
                    self.inner
                        .signed_distance(&Point3::new(c[0], c[1], c[2]))
                        .map_or(f64::INFINITY, |r| r.0)
                })
                .collect();
            Ok(Array1::from_vec(d).into_pyarray(py))
        })
    }

    fn __len__(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.len()))
    }

    fn __contains__(&self, name: &str) -> PyResult<bool> {
        guard(|| Ok(self.inner.contains(name)))
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                format!(
                    "CollisionWorld({} objects: {})",
                    self.inner.len(),
                    self.names()?.join(", ")
                )
            })
        })
    }
}

/// A robot's sphere model: spheres per link in the link frame.
#[pyclass(name = "SphereModel", module = "ferrobot", frozen)]
pub struct PySphereModel {
    /// The model the spheres belong to.
    pub model: Arc<ferrobot_model::RobotModel>,
    /// The spheres.
    pub inner: RobotSpheres,
    /// Per-link reports of the automatic spherizer (empty for loaded models).
    pub report: Vec<(String, usize, f64, f64, f64)>,
}

#[pymethods]
impl PySphereModel {
    /// Spheres made automatically from each link's collision geometry:
    /// every surface point within `tolerance` of a sphere; `total_budget`
    /// caps the count (split among links), `max_per_link` caps each link.
    #[staticmethod]
    #[pyo3(signature = (model, *, tolerance=0.001, total_budget=None, max_per_link=None, seed=0))]
    fn automatic(
        py: Python<'_>,
        model: &PyRobotModel,
        tolerance: f64,
        total_budget: Option<usize>,
        max_per_link: Option<usize>,
        seed: u64,
    ) -> PyResult<Self> {
        guard(|| {
            let opts = SpherizeOptions {
                tolerance,
                total_budget,
                max_per_link,
                seed,
                ..SpherizeOptions::default()
            };
            let m = model.inner.clone();
            let (links, reports) = py
                .detach(|| spherize_robot(&m, &opts))
                .map_err(collision_err)?;
            let inner = RobotSpheres::new(&m, links).map_err(collision_err)?;
            let report = reports
                .into_iter()
                .map(|r| {
                    (
                        r.link,
                        r.spheres,
                        r.coverage,
                        r.mean_protrusion,
                        r.max_protrusion,
                    )
                })
                .collect();
            Ok(Self {
                model: m,
                inner,
                report,
            })
        })
    }

    /// The sphere collision elements of a spherized URDF, mapped onto `model` by link name.
    #[staticmethod]
    fn from_spherized_urdf(model: &PyRobotModel, path: std::path::PathBuf) -> PyResult<Self> {
        guard(|| {
            let inner =
                RobotSpheres::from_spherized_urdf(&model.inner, &path).map_err(collision_err)?;
            Ok(Self {
                model: model.inner.clone(),
                inner,
                report: Vec::new(),
            })
        })
    }

    /// cuRobo's YAML map `{link: [{center: [x, y, z], radius: r}]}` (file), also as written by `save`.
    #[staticmethod]
    fn load(model: &PyRobotModel, path: std::path::PathBuf) -> PyResult<Self> {
        guard(|| {
            let inner = RobotSpheres::load(&model.inner, &path).map_err(collision_err)?;
            Ok(Self {
                model: model.inner.clone(),
                inner,
                report: Vec::new(),
            })
        })
    }

    /// Writes cuRobo's YAML format.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        guard(|| self.inner.save(&self.model, &path).map_err(collision_err))
    }

    /// cuRobo's YAML format as text.
    fn to_yaml(&self) -> PyResult<String> {
        guard(|| Ok(self.inner.to_curobo_yaml(&self.model)))
    }

    /// Total number of spheres.
    #[getter]
    fn count(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.count()))
    }

    /// Spheres of `link` as (N, 4): x, y, z (link frame), radius.
    fn spheres<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let l = self.model.link(link).map_err(crate::errors::model_err)?;
            let s = &self.inner.links[l];
            let flat: Vec<f64> = s
                .iter()
                .flat_map(|s| [s.center.x, s.center.y, s.center.z, s.radius])
                .collect();
            Ok(Array2::from_shape_vec((s.len(), 4), flat)
                .expect("N x 4")
                .into_pyarray(py))
        })
    }

    /// Per-link report of the automatic spherizer: `SphereFit`s with `link`,
    /// `spheres`, `coverage`, `mean_protrusion`, `max_protrusion` (m).
    #[getter]
    fn report(&self) -> Vec<crate::results::PySphereFit> {
        self.report
            .iter()
            .map(|(l, n, c, mean, max)| crate::results::PySphereFit {
                link: l.clone(),
                spheres: *n,
                coverage: *c,
                mean_protrusion: *mean,
                max_protrusion: *max,
            })
            .collect()
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                format!(
                    "SphereModel({} spheres on {})",
                    self.inner.count(),
                    self.model.name()
                )
            })
        })
    }
}

/// Collision queries for a robot in a world.
///
/// Safe to share between threads: queries work on a snapshot (an `Arc`
/// clone) of the checker, and a change (`update_world`, `attach`, ...)
/// edits a copy when a query holds the current one, so a query always sees
/// one consistent world and never fails because another thread changed it.
#[pyclass(name = "CollisionChecker", module = "ferrobot", frozen)]
pub struct PyCollisionChecker {
    inner: std::sync::RwLock<Arc<CollisionChecker>>,
}

impl PyCollisionChecker {
    /// The current checker (a snapshot unaffected by later changes).
    fn snap(&self) -> Arc<CollisionChecker> {
        self.inner
            .read()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone()
    }

    /// Applies `f` to the checker (copy-on-write if a query holds it).
    fn edit<T>(&self, f: impl FnOnce(&mut CollisionChecker) -> PyResult<T>) -> PyResult<T> {
        let mut g = self
            .inner
            .write()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        f(Arc::make_mut(&mut g))
    }

    fn q(&self, q: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
        Ok(
            read_array(q, what, 1, &[Some(self.snap().model().num_dof())])?
                .data()
                .to_vec(),
        )
    }
}

/// The model's automatic allowed-collision matrix for `spheres`
/// ([`ferrobot_collision::acm::automatic_acm`]), cached on the model; the
/// pairs found always in contact are reported once with a warning.
fn automatic_acm_cached(
    py: Python<'_>,
    model: &PyRobotModel,
    spheres: &RobotSpheres,
) -> PyResult<AllowedCollisions> {
    if let Some((_, acm)) = model
        .auto_acm
        .lock()
        .expect("not poisoned")
        .as_ref()
        .filter(|(s, _)| s == spheres)
    {
        return Ok(acm.clone());
    }
    let m = model.inner.clone();
    let sp = spheres.clone();
    let (acm, always) = py
        .detach(|| ferrobot_collision::acm::automatic_acm(&m, &sp))
        .map_err(collision_err)?;
    if !always.is_empty() {
        let reason = |a: usize, b: usize| {
            acm.pairs()
                .find(|&(x, y, _)| (x.min(y), x.max(y)) == (a.min(b), a.max(b)))
                .map_or("", |(_, _, r)| r)
        };
        let names: Vec<String> = always
            .iter()
            .map(|&(a, b)| {
                format!(
                    "{}-{} ({})",
                    m.links()[a].name,
                    m.links()[b].name,
                    reason(a, b)
                )
            })
            .collect();
        let message = format!(
            "robot '{}': {} link pair(s) are in contact by design and no SRDF disables them: \
             in every one of {} sampled configurations (reason '{}': links overlapping by design) \
             or only at an end of the range of the one joint between them (reason '{}': fingers \
             closed on nothing, a linkage on its stop), or at the neutral configuration while no \
             planning-group joint moves them (reason '{}': a hand at rest); their self-collision \
             checks are off (see allowed_collision_pairs): {}",
            m.name(),
            always.len(),
            ferrobot_collision::acm::AUTO_ALWAYS_SAMPLES,
            ferrobot_collision::acm::AUTO_ALWAYS_REASON,
            ferrobot_collision::acm::AUTO_STOP_REASON,
            ferrobot_collision::acm::AUTO_DEFAULT_REASON,
            names.join(", ")
        );
        let category = py.import("builtins")?.getattr("UserWarning")?;
        let message = std::ffi::CString::new(message.replace('\0', " ")).expect("no interior NUL");
        PyErr::warn(py, &category, &message, 1)?;
    }
    *model.auto_acm.lock().expect("not poisoned") = Some((spheres.clone(), acm.clone()));
    Ok(acm)
}

/// A collision checker for `model` in `world` (default: empty) with
/// `spheres` (default: the automatic sphere model), excluded pairs from
/// adjacency, rigid attachment, the SRDF and the pairs found always in
/// contact ([`automatic_acm_cached`]). Checkers and planners made with the
/// automatic spheres share one [`RobotCollisionModel`]. Shared by the
/// checker and the planner bindings.
pub(crate) fn build_checker(
    py: Python<'_>,
    model: &PyRobotModel,
    world: Option<&PyCollisionWorld>,
    spheres: Option<&PySphereModel>,
    margin: f64,
) -> PyResult<CollisionChecker> {
    let m = model.inner.clone();
    let spheres = match spheres {
        Some(s) => {
            let same_links = s.model.links().len() == m.links().len()
                && s.model
                    .links()
                    .iter()
                    .zip(m.links())
                    .all(|(a, b)| a.name == b.name);
            if !Arc::ptr_eq(&s.model, &m) && !same_links {
                return Err(InvalidArgumentError::new_err(format!(
                    "spheres: made for robot '{}', whose links differ from those of '{}'",
                    s.model.name(),
                    m.name()
                )));
            }
            s.inner.clone()
        }
        None => {
            let shared = match model.auto_collision.get() {
                Some(s) => s.clone(),
                None => {
                    let (links, _) = py
                        .detach(|| spherize_robot(&m, &SpherizeOptions::default()))
                        .map_err(collision_err)?;
                    let made = RobotSpheres::new(&m, links).map_err(collision_err)?;
                    let acm = automatic_acm_cached(py, model, &made)?;
                    let shared = Arc::new(
                        RobotCollisionModel::new(m.clone(), made, acm).map_err(collision_err)?,
                    );
                    model.auto_collision.get_or_init(|| shared).clone()
                }
            };
            let w = world.map(|w| w.inner.clone()).unwrap_or_default();
            let mut inner = CollisionChecker::with_model(shared, w);
            inner.set_margin(margin).map_err(collision_err)?;
            return Ok(inner);
        }
    };
    let acm = automatic_acm_cached(py, model, &spheres)?;
    let w = world.map(|w| w.inner.clone()).unwrap_or_default();
    let mut inner = CollisionChecker::new(m, spheres, acm, w).map_err(collision_err)?;
    inner.set_margin(margin).map_err(collision_err)?;
    Ok(inner)
}

#[pymethods]
impl PyCollisionChecker {
    /// A checker for `model` in `world` (default: empty) with `spheres`
    /// (default: the automatic sphere model). Self-collision excludes
    /// adjacent and rigidly attached links and the SRDF's pairs.
    #[new]
    #[pyo3(signature = (model, world=None, spheres=None, *, margin=0.0))]
    fn new(
        py: Python<'_>,
        model: &PyRobotModel,
        world: Option<&PyCollisionWorld>,
        spheres: Option<&PySphereModel>,
        margin: f64,
    ) -> PyResult<Self> {
        guard(|| {
            Ok(Self {
                inner: std::sync::RwLock::new(Arc::new(build_checker(
                    py, model, world, spheres, margin,
                )?)),
            })
        })
    }

    /// Replaces the world (a copy is taken).
    fn update_world(&self, world: &PyCollisionWorld) -> PyResult<()> {
        guard(|| {
            let w = world.inner.clone();
            self.edit(|c| {
                c.set_world(w);
                Ok(())
            })
        })
    }

    /// A copy of the current world.
    #[getter]
    fn world(&self) -> PyResult<PyCollisionWorld> {
        guard(|| {
            Ok({
                PyCollisionWorld {
                    inner: self.snap().world().clone(),
                }
            })
        })
    }

    /// Clearance (m) added to every sphere.
    #[getter]
    fn margin(&self) -> PyResult<f64> {
        guard(|| Ok(self.snap().margin()))
    }

    #[setter]
    fn set_margin(&self, margin: f64) -> PyResult<()> {
        guard(|| self.edit(|c| c.set_margin(margin).map_err(collision_err)))
    }

    /// Whether `q` collides with the world or itself.
    fn in_collision(&self, q: &Bound<'_, PyAny>) -> PyResult<bool> {
        guard(|| {
            let q = self.q(q, "q")?;
            Ok(self.snap().in_collision_unchecked(&q))
        })
    }

    /// Collision flags for (N, num_dof) configurations (SIMD, parallel, GIL released).
    fn in_collision_batch<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        guard(|| {
            let inner = self.snap();
            let arr = read_array(q, "q", 2, &[Some(inner.model().num_dof())])?;
            let mut out = vec![false; arr.shape[0]];
            let data = arr.data();
            py.detach(|| inner.in_collision_batch_into(data, &mut out));
            Ok(Array1::from_vec(out).into_pyarray(py))
        })
    }

    /// Whether the straight joint-space motion q0 -> q1 is free, checked so
    /// that no joint moves more than `resolution` (rad or m) between checks.
    #[pyo3(signature = (q0, q1, resolution=0.005))]
    fn motion_valid(
        &self,
        q0: &Bound<'_, PyAny>,
        q1: &Bound<'_, PyAny>,
        resolution: f64,
    ) -> PyResult<bool> {
        guard(|| {
            let (a, b) = (self.q(q0, "q0")?, self.q(q1, "q1")?);
            self.snap()
                .motion_valid(&a, &b, resolution)
                .map_err(collision_err)
        })
    }

    /// Signed distance to the world and to itself with its gradient: a
    /// `CollisionDistance` with `distance`, `world_distance`,
    /// `self_distance`, `gradient` (num_dof,) and `closest` (robot body,
    /// other) or None.
    fn distance<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<crate::results::PyCollisionDistance> {
        guard(|| {
            let q = self.q(q, "q")?;
            let d = self.snap().distance(&q).map_err(collision_err)?;
            Ok(crate::results::PyCollisionDistance {
                distance: d.distance,
                world_distance: d.world_distance,
                self_distance: d.self_distance,
                gradient: crate::results::arr1(py, d.gradient),
                closest: d.closest,
            })
        })
    }

    /// What collides at `q`: `Contact`s with `body`, `other`,
    /// `self_collision`, `depth` (m), deepest first.
    fn contacts(&self, q: &Bound<'_, PyAny>) -> PyResult<Vec<crate::results::PyContact>> {
        guard(|| {
            let q = self.q(q, "q")?;
            let contacts = self.snap().contacts(&q).map_err(collision_err)?;
            Ok(contacts
                .into_iter()
                .map(|c| crate::results::PyContact {
                    body: c.body,
                    other: c.other,
                    self_collision: c.self_collision,
                    depth: c.depth,
                })
                .collect())
        })
    }

    /// A one-line explanation of the collision at `q`, or "collision-free".
    fn explain(&self, q: &Bound<'_, PyAny>) -> PyResult<String> {
        guard(|| {
            let q = self.q(q, "q")?;
            let contacts = self.snap().contacts(&q).map_err(collision_err)?;
            if contacts.is_empty() {
                return Ok("collision-free".into());
            }
            let parts: Vec<String> = contacts.iter().take(5).map(|c| c.to_string()).collect();
            Ok(parts.join("; "))
        })
    }

    /// Samples configurations and excludes link pairs never or always in
    /// contact (MoveIt setup-assistant style). Returns the counts per
    /// reason, a `SelfCollisionAnalysis`.
    #[pyo3(signature = (samples=10000, seed=0))]
    fn analyze_self_collisions(
        &self,
        py: Python<'_>,
        samples: usize,
        seed: u64,
    ) -> PyResult<crate::results::PySelfCollisionAnalysis> {
        guard(|| {
            let current = self.snap();
            let mut acm = current.allowed_collisions().clone();
            let model = current.model().clone();
            let spheres = current.spheres().clone();
            let report = py
                .detach(|| acm.analyze(&model, &spheres, samples, seed))
                .map_err(collision_err)?;
            self.edit(|c| {
                c.set_allowed_collisions(acm);
                Ok(())
            })?;
            Ok(crate::results::PySelfCollisionAnalysis {
                samples: report.samples,
                never: report.never.len(),
                always: report.always.len(),
                sometimes: report.sometimes.len(),
            })
        })
    }

    /// Excluded self-collision pairs as (link1, link2, reason).
    #[getter]
    fn allowed_collision_pairs(&self) -> PyResult<Vec<(String, String, String)>> {
        guard(|| {
            Ok({
                let c = self.snap();
                let links = c.model().links();
                c.allowed_collisions()
                    .pairs()
                    .map(|(a, b, r)| (links[a].name.clone(), links[b].name.clone(), r.to_string()))
                    .collect()
            })
        })
    }

    /// The excluded pairs as SRDF `disable_collisions` text, to save beside the robot.
    fn allowed_collisions_srdf(&self) -> PyResult<String> {
        guard(|| {
            let c = self.snap();
            Ok(c.allowed_collisions().to_srdf(c.model()))
        })
    }

    /// Attaches a shape ("box", [sx, sy, sz]) / ("sphere", r) / ("cylinder", r, length) /
    /// ("capsule", r, length) to `link` at `pose` (link frame); it may touch `touch_links`.
    #[pyo3(signature = (name, link, shape, pose=None, touch_links=Vec::new()))]
    fn attach(
        &self,
        name: &str,
        link: &str,
        shape: &Bound<'_, PyAny>,
        pose: Option<&Bound<'_, PyAny>>,
        touch_links: Vec<String>,
    ) -> PyResult<()> {
        guard(|| {
            let shape = shape_from_tuple(shape)?;
            let pose = read_pose_or_identity(pose, "pose")?;
            let touch: Vec<&str> = touch_links.iter().map(String::as_str).collect();
            self.edit(|c| {
                c.attach(
                    name,
                    link,
                    pose,
                    vec![(shape, Isometry3::identity())],
                    &touch,
                )
                .map_err(collision_err)
            })
        })
    }

    /// Moves world object `name` onto `link`, keeping its pose relative to the link at `q`.
    #[pyo3(signature = (name, link, q, touch_links=Vec::new()))]
    fn attach_world_object(
        &self,
        name: &str,
        link: &str,
        q: &Bound<'_, PyAny>,
        touch_links: Vec<String>,
    ) -> PyResult<()> {
        guard(|| {
            let q = self.q(q, "q")?;
            let touch: Vec<&str> = touch_links.iter().map(String::as_str).collect();
            self.edit(|c| {
                c.attach_world_object(name, link, &q, &touch)
                    .map_err(collision_err)
            })
        })
    }

    /// Detaches `name`; with `q` it returns to the world at its pose at `q`.
    #[pyo3(signature = (name, q=None))]
    fn detach(&self, name: &str, q: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        guard(|| {
            let q = q.map(|q| self.q(q, "q")).transpose()?;
            self.edit(|c| {
                c.detach(name, q.as_deref())
                    .map(|_| ())
                    .map_err(collision_err)
            })
        })
    }

    /// Names of attached objects.
    #[getter]
    fn attached(&self) -> PyResult<Vec<String>> {
        guard(|| {
            Ok({
                self.snap()
                    .attached()
                    .iter()
                    .map(|a| a.name.clone())
                    .collect()
            })
        })
    }

    /// Number of spheres (robot and attached objects).
    #[getter]
    fn num_spheres(&self) -> PyResult<usize> {
        guard(|| Ok(self.snap().compiled().0.centers.len()))
    }
}
