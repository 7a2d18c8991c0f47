//! Checking a URDF before use, in the spirit of ROS's `check_urdf` and
//! more: the kinematic tree, and problems reported with their line numbers
//! and a severity (missing or non-physical inertials, missing limits,
//! unreachable meshes, non-unit joint axes).
//!
//! This module reads the XML itself (roxmltree, for the line numbers) so
//! that it can report every problem of a file that would not load. Checks
//! that need a loaded model and the collision crate (self-collision at the
//! named states, sphere-model coverage) live in `ferrobot-collision`'s
//! `urdf_check` module, which extends the [`CheckReport`] made here.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use nalgebra::{Matrix3, SymmetricEigen};

use crate::geometry::Inertial;
use crate::resolve::PackageResolver;

/// How serious a finding is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    /// Informational (e.g. sphere-model coverage).
    Info,
    /// Probably wrong, or missing data a controller or simulator needs.
    Warning,
    /// Wrong: the model does not load, or is not physical.
    Error,
}

impl Severity {
    /// "error", "warning" or "info".
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Info => "info",
            Self::Warning => "warning",
            Self::Error => "error",
        }
    }
}

/// One problem (or fact) found in a robot description.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// Severity.
    pub severity: Severity,
    /// A stable short code, e.g. `missing-inertial`, `inertia-triangle`.
    pub code: &'static str,
    /// 1-based line of the element in the checked file, when known.
    pub line: Option<u32>,
    /// The link or joint concerned ("" for the whole robot).
    pub element: String,
    /// What is wrong, and the values involved.
    pub message: String,
}

/// The result of checking one URDF.
#[derive(Debug, Clone, Default)]
pub struct CheckReport {
    /// The robot's name (`<robot name>`).
    pub robot: String,
    /// The file checked (or `<string>`).
    pub source: String,
    /// The kinematic tree as text (`check_urdf`'s layout).
    pub tree: String,
    /// Everything found, in file order within each check.
    pub findings: Vec<Finding>,
    /// Line of each `<link>` element.
    pub link_lines: HashMap<String, u32>,
    /// Line of each `<joint>` element.
    pub joint_lines: HashMap<String, u32>,
}

impl CheckReport {
    /// Number of findings of `severity`.
    pub fn count(&self, severity: Severity) -> usize {
        self.findings
            .iter()
            .filter(|f| f.severity == severity)
            .count()
    }

    fn push(
        &mut self,
        severity: Severity,
        code: &'static str,
        line: Option<u32>,
        element: &str,
        message: String,
    ) {
        self.findings.push(Finding {
            severity,
            code,
            line,
            element: element.to_string(),
            message,
        });
    }

    /// Adds a finding (used by the collision crate's checks).
    pub fn add(
        &mut self,
        severity: Severity,
        code: &'static str,
        line: Option<u32>,
        element: &str,
        message: impl Into<String>,
    ) {
        self.push(severity, code, line, element, message.into());
    }
}

/// Relative tolerance of the inertia checks (eigenvalues, triangle
/// inequality), times the trace: rounding in URDF files is tolerated.
pub const INERTIA_RTOL: f64 = 1e-6;
/// Tolerance on |axis| - 1 before a joint axis counts as not unit.
pub const AXIS_TOL: f64 = 1e-6;

/// What is wrong with a mass-properties record, or `None` when it is
/// physical: finite pose, mass >= 0, and for mass > 0 a finite symmetric
/// inertia whose principal moments are > 0 and satisfy the triangle
/// inequality (each at most the sum of the other two), within
/// [`INERTIA_RTOL`] x trace.
pub fn inertial_problem(inertial: &Inertial) -> Option<String> {
    let t = inertial.origin.translation.vector;
    let r = inertial.origin.rotation;
    if !(t.iter().all(|v| v.is_finite()) && r.coords.iter().all(|v| v.is_finite())) {
        return Some("the inertial origin is not finite".into());
    }
    if !(inertial.mass.is_finite() && inertial.mass >= 0.0) {
        return Some(format!(
            "mass must be finite and >= 0, got {}",
            inertial.mass
        ));
    }
    if inertial.mass == 0.0 {
        return None;
    }
    inertia_problem(&inertial.inertia)
}

/// What is wrong with an inertia tensor (see [`inertial_problem`]).
pub fn inertia_problem(i: &[[f64; 3]; 3]) -> Option<String> {
    if !i.iter().flatten().all(|v| v.is_finite()) {
        return Some("the inertia tensor is not finite".into());
    }
    let m = Matrix3::from_fn(|r, c| i[r][c]);
    let scale = m.trace().abs().max(f64::MIN_POSITIVE);
    if (m - m.transpose()).abs().max() > INERTIA_RTOL * scale {
        return Some("the inertia tensor is not symmetric".into());
    }
    let mut p: Vec<f64> = SymmetricEigen::new(m).eigenvalues.iter().copied().collect();
    p.sort_by(f64::total_cmp);
    let tol = INERTIA_RTOL * scale;
    if p[0] <= tol {
        return Some(format!(
            "the inertia is not positive definite: principal moments {:.4e}, {:.4e}, {:.4e}",
            p[0], p[1], p[2]
        ));
    }
    if p[2] > p[0] + p[1] + tol {
        return Some(format!(
            "the principal moments {:.4e}, {:.4e}, {:.4e} violate the triangle inequality \
             ({:.4e} > {:.4e} + {:.4e}): no rigid body has this inertia",
            p[0], p[1], p[2], p[2], p[0], p[1]
        ));
    }
    None
}

fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, tag: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children().find(|c| c.tag_name().name() == tag)
}

fn parse_f64(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok()
}

fn parse_vec(s: &str) -> Option<Vec<f64>> {
    s.split_whitespace().map(parse_f64).collect()
}

/// Checks URDF text. `source` names it; `urdf_dir` and `package_dirs`
/// resolve mesh files exactly as the loader does (see [`PackageResolver`]).
/// Malformed XML gives a report with one error finding.
pub fn check_urdf_text(
    text: &str,
    source: &str,
    urdf_dir: Option<&Path>,
    package_dirs: &[PathBuf],
) -> CheckReport {
    let mut report = CheckReport {
        source: source.to_string(),
        ..Default::default()
    };
    let doc = match roxmltree::Document::parse(text) {
        Ok(d) => d,
        Err(e) => {
            report.push(
                Severity::Error,
                "xml",
                Some(e.pos().row),
                "",
                format!("malformed XML: {e}"),
            );
            return report;
        }
    };
    let lines = crate::xml::LineIndex::new(text);
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        report.push(
            Severity::Error,
            "xml",
            Some(lines.line_of(root)),
            "",
            format!(
                "the root element is <{}>, a URDF needs <robot>",
                root.tag_name().name()
            ),
        );
        return report;
    }
    report.robot = root.attribute("name").unwrap_or("").to_string();
    let resolver = PackageResolver::new(urdf_dir, package_dirs);
    let mut links: Vec<(String, roxmltree::Node)> = Vec::new();
    let mut joints: Vec<(String, roxmltree::Node)> = Vec::new();
    for node in root.children().filter(|n| n.is_element()) {
        let line = lines.line_of(node);
        match node.tag_name().name() {
            "link" => {
                let name = node.attribute("name").unwrap_or("").to_string();
                report.link_lines.insert(name.clone(), line);
                links.push((name, node));
            }
            "joint" => {
                let name = node.attribute("name").unwrap_or("").to_string();
                report.joint_lines.insert(name.clone(), line);
                joints.push((name, node));
            }
            _ => {}
        }
    }
    // Tree topology.
    let mut parent_of: HashMap<&str, &str> = HashMap::new();
    let mut children: HashMap<&str, Vec<&str>> = HashMap::new();
    for (name, j) in &joints {
        let p = child(*j, "parent").and_then(|c| c.attribute("link"));
        let c = child(*j, "child").and_then(|c| c.attribute("link"));
        let line = Some(lines.line_of(*j));
        match (p, c) {
            (Some(p), Some(c)) => {
                for (role, l) in [("parent", p), ("child", c)] {
                    if !report.link_lines.contains_key(l) {
                        report.push(
                            Severity::Error,
                            "unknown-link",
                            line,
                            name,
                            format!("joint '{name}' names {role} link '{l}', which is not defined"),
                        );
                    }
                }
                if parent_of.insert(c, p).is_some() {
                    report.push(
                        Severity::Error,
                        "not-a-tree",
                        line,
                        name,
                        format!("link '{c}' has two parent joints (a URDF must be a tree)"),
                    );
                }
                children.entry(p).or_default().push(c);
            }
            _ => report.push(
                Severity::Error,
                "joint-links",
                line,
                name,
                format!("joint '{name}' lacks <parent link> or <child link>"),
            ),
        }
    }
    let roots: Vec<&str> = links
        .iter()
        .map(|(n, _)| n.as_str())
        .filter(|n| !parent_of.contains_key(n))
        .collect();
    let _ = writeln!(report.tree, "robot name is: {}", report.robot);
    match roots.as_slice() {
        [] => report.push(
            Severity::Error,
            "no-root",
            None,
            "",
            "every link has a parent joint: there is no root link".into(),
        ),
        [root_link] => {
            let n = children.get(root_link).map_or(0, Vec::len);
            let _ = writeln!(
                report.tree,
                "---------- Successfully Parsed XML ---------------"
            );
            let _ = writeln!(report.tree, "root Link: {root_link} has {n} child(ren)");
            fn walk(
                out: &mut String,
                children: &HashMap<&str, Vec<&str>>,
                link: &str,
                depth: usize,
                seen: &mut Vec<String>,
            ) {
                if seen.iter().any(|s| s == link) || depth > 1000 {
                    return;
                }
                seen.push(link.to_string());
                for (k, c) in children.get(link).into_iter().flatten().enumerate() {
                    let _ = writeln!(out, "{}child({}):  {c}", "    ".repeat(depth), k + 1);
                    walk(out, children, c, depth + 1, seen);
                }
            }
            let mut seen = Vec::new();
            walk(&mut report.tree, &children, root_link, 1, &mut seen);
        }
        many => {
            let line = report.link_lines.get(many[1]).copied();
            report.push(
                Severity::Error,
                "many-roots",
                line,
                many[1],
                format!(
                    "the robot has {} root links ({}); a URDF must be one tree",
                    many.len(),
                    many.join(", ")
                ),
            );
        }
    }

    for (name, node) in &links {
        check_link(
            &lines,
            &mut report,
            name,
            *node,
            &resolver,
            roots.first() == Some(&name.as_str()),
        );
    }
    for (name, node) in &joints {
        check_joint(&lines, &mut report, name, *node);
    }
    report
}

fn check_link(
    lines: &crate::xml::LineIndex,
    report: &mut CheckReport,
    name: &str,
    node: roxmltree::Node,
    resolver: &PackageResolver,
    is_root: bool,
) {
    let line = Some(lines.line_of(node));
    let has_collision = child(node, "collision").is_some();
    match child(node, "inertial") {
        None => {
            if is_root {
                report.push(
                    Severity::Info,
                    "missing-inertial",
                    line,
                    name,
                    format!("root link '{name}' has no <inertial> (fine for a fixed base)"),
                );
            } else {
                report.push(
                    Severity::Warning,
                    "missing-inertial",
                    line,
                    name,
                    format!(
                        "link '{name}' has no <inertial>: simulators give it a made-up mass{}",
                        if has_collision {
                            ""
                        } else {
                            " (it has no collision geometry either)"
                        }
                    ),
                );
            }
        }
        Some(inertial) => {
            let iline = Some(lines.line_of(inertial));
            let mass = child(inertial, "mass").and_then(|m| m.attribute("value"));
            match mass.map(|m| (m, parse_f64(m))) {
                None => report.push(
                    Severity::Error,
                    "missing-mass",
                    iline,
                    name,
                    format!("link '{name}': <inertial> has no <mass value>"),
                ),
                Some((text, None)) => report.push(
                    Severity::Error,
                    "bad-mass",
                    iline,
                    name,
                    format!("link '{name}': mass '{text}' is not a number"),
                ),
                Some((_, Some(0.0))) => report.push(
                    Severity::Warning,
                    "zero-mass",
                    iline,
                    name,
                    format!(
                        "link '{name}': mass 0 (a massless frame; simulators need mass on links moved by a joint)"
                    ),
                ),
                Some((_, Some(m))) if !(m.is_finite() && m > 0.0) => report.push(
                    Severity::Error,
                    "non-positive-mass",
                    iline,
                    name,
                    format!("link '{name}': mass must be positive and finite, got {m}"),
                ),
                Some(_) => {}
            }
            let massless = mass.and_then(parse_f64) == Some(0.0);
            match child(inertial, "inertia") {
                Some(_) if massless => {}
                None => report.push(
                    Severity::Error,
                    "missing-inertia",
                    iline,
                    name,
                    format!("link '{name}': <inertial> has no <inertia>"),
                ),
                Some(i) => {
                    let get = |a: &str| i.attribute(a).and_then(parse_f64);
                    let vals: Option<Vec<f64>> = ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"]
                        .iter()
                        .map(|a| get(a))
                        .collect();
                    let il = Some(lines.line_of(i));
                    match vals {
                        None => report.push(
                            Severity::Error,
                            "bad-inertia",
                            il,
                            name,
                            format!(
                                "link '{name}': <inertia> needs numeric ixx, ixy, ixz, iyy, iyz, izz"
                            ),
                        ),
                        Some(v) => {
                            let m = [[v[0], v[1], v[2]], [v[1], v[3], v[4]], [v[2], v[4], v[5]]];
                            if let Some(p) = inertia_problem(&m) {
                                let code = if p.contains("triangle") {
                                    "inertia-triangle"
                                } else {
                                    "inertia-not-positive-definite"
                                };
                                report.push(Severity::Error, code, il, name, format!("link '{name}': {p}"));
                            }
                        }
                    }
                }
            }
        }
    }
    for kind in ["collision", "visual"] {
        for g in node.children().filter(|c| c.tag_name().name() == kind) {
            let Some(mesh) = child(g, "geometry").and_then(|g| child(g, "mesh")) else {
                continue;
            };
            let ml = Some(lines.line_of(mesh));
            let Some(filename) = mesh.attribute("filename") else {
                report.push(
                    Severity::Error,
                    "mesh-filename",
                    ml,
                    name,
                    format!("link '{name}': {kind} <mesh> has no filename"),
                );
                continue;
            };
            if let Err(why) = resolver.resolve(filename) {
                report.push(
                    Severity::Error,
                    "mesh-not-found",
                    ml,
                    name,
                    format!("link '{name}': {kind} mesh '{filename}': {why}"),
                );
            }
        }
    }
}

fn check_joint(
    lines: &crate::xml::LineIndex,
    report: &mut CheckReport,
    name: &str,
    node: roxmltree::Node,
) {
    let line = Some(lines.line_of(node));
    let kind = node.attribute("type").unwrap_or("");
    let movable = matches!(kind, "revolute" | "continuous" | "prismatic");
    if !movable && kind != "fixed" {
        report.push(
            Severity::Error,
            "joint-type",
            line,
            name,
            format!("joint '{name}' has type '{kind}' (supported: revolute, continuous, prismatic, fixed)"),
        );
        return;
    }
    if !movable {
        return;
    }
    match child(node, "axis") {
        None => report.push(
            Severity::Info,
            "default-axis",
            line,
            name,
            format!("joint '{name}' has no <axis>: the default (1, 0, 0) applies"),
        ),
        Some(axis) => {
            let al = Some(lines.line_of(axis));
            match axis.attribute("xyz").and_then(parse_vec) {
                Some(v) if v.len() == 3 && v.iter().all(|x| x.is_finite()) => {
                    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    if n < 1e-12 {
                        report.push(
                            Severity::Error,
                            "zero-axis",
                            al,
                            name,
                            format!(
                                "joint '{name}': axis ({}, {}, {}) is zero",
                                v[0], v[1], v[2]
                            ),
                        );
                    } else if (n - 1.0).abs() > AXIS_TOL {
                        report.push(
                            Severity::Warning,
                            "non-unit-axis",
                            al,
                            name,
                            format!(
                                "joint '{name}': axis ({}, {}, {}) has length {n:.6}, not 1 (loaders normalise it; Jacobian scaling may differ between tools)",
                                v[0], v[1], v[2]
                            ),
                        );
                    }
                }
                _ => report.push(
                    Severity::Error,
                    "bad-axis",
                    al,
                    name,
                    format!("joint '{name}': <axis xyz> must be three finite numbers"),
                ),
            }
        }
    }
    let Some(limit) = child(node, "limit") else {
        let (sev, what) = if kind == "continuous" {
            (Severity::Warning, "no effort or velocity limit")
        } else {
            (
                Severity::Error,
                "no lower/upper limits (the URDF spec requires <limit>)",
            )
        };
        report.push(
            sev,
            "missing-limit",
            line,
            name,
            format!("{kind} joint '{name}' has no <limit>: {what}"),
        );
        return;
    };
    let ll = Some(lines.line_of(limit));
    if kind != "continuous" {
        let lo = limit.attribute("lower").map(parse_f64);
        let hi = limit.attribute("upper").map(parse_f64);
        match (lo, hi) {
            (Some(Some(lo)), Some(Some(hi))) => {
                if !(lo.is_finite() && hi.is_finite()) || lo > hi {
                    report.push(
                        Severity::Error,
                        "bad-limit",
                        ll,
                        name,
                        format!("joint '{name}': limits [{lo}, {hi}] are not a finite interval"),
                    );
                } else if lo == hi {
                    report.push(
                        Severity::Warning,
                        "zero-range",
                        ll,
                        name,
                        format!("joint '{name}': lower = upper = {lo}: the joint cannot move"),
                    );
                }
            }
            _ => report.push(
                Severity::Error,
                "missing-limit",
                ll,
                name,
                format!("{kind} joint '{name}': <limit> needs numeric 'lower' and 'upper'"),
            ),
        }
    }
    for attr in ["effort", "velocity"] {
        match limit.attribute(attr).map(parse_f64) {
            None => report.push(
                Severity::Warning,
                if attr == "effort" {
                    "missing-effort"
                } else {
                    "missing-velocity"
                },
                ll,
                name,
                format!("joint '{name}': <limit> has no '{attr}' (taken as unlimited)"),
            ),
            Some(None) => report.push(
                Severity::Error,
                "bad-limit",
                ll,
                name,
                format!("joint '{name}': '{attr}' is not a number"),
            ),
            Some(Some(v)) if v.is_nan() || v <= 0.0 => report.push(
                Severity::Warning,
                if attr == "effort" {
                    "missing-effort"
                } else {
                    "missing-velocity"
                },
                ll,
                name,
                format!(
                    "joint '{name}': {attr} limit {v} is not positive (the joint cannot be driven)"
                ),
            ),
            Some(_) => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_and_definiteness() {
        assert!(inertia_problem(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).is_none());
        let p = inertia_problem(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]]).unwrap();
        assert!(p.contains("triangle"), "{p}");
        let p = inertia_problem(&[[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        assert!(p.contains("positive definite"), "{p}");
        // Off-diagonal terms: principal moments decide.
        let p = inertia_problem(&[[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).unwrap();
        assert!(p.contains("positive definite"), "{p}");
    }
}
