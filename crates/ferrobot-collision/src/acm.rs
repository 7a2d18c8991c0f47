//! The allowed-collision matrix: link pairs never checked against each
//! other, from adjacency, rigid attachment, the SRDF and an automatic
//! analysis that samples configurations (as MoveIt's setup assistant does).

use std::collections::BTreeMap;

use ferrobot_model::RobotModel;
use nalgebra::Point3;
use rand::{Rng, SeedableRng, rngs::StdRng};
use rayon::prelude::*;

use crate::error::Result;
use crate::robot_spheres::RobotSpheres;

/// Link pairs (link indices, smaller first) excluded from self-collision
/// checks, each with its reason.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AllowedCollisions {
    pairs: BTreeMap<(usize, usize), String>,
}

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

fn key(a: usize, b: usize) -> (usize, usize) {
    (a.min(b), a.max(b))
}

impl AllowedCollisions {
    /// Pairs joined by a joint (`Adjacent`), pairs that cannot move relative
    /// to each other (`Rigid`: only fixed joints between them), and the SRDF's
    /// `disable_collisions` pairs (with their reasons).
    pub fn from_model(model: &RobotModel) -> Self {
        let mut acm = Self::default();
        for j in model.joints() {
            acm.allow(j.parent, j.child, "Adjacent");
        }
        // Rigid groups: links joined only by fixed joints.
        let n = model.links().len();
        let mut group: Vec<usize> = (0..n).collect();
        for (l, link) in model.links().iter().enumerate() {
            if let Some(j) = link.parent_joint {
                let joint = &model.joints()[j];
                if !joint.kind.is_movable() {
                    group[l] = group[joint.parent];
                }
            }
        }
        for a in 0..n {
            for b in a + 1..n {
                if group[a] == group[b] && !acm.is_allowed(a, b) {
                    acm.allow(a, b, "Rigid");
                }
            }
        }
        for (a, b, reason) in model.disabled_collision_pairs() {
            acm.allow(a, b, if reason.is_empty() { "SRDF" } else { &reason });
        }
        acm
    }

    /// Excludes the pair `(a, b)`.
    pub fn allow(&mut self, a: usize, b: usize, reason: &str) {
        if a != b {
            self.pairs
                .entry(key(a, b))
                .or_insert_with(|| reason.to_string());
        }
    }

    /// Checks the pair `(a, b)` again.
    pub fn disallow(&mut self, a: usize, b: usize) {
        self.pairs.remove(&key(a, b));
    }

    /// Whether the pair is excluded.
    pub fn is_allowed(&self, a: usize, b: usize) -> bool {
        a == b || self.pairs.contains_key(&key(a, b))
    }

    /// The excluded pairs with their reasons.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize, &str)> {
        self.pairs.iter().map(|(&(a, b), r)| (a, b, r.as_str()))
    }

    /// Samples `samples` random configurations within the limits (seeded)
    /// and excludes the sphere-model link pairs that are in contact in every
    /// sample (`Always`) or in none (`Never`). Pairs already excluded are not
    /// looked at. Like MoveIt's setup assistant this is statistical: a pair
    /// that touches only in rare configurations can be missed; use more
    /// samples for more confidence.
    pub fn analyze(
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

    /// The pairs as SRDF `<disable_collisions>` elements (to save next to
    /// the robot; load them with the SRDF).
    pub fn to_srdf(&self, model: &RobotModel) -> String {
        let mut out = format!(
            "<?xml version=\"1.0\"?>\n<robot name=\"{}\">\n",
            model.name()
        );
        for (a, b, reason) in self.pairs() {
            out.push_str(&format!(
                "  <disable_collisions link1=\"{}\" link2=\"{}\" reason=\"{}\"/>\n",
                model.links()[a].name,
                model.links()[b].name,
                reason
            ));
        }
        out.push_str("</robot>\n");
        out
    }
}
