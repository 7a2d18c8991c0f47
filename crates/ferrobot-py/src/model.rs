//! `ferrobot.RobotModel`: the robot model and its kinematics.

use std::path::PathBuf;
use std::sync::Arc;

use ferrobot_model::{
    Geometry, JointCoupling, LoadOptions, RobotModel, Shape, SrdfSource, pose_to_matrix,
};
use nalgebra::Isometry3;
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::arrays::read_array;
use crate::errors::{guard, model_err};

/// A robot model loaded from URDF (and optionally SRDF): kinematic tree,
/// limits, geometry, planning group, forward kinematics and Jacobians.
#[pyclass(name = "RobotModel", module = "ferrobot", frozen)]
pub struct PyRobotModel {
    /// The shared model (later crates hold it too).
    pub inner: Arc<RobotModel>,
    /// The robot collision model with the automatic sphere model and the
    /// default allowed-collision matrix, made once on first use (checkers
    /// and planners of this model share it, compiled robot included).
    pub auto_collision: std::sync::OnceLock<Arc<ferrobot_collision::RobotCollisionModel>>,
    /// The automatic allowed-collision matrix (adjacent, rigid, SRDF and
    /// always-in-contact pairs) for the sphere model it was made with, made
    /// on first use and reused while checkers use the same spheres.
    pub auto_acm: std::sync::Mutex<
        Option<(
            ferrobot_collision::RobotSpheres,
            ferrobot_collision::AllowedCollisions,
        )>,
    >,
}

fn options(
    srdf: Option<&Bound<'_, PyAny>>,
    package_dirs: Option<Vec<PathBuf>>,
    base_link: Option<String>,
    ee_link: Option<String>,
    group: Option<String>,
    strict: bool,
) -> PyResult<LoadOptions> {
    let srdf = match srdf {
        None => None,
        Some(obj) => {
            let path: PathBuf = obj.extract().map_err(|_| {
                crate::errors::InvalidArgumentError::new_err("srdf: expected a path or SRDF text")
            })?;
            let text = path.to_string_lossy();
            Some(if text.trim_start().starts_with('<') {
                SrdfSource::Text(text.into_owned())
            } else {
                SrdfSource::File(path)
            })
        }
    };
    Ok(LoadOptions {
        srdf,
        package_dirs: package_dirs.unwrap_or_default(),
        base_link,
        ee_link,
        group,
        strict,
    })
}

fn matrix<'py>(py: Python<'py>, pose: &Isometry3<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_vec((4, 4), pose_to_matrix(pose).to_vec())
        .expect("4x4")
        .into_pyarray(py)
}

fn geometry_dicts<'py>(py: Python<'py>, geoms: &[Geometry]) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for g in geoms {
        let d = PyDict::new(py);
        d.set_item("type", g.shape.kind())?;
        d.set_item("name", g.name.clone())?;
        d.set_item("origin", matrix(py, &g.origin))?;
        d.set_item("rgba", g.rgba.map(|c| c.to_vec()))?;
        match &g.shape {
            Shape::Box { half_extents } => {
                d.set_item("size", (half_extents * 2.0).as_slice().to_vec())?
            }
            Shape::Sphere { radius } => d.set_item("radius", radius)?,
            Shape::Cylinder {
                radius,
                half_height,
            }
            | Shape::Capsule {
                radius,
                half_height,
            } => {
                d.set_item("radius", radius)?;
                d.set_item("length", 2.0 * half_height)?;
            }
            Shape::Mesh(m) | Shape::ConvexDecomposition(m) => {
                if let Some(src) = m.source() {
                    d.set_item("filename", &src.filename)?;
                    d.set_item("path", src.path.display().to_string())?;
                }
                d.set_item("scale", m.scale().as_slice().to_vec())?;
                let mesh = m.data();
                let v: Vec<f64> = mesh.vertices.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
                d.set_item(
                    "vertices",
                    Array2::from_shape_vec((mesh.vertices.len(), 3), v)
                        .expect("n x 3")
                        .into_pyarray(py),
                )?;
                let f: Vec<i64> = mesh
                    .triangles
                    .iter()
                    .flat_map(|t| t.map(i64::from))
                    .collect();
                d.set_item(
                    "faces",
                    Array2::from_shape_vec((mesh.triangles.len(), 3), f)
                        .expect("m x 3")
                        .into_pyarray(py),
                )?;
            }
            // A URDF never yields these: the type alone describes them.
            Shape::ConvexHull(_) | Shape::PointCloud(_) => {}
        }
        list.append(d)?;
    }
    Ok(list)
}

impl PyRobotModel {
    fn link_arg(&self, link: Option<&str>) -> PyResult<Option<usize>> {
        link.map(|l| self.inner.link(l).map_err(model_err))
            .transpose()
    }

    fn q_arg(&self, q: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
        Ok(read_array(q, "q", 1, &[Some(self.inner.num_dof())])?
            .data()
            .to_vec())
    }

    /// Wraps a shared model (its automatic sphere model made on first use).
    pub fn from_arc(inner: Arc<RobotModel>) -> Self {
        Self {
            inner,
            auto_collision: std::sync::OnceLock::new(),
            auto_acm: std::sync::Mutex::new(None),
        }
    }

    /// Runs a loader with the GIL released and panics caught.
    fn load(
        py: Python<'_>,
        loader: impl FnOnce(&LoadOptions) -> ferrobot_model::Result<RobotModel> + Send,
        opts: &LoadOptions,
    ) -> PyResult<Self> {
        guard(|| {
            let model = py.detach(|| loader(opts)).map_err(model_err)?;
            let skipped = model.srdf_warnings();
            if !skipped.is_empty() {
                let category = py.import("ferrobot.errors")?.getattr("SrdfWarning")?;
                let message = format!(
                    "the SRDF has {} entr{} naming what the URDF lacks or missing a required attribute, skipped as MoveIt's srdfdom does (strict=True raises instead; RobotModel.srdf_warnings lists them):\n{}",
                    skipped.len(),
                    if skipped.len() == 1 { "y" } else { "ies" },
                    skipped.join("\n")
                );
                let message =
                    std::ffi::CString::new(message.replace('\0', " ")).expect("no interior NUL");
                PyErr::warn(py, &category, &message, 1)?;
            }
            Ok(Self {
                inner: Arc::new(model),
                auto_collision: std::sync::OnceLock::new(),
                auto_acm: std::sync::Mutex::new(None),
            })
        })
    }

    fn vec1<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
        Array1::from_vec(v).into_pyarray(py)
    }
}

/// A mimic joint: (name, (driver, multiplier, offset)).
type MimicEntry = (String, (String, f64, f64));

#[pymethods]
impl PyRobotModel {
    /// Loads a URDF file. See the class documentation for the options.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (path, *, srdf=None, package_dirs=None, base_link=None, ee_link=None, group=None, strict=false))]
    fn from_urdf(
        py: Python<'_>,
        path: PathBuf,
        srdf: Option<&Bound<'_, PyAny>>,
        package_dirs: Option<Vec<PathBuf>>,
        base_link: Option<String>,
        ee_link: Option<String>,
        group: Option<String>,
        strict: bool,
    ) -> PyResult<Self> {
        guard(|| {
            let opts = options(srdf, package_dirs, base_link, ee_link, group, strict)?;
            Self::load(py, |o| RobotModel::from_urdf_file(&path, o), &opts)
        })
    }

    /// Loads URDF text; relative and package:// meshes resolve against
    /// `package_dirs`, then ROS_PACKAGE_PATH, then the working directory.
    #[staticmethod]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (text, *, srdf=None, package_dirs=None, base_link=None, ee_link=None, group=None, strict=false))]
    fn from_urdf_string(
        py: Python<'_>,
        text: String,
        srdf: Option<&Bound<'_, PyAny>>,
        package_dirs: Option<Vec<PathBuf>>,
        base_link: Option<String>,
        ee_link: Option<String>,
        group: Option<String>,
        strict: bool,
    ) -> PyResult<Self> {
        guard(|| {
            let opts = options(srdf, package_dirs, base_link, ee_link, group, strict)?;
            Self::load(py, |o| RobotModel::from_urdf_str(&text, o), &opts)
        })
    }

    /// Reads a UsdPhysics articulation from a USD file (through PyPI
    /// `usd-core`, `ferrobot.usd.read_usd`): joints, limits, drives' force
    /// limits, mimic couplings, geometry, masses and inertias.
    #[staticmethod]
    #[pyo3(signature = (path, *, root=None, srdf=None, base_link=None, ee_link=None, group=None))]
    fn from_usd<'py>(
        py: Python<'py>,
        path: PathBuf,
        root: Option<String>,
        srdf: Option<&Bound<'py, PyAny>>,
        base_link: Option<String>,
        ee_link: Option<String>,
        group: Option<String>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let kw = PyDict::new(py);
        kw.set_item("root", root)?;
        kw.set_item("srdf", srdf)?;
        kw.set_item("base_link", base_link)?;
        kw.set_item("ee_link", ee_link)?;
        kw.set_item("group", group)?;
        py.import("ferrobot.usd")?
            .getattr("read_usd")?
            .call((path,), Some(&kw))?
            .getattr("model")
    }

    /// Writes the model as a UsdPhysics articulation (`ferrobot.usd.write_usd`,
    /// needs `usd-core`); returns the path.
    fn to_usd<'py>(slf: &Bound<'py, Self>, path: PathBuf) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("ferrobot.usd")?
            .getattr("write_usd")?
            .call1((slf, path))
    }

    /// What a lenient load skipped from the SRDF (entries naming links or
    /// joints the URDF lacks, elements missing a required attribute), one
    /// message per entry with file and line; empty after `strict=True`.
    #[getter]
    fn srdf_warnings(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.inner.srdf_warnings().to_vec()))
    }

    /// The robot's name.
    #[getter]
    fn name(&self) -> PyResult<String> {
        guard(|| Ok(self.inner.name().to_string()))
    }

    /// Names of the independent joints, in DOF-vector order (the URDF tree,
    /// depth first; mimic and fixed joints excluded).
    #[getter]
    fn dof_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.inner.dof_names().to_vec()))
    }

    /// Number of independent joints.
    #[getter]
    fn num_dof(&self) -> PyResult<usize> {
        guard(|| Ok(self.inner.num_dof()))
    }

    /// All link names, depth first from the root.
    #[getter]
    fn link_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.inner.links().iter().map(|l| l.name.clone()).collect()))
    }

    /// All joint names (fixed and mimic included); joint k is the parent
    /// joint of link k + 1.
    #[getter]
    fn joint_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.inner.joints().iter().map(|j| j.name.clone()).collect()))
    }

    /// Lower position limits per DOF (-inf for continuous joints).
    #[getter]
    fn lower_limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(Self::vec1(py, self.inner.lower_limits())))
    }

    /// Upper position limits per DOF (+inf for continuous joints).
    #[getter]
    fn upper_limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(Self::vec1(py, self.inner.upper_limits())))
    }

    /// Velocity limits per DOF (inf where the URDF states none).
    #[getter]
    fn velocity_limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(Self::vec1(py, self.inner.velocity_limits())))
    }

    /// Effort limits per DOF (inf where the URDF states none).
    #[getter]
    fn effort_limits<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(Self::vec1(py, self.inner.effort_limits())))
    }

    /// The link all poses are expressed in.
    #[getter]
    fn base_link(&self) -> PyResult<String> {
        guard(|| Ok(self.inner.links()[self.inner.base_link()].name.clone()))
    }

    /// The default link of `fk`, `fk_batch` and `jacobian`.
    #[getter]
    fn ee_link(&self) -> PyResult<String> {
        guard(|| Ok(self.inner.links()[self.inner.ee_link()].name.clone()))
    }

    /// The SRDF group planned for, or None (joints from base to ee).
    #[getter]
    fn group_name(&self) -> PyResult<Option<String>> {
        guard(|| Ok(self.inner.group_name().map(str::to_string)))
    }

    /// DOF indices of the planning group.
    #[getter]
    fn group_dof_indices(&self) -> PyResult<Vec<usize>> {
        guard(|| Ok(self.inner.group_dofs().to_vec()))
    }

    /// DOF names of the planning group.
    #[getter]
    fn group_dof_names(&self) -> PyResult<Vec<String>> {
        guard(|| {
            Ok({
                self.inner
                    .group_dofs()
                    .iter()
                    .map(|&d| self.inner.dof_names()[d].clone())
                    .collect()
            })
        })
    }

    /// Mimic joints: name -> (driving DOF name, multiplier, offset).
    #[getter]
    fn mimic_joints(&self) -> PyResult<Vec<MimicEntry>> {
        guard(|| {
            Ok({
                self.inner
                    .joints()
                    .iter()
                    .filter_map(|j| match j.coupling {
                        JointCoupling::Mimic {
                            dof,
                            multiplier,
                            offset,
                        } => Some((
                            j.name.clone(),
                            (self.inner.dof_names()[dof].clone(), multiplier, offset),
                        )),
                        _ => None,
                    })
                    .collect()
            })
        })
    }

    /// SRDF group names.
    #[getter]
    fn group_names(&self) -> PyResult<Vec<String>> {
        guard(|| Ok(self.inner.group_names()))
    }

    /// SRDF named states as (group, name) pairs.
    #[getter]
    fn named_states(&self) -> PyResult<Vec<(String, String)>> {
        guard(|| {
            Ok({
                self.inner
                    .srdf()
                    .map(|s| {
                        s.group_states
                            .iter()
                            .map(|g| (g.group.clone(), g.name.clone()))
                            .collect()
                    })
                    .unwrap_or_default()
            })
        })
    }

    /// SRDF `disable_collisions` pairs as (link1, link2, reason).
    #[getter]
    fn disabled_collision_pairs(&self) -> PyResult<Vec<(String, String, String)>> {
        guard(|| {
            Ok({
                let links = self.inner.links();
                self.inner
                    .disabled_collision_pairs()
                    .into_iter()
                    .map(|(a, b, r)| (links[a].name.clone(), links[b].name.clone(), r))
                    .collect()
            })
        })
    }

    /// Joint names of an SRDF group (all kinds), in model order.
    fn group_joint_names(&self, group: &str) -> PyResult<Vec<String>> {
        guard(|| {
            let joints = self.inner.group_joints(group).map_err(model_err)?;
            Ok(joints
                .into_iter()
                .map(|j| self.inner.joints()[j].name.clone())
                .collect())
        })
    }

    /// The DOF vector of SRDF named state `name` (others at neutral).
    #[pyo3(signature = (name, group=None))]
    fn named_state<'py>(
        &self,
        py: Python<'py>,
        name: &str,
        group: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| {
            let q = self.inner.named_state(name, group).map_err(model_err)?;
            Ok(Self::vec1(py, q))
        })
    }

    /// 0 for every DOF, or the nearest limit where 0 is outside the limits.
    fn neutral_configuration<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        guard(|| Ok(Self::vec1(py, self.inner.neutral_configuration())))
    }

    /// A joint's description, a `JointInfo`: type, parent and child links,
    /// origin (4x4), axis, limits, mimic and dynamics.
    fn joint_info(&self, py: Python<'_>, name: &str) -> PyResult<crate::results::PyJointInfo> {
        guard(|| {
            let j = &self.inner.joints()[self.inner.joint(name).map_err(model_err)?];
            let links = self.inner.links();
            Ok(crate::results::PyJointInfo {
                name: j.name.clone(),
                r#type: j.kind.as_str().to_string(),
                parent: links[j.parent].name.clone(),
                child: links[j.child].name.clone(),
                origin: matrix(py, &j.origin).unbind(),
                axis: crate::results::arr1(py, j.axis.as_slice().to_vec()),
                lower: j.limits.lower,
                upper: j.limits.upper,
                velocity: j.limits.velocity,
                effort: j.limits.effort,
                damping: j.damping,
                friction: j.friction,
                mimic: j
                    .mimic
                    .as_ref()
                    .map(|m| (m.joint.clone(), m.multiplier, m.offset)),
            })
        })
    }

    /// Collision geometry of `link`: a list of dicts with `type` (box,
    /// sphere, cylinder, capsule, mesh), `origin` (4x4 in the link frame) and
    /// the shape's parameters (`size`; `radius`, `length`; `path`, `scale`,
    /// `vertices`, `faces` for meshes).
    fn collision_geometry<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyList>> {
        guard(|| {
            let l = self.inner.link(link).map_err(model_err)?;
            geometry_dicts(py, &self.inner.links()[l].collisions)
        })
    }

    /// Visual geometry of `link`, as `collision_geometry`, plus `rgba`.
    fn visual_geometry<'py>(&self, py: Python<'py>, link: &str) -> PyResult<Bound<'py, PyList>> {
        guard(|| {
            let l = self.inner.link(link).map_err(model_err)?;
            geometry_dicts(py, &self.inner.links()[l].visuals)
        })
    }

    /// Mass, centre-of-mass origin (4x4) and inertia (3x3) of `link`, an
    /// `Inertial` (the URDF `<inertial>`).
    fn inertial(&self, py: Python<'_>, link: &str) -> PyResult<crate::results::PyInertial> {
        guard(|| {
            let l = self.inner.link(link).map_err(model_err)?;
            let i = &self.inner.links()[l].inertial;
            let flat: Vec<f64> = i.inertia.iter().flatten().copied().collect();
            Ok(crate::results::PyInertial {
                mass: i.mass,
                origin: matrix(py, &i.origin).unbind(),
                inertia: crate::results::arr2(py, 3, 3, flat),
            })
        })
    }

    /// Pose (4x4) of `link` (default: the end effector) in the base frame
    /// for DOF vector `q` (shape (num_dof,), dof_names order).
    #[pyo3(signature = (q, link=None))]
    fn fk<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let link = self.link_arg(link)?;
            let q = self.q_arg(q)?;
            let pose = self.inner.fk(&q, link).map_err(model_err)?;
            Ok(matrix(py, &pose))
        })
    }

    /// Poses of every link, shape (num_links, 4, 4), in `link_names` order.
    fn fk_all<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        guard(|| {
            let q = self.q_arg(q)?;
            let poses = self.inner.fk_all(&q).map_err(model_err)?;
            let flat: Vec<f64> = poses.iter().flat_map(pose_to_matrix).collect();
            Ok(Array3::from_shape_vec((poses.len(), 4, 4), flat)
                .expect("L x 4 x 4")
                .into_pyarray(py))
        })
    }

    /// Poses of `link` for a batch `Q` of shape (N, num_dof), as (N, 7)
    /// `[x, y, z, qw, qx, qy, qz]` with qw >= 0. Parallel; releases the GIL.
    #[pyo3(signature = (q, link=None))]
    fn fk_batch<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let link = self.link_arg(link)?;
            let arr = read_array(q, "q", 2, &[Some(self.inner.num_dof())])?;
            let n = arr.shape[0];
            let model = &self.inner;
            let data = arr.data();
            let mut out = vec![0.0; n * 7];
            py.detach(|| model.fk_batch_into(data, link, &mut out));
            Ok(Array2::from_shape_vec((n, 7), out)
                .expect("N x 7")
                .into_pyarray(py))
        })
    }

    /// Geometric Jacobian, shape (6, num_dof): rows are the linear velocity
    /// of the origin of `link` (default: the end effector), then the angular
    /// velocity, both in the base frame.
    #[pyo3(signature = (q, link=None))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
        link: Option<&str>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        guard(|| {
            let link = self.link_arg(link)?;
            let q = self.q_arg(q)?;
            let j = self.inner.jacobian(&q, link).map_err(model_err)?;
            Ok(Array2::from_shape_vec((6, self.inner.num_dof()), j)
                .expect("6 x dof")
                .into_pyarray(py))
        })
    }

    fn __repr__(&self) -> PyResult<String> {
        guard(|| {
            Ok({
                format!(
                    "RobotModel(name='{}', num_dof={}, base_link='{}', ee_link='{}')",
                    self.inner.name(),
                    self.inner.num_dof(),
                    self.base_link()?,
                    self.ee_link()?
                )
            })
        })
    }
}
