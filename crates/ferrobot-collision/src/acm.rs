//! The automatic part of the allowed-collision matrix: an analysis that
//! samples configurations against a sphere model (as MoveIt's setup
//! assistant does). The matrix itself only reads the model and lives in
//! `ferrobot_model::acm`; it is re-exported here.

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
