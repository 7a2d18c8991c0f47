//! The automatic part of the allowed-collision matrix: an analysis that
//! samples configurations against a sphere model (as MoveIt's setup
//! assistant does). The matrix itself only reads the model and lives in
//! `ferrobot_model::acm`; it is re-exported here.

use std::sync::Arc;

use nalgebra::Point3;
use rand::{Rng, SeedableRng, rngs::StdRng};
use rayon::prelude::*;

use ferrobot_model::RobotModel;
pub use ferrobot_model::acm::AllowedCollisions;

use crate::error::Result;
use crate::robot_spheres::RobotSpheres;

/// What [`AllowedCollisions::analyze`] found.
#[derive(Debug, Clone, Default)]
pub struct AnalysisReport {
    /// Configurations sampled.
    pub samples: usize,
    /// Pairs in contact in every sample (disabled, reason `Always`).
    pub always: Vec<(usize, usize)>,
    /// Pairs never in contact in any sample (disabled, reason `Never`).
    pub never: Vec<(usize, usize)>,
    /// Pairs that are sometimes in contact (kept).
    pub sometimes: Vec<(usize, usize)>,
}

/// Configurations sampled by [`always_in_contact`] when a checker is made
/// with the automatic allowed-collision matrix ([`automatic_acm`]).
pub const AUTO_ALWAYS_SAMPLES: usize = 200;

/// The reason recorded for pairs [`automatic_acm`] disables.
pub const AUTO_ALWAYS_REASON: &str = "Always (automatic)";

/// Random configurations within the limits (continuous joints in
/// `[-pi, pi]`), sample `s` of `seed` as in [`AnalyzeCollisions::analyze`].
fn sample_q(model: &RobotModel, seed: u64, s: usize) -> Vec<f64> {
    let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(1_000_003).wrapping_add(s as u64));
    model
        .lower_limits()
        .iter()
        .zip(model.upper_limits())
        .map(|(&l, h)| {
            let l = if l.is_finite() {
                l
            } else {
                -std::f64::consts::PI
            };
            let h = if h.is_finite() {
                h
            } else {
                std::f64::consts::PI
            };
            if h > l { rng.random_range(l..h) } else { l }
        })
        .collect()
}

/// Link pairs that `acm` still checks and that are in contact in every one
/// of `samples` random configurations (seeded): links overlapping by
/// design, such as a linkage gripper opened into a mimic tree or a torso
/// housing a joint. A pair counts when its spheres overlap in every sample
/// *and* the checker with the links' exact geometry (convex hulls,
/// primitives) confirms the contact in every sample, so a pair that is
/// merely close (spheres overlapping, geometry apart) is kept. Statistical
/// like MoveIt's setup assistant: a pair apart only in rare configurations
/// may be listed.
pub fn always_in_contact(
    model: &Arc<RobotModel>,
    spheres: &RobotSpheres,
    acm: &AllowedCollisions,
    samples: usize,
    seed: u64,
) -> Result<Vec<(usize, usize)>> {
    let mut probe = acm.clone();
    let report = probe.analyze(model, spheres, samples, seed)?;
    if report.always.is_empty() {
        return Ok(Vec::new());
    }
    let qs: Vec<f64> = (0..samples)
        .flat_map(|s| sample_q(model, seed, s))
        .collect();
    let mut out = Vec::new();
    for &(a, b) in &report.always {
        let checker = pair_checker(model, spheres, a, b)?;
        if checker.in_collision_batch(&qs)?.iter().all(|&c| c) {
            out.push((a, b));
        }
    }
    Ok(out)
}

/// The reason recorded for pairs [`touching_at_stop`] finds.
pub const AUTO_STOP_REASON: &str = "Stop (automatic)";

/// Joint values tried over the range of the one joint between two links by
/// [`touching_at_stop`] (ends included).
pub const STOP_STEPS: usize = 64;

/// A checker that sees only the link pair `(a, b)`, with exact confirmation.
fn pair_checker(
    model: &Arc<RobotModel>,
    spheres: &RobotSpheres,
    a: usize,
    b: usize,
) -> Result<crate::CollisionChecker> {
    let n = model.links().len();
    let mut only = AllowedCollisions::default();
    for x in 0..n {
        for y in x + 1..n {
            if (x, y) != (a.min(b), a.max(b)) {
                only.allow(x, y, "probe");
            }
        }
    }
    crate::CollisionChecker::new(
        model.clone(),
        spheres.clone(),
        only,
        crate::CollisionWorld::new(),
    )
}

/// Link pairs that `acm` still checks, whose relative pose is set by one
/// independent joint (its mimic followers included) and whose exact
/// geometry touches only at an end of that joint's range: fingers that meet
/// when a gripper is closed on nothing, a linkage resting on its end stop.
/// That state is where the joint's own actuator puts the robot, not a
/// collision a planner could avoid; MoveIt's setup assistant disables such
/// pairs too (its `Default` reason, e.g. the Panda's two fingers). The joint
/// is tried at [`STOP_STEPS`] values over its range, every other joint at the
/// model's neutral configuration; a pair counts when it is in contact at one
/// or both ends and apart at every value in between, so a pair that overlaps
/// over part of the range (a real collision) is kept. Pairs that no joint or
/// several independent joints move relative to each other are not looked at.
pub fn touching_at_stop(
    model: &Arc<RobotModel>,
    spheres: &RobotSpheres,
    acm: &AllowedCollisions,
) -> Result<Vec<(usize, usize)>> {
    let n = model.links().len();
    let lo = model.lower_limits();
    let hi = model.upper_limits();
    let neutral = model.neutral_configuration();
    let mut out = Vec::new();
    for a in 0..n {
        if spheres.links[a].is_empty() {
            continue;
        }
        for b in a + 1..n {
            if spheres.links[b].is_empty() || acm.is_allowed(a, b) {
                continue;
            }
            let mut dofs = model.dofs_between(a, b);
            dofs.extend(model.dofs_between(b, a));
            dofs.sort_unstable();
            dofs.dedup();
            let [d] = dofs[..] else {
                continue;
            };
            let (l, h) = (lo[d], hi[d]);
            if !(l.is_finite() && h.is_finite() && h > l) {
                continue;
            }
            let qs: Vec<f64> = (0..STOP_STEPS)
                .flat_map(|k| {
                    let mut q = neutral.clone();
                    q[d] = l + (h - l) * k as f64 / (STOP_STEPS - 1) as f64;
                    q
                })
                .collect();
            let hit = pair_checker(model, spheres, a, b)?.in_collision_batch(&qs)?;
            let ends = hit[0] || hit[STOP_STEPS - 1];
            if ends && !hit[1..STOP_STEPS - 1].iter().any(|&c| c) {
                out.push((a, b));
            }
        }
    }
    Ok(out)
}

/// The reason recorded for pairs [`touching_at_rest`] finds.
pub const AUTO_DEFAULT_REASON: &str = "Default (automatic)";

/// Link pairs that `acm` still checks, in contact (spheres and exact
/// geometry) at the model's neutral configuration, and that no joint of the
/// planning group ([`RobotModel::group_dofs`]) moves relative to each
/// other: a hand's finger segments overlapping in its rest pose, pads of a
/// closed gripper. A planner moving the group cannot change such a contact,
/// so checking it would refuse every configuration. MoveIt's setup
/// assistant disables pairs in contact in the default configuration
/// (`Default`); this keeps the pairs a group joint moves (an arm folded onto
/// itself at zero stays checked).
pub fn touching_at_rest(
    model: &Arc<RobotModel>,
    spheres: &RobotSpheres,
    acm: &AllowedCollisions,
) -> Result<Vec<(usize, usize)>> {
    let checker = crate::CollisionChecker::new(
        model.clone(),
        spheres.clone(),
        acm.clone(),
        crate::CollisionWorld::new(),
    )?;
    let group = model.group_dofs();
    let mut out = Vec::new();
    for c in checker.contacts(&model.neutral_configuration())? {
        if !c.self_collision {
            continue;
        }
        let (Ok(a), Ok(b)) = (model.link(&c.body), model.link(&c.other)) else {
            continue;
        };
        let mut dofs = model.dofs_between(a, b);
        dofs.extend(model.dofs_between(b, a));
        if !dofs.is_empty() && !dofs.iter().any(|d| group.contains(d)) {
            out.push((a.min(b), a.max(b)));
        }
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

/// The allowed-collision matrix a checker gets when none is given:
/// [`AllowedCollisions::from_model`] (adjacent, rigid and SRDF pairs), plus
/// the pairs [`always_in_contact`] finds among those still checked
/// ([`AUTO_ALWAYS_SAMPLES`] samples, seed 0), with reason
/// [`AUTO_ALWAYS_REASON`], then the pairs [`touching_at_stop`] finds
/// (reason [`AUTO_STOP_REASON`]) and those [`touching_at_rest`] finds
/// (reason [`AUTO_DEFAULT_REASON`]). With an SRDF that disables them
/// already, nothing is added. Also returns the added pairs (their reasons
/// are in the matrix).
pub fn automatic_acm(
    model: &Arc<RobotModel>,
    spheres: &RobotSpheres,
) -> Result<(AllowedCollisions, Vec<(usize, usize)>)> {
    let mut acm = AllowedCollisions::from_model(model);
    let mut added = always_in_contact(model, spheres, &acm, AUTO_ALWAYS_SAMPLES, 0)?;
    for &(a, b) in &added {
        acm.allow(a, b, AUTO_ALWAYS_REASON);
    }
    let stops = touching_at_stop(model, spheres, &acm)?;
    for &(a, b) in &stops {
        acm.allow(a, b, AUTO_STOP_REASON);
    }
    added.extend(stops);
    let rest = touching_at_rest(model, spheres, &acm)?;
    for &(a, b) in &rest {
        acm.allow(a, b, AUTO_DEFAULT_REASON);
    }
    added.extend(rest);
    Ok((acm, added))
}

/// The sampling analysis of an [`AllowedCollisions`] (import the trait to
/// call `acm.analyze(...)`).
pub trait AnalyzeCollisions {
    /// Samples `samples` random configurations within the limits (seeded)
    /// and excludes the sphere-model link pairs that are in contact in every
    /// sample (`Always`) or in none (`Never`). Pairs already excluded are not
    /// looked at. Like MoveIt's setup assistant this is statistical: a pair
    /// that touches only in rare configurations can be missed; use more
    /// samples for more confidence.
    fn analyze(
        &mut self,
        model: &RobotModel,
        spheres: &RobotSpheres,
        samples: usize,
        seed: u64,
    ) -> Result<AnalysisReport>;
}

impl AnalyzeCollisions for AllowedCollisions {
    fn analyze(
        &mut self,
        model: &RobotModel,
        spheres: &RobotSpheres,
        samples: usize,
        seed: u64,
    ) -> Result<AnalysisReport> {
        // At least one sample; at most ranges::MAX_ANALYSIS_SAMPLES (about
        // a minute of checking: 1e12 ran unbounded).
        ferrobot_model::ranges::check_count(
            "samples",
            samples,
            1,
            ferrobot_model::ranges::MAX_ANALYSIS_SAMPLES,
        )?;
        let links: Vec<usize> = (0..model.links().len())
            .filter(|&l| !spheres.links[l].is_empty())
            .collect();
        let mut candidates = Vec::new();
        for (i, &a) in links.iter().enumerate() {
            for &b in &links[i + 1..] {
                if !self.is_allowed(a, b) {
                    candidates.push((a, b));
                }
            }
        }
        let lo = model.lower_limits();
        let hi = model.upper_limits();
        let counts = (0..samples)
            .into_par_iter()
            .map(|s| {
                let mut rng =
                    StdRng::seed_from_u64(seed.wrapping_mul(1_000_003).wrapping_add(s as u64));
                let q: Vec<f64> = lo
                    .iter()
                    .zip(&hi)
                    .map(|(&l, &h)| {
                        let (l, h) = (
                            if l.is_finite() {
                                l
                            } else {
                                -std::f64::consts::PI
                            },
                            if h.is_finite() {
                                h
                            } else {
                                std::f64::consts::PI
                            },
                        );
                        if h > l { rng.random_range(l..h) } else { l }
                    })
                    .collect();
                let poses = model.fk_all(&q).expect("sampled within limits");
                let world: Vec<Vec<(Point3<f64>, f64)>> = spheres
                    .links
                    .iter()
                    .enumerate()
                    .map(|(l, ss)| ss.iter().map(|s| (poses[l] * s.center, s.radius)).collect())
                    .collect();
                candidates
                    .iter()
                    .map(|&(a, b)| {
                        world[a].iter().any(|(ca, ra)| {
                            world[b]
                                .iter()
                                .any(|(cb, rb)| (ca - cb).norm_squared() < (ra + rb) * (ra + rb))
                        }) as usize
                    })
                    .collect::<Vec<usize>>()
            })
            .reduce(
                || vec![0; candidates.len()],
                |mut a, b| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                    a
                },
            );
        let mut report = AnalysisReport {
            samples,
            ..Default::default()
        };
        for (&(a, b), &c) in candidates.iter().zip(&counts) {
            if c == 0 {
                self.allow(a, b, "Never");
                report.never.push((a, b));
            } else if c == samples {
                self.allow(a, b, "Always");
                report.always.push((a, b));
            } else {
                report.sometimes.push((a, b));
            }
        }
        Ok(report)
    }
}
