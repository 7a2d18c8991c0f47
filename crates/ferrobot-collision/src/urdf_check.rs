//! The checks of `ferrobot check` that need a loaded model and this crate:
//! self-collision at the home and named states, and how well the automatic
//! sphere model covers the collision meshes. They extend the XML checks of
//! [`ferrobot_model::check`].

use std::path::{Path, PathBuf};
use std::sync::Arc;

use ferrobot_model::check::{CheckReport, Severity, check_urdf_text};
use ferrobot_model::{LoadOptions, ModelError, RobotModel, Shape, SrdfSource};

use crate::spherize::{SpherizeOptions, spherize_robot};
use crate::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};

/// Coverage (fraction of collision-mesh vertices within the spherizer's
/// tolerance of a sphere) below which a link gets a warning.
pub const COVERAGE_WARNING: f64 = 0.95;

/// Options of [`check_urdf_file`].
#[derive(Debug, Clone, Default)]
pub struct CheckOptions {
    /// SRDF whose named states and disabled pairs the self-collision check uses.
    pub srdf: Option<PathBuf>,
    /// Extra roots for `package://` and relative mesh paths.
    pub package_dirs: Vec<PathBuf>,
    /// Skip the sphere-model coverage check (it fits spheres: seconds).
    pub skip_coverage: bool,
}

/// Checks the URDF file at `path`: the XML checks of
/// [`ferrobot_model::check::check_urdf_text`], then (when the model loads)
/// self-collision at the home configuration (the neutral configuration: 0
/// clamped into the limits) and every SRDF named state, and sphere-model
/// coverage per link. Fails only when the file cannot be read.
pub fn check_urdf_file(path: &Path, options: &CheckOptions) -> std::io::Result<CheckReport> {
    let text = std::fs::read_to_string(path)?;
    let source = path.display().to_string();
    let mut report = check_urdf_text(&text, &source, path.parent(), &options.package_dirs);
    let load = LoadOptions {
        srdf: options.srdf.clone().map(SrdfSource::File),
        package_dirs: options.package_dirs.clone(),
        ..Default::default()
    };
    let model = match RobotModel::from_urdf_file(path, &load) {
        Ok(m) => Arc::new(m),
        Err(e) => {
            // Mesh errors are already reported with their line.
            if !matches!(e, ModelError::Mesh { .. }) && report.count(Severity::Error) == 0
                || matches!(e, ModelError::Srdf { .. })
            {
                let (line, code) = match &e {
                    ModelError::Urdf { location, .. } => (location.line, "load"),
                    ModelError::Srdf { location, .. } => (location.line, "srdf"),
                    _ => (None, "load"),
                };
                report.add(
                    Severity::Error,
                    code,
                    line,
                    "",
                    format!("the model does not load: {e}"),
                );
            }
            report.add(
                Severity::Info,
                "skipped",
                None,
                "",
                "self-collision and sphere coverage not checked: the model does not load",
            );
            return Ok(report);
        }
    };
    model_checks(&mut report, &model, options.skip_coverage);
    Ok(report)
}

fn model_checks(report: &mut CheckReport, model: &Arc<RobotModel>, skip_coverage: bool) {
    let sph_options = SpherizeOptions::default();
    let spheres = match spherize_robot(model, &sph_options) {
        Ok((links, link_reports)) => {
            if !skip_coverage {
                coverage(report, model, &links, &link_reports, sph_options.tolerance);
            }
            links
        }
        Err(e) => {
            report.add(
                Severity::Error,
                "spheres",
                None,
                "",
                format!("the sphere model cannot be made: {e}"),
            );
            return;
        }
    };
    let spheres = match RobotSpheres::new(model, spheres) {
        Ok(s) => s,
        Err(e) => {
            report.add(
                Severity::Error,
                "spheres",
                None,
                "",
                format!("the sphere model cannot be made: {e}"),
            );
            return;
        }
    };
    let acm = AllowedCollisions::from_model(model);
    let checker =
        match CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::default()) {
            Ok(c) => c,
            Err(e) => {
                report.add(
                    Severity::Error,
                    "self-collision",
                    None,
                    "",
                    format!("no collision checker: {e}"),
                );
                return;
            }
        };
    let mut states: Vec<(String, Vec<f64>)> = vec![("home".into(), model.neutral_configuration())];
    if let Some(srdf) = model.srdf() {
        for s in &srdf.group_states {
            if let Ok(q) = model.named_state(&s.name, Some(&s.group)) {
                states.push((format!("{} ({})", s.name, s.group), q));
            }
        }
    }
    for (name, q) in states {
        match checker.contacts(&q) {
            Ok(contacts) => {
                let mut any = false;
                for c in contacts.iter().filter(|c| c.self_collision) {
                    any = true;
                    let line = report.link_lines.get(&c.body).copied();
                    report.add(
                        Severity::Warning,
                        "self-collision",
                        line,
                        &c.body,
                        format!(
                            "state '{name}': link '{}' collides with link '{}' ({:.1} mm deep); \
                             add a disable_collisions pair to the SRDF if this is by design",
                            c.body,
                            c.other,
                            c.depth * 1e3
                        ),
                    );
                }
                if !any {
                    report.add(
                        Severity::Info,
                        "self-collision",
                        None,
                        "",
                        format!("state '{name}': no self-collision"),
                    );
                }
            }
            Err(e) => report.add(
                Severity::Error,
                "self-collision",
                None,
                "",
                format!("state '{name}': {e}"),
            ),
        }
    }
}

fn coverage(
    report: &mut CheckReport,
    model: &RobotModel,
    spheres: &[Vec<crate::Sphere>],
    link_reports: &[crate::spherize::LinkSphereReport],
    tolerance: f64,
) {
    for (link, s) in model.links().iter().zip(spheres) {
        let mut total = 0usize;
        let mut covered = 0usize;
        for g in &link.collisions {
            if let Shape::Mesh(mesh) = &g.shape {
                for v in mesh.vertices() {
                    let p = g.origin * v;
                    total += 1;
                    if s.iter()
                        .any(|sp| (p - sp.center).norm() <= sp.radius + tolerance)
                    {
                        covered += 1;
                    }
                }
            }
        }
        let Some(r) = link_reports.iter().find(|r| r.link == link.name) else {
            continue;
        };
        let line = report.link_lines.get(&link.name).copied();
        let vertex_text = if total > 0 {
            format!(
                "{:.1}% of {total} mesh vertices covered",
                100.0 * covered as f64 / total as f64
            )
        } else {
            "no mesh vertices (primitive shapes)".into()
        };
        let frac = if total > 0 {
            covered as f64 / total as f64
        } else {
            1.0
        };
        let severity = if frac < COVERAGE_WARNING {
            Severity::Warning
        } else {
            Severity::Info
        };
        report.add(
            severity,
            "sphere-coverage",
            line,
            &link.name,
            format!(
                "link '{}': {} spheres, {vertex_text} (within {:.1} mm), max protrusion {:.1} mm",
                link.name,
                r.spheres,
                tolerance * 1e3,
                r.max_protrusion * 1e3
            ),
        );
    }
}
