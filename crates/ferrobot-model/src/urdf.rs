//! Reading URDF: urdf-rs parses the document; a roxmltree pass before it
//! gives errors with line numbers, checks joint types and limits, and fills
//! documented defaults that urdf-rs cannot express.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use crate::error::{ModelError, Result, SourceLocation};
use crate::geometry::{Geometry, Inertial, Shape};
use crate::joint::{Joint, JointCoupling, JointKind, JointLimits, Mimic};
use crate::link::Link;
use crate::resolve::PackageResolver;
use ferrobot_geometry::{Mesh, MeshSource, TriMesh};

/// What the XML pre-pass learnt about one `<joint>` element.
#[derive(Debug, Clone)]
struct JointInfo {
    line: u32,
    has_limit: bool,
    file_order: usize,
}

/// Result of the XML pre-pass: the text urdf-rs will read and line numbers.
struct PrePass {
    text: String,
    joints: HashMap<String, JointInfo>,
    links: HashMap<String, u32>,
}

/// A URDF read into links and joints (not yet a model: no DOF order).
#[derive(Debug, Clone)]
pub struct ParsedUrdf {
    /// The robot's name.
    pub name: String,
    /// Links in depth-first order from the root (root first).
    pub links: Vec<Link>,
    /// Joints; `joints[k - 1]` is the parent joint of `links[k]`.
    pub joints: Vec<Joint>,
    /// Where the text came from (a path or `<string>`).
    pub source: String,
    /// Line of each joint element, for later error messages.
    pub joint_lines: HashMap<String, u32>,
}

const JOINT_TYPES: [&str; 7] = [
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
];

fn pre_pass(text: &str, source: &str) -> Result<PrePass> {
    crate::xml::check_limits(text)
        .map_err(|e| ModelError::urdf(SourceLocation::new(source, e.line), e.message))?;
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        ModelError::urdf(
            SourceLocation::new(source, Some(e.pos().row)),
            format!("malformed XML: {e}"),
        )
    })?;
    let lines = crate::xml::LineIndex::new(text);
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(ModelError::urdf(
            SourceLocation::new(source, Some(lines.line_of(root))),
            format!(
                "the root element is <{}>, a URDF needs <robot>",
                root.tag_name().name()
            ),
        ));
    }
    let mut joints = HashMap::new();
    let mut links = HashMap::new();
    // (byte offset, text) to insert, applied back to front.
    let mut inserts: Vec<(usize, &'static str)> = Vec::new();
    for node in root.children().filter(|n| n.is_element()) {
        let line = lines.line_of(node);
        let loc = || SourceLocation::new(source, Some(line));
        match node.tag_name().name() {
            "link" => {
                let name = node.attribute("name").ok_or_else(|| {
                    ModelError::urdf(loc(), "a <link> element has no name attribute")
                })?;
                if links.insert(name.to_string(), line).is_some() {
                    return Err(ModelError::urdf(
                        loc(),
                        format!("link '{name}' is defined twice"),
                    ));
                }
            }
            "joint" => {
                let name = node.attribute("name").ok_or_else(|| {
                    ModelError::urdf(loc(), "a <joint> element has no name attribute")
                })?;
                let kind = node.attribute("type").ok_or_else(|| {
                    ModelError::urdf(loc(), format!("joint '{name}' has no type attribute"))
                })?;
                if !JOINT_TYPES.contains(&kind) {
                    return Err(ModelError::urdf(
                        loc(),
                        format!(
                            "joint '{name}' has unknown type '{kind}' (known: revolute, continuous, prismatic, fixed)"
                        ),
                    ));
                }
                if matches!(kind, "floating" | "planar" | "spherical") {
                    return Err(ModelError::urdf(
                        loc(),
                        format!(
                            "joint '{name}' has type '{kind}', which is not supported (supported: revolute, continuous, prismatic, fixed)"
                        ),
                    ));
                }
                for required in ["parent", "child"] {
                    let ok = node
                        .children()
                        .any(|c| c.tag_name().name() == required && c.attribute("link").is_some());
                    if !ok {
                        return Err(ModelError::urdf(
                            loc(),
                            format!("joint '{name}' has no <{required} link=\"...\"/>"),
                        ));
                    }
                }
                let limit = node.children().find(|c| c.tag_name().name() == "limit");
                if matches!(kind, "revolute" | "prismatic") {
                    let limit = limit.ok_or_else(|| {
                        ModelError::urdf(
                            loc(),
                            format!("{kind} joint '{name}' has no <limit> element"),
                        )
                    })?;
                    for attr in ["lower", "upper"] {
                        if limit.attribute(attr).is_none() {
                            return Err(ModelError::urdf(
                                loc(),
                                format!("{kind} joint '{name}': <limit> has no '{attr}' attribute"),
                            ));
                        }
                    }
                }
                if let Some(limit) = limit {
                    let at = limit.range().start + "<limit".len();
                    if limit.attribute("velocity").is_none() {
                        inserts.push((at, " velocity=\"inf\""));
                    }
                    if limit.attribute("effort").is_none() {
                        inserts.push((at, " effort=\"inf\""));
                    }
                }
                let info = JointInfo {
                    line,
                    has_limit: limit.is_some(),
                    file_order: joints.len(),
                };
                if joints.insert(name.to_string(), info).is_some() {
                    return Err(ModelError::urdf(
                        loc(),
                        format!("joint '{name}' is defined twice"),
                    ));
                }
            }
            _ => {}
        }
    }
    // One pass front to back (inserting back to front into one String
    // moved the tail once per insert: quadratic in the number of joints).
    inserts.sort_by_key(|&(at, _)| at);
    let mut patched = String::with_capacity(text.len() + inserts.len() * 16);
    let mut done = 0;
    for (at, what) in inserts {
        patched.push_str(&text[done..at]);
        patched.push_str(what);
        done = at;
    }
    patched.push_str(&text[done..]);
    Ok(PrePass {
        text: patched,
        joints,
        links,
    })
}

fn pose_of(p: &urdf_rs::Pose) -> Option<Isometry3<f64>> {
    let all = p.xyz.iter().chain(p.rpy.iter());
    if !all.clone().all(|v| v.is_finite()) {
        return None;
    }
    Some(Isometry3::from_parts(
        Translation3::new(p.xyz[0], p.xyz[1], p.xyz[2]),
        UnitQuaternion::from_euler_angles(p.rpy[0], p.rpy[1], p.rpy[2]),
    ))
}

/// Builds geometry, resolving and loading meshes (each file once).
struct GeometryBuilder<'a> {
    resolver: &'a PackageResolver,
    cache: HashMap<PathBuf, Arc<TriMesh>>,
    materials: HashMap<String, [f64; 4]>,
}

impl GeometryBuilder<'_> {
    fn shape(&mut self, link: &str, g: &urdf_rs::Geometry, loc: &SourceLocation) -> Result<Shape> {
        let positive = |what: &str, v: f64| -> Result<f64> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(ModelError::urdf(
                    loc.clone(),
                    format!("link '{link}': {what} must be positive and finite, got {v}"),
                ))
            }
        };
        Ok(match g {
            urdf_rs::Geometry::Box { size } => Shape::Box {
                half_extents: Vector3::new(
                    positive("box size", size[0])? / 2.0,
                    positive("box size", size[1])? / 2.0,
                    positive("box size", size[2])? / 2.0,
                ),
            },
            urdf_rs::Geometry::Sphere { radius } => Shape::Sphere {
                radius: positive("sphere radius", *radius)?,
            },
            urdf_rs::Geometry::Cylinder { radius, length } => Shape::cylinder_from_length(
                positive("cylinder radius", *radius)?,
                positive("cylinder length", *length)?,
            ),
            urdf_rs::Geometry::Capsule { radius, length } => Shape::capsule_from_length(
                positive("capsule radius", *radius)?,
                if *length == 0.0 {
                    0.0
                } else {
                    positive("capsule length", *length)?
                },
            ),
            urdf_rs::Geometry::Mesh { filename, scale } => {
                let scale = scale
                    .map(|s| Vector3::new(s[0], s[1], s[2]))
                    .unwrap_or(Vector3::repeat(1.0));
                if !scale.iter().all(|s| s.is_finite() && *s != 0.0) {
                    return Err(ModelError::urdf(
                        loc.clone(),
                        format!(
                            "link '{link}': mesh '{filename}' has an invalid scale {:?}",
                            scale.as_slice()
                        ),
                    ));
                }
                let mesh_error = |message: String| ModelError::Mesh {
                    link: link.to_string(),
                    filename: filename.clone(),
                    message,
                };
                let path = self.resolver.resolve(filename).map_err(mesh_error)?;
                let mesh = match self.cache.get(&path) {
                    Some(m) => m.clone(),
                    None => {
                        let m = Arc::new(TriMesh::load(&path).map_err(mesh_error)?);
                        self.cache.insert(path.clone(), m.clone());
                        m
                    }
                };
                Shape::Mesh(Arc::new(Mesh::from_shared(
                    mesh,
                    scale,
                    Some(MeshSource {
                        filename: filename.clone(),
                        path,
                    }),
                )))
            }
        })
    }
}

/// Reads URDF text. `source` names it in errors; `urdf_dir` anchors
/// relative and `package://` mesh paths.
pub fn parse_urdf(
    text: &str,
    source: &str,
    urdf_dir: Option<&Path>,
    package_dirs: &[PathBuf],
) -> Result<ParsedUrdf> {
    let pre = pre_pass(text, source)?;
    let robot = urdf_rs::read_from_string(&pre.text).map_err(|e| {
        ModelError::urdf(
            SourceLocation::new(source, None),
            format!("invalid URDF: {e}"),
        )
    })?;
    let joint_loc = |name: &str| SourceLocation::new(source, pre.joints.get(name).map(|j| j.line));
    let link_loc = |name: &str| SourceLocation::new(source, pre.links.get(name).copied());

    // Topology: parent joint of each link, children in file order.
    let link_index: HashMap<&str, usize> = robot
        .links
        .iter()
        .enumerate()
        .map(|(i, l)| (l.name.as_str(), i))
        .collect();
    let mut parent_of: Vec<Option<usize>> = vec![None; robot.links.len()];
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); robot.links.len()];
    let mut joint_order: Vec<usize> = (0..robot.joints.len()).collect();
    joint_order.sort_by_key(|&j| pre.joints.get(&robot.joints[j].name).map(|i| i.file_order));
    for &j in &joint_order {
        let joint = &robot.joints[j];
        let find = |name: &str, role: &str| {
            link_index.get(name).copied().ok_or_else(|| {
                ModelError::urdf(
                    joint_loc(&joint.name),
                    format!(
                        "joint '{}' names {role} link '{name}', which is not defined",
                        joint.name
                    ),
                )
            })
        };
        let parent = find(&joint.parent.link, "parent")?;
        let child = find(&joint.child.link, "child")?;
        if parent == child {
            return Err(ModelError::urdf(
                joint_loc(&joint.name),
                format!(
                    "joint '{}' connects link '{}' to itself",
                    joint.name, joint.child.link
                ),
            ));
        }
        if let Some(other) = parent_of[child] {
            return Err(ModelError::urdf(
                joint_loc(&joint.name),
                format!(
                    "kinematic loop: link '{}' is the child of both joint '{}' and joint '{}' (a URDF must be a tree)",
                    joint.child.link, robot.joints[other].name, joint.name
                ),
            ));
        }
        parent_of[child] = Some(j);
        children[parent].push(j);
    }
    let roots: Vec<usize> = (0..robot.links.len())
        .filter(|&l| parent_of[l].is_none())
        .collect();
    if robot.links.is_empty() {
        return Err(ModelError::urdf(
            SourceLocation::new(source, None),
            "the robot has no links",
        ));
    }
    if roots.len() > 1 {
        let names: Vec<&str> = roots
            .iter()
            .map(|&l| robot.links[l].name.as_str())
            .collect();
        return Err(ModelError::urdf(
            link_loc(names[1]),
            format!(
                "the robot has {} root links ({}); a URDF must be one tree with one root",
                roots.len(),
                names.join(", ")
            ),
        ));
    }
    let Some(&root) = roots.first() else {
        return Err(ModelError::urdf(
            SourceLocation::new(source, None),
            "kinematic loop: every link has a parent joint, so there is no root link",
        ));
    };

    // Depth-first order from the root.
    let mut order: Vec<usize> = Vec::with_capacity(robot.links.len());
    let mut stack = vec![root];
    while let Some(l) = stack.pop() {
        order.push(l);
        for &j in children[l].iter().rev() {
            stack.push(link_index[robot.joints[j].child.link.as_str()]);
        }
    }
    if order.len() != robot.links.len() {
        let mut seen = vec![false; robot.links.len()];
        order.iter().for_each(|&l| seen[l] = true);
        let lost: Vec<&str> = (0..robot.links.len())
            .filter(|&l| !seen[l])
            .map(|l| robot.links[l].name.as_str())
            .collect();
        return Err(ModelError::urdf(
            link_loc(lost[0]),
            format!("kinematic loop through links {}", lost.join(", ")),
        ));
    }
    let new_index: HashMap<usize, usize> = order
        .iter()
        .enumerate()
        .map(|(new, &old)| (old, new))
        .collect();

    let resolver = PackageResolver::new(urdf_dir, package_dirs);
    let mut builder = GeometryBuilder {
        resolver: &resolver,
        cache: HashMap::new(),
        materials: robot
            .materials
            .iter()
            .filter_map(|m| m.color.as_ref().map(|c| (m.name.clone(), c.rgba.0)))
            .collect(),
    };

    let mut links = Vec::with_capacity(order.len());
    let mut joints = Vec::with_capacity(order.len().saturating_sub(1));
    for (k, &old) in order.iter().enumerate() {
        let ul = &robot.links[old];
        let loc = link_loc(&ul.name);
        let bad_origin = |what: &str| {
            ModelError::urdf(
                loc.clone(),
                format!("link '{}': {what} <origin> is not finite", ul.name),
            )
        };
        let mut collisions = Vec::new();
        for c in &ul.collision {
            collisions.push(Geometry {
                name: c.name.clone(),
                origin: pose_of(&c.origin).ok_or_else(|| bad_origin("collision"))?,
                shape: builder.shape(&ul.name, &c.geometry, &loc)?,
                rgba: None,
            });
        }
        let mut visuals = Vec::new();
        for v in &ul.visual {
            let rgba = v.material.as_ref().and_then(|m| {
                m.color
                    .as_ref()
                    .map(|c| c.rgba.0)
                    .or_else(|| builder.materials.get(&m.name).copied())
            });
            visuals.push(Geometry {
                name: v.name.clone(),
                origin: pose_of(&v.origin).ok_or_else(|| bad_origin("visual"))?,
                shape: builder.shape(&ul.name, &v.geometry, &loc)?,
                rgba,
            });
        }
        let i = &ul.inertial.inertia;
        let inertial = Inertial {
            origin: pose_of(&ul.inertial.origin).ok_or_else(|| bad_origin("inertial"))?,
            mass: ul.inertial.mass.value,
            inertia: [
                [i.ixx, i.ixy, i.ixz],
                [i.ixy, i.iyy, i.iyz],
                [i.ixz, i.iyz, i.izz],
            ],
        };
        if !(inertial.mass.is_finite() && inertial.mass >= 0.0) {
            return Err(ModelError::urdf(
                loc,
                format!(
                    "link '{}': mass must be finite and non-negative, got {}",
                    ul.name, inertial.mass
                ),
            ));
        }
        links.push(Link {
            name: ul.name.clone(),
            parent_joint: (k > 0).then(|| k - 1),
            child_joints: Vec::new(),
            collisions,
            visuals,
            inertial,
        });
        if k == 0 {
            continue;
        }
        let uj = &robot.joints[parent_of[old].expect("non-root link has a parent joint")];
        let loc = joint_loc(&uj.name);
        // The pre-pass (roxmltree) normalises attribute whitespace as XML
        // says, urdf-rs does not: a name with a tab or newline differs.
        let info = pre.joints.get(&uj.name).ok_or_else(|| {
            ModelError::urdf(
                loc.clone(),
                format!(
                    "joint name {:?} contains whitespace other than spaces",
                    uj.name
                ),
            )
        })?;
        let kind = match uj.joint_type {
            urdf_rs::JointType::Revolute => JointKind::Revolute,
            urdf_rs::JointType::Continuous => JointKind::Continuous,
            urdf_rs::JointType::Prismatic => JointKind::Prismatic,
            urdf_rs::JointType::Fixed => JointKind::Fixed,
            ref other => {
                return Err(ModelError::urdf(
                    loc,
                    format!("joint '{}' has unsupported type {other:?}", uj.name),
                ));
            }
        };
        let origin = pose_of(&uj.origin).ok_or_else(|| {
            ModelError::urdf(
                loc.clone(),
                format!("joint '{}': <origin> is not finite", uj.name),
            )
        })?;
        let raw_axis = Vector3::new(uj.axis.xyz[0], uj.axis.xyz[1], uj.axis.xyz[2]);
        let axis = if kind.is_movable() {
            let norm = raw_axis.norm();
            if !(norm.is_finite() && norm > 1e-12) {
                return Err(ModelError::urdf(
                    loc,
                    format!(
                        "joint '{}': axis {:?} is not a direction",
                        uj.name,
                        raw_axis.as_slice()
                    ),
                ));
            }
            Unit::new_normalize(raw_axis)
        } else {
            Vector3::z_axis()
        };
        let l = &uj.limit;
        let limits = match kind {
            JointKind::Fixed => JointLimits::FIXED,
            JointKind::Continuous => JointLimits {
                lower: f64::NEG_INFINITY,
                upper: f64::INFINITY,
                velocity: if info.has_limit {
                    l.velocity
                } else {
                    f64::INFINITY
                },
                effort: if info.has_limit {
                    l.effort
                } else {
                    f64::INFINITY
                },
            },
            JointKind::Revolute | JointKind::Prismatic => JointLimits {
                lower: l.lower,
                upper: l.upper,
                velocity: l.velocity,
                effort: l.effort,
            },
        };
        if kind.is_movable() {
            if limits.lower.is_nan() || limits.upper.is_nan() || limits.lower > limits.upper {
                return Err(ModelError::urdf(
                    loc,
                    format!(
                        "joint '{}': lower limit {} is above upper limit {}",
                        uj.name, limits.lower, limits.upper
                    ),
                ));
            }
            if limits.velocity.is_nan()
                || limits.velocity < 0.0
                || limits.effort.is_nan()
                || limits.effort < 0.0
            {
                return Err(ModelError::urdf(
                    loc,
                    format!(
                        "joint '{}': velocity and effort limits must be non-negative",
                        uj.name
                    ),
                ));
            }
        }
        let mimic = uj.mimic.as_ref().map(|m| Mimic {
            joint: m.joint.clone(),
            multiplier: m.multiplier.unwrap_or(1.0),
            offset: m.offset.unwrap_or(0.0),
        });
        let (damping, friction) = uj
            .dynamics
            .as_ref()
            .map(|d| (d.damping, d.friction))
            .unwrap_or((0.0, 0.0));
        joints.push(Joint {
            name: uj.name.clone(),
            kind,
            parent: new_index[&link_index[uj.parent.link.as_str()]],
            child: k,
            origin,
            axis,
            limits,
            mimic,
            coupling: JointCoupling::Fixed,
            damping,
            friction,
        });
    }
    for (j, joint) in joints.iter().enumerate() {
        links[joint.parent].child_joints.push(j);
    }
    Ok(ParsedUrdf {
        name: robot.name,
        links,
        joints,
        source: source.to_string(),
        joint_lines: pre.joints.into_iter().map(|(k, v)| (k, v.line)).collect(),
    })
}
