//! Inverse kinematics: multi-seed damped least squares (Levenberg-Marquardt)
//! with joint limits, optionally collision-free, for single goals, goal sets
//! and batches spread over cores.
//!
//! Each seed iterates `dq = J^T (J J^T + lambda I)^-1 e` on the 6-D pose
//! error `e` (position, then the rotation vector taking the current
//! orientation to the goal, both in the base frame), clamps to the joint
//! limits, and stops once the position and rotation errors are below the
//! tolerances (cuRobo's defaults: 1 mm and 0.01 rad). A seed that stalls is
//! abandoned for the next (the given seeds first, then uniform random ones).

use ferrobot_collision::CollisionChecker;
use ferrobot_model::{KinematicChain, RobotModel};
use nalgebra::{Isometry3, Matrix6, Vector6};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;

use crate::error::{PlanningError, Result};
use crate::limits::KinematicLimits;
use crate::space::ActiveSpace;

/// Options of an IK solve.
#[derive(Debug, Clone)]
pub struct IkOptions {
    /// Position tolerance (m).
    pub position_tolerance: f64,
    /// Rotation tolerance (rad).
    pub rotation_tolerance: f64,
    /// Seeds to try at most (given seeds count towards it).
    pub num_seeds: usize,
    /// Iterations per seed at most.
    pub max_iterations: usize,
    /// Reject solutions in collision (needs a collision checker).
    pub collision_free: bool,
    /// Random seed of the random restarts (results are deterministic).
    pub seed: u64,
}

impl Default for IkOptions {
    fn default() -> Self {
        Self {
            position_tolerance: 1e-3,
            rotation_tolerance: 0.01,
            num_seeds: 200,
            max_iterations: 60,
            collision_free: false,
            seed: 0,
        }
    }
}

impl IkOptions {
    /// Checks the tolerances and counts.
    pub fn validate(&self) -> Result<()> {
        use ferrobot_model::ranges::{
            MAX_IK_ITERATIONS, MAX_IK_SEEDS, POSITION_TOLERANCE, ROTATION_TOLERANCE, check_count,
        };
        POSITION_TOLERANCE.check(self.position_tolerance)?;
        ROTATION_TOLERANCE.check(self.rotation_tolerance)?;
        check_count("num_seeds", self.num_seeds, 1, MAX_IK_SEEDS)?;
        check_count("max_iterations", self.max_iterations, 1, MAX_IK_ITERATIONS)?;
        Ok(())
    }
}

/// The outcome of one IK solve.
#[derive(Debug, Clone, PartialEq)]
pub struct IkSolution {
    /// Whether both tolerances were met (and, if asked, collision-free).
    pub success: bool,
    /// The solution (or the best attempt), active DOFs.
    pub q: Vec<f64>,
    /// Position error of `q` (m).
    pub position_error: f64,
    /// Rotation error of `q` (rad).
    pub rotation_error: f64,
    /// Index of the goal reached in the goal set.
    pub goal_index: usize,
    /// Seeds tried.
    pub seeds_tried: usize,
}

/// IK for one link of a robot over an active space.
#[derive(Debug, Clone)]
pub struct IkSolver<'a> {
    model: &'a RobotModel,
    space: &'a ActiveSpace,
    limits: KinematicLimits,
    chain: &'a KinematicChain,
    checker: Option<&'a CollisionChecker>,
}

/// Pose error `[position; rotation vector]` taking `pose` to `goal`.
#[inline]
fn pose_error(pose: &Isometry3<f64>, goal: &Isometry3<f64>) -> Vector6<f64> {
    let ep = goal.translation.vector - pose.translation.vector;
    let er = (goal.rotation * pose.rotation.inverse()).scaled_axis();
    Vector6::new(ep.x, ep.y, ep.z, er.x, er.y, er.z)
}

impl<'a> IkSolver<'a> {
    /// A solver for `link` of `model` moving the DOFs of `space`; solutions
    /// are checked against `checker` when collision-free IK is asked.
    pub fn new(
        model: &'a RobotModel,
        space: &'a ActiveSpace,
        link: usize,
        checker: Option<&'a CollisionChecker>,
    ) -> Result<Self> {
        if link >= model.links().len() {
            return Err(PlanningError::InvalidArgument(format!(
                "link index {link} out of range"
            )));
        }
        let chain = model.chain(link);
        if !chain.dofs().any(|d| space.dofs.contains(&d)) {
            return Err(PlanningError::InvalidArgument(format!(
                "no planned joint moves link '{}'",
                model.links()[link].name
            )));
        }
        Ok(Self {
            model,
            space,
            limits: KinematicLimits::from_model(model, &space.dofs),
            chain,
            checker,
        })
    }

    /// Pose of the link (base frame) at active configuration `q`.
    pub fn pose(&self, q: &[f64]) -> Isometry3<f64> {
        self.chain.pose(&self.space.expand(q))
    }

    /// Runs one seed from `q` towards `goal`: returns (errors met, position
    /// error, rotation error); `q` holds the end point.
    fn descend(
        &self,
        goal: &Isometry3<f64>,
        q: &mut [f64],
        opts: &IkOptions,
        full: &mut [f64],
        jac: &mut [f64],
    ) -> (bool, f64, f64) {
        let n = self.model.num_dof();
        let mut best = f64::INFINITY;
        let mut stall = 0;
        for _ in 0..opts.max_iterations {
            self.space.expand_into(q, full);
            jac.iter_mut().for_each(|v| *v = 0.0);
            let pose = self.chain.jacobian_into(full, n, jac);
            let e = pose_error(&pose, goal);
            let (ep, er) = (e.fixed_rows::<3>(0).norm(), e.fixed_rows::<3>(3).norm());
            if ep <= opts.position_tolerance && er <= opts.rotation_tolerance {
                return (true, ep, er);
            }
            let cost = ep * ep + er * er;
            if cost < best * 0.999 {
                best = cost;
                stall = 0;
            } else {
                stall += 1;
                if stall >= 6 {
                    break;
                }
            }
            // A = J J^T + lambda I over the active columns.
            let lambda = 1e-6 + 1e-3 * cost.min(1.0);
            let mut a = Matrix6::<f64>::identity() * lambda;
            for &d in &self.space.dofs {
                let col = Vector6::from_fn(|r, _| jac[r * n + d]);
                a += col * col.transpose();
            }
            let Some(chol) = a.cholesky() else { break };
            let y = chol.solve(&e);
            let mut step_max = 0.0f64;
            let mut dq = [0.0f64; 64];
            for (k, &d) in self.space.dofs.iter().enumerate() {
                let col = Vector6::from_fn(|r, _| jac[r * n + d]);
                dq[k] = col.dot(&y);
                step_max = step_max.max(dq[k].abs());
            }
            let scale = if step_max > 0.5 { 0.5 / step_max } else { 1.0 };
            for (k, v) in q.iter_mut().enumerate() {
                *v = (*v + dq[k] * scale).clamp(self.limits.lower[k], self.limits.upper[k]);
            }
        }
        // Errors at the end point.
        self.space.expand_into(q, full);
        let e = pose_error(&self.chain.pose(full), goal);
        let (ep, er) = (e.fixed_rows::<3>(0).norm(), e.fixed_rows::<3>(3).norm());
        (
            ep <= opts.position_tolerance && er <= opts.rotation_tolerance,
            ep,
            er,
        )
    }

    fn random_seed(&self, rng: &mut SmallRng) -> Vec<f64> {
        self.space
            .sample_lower
            .iter()
            .zip(&self.space.sample_upper)
            .map(|(&lo, &hi)| rng.random_range(lo..=hi))
            .collect()
    }

    fn check_inputs(
        &self,
        goals: &[Isometry3<f64>],
        seeds: &[Vec<f64>],
        opts: &IkOptions,
    ) -> Result<()> {
        opts.validate()?;
        if goals.is_empty() {
            return Err(PlanningError::InvalidArgument(
                "the goal set is empty".into(),
            ));
        }
        if self.space.len() > 64 {
            return Err(PlanningError::InvalidArgument(
                "IK supports at most 64 active DOFs".into(),
            ));
        }
        if opts.collision_free && self.checker.is_none() {
            return Err(PlanningError::InvalidArgument(
                "collision-free IK needs a collision checker".into(),
            ));
        }
        for s in seeds {
            if s.len() != self.space.len() {
                return Err(ferrobot_model::ModelError::Shape {
                    what: "seed".into(),
                    expected: format!("({},) planned joints", self.space.len()),
                    got: format!("({},)", s.len()),
                }
                .into());
            }
            crate::error::check_finite("seed", s)?;
        }
        Ok(())
    }

    /// Solves for any goal of the set `goals` (base frame). The given
    /// `seeds` are tried first (each against every goal), then random seeds
    /// round-robin over the goals.
    pub fn solve(
        &self,
        goals: &[Isometry3<f64>],
        seeds: &[Vec<f64>],
        opts: &IkOptions,
    ) -> Result<IkSolution> {
        self.check_inputs(goals, seeds, opts)?;
        Ok(self
            .solve_unchecked(goals, seeds, opts, opts.seed, 1, None)
            .remove(0))
    }

    /// Up to `count` distinct successful solutions over the goal set (fewer
    /// if the seed budget runs out; the best attempt if none succeeds).
    pub fn solve_many(
        &self,
        goals: &[Isometry3<f64>],
        seeds: &[Vec<f64>],
        opts: &IkOptions,
        count: usize,
    ) -> Result<Vec<IkSolution>> {
        self.check_inputs(goals, seeds, opts)?;
        Ok(self.solve_unchecked(goals, seeds, opts, opts.seed, count.max(1), None))
    }

    /// [`IkSolver::solve_many`] that stops drawing seeds once `deadline`
    /// has passed (the planner's time limit; at least one seed is tried).
    pub(crate) fn solve_many_until(
        &self,
        goals: &[Isometry3<f64>],
        seeds: &[Vec<f64>],
        opts: &IkOptions,
        count: usize,
        deadline: std::time::Instant,
    ) -> Result<Vec<IkSolution>> {
        self.check_inputs(goals, seeds, opts)?;
        Ok(self.solve_unchecked(goals, seeds, opts, opts.seed, count.max(1), Some(deadline)))
    }

    fn solve_unchecked(
        &self,
        goals: &[Isometry3<f64>],
        seeds: &[Vec<f64>],
        opts: &IkOptions,
        rng_seed: u64,
        count: usize,
        deadline: Option<std::time::Instant>,
    ) -> Vec<IkSolution> {
        let mut rng = SmallRng::seed_from_u64(rng_seed);
        let mut full = self.space.locked.clone();
        let mut jac = vec![0.0; 6 * self.model.num_dof()];
        let mut best: Option<IkSolution> = None;
        let mut found: Vec<IkSolution> = Vec::new();
        let given = seeds.len() * goals.len();
        let budget = opts.num_seeds.max(given);
        let mut tried = budget;
        for attempt in 0..budget {
            if attempt > 0 && deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                tried = attempt;
                break;
            }
            let (mut q, gi) = if attempt < given {
                (seeds[attempt / goals.len()].clone(), attempt % goals.len())
            } else {
                (self.random_seed(&mut rng), attempt % goals.len())
            };
            // Seeds outside the limits start at the nearest limit.
            for (k, v) in q.iter_mut().enumerate() {
                *v = v.clamp(self.limits.lower[k], self.limits.upper[k]);
            }
            let (ok, ep, er) = self.descend(&goals[gi], &mut q, opts, &mut full, &mut jac);
            let free = !ok
                || !opts.collision_free
                || self.checker.is_some_and(|c| {
                    self.space.expand_into(&q, &mut full);
                    !c.in_collision_unchecked(&full)
                });
            let sol = IkSolution {
                success: ok && free,
                q,
                position_error: ep,
                rotation_error: er,
                goal_index: gi,
                seeds_tried: attempt + 1,
            };
            if sol.success {
                let distinct = found.iter().all(|f| {
                    f.q.iter()
                        .zip(&sol.q)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max)
                        > 1e-2
                });
                if distinct {
                    found.push(sol);
                    if found.len() >= count {
                        break;
                    }
                }
            } else if best
                .as_ref()
                .is_none_or(|b| ep + er < b.position_error + b.rotation_error)
            {
                best = Some(sol);
            }
        }
        if found.is_empty() {
            let mut b = best.expect("at least one attempt");
            b.seeds_tried = tried;
            vec![b]
        } else {
            found
        }
    }

    /// Solves each goal of `goals` independently (goal `i` seeded by
    /// `seeds[i]` when given), in parallel.
    pub fn solve_batch(
        &self,
        goals: &[Isometry3<f64>],
        seeds: Option<&[Vec<f64>]>,
        opts: &IkOptions,
    ) -> Result<Vec<IkSolution>> {
        if let Some(s) = seeds
            && s.len() != goals.len()
        {
            return Err(PlanningError::InvalidArgument(format!(
                "{} seeds for {} goals",
                s.len(),
                goals.len()
            )));
        }
        self.check_inputs(goals, seeds.unwrap_or(&[]), opts)?;
        Ok(goals
            .par_iter()
            .enumerate()
            .with_min_len(8)
            .map(|(i, g)| {
                let seed: &[Vec<f64>] = match seeds {
                    Some(s) => std::slice::from_ref(&s[i]),
                    None => &[],
                };
                let rng_seed = opts.seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                self.solve_unchecked(std::slice::from_ref(g), seed, opts, rng_seed, 1, None)
                    .remove(0)
            })
            .collect())
    }
}

/// The rotation vector angle between two orientations (rad).
pub fn rotation_distance(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    (a.rotation * b.rotation.inverse()).angle()
}

/// The distance between two positions (m).
pub fn position_distance(a: &Isometry3<f64>, b: &Isometry3<f64>) -> f64 {
    (a.translation.vector - b.translation.vector).norm()
}
