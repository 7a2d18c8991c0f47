//! Fault injection for controller testing: joint encoder noise, depth
//! camera noise (axial noise growing with depth, random and edge dropout)
//! and the arbitration between command sources for the same joints.
//!
//! Noise models (every generator is seeded, so a run is reproducible):
//!
//! * encoder: `q_measured = round((q + n) / resolution) · resolution` with
//!   `n ~ N(0, σ²)` per joint and sample (resolution 0: no quantisation);
//! * depth (structured light / time of flight; the axial term after Nguyen,
//!   Izadi and Lovell 2012): a valid depth `z` becomes `z + n` with
//!   `n ~ N(0, (σ₀ + σ₂ (z − z₀)²)²)`; a pixel is missing with probability
//!   `dropout`; a pixel on a depth discontinuity (a 4-neighbour differs by
//!   more than `edge_threshold` or has no reading) is missing with
//!   probability `edge_dropout` on top; missing pixels get `missing_value`;
//!   pixels without a reading (non-finite or <= 0) stay missing.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crate::error::{ControlError, Result, check_finite};

fn invalid(msg: String) -> ControlError {
    ControlError::InvalidArgument(msg)
}

fn non_negative(what: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(invalid(format!("{what} must be finite and >= 0, got {v}")))
    }
}

fn probability(what: &str, v: f64) -> Result<f64> {
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(invalid(format!("{what} must be in [0, 1], got {v}")))
    }
}

/// A standard normal sample (Box-Muller on two uniform draws).
fn gaussian(rng: &mut StdRng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Joint encoder noise: Gaussian `sigma` (one value for every joint or one
/// per joint) then quantisation to `resolution` (0: none).
#[derive(Debug, Clone)]
pub struct EncoderNoise {
    sigma: Vec<f64>,
    resolution: f64,
    rng: StdRng,
}

impl EncoderNoise {
    /// `sigma` (rad or m, each finite and >= 0; one value or one per joint),
    /// `resolution` (finite, >= 0), `seed`.
    pub fn new(sigma: &[f64], resolution: f64, seed: u64) -> Result<Self> {
        if sigma.is_empty() {
            return Err(invalid("sigma: at least one value".into()));
        }
        for &s in sigma {
            non_negative("sigma", s)?;
        }
        Ok(Self {
            sigma: sigma.to_vec(),
            resolution: non_negative("resolution", resolution)?,
            rng: StdRng::seed_from_u64(seed),
        })
    }

    /// The standard deviations (one or one per joint).
    pub fn sigma(&self) -> &[f64] {
        &self.sigma
    }

    /// The quantisation step (0: none).
    pub fn resolution(&self) -> f64 {
        self.resolution
    }

    /// Noisy readings of `q`, `rows` rows of `q.len() / rows` joints each
    /// (row-major); a per-joint `sigma` must match the row length.
    pub fn apply(&mut self, q: &[f64], rows: usize) -> Result<Vec<f64>> {
        check_finite("q", q)?;
        let n = q.len().checked_div(rows).unwrap_or(0);
        if rows == 0 || n * rows != q.len() {
            return Err(ControlError::InvalidArgument(format!(
                "q: {} values do not split into {rows} rows",
                q.len()
            )));
        }
        if self.sigma.len() != 1 && self.sigma.len() != n {
            return Err(ControlError::InvalidArgument(format!(
                "q: {n} joints per row, but sigma has {} values",
                self.sigma.len()
            )));
        }
        let mut out = Vec::with_capacity(q.len());
        for (i, &v) in q.iter().enumerate() {
            let s = if self.sigma.len() == 1 {
                self.sigma[0]
            } else {
                self.sigma[i % n]
            };
            let mut x = v + s * gaussian(&mut self.rng);
            if self.resolution > 0.0 {
                x = (x / self.resolution).round() * self.resolution;
            }
            out.push(x);
        }
        Ok(out)
    }
}

/// Depth camera noise; see the module documentation for the model.
#[derive(Debug, Clone)]
pub struct DepthNoise {
    /// Axial standard deviation at `z0` (m), >= 0.
    pub sigma0: f64,
    /// Quadratic growth of the standard deviation (1/m), >= 0.
    pub sigma2: f64,
    /// Depth (m) of the smallest noise, finite.
    pub z0: f64,
    /// Probability that any valid pixel is missing, [0, 1].
    pub dropout: f64,
    /// Depth jump (m) between 4-neighbours that makes a discontinuity, > 0.
    pub edge_threshold: f64,
    /// Extra probability that a pixel on a discontinuity is missing, [0, 1].
    pub edge_dropout: f64,
    /// Value written into missing pixels (finite or not).
    pub missing_value: f64,
    rng: StdRng,
}

/// The parameters of a [`DepthNoise`] model; `Default` holds the defaults
/// (the one definition; the Python `DepthNoise` takes them from here).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthNoiseParams {
    /// Axial standard deviation at `z0` (m), >= 0 (default 0.0012).
    pub sigma0: f64,
    /// Quadratic growth of the standard deviation (1/m), >= 0
    /// (default 0.0019).
    pub sigma2: f64,
    /// Depth (m) of the smallest noise, finite (default 0.4).
    pub z0: f64,
    /// Probability that any valid pixel is missing, [0, 1] (default 0.01).
    pub dropout: f64,
    /// Depth jump (m) between 4-neighbours that makes a discontinuity, > 0
    /// (default 0.02).
    pub edge_threshold: f64,
    /// Extra probability that a pixel on a discontinuity is missing, [0, 1]
    /// (default 0.5).
    pub edge_dropout: f64,
    /// Value written into missing pixels (finite or not; default 0).
    pub missing_value: f64,
    /// Seed of the noise (default 0).
    pub seed: u64,
}

impl Default for DepthNoiseParams {
    fn default() -> Self {
        Self {
            sigma0: 0.0012,
            sigma2: 0.0019,
            z0: 0.4,
            dropout: 0.01,
            edge_threshold: 0.02,
            edge_dropout: 0.5,
            missing_value: 0.0,
            seed: 0,
        }
    }
}

impl DepthNoise {
    /// A model with the given parameters (ranges as documented on the fields).
    pub fn new(p: DepthNoiseParams) -> Result<Self> {
        let DepthNoiseParams {
            sigma0,
            sigma2,
            z0,
            dropout,
            edge_threshold,
            edge_dropout,
            missing_value,
            seed,
        } = p;
        if !z0.is_finite() {
            return Err(invalid(format!("z0 must be finite, got {z0}")));
        }
        if !(edge_threshold.is_finite() && edge_threshold > 0.0) {
            return Err(invalid(format!(
                "edge_threshold must be finite and > 0, got {edge_threshold}"
            )));
        }
        Ok(Self {
            sigma0: non_negative("sigma0", sigma0)?,
            sigma2: non_negative("sigma2", sigma2)?,
            z0,
            dropout: probability("dropout", dropout)?,
            edge_threshold,
            edge_dropout: probability("edge_dropout", edge_dropout)?,
            missing_value,
            rng: StdRng::seed_from_u64(seed),
        })
    }

    /// Axial standard deviation (m) at depth `z` (m).
    pub fn sigma(&self, z: f64) -> f64 {
        self.sigma0 + self.sigma2 * (z - self.z0) * (z - self.z0)
    }

    fn valid(z: f64) -> bool {
        z.is_finite() && z > 0.0
    }

    fn check_shape(depth: &[f64], height: usize, width: usize) -> Result<()> {
        if height * width != depth.len() {
            return Err(ControlError::InvalidArgument(format!(
                "depth: {} values for a {height} x {width} image",
                depth.len()
            )));
        }
        Ok(())
    }

    /// Discontinuities of a `height x width` depth image (row-major): valid
    /// pixels with a 4-neighbour whose depth differs by more than
    /// `edge_threshold` or that has no reading.
    pub fn edges(&self, depth: &[f64], height: usize, width: usize) -> Result<Vec<bool>> {
        Self::check_shape(depth, height, width)?;
        let mut edge = vec![false; depth.len()];
        let jump = |a: f64, b: f64| {
            !(Self::valid(a) && Self::valid(b) && (a - b).abs() <= self.edge_threshold)
        };
        for r in 0..height {
            for c in 0..width {
                let i = r * width + c;
                if !Self::valid(depth[i]) {
                    continue;
                }
                let mut e = false;
                if c + 1 < width {
                    e |= jump(depth[i], depth[i + 1]);
                }
                if c > 0 {
                    e |= jump(depth[i], depth[i - 1]);
                }
                if r + 1 < height {
                    e |= jump(depth[i], depth[i + width]);
                }
                if r > 0 {
                    e |= jump(depth[i], depth[i - width]);
                }
                edge[i] = e;
            }
        }
        Ok(edge)
    }

    /// A noisy copy of a `height x width` depth image (m) and its mask of
    /// missing pixels.
    pub fn apply(
        &mut self,
        depth: &[f64],
        height: usize,
        width: usize,
    ) -> Result<(Vec<f64>, Vec<bool>)> {
        let edge = self.edges(depth, height, width)?;
        let mut out = Vec::with_capacity(depth.len());
        let mut missing = Vec::with_capacity(depth.len());
        for (&z, &e) in depth.iter().zip(&edge) {
            if !Self::valid(z) {
                out.push(self.missing_value);
                missing.push(true);
                continue;
            }
            let noisy = z + self.sigma(z) * gaussian(&mut self.rng);
            let mut drop = self.rng.random::<f64>() < self.dropout;
            if e {
                drop |= self.rng.random::<f64>() < self.edge_dropout;
            }
            out.push(if drop { self.missing_value } else { noisy });
            missing.push(drop);
        }
        Ok((out, missing))
    }
}

/// A resolution where two or more fresh sources commanded one joint with
/// values differing by more than the tolerance.
#[derive(Debug, Clone, PartialEq)]
pub struct Conflict {
    /// Query time (s).
    pub t: f64,
    /// Joint index.
    pub joint: usize,
    /// Winning source.
    pub winner: String,
    /// The other fresh sources, in the order they lost.
    pub losers: Vec<String>,
}

#[derive(Debug, Clone)]
struct Source {
    name: String,
    priority: i64,
    /// Per joint: (time, value) of the latest command.
    latest: Vec<Option<(f64, f64)>>,
}

/// Arbitration between command sources for the same joints. For each joint,
/// among the sources whose latest command for it is fresh (issued within
/// `timeout` s before the query time, and not after it), the highest
/// priority wins; among equal priorities the latest command; among equal
/// times the source registered first. Every resolution where two or more
/// fresh sources command one joint with values differing by more than
/// `tolerance` is recorded as a [`Conflict`].
#[derive(Debug, Clone)]
pub struct Arbiter {
    n: usize,
    timeout: f64,
    tolerance: f64,
    sources: Vec<Source>,
    conflicts: Vec<Conflict>,
}

impl Arbiter {
    /// An arbiter for `num_joints` (>= 1) joints, `timeout` (s, > 0) and
    /// `tolerance` (>= 0).
    pub fn new(num_joints: usize, timeout: f64, tolerance: f64) -> Result<Self> {
        if num_joints == 0 {
            return Err(invalid("num_joints must be >= 1, got 0".into()));
        }
        if !(timeout.is_finite() && timeout > 0.0) {
            return Err(invalid(format!(
                "timeout must be finite and > 0, got {timeout}"
            )));
        }
        Ok(Self {
            n: num_joints,
            timeout,
            tolerance: non_negative("tolerance", tolerance)?,
            sources: Vec::new(),
            conflicts: Vec::new(),
        })
    }

    /// Number of joints.
    pub fn num_joints(&self) -> usize {
        self.n
    }

    /// The freshness timeout (s).
    pub fn timeout(&self) -> f64 {
        self.timeout
    }

    /// Source names in registration order.
    pub fn sources(&self) -> Vec<&str> {
        self.sources.iter().map(|s| s.name.as_str()).collect()
    }

    /// Registers a source with a priority (higher wins).
    pub fn add_source(&mut self, name: &str, priority: i64) -> Result<()> {
        if self.sources.iter().any(|s| s.name == name) {
            return Err(invalid(format!("name: source '{name}' exists already")));
        }
        self.sources.push(Source {
            name: name.to_string(),
            priority,
            latest: vec![None; self.n],
        });
        Ok(())
    }

    /// Source `source` commands `values` for the joint indices `joints` at
    /// time `t`.
    pub fn command(
        &mut self,
        source: &str,
        t: f64,
        joints: &[usize],
        values: &[f64],
    ) -> Result<()> {
        let known = self.sources().join(", ");
        let n = self.n;
        let src = self
            .sources
            .iter_mut()
            .find(|s| s.name == source)
            .ok_or_else(|| {
                ControlError::UnknownName(format!(
                    "source: unknown source '{source}'; known: {known}"
                ))
            })?;
        if !t.is_finite() {
            return Err(ControlError::NonFinite(format!("t: non-finite time {t}")));
        }
        if joints.len() != values.len() {
            return Err(invalid(format!(
                "values: {} values for {} joints",
                values.len(),
                joints.len()
            )));
        }
        if let Some(j) = joints.iter().find(|&&j| j >= n) {
            return Err(ControlError::UnknownName(format!(
                "joints: index {j} is not in [0, {n})"
            )));
        }
        check_finite("values", values)?;
        for (&j, &v) in joints.iter().zip(values) {
            src.latest[j] = Some((t, v));
        }
        Ok(())
    }

    /// Per joint, the winning value (`None`: no fresh command) and the
    /// index of the winning source; conflicts are recorded.
    pub fn resolve(&mut self, t: f64) -> Result<Vec<Option<(f64, usize)>>> {
        if !t.is_finite() {
            return Err(ControlError::NonFinite(format!("t: non-finite time {t}")));
        }
        let mut out = vec![None; self.n];
        for (j, slot) in out.iter_mut().enumerate() {
            // (priority, time, rank, value)
            let mut fresh: Vec<(i64, f64, usize, f64)> = self
                .sources
                .iter()
                .enumerate()
                .filter_map(|(rank, s)| {
                    let (tc, v) = s.latest[j]?;
                    (t - tc <= self.timeout && tc <= t + 1e-12).then_some((s.priority, tc, rank, v))
                })
                .collect();
            if fresh.is_empty() {
                continue;
            }
            fresh.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.total_cmp(&a.1)).then(a.2.cmp(&b.2)));
            let win = fresh[0];
            *slot = Some((win.3, win.2));
            if fresh[1..]
                .iter()
                .any(|f| (f.3 - win.3).abs() > self.tolerance)
            {
                self.conflicts.push(Conflict {
                    t,
                    joint: j,
                    winner: self.sources[win.2].name.clone(),
                    losers: fresh[1..]
                        .iter()
                        .map(|f| self.sources[f.2].name.clone())
                        .collect(),
                });
            }
        }
        Ok(out)
    }

    /// Every conflict recorded so far.
    pub fn conflicts(&self) -> &[Conflict] {
        &self.conflicts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arbitration_rule() {
        let mut a = Arbiter::new(2, 0.1, 0.0).unwrap();
        a.add_source("low", 0).unwrap();
        a.add_source("high", 1).unwrap();
        a.add_source("low2", 0).unwrap();
        a.command("low", 0.0, &[0, 1], &[1.0, 2.0]).unwrap();
        a.command("low2", 0.01, &[1], &[3.0]).unwrap();
        a.command("high", 0.0, &[0], &[5.0]).unwrap();
        let r = a.resolve(0.02).unwrap();
        assert_eq!(r[0], Some((5.0, 1))); // priority
        assert_eq!(r[1], Some((3.0, 2))); // equal priority: the latest
        assert_eq!(a.conflicts().len(), 2);
        let r = a.resolve(0.5).unwrap(); // all stale
        assert_eq!(r, vec![None, None]);
    }
}
