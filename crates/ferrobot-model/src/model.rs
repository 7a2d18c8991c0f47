//! The robot model: links, joints, DOF order, base and end-effector links,
//! the planning group and the SRDF, built from URDF (and SRDF) text.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use nalgebra::Isometry3;

use crate::chain::KinematicChain;
use crate::error::{ModelError, Result, SourceLocation};
use crate::geometry::Inertial;
use crate::joint::{Joint, JointCoupling};
use crate::link::Link;
use crate::srdf::Srdf;
use crate::urdf::{ParsedUrdf, parse_urdf};

/// Where an SRDF comes from.
#[derive(Debug, Clone)]
pub enum SrdfSource {
    /// A file.
    File(PathBuf),
    /// SRDF text.
    Text(String),
}

/// Options for loading a model.
#[derive(Debug, Clone, Default)]
pub struct LoadOptions {
    /// SRDF with groups, named states and disabled collision pairs.
    pub srdf: Option<SrdfSource>,
    /// Extra roots searched first for `package://` and relative mesh paths.
    pub package_dirs: Vec<PathBuf>,
    /// The link poses are expressed in (default: the root link). It must be
    /// fixed to the root (no movable joint between them).
    pub base_link: Option<String>,
    /// The end-effector link (default: a group chain's tip, an SRDF end
    /// effector's parent link, or the end of the longest unbranched chain).
    pub ee_link: Option<String>,
    /// An SRDF group to plan for (default: the joints from base to ee).
    pub group: Option<String>,
    /// SRDF strictness. `false` (the default, as MoveIt's srdfdom): SRDF
    /// entries that cannot be read or that name links or joints the URDF
    /// lacks are skipped and listed in [`RobotModel::srdf_warnings`].
    /// `true`: the first such entry is an error.
    pub strict: bool,
}

/// A robot: kinematic tree, limits, geometry and semantics.
///
/// Conventions: links are stored in depth-first order from the root (the
/// root first, siblings in URDF order); `joints[k - 1]` is the parent joint
/// of `links[k]`. The DOF vector holds the independent movable joints (mimic
/// joints excluded) in that same depth-first order. Poses are expressed in
/// the base link's frame.
#[derive(Debug, Clone)]
pub struct RobotModel {
    pub(crate) name: String,
    pub(crate) source: String,
    pub(crate) links: Vec<Link>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) dof_joints: Vec<usize>,
    pub(crate) dof_names: Vec<String>,
    pub(crate) link_index: HashMap<String, usize>,
    pub(crate) joint_index: HashMap<String, usize>,
    pub(crate) base: usize,
    pub(crate) ee: usize,
    /// Pose of the root in the base frame (constant: the base is fixed to the root).
    pub(crate) root_in_base: Isometry3<f64>,
    /// Compiled chain of each link, made on first use: compiling all of
    /// them at load took memory quadratic in the depth of the tree (a
    /// 10,000-joint chain needed gigabytes).
    pub(crate) chains: Vec<std::sync::OnceLock<KinematicChain>>,
    pub(crate) group_name: Option<String>,
    pub(crate) group_dofs: Vec<usize>,
    pub(crate) srdf: Option<Srdf>,
}

impl RobotModel {
    /// Loads a URDF file; meshes resolve relative to its folder.
    pub fn from_urdf_file(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| {
            ModelError::urdf(
                SourceLocation::new(path.display().to_string(), None),
                format!("cannot read the URDF file: {e}"),
            )
        })?;
        let dir = path.parent().map(|d| {
            if d.as_os_str().is_empty() {
                Path::new(".")
            } else {
                d
            }
        });
        let dir = dir.map(|d| std::fs::canonicalize(d).unwrap_or_else(|_| d.to_path_buf()));
        let parsed = parse_urdf(
            &text,
            &path.display().to_string(),
            dir.as_deref(),
            &options.package_dirs,
        )?;
        Self::assemble(parsed, options)
    }

    /// Loads URDF text; meshes resolve against `package_dirs`, then
    /// `ROS_PACKAGE_PATH`, then the working directory.
    pub fn from_urdf_str(text: &str, options: &LoadOptions) -> Result<Self> {
        let parsed = parse_urdf(text, "<string>", None, &options.package_dirs)?;
        Self::assemble(parsed, options)
    }

    fn assemble(parsed: ParsedUrdf, options: &LoadOptions) -> Result<Self> {
        let ParsedUrdf {
            name,
            links,
            mut joints,
            source,
            joint_lines,
        } = parsed;
        let link_index: HashMap<String, usize> = links
            .iter()
            .enumerate()
            .map(|(i, l)| (l.name.clone(), i))
            .collect();
        let joint_index: HashMap<String, usize> = joints
            .iter()
            .enumerate()
            .map(|(i, j)| (j.name.clone(), i))
            .collect();
        let joint_loc =
            |name: &str| SourceLocation::new(source.clone(), joint_lines.get(name).copied());

        // Independent DOFs: movable joints that mimic nothing.
        let mut dof_joints = Vec::new();
        for (j, joint) in joints.iter_mut().enumerate() {
            if joint.kind.is_movable() && joint.mimic.is_none() {
                joint.coupling = JointCoupling::Dof(dof_joints.len());
                dof_joints.push(j);
            }
        }
        // Mimic joints: follow the chain of mimics to an independent DOF.
        for j in 0..joints.len() {
            if !joints[j].kind.is_movable() || joints[j].mimic.is_none() {
                continue;
            }
            let (mut gain, mut offset, mut current) = (1.0, 0.0, j);
            let mut steps = 0;
            let coupling = loop {
                let Some(m) = joints[current].mimic.clone() else {
                    let JointCoupling::Dof(dof) = joints[current].coupling else {
                        unreachable!("a movable joint without mimic has a DOF")
                    };
                    break JointCoupling::Mimic {
                        dof,
                        multiplier: gain,
                        offset,
                    };
                };
                let target = *joint_index.get(&m.joint).ok_or_else(|| {
                    ModelError::urdf(
                        joint_loc(&joints[j].name),
                        format!(
                            "joint '{}' mimics joint '{}', which is not defined",
                            joints[current].name, m.joint
                        ),
                    )
                })?;
                if !joints[target].kind.is_movable() {
                    return Err(ModelError::urdf(
                        joint_loc(&joints[j].name),
                        format!(
                            "joint '{}' mimics joint '{}', which is fixed",
                            joints[current].name, m.joint
                        ),
                    ));
                }
                if !(m.multiplier.is_finite() && m.offset.is_finite()) {
                    return Err(ModelError::urdf(
                        joint_loc(&joints[j].name),
                        format!(
                            "joint '{}': mimic multiplier and offset must be finite",
                            joints[current].name
                        ),
                    ));
                }
                offset += gain * m.offset;
                gain *= m.multiplier;
                current = target;
                steps += 1;
                if steps > joints.len() {
                    return Err(ModelError::urdf(
                        joint_loc(&joints[j].name),
                        format!(
                            "joint '{}' is part of a loop of mimic joints",
                            joints[j].name
                        ),
                    ));
                }
            };
            joints[j].coupling = coupling;
        }
        let dof_names = dof_joints.iter().map(|&j| joints[j].name.clone()).collect();

        let srdf = match &options.srdf {
            None => None,
            Some(SrdfSource::Text(text)) => {
                Some(Srdf::parse_with(text, "<srdf string>", options.strict)?)
            }
            Some(SrdfSource::File(path)) => {
                let text = std::fs::read_to_string(path).map_err(|e| {
                    ModelError::srdf(
                        SourceLocation::new(path.display().to_string(), None),
                        format!("cannot read the SRDF file: {e}"),
                    )
                })?;
                Some(Srdf::parse_with(
                    &text,
                    &path.display().to_string(),
                    options.strict,
                )?)
            }
        };

        let mut model = RobotModel {
            name,
            source,
            links,
            joints,
            dof_joints,
            dof_names,
            link_index,
            joint_index,
            base: 0,
            ee: 0,
            root_in_base: Isometry3::identity(),
            chains: Vec::new(),
            group_name: None,
            group_dofs: Vec::new(),
            srdf: None,
        };
        let mut srdf = srdf;
        if let Some(srdf) = &mut srdf {
            model.resolve_srdf(srdf, options.strict)?;
        }
        model.srdf = srdf;

        // Base link: fixed to the root.
        if let Some(base) = &options.base_link {
            let b = model.link(base)?;
            if let Some(j) = model
                .path_to(b)
                .into_iter()
                .find(|&j| model.joints[j].kind.is_movable())
            {
                return Err(ModelError::InvalidArgument(format!(
                    "base_link '{base}' is moved by joint '{}'; choose a link fixed to the root '{}'",
                    model.joints[j].name, model.links[0].name
                )));
            }
            model.base = b;
        }
        let base_pose = model
            .path_to(model.base)
            .iter()
            .fold(Isometry3::identity(), |acc, &j| {
                acc * model.joints[j].origin
            });
        model.root_in_base = base_pose.inverse();
        model.chains = (0..model.links.len())
            .map(|_| std::sync::OnceLock::new())
            .collect();

        model.group_name = options.group.clone();
        model.ee = match &options.ee_link {
            Some(ee) => model.link(ee)?,
            None => model.default_ee(options.group.as_deref())?,
        };
        model.group_dofs = match &options.group {
            Some(g) => model.group_dof_indices(g)?,
            None => model.dofs_between(model.base, model.ee),
        };
        Ok(model)
    }

    /// Joint indices from the root to `link`, root side first.
    pub fn path_to(&self, link: usize) -> Vec<usize> {
        let mut path = Vec::new();
        let mut l = link;
        while let Some(j) = self.links[l].parent_joint {
            path.push(j);
            l = self.joints[j].parent;
        }
        path.reverse();
        path
    }

    /// The independent DOFs moving `tip` relative to `base`, in DOF order.
    pub fn dofs_between(&self, base: usize, tip: usize) -> Vec<usize> {
        let to_base = self.path_to(base);
        let mut dofs: Vec<usize> = self
            .path_to(tip)
            .into_iter()
            .filter(|j| !to_base.contains(j))
            .filter_map(|j| self.joints[j].coupling.driver().map(|(d, _)| d))
            .collect();
        dofs.sort_unstable();
        dofs.dedup();
        dofs
    }

    fn default_ee(&self, group: Option<&str>) -> Result<usize> {
        if let (Some(g), Some(srdf)) = (group, &self.srdf) {
            let grp = srdf.group(g).ok_or_else(|| {
                ModelError::unknown("group", g, srdf.groups.iter().map(|g| g.name.as_str()))
            })?;
            if let [(_, tip)] = grp.chains.as_slice() {
                return self.link(tip);
            }
            if let Some(ee) = srdf
                .end_effectors
                .iter()
                .find(|e| e.parent_group.as_deref() == Some(g))
            {
                return self.link(&ee.parent_link);
            }
        }
        // The end of the longest unbranched chain below the base: descend
        // while one child subtree is strictly deepest; stop where several
        // tie (e.g. a hand whose fingers branch off).
        let mut depth = vec![0usize; self.links.len()];
        for l in (0..self.links.len()).rev() {
            depth[l] = self.links[l]
                .child_joints
                .iter()
                .map(|&j| depth[self.joints[j].child] + 1)
                .max()
                .unwrap_or(0);
        }
        let descend = |from: usize| -> (usize, Vec<usize>) {
            let mut l = from;
            loop {
                let kids: Vec<usize> = self.links[l]
                    .child_joints
                    .iter()
                    .map(|&j| self.joints[j].child)
                    .collect();
                let Some(best) = kids.iter().map(|&c| depth[c]).max() else {
                    return (l, Vec::new());
                };
                let deepest: Vec<usize> = kids.into_iter().filter(|&c| depth[c] == best).collect();
                if deepest.len() != 1 {
                    return (l, deepest);
                }
                l = deepest[0];
            }
        };
        let (l, tied) = descend(self.base);
        // A branch point before any movable joint (two arms on a torso):
        // the base-to-ee group would be empty. Name the choices instead.
        // Whether the subtree hanging from each link (its parent joint
        // included) has a movable joint.
        let mut moves = vec![false; self.links.len()];
        for k in (0..self.links.len()).rev() {
            let own = self.links[k]
                .parent_joint
                .is_some_and(|j| self.joints[j].kind.is_movable());
            moves[k] = own
                || self.links[k]
                    .child_joints
                    .iter()
                    .any(|&j| moves[self.joints[j].child]);
        }
        let moving = |c: usize| moves[c];
        if self.dofs_between(self.base, l).is_empty()
            && tied.iter().filter(|&&c| moving(c)).count() >= 2
        {
            let tips: Vec<&str> = tied
                .iter()
                .filter(|&&c| moving(c))
                .map(|&c| self.links[descend(c).0].name.as_str())
                .collect();
            let groups: Vec<&str> = self
                .srdf
                .iter()
                .flat_map(|s| s.groups.iter().map(|g| g.name.as_str()))
                .collect();
            let groups = if groups.is_empty() {
                "none".to_string()
            } else {
                groups.join(", ")
            };
            return Err(ModelError::InvalidArgument(format!(
                "robot '{}' branches at link '{}' into {} chains of equal length before any movable joint, \
                 so there is no single default arm: choose group= (SRDF groups: {groups}) or ee_link= \
                 (ends of the branches: {})",
                self.name,
                self.links[l].name,
                tips.len(),
                tips.join(", ")
            )));
        }
        Ok(l)
    }

    /// Index of the link named `name`.
    pub fn link(&self, name: &str) -> Result<usize> {
        self.link_index.get(name).copied().ok_or_else(|| {
            ModelError::unknown("link", name, self.links.iter().map(|l| l.name.as_str()))
        })
    }

    /// Index of the joint named `name`.
    pub fn joint(&self, name: &str) -> Result<usize> {
        self.joint_index.get(name).copied().ok_or_else(|| {
            ModelError::unknown("joint", name, self.joints.iter().map(|j| j.name.as_str()))
        })
    }

    /// DOF index of the independent joint named `name`.
    pub fn dof(&self, name: &str) -> Result<usize> {
        self.dof_names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| {
                ModelError::unknown("DOF joint", name, self.dof_names.iter().map(String::as_str))
            })
    }

    /// Where the columns of a joint vector named `names` (a trajectory in
    /// another tool's joint order) go: (column, DOF index) pairs for the
    /// independent joints. Mimic joints are skipped (their drivers move
    /// them); any other name is an `UnknownName` error.
    pub fn dof_columns(&self, names: &[String]) -> Result<Vec<(usize, usize)>> {
        let mut out = Vec::with_capacity(names.len());
        for (c, name) in names.iter().enumerate() {
            match self.dof(name) {
                Ok(d) => out.push((c, d)),
                Err(e) => {
                    let mimic = self
                        .joint(name)
                        .is_ok_and(|j| self.joints[j].mimic.is_some());
                    if !mimic {
                        return Err(e);
                    }
                }
            }
        }
        Ok(out)
    }

    /// The robot's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Where the URDF came from.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Links in depth-first order.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// Joints; `joints()[k - 1]` is the parent joint of `links()[k]`.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Names of the independent DOFs, in DOF-vector order.
    pub fn dof_names(&self) -> &[String] {
        &self.dof_names
    }

    /// Number of independent DOFs.
    pub fn num_dof(&self) -> usize {
        self.dof_joints.len()
    }

    /// The joint behind each DOF.
    pub fn dof_joints(&self) -> &[usize] {
        &self.dof_joints
    }

    /// Limits of each DOF's joint, mapped by `f`.
    fn dof_limit(&self, f: impl Fn(&crate::joint::JointLimits) -> f64) -> Vec<f64> {
        self.dof_joints
            .iter()
            .map(|&j| f(&self.joints[j].limits))
            .collect()
    }

    /// Lower position limits per DOF (-inf for continuous joints).
    pub fn lower_limits(&self) -> Vec<f64> {
        self.dof_limit(|l| l.lower)
    }

    /// Upper position limits per DOF (+inf for continuous joints).
    pub fn upper_limits(&self) -> Vec<f64> {
        self.dof_limit(|l| l.upper)
    }

    /// Velocity limits per DOF (inf where the URDF gives none).
    pub fn velocity_limits(&self) -> Vec<f64> {
        self.dof_limit(|l| l.velocity)
    }

    /// Effort limits per DOF (inf where the URDF gives none).
    pub fn effort_limits(&self) -> Vec<f64> {
        self.dof_limit(|l| l.effort)
    }

    /// Index of the base link.
    pub fn base_link(&self) -> usize {
        self.base
    }

    /// Index of the end-effector link.
    pub fn ee_link(&self) -> usize {
        self.ee
    }

    /// The named SRDF group planned for, if one was chosen.
    pub fn group_name(&self) -> Option<&str> {
        self.group_name.as_deref()
    }

    /// DOF indices of the planning group, in DOF order.
    pub fn group_dofs(&self) -> &[usize] {
        &self.group_dofs
    }

    /// What a lenient load skipped from the SRDF (see
    /// [`LoadOptions::strict`]), one message per entry naming file, line
    /// and the missing name; empty without an SRDF or after a strict load.
    pub fn srdf_warnings(&self) -> &[String] {
        self.srdf.as_ref().map_or(&[], |s| s.skipped.as_slice())
    }

    /// The SRDF, if one was loaded.
    pub fn srdf(&self) -> Option<&Srdf> {
        self.srdf.as_ref()
    }

    /// The compiled chain of link `link`.
    pub fn chain(&self, link: usize) -> &KinematicChain {
        self.chains[link].get_or_init(|| {
            KinematicChain::compile(&self.joints, &self.path_to(link), self.root_in_base)
        })
    }

    /// The neutral configuration: 0 for each DOF, or the nearest limit when
    /// 0 lies outside the limits.
    pub fn neutral_configuration(&self) -> Vec<f64> {
        self.dof_joints
            .iter()
            .map(|&j| {
                let l = &self.joints[j].limits;
                0.0f64.max(l.lower).min(l.upper)
            })
            .collect()
    }

    /// Checks that `q` is a full, finite DOF vector.
    pub fn check_configuration(&self, what: &str, q: &[f64]) -> Result<()> {
        if q.len() != self.num_dof() {
            return Err(ModelError::Shape {
                what: what.to_string(),
                expected: format!("({},) in dof_names order", self.num_dof()),
                got: format!("({},)", q.len()),
            });
        }
        crate::error::check_finite(what, q)
    }

    /// Replaces the mass properties of link `link` (run-time calibration;
    /// see [`crate::check::inertial_problem`] for what is accepted: finite
    /// pose, mass >= 0, and for mass > 0 a symmetric, positive definite
    /// inertia meeting the triangle inequality).
    pub fn set_link_inertial(&mut self, link: usize, inertial: Inertial) -> Result<()> {
        let name = self
            .links
            .get(link)
            .map(|l| l.name.clone())
            .ok_or_else(|| {
                ModelError::InvalidArgument(format!("link index {link} out of range"))
            })?;
        if let Some(problem) = crate::check::inertial_problem(&inertial) {
            return Err(ModelError::InvalidArgument(format!(
                "link '{name}': {problem}"
            )));
        }
        self.links[link].inertial = inertial;
        Ok(())
    }
}
