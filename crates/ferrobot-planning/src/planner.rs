//! The motion generator: start and goal checks, IK goal sets for pose
//! goals, RRT-Connect, simplification, the smooth time-parametrised
//! trajectory and its dense collision re-check. A plan that fails returns a
//! [`PlanResult`] with its [`PlanStatus`]; only invalid calls are errors.

use std::sync::Arc;
use std::time::Instant;

use ferrobot_collision::{CollisionChecker, CollisionWorld};
use ferrobot_model::RobotModel;
use nalgebra::Isometry3;
use rand::SeedableRng;
use rand::rngs::SmallRng;

use crate::error::{Result, check_finite};
use crate::ik::{IkOptions, IkSolution, IkSolver};
use crate::limits::{KinematicLimits, LIMIT_TOLERANCE};
use crate::recheck;
use crate::rrt::{Edges, RrtFailure, RrtOptions, rrt_connect_until};
use crate::simplify::{SimplifyOptions, path_length, simplify};

impl PlanResult {
    /// Euclidean length of the path in the active space.
    pub fn path_length(&self) -> f64 {
        path_length(&self.path)
    }
}
use crate::space::ActiveSpace;
use crate::spline::Trajectory;
use crate::timing::{parametrize, parametrize_polyline};

/// Options of [`Planner::plan`].
#[derive(Debug, Clone)]
pub struct PlanOptions {
    /// RRT-Connect options (range, motion-check resolution, limits, seed).
    pub rrt: RrtOptions,
    /// Shortcutting options.
    pub simplify: SimplifyOptions,
    /// Simplify the path (true) or return RRT-Connect's path.
    pub simplify_path: bool,
    /// Build the time-parametrised trajectory (true) or stop at the path.
    pub trajectory: bool,
    /// IK options for pose goals (collision-free IK is always used).
    pub ik: IkOptions,
    /// IK solutions used as goal configurations for pose goals.
    pub goal_solutions: usize,
    /// Velocity limit factor in (0, 1].
    pub velocity_scale: f64,
    /// Acceleration and jerk limit factor in (0, 1].
    pub acceleration_scale: f64,
    /// RRT-Connect and shortcutting check motions at `rrt.resolution`
    /// times this factor; the final path is then checked at
    /// `rrt.resolution` (1 checks at the fine resolution throughout).
    pub coarse_factor: f64,
    /// Times the smooth trajectory is refined (a waypoint added where it
    /// collided) before falling back to stopping at every waypoint.
    pub refinements: usize,
}

impl Default for PlanOptions {
    fn default() -> Self {
        Self {
            rrt: RrtOptions::default(),
            simplify: SimplifyOptions::default(),
            simplify_path: true,
            trajectory: true,
            ik: IkOptions::default(),
            goal_solutions: 4,
            velocity_scale: 1.0,
            acceleration_scale: 1.0,
            refinements: 4,
            coarse_factor: 4.0,
        }
    }
}

impl PlanOptions {
    /// Checks every option.
    pub fn validate(&self) -> Result<()> {
        use ferrobot_model::ranges::{
            COARSE_FACTOR, MAX_GOAL_SOLUTIONS, MAX_RRT_SAMPLES, RESOLUTION, RRT_RANGE, SPEED_SCALE,
            TIME_LIMIT, check_count,
        };
        RRT_RANGE.check(self.rrt.range)?;
        RESOLUTION.check(self.rrt.resolution)?;
        TIME_LIMIT.check(self.rrt.time_limit.as_secs_f64())?;
        COARSE_FACTOR.check(self.coarse_factor)?;
        // The coarse search resolution stays a valid resolution too.
        RESOLUTION.check_as(
            "resolution * coarse_factor",
            self.rrt.resolution * self.coarse_factor,
        )?;
        SPEED_SCALE.check_as("velocity_scale", self.velocity_scale)?;
        SPEED_SCALE.check_as("acceleration_scale", self.acceleration_scale)?;
        check_count("max_samples", self.rrt.max_samples, 1, MAX_RRT_SAMPLES)?;
        check_count("goal_solutions", self.goal_solutions, 1, MAX_GOAL_SOLUTIONS)?;
        check_count("refinements", self.refinements, 0, 64)?;
        self.simplify.validate()?;
        self.ik.validate()
    }
}

/// The smooth trajectory of a plan and what making it cost.
#[derive(Debug, Default)]
struct Smoothed {
    trajectory: Trajectory,
    /// It stops at every waypoint (the smooth spline kept colliding, or
    /// the deadline passed).
    fell_back: bool,
    /// The fall-back was for the deadline.
    timed_out: bool,
    /// Time in spline fits and time parametrisation (s).
    fit: f64,
    /// Time in collision re-checks (s).
    recheck: f64,
    /// Configurations re-checked.
    samples: usize,
    /// Waypoints added.
    refinements: usize,
}

/// A check gave up because its deadline passed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimedOut;

/// The outcome of certifying (and repairing) a path found at samples.
enum Certified {
    /// Every edge of the (possibly repaired) path is certified free; per
    /// edge, whether its tube was certified too.
    Free(Vec<Vec<f64>>, Vec<bool>),
    /// An edge was not free and could not be repaired locally.
    Collides,
    /// The deadline passed.
    TimedOut,
}

/// Outcome of a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlanStatus {
    /// A collision-free path (and trajectory, if asked) was found.
    Solved,
    /// The start lies outside the joint limits.
    StartOutOfLimits,
    /// The goal configuration lies outside the joint limits.
    GoalOutOfLimits,
    /// The start configuration is in collision.
    StartInCollision,
    /// The goal configuration is in collision.
    GoalInCollision,
    /// No collision-free IK solution for any goal pose.
    IkFailed,
    /// The time limit passed before a path was found and checked at the
    /// final resolution (RRT-Connect, or the check of its path).
    Timeout,
    /// RRT-Connect ran out of samples.
    SampleLimit,
}

impl PlanStatus {
    /// A short snake_case name (used by the Python API and reports).
    pub fn name(self) -> &'static str {
        match self {
            Self::Solved => "solved",
            Self::StartOutOfLimits => "start_out_of_limits",
            Self::GoalOutOfLimits => "goal_out_of_limits",
            Self::StartInCollision => "start_in_collision",
            Self::GoalInCollision => "goal_in_collision",
            Self::IkFailed => "ik_failed",
            Self::Timeout => "timeout",
            Self::SampleLimit => "sample_limit",
        }
    }
}

/// Wall-clock time of each stage (s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// IK for pose goals.
    pub ik: f64,
    /// Checks of start and goal, and RRT-Connect.
    pub planning: f64,
    /// Shortcutting, and the continuous certification of the final path
    /// (with its repairs).
    pub simplify: f64,
    /// Of `simplify`: the certification of the final path.
    pub certify: f64,
    /// Trajectory fitting, time parametrisation and dense re-check.
    pub trajectory: f64,
    /// Of `trajectory`: spline fits and time parametrisation (every
    /// refinement included).
    pub fit: f64,
    /// Of `trajectory`: collision re-checks of the smooth trajectory.
    pub recheck: f64,
    /// Everything.
    pub total: f64,
}

/// What a plan's stages did, counted (for profiling the planner; the
/// figures of `examples/plan_ab.rs`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PlanCounts {
    /// Motion checks of RRT-Connect (the direct connection included).
    pub rrt_checks: usize,
    /// Waypoints of RRT-Connect's path.
    pub rrt_vertices: usize,
    /// Motion checks of the vertex reductions (before and after the
    /// shortcuts).
    pub reduce_checks: usize,
    /// Shortcut candidates drawn (the same segment twice included).
    pub shortcuts_drawn: usize,
    /// Of them, not checked for gaining less than `min_gain`.
    pub shortcuts_small: usize,
    /// Of them, motion-checked.
    pub shortcuts_checked: usize,
    /// Of them, free and kept.
    pub shortcuts_kept: usize,
    /// Edges of the shortcut path certified.
    pub certify_edges: usize,
    /// Configurations the continuous certification of the final path
    /// tested (world, with the tube and without it).
    pub certify_tested: usize,
    /// Chunks whose tube was not certified (redone without it).
    pub tube_failures: usize,
    /// Edges not free at the final resolution (each repaired locally or the
    /// whole problem searched again).
    pub not_free: usize,
    /// Local repairs that succeeded.
    pub repairs: usize,
}

/// The result of a plan (active DOFs throughout).
#[derive(Debug, Clone)]
pub struct PlanResult {
    /// Outcome.
    pub status: PlanStatus,
    /// A human-readable reason (when solved: empty, or a note such as the
    /// time limit cutting smoothing short).
    pub message: String,
    /// The geometric path (start first); empty unless solved.
    pub path: Vec<Vec<f64>>,
    /// The time-parametrised trajectory, if solved and asked for.
    pub trajectory: Option<Trajectory>,
    /// The goal configuration reached (for pose goals: the IK solution).
    pub goal: Option<Vec<f64>>,
    /// Stage times.
    pub times: StageTimes,
    /// RRT-Connect samples drawn.
    pub samples: usize,
    /// Whether the trajectory had to stop at every waypoint (the smooth
    /// spline collided even after refinement).
    pub stops_at_waypoints: bool,
    /// Configurations the trajectory's collision re-checks tested.
    pub recheck_samples: usize,
    /// Waypoints added to the smooth trajectory where it collided.
    pub refinements: usize,
    /// What the stages did, counted.
    pub counts: PlanCounts,
}

impl PlanResult {
    /// Whether the plan succeeded.
    pub fn success(&self) -> bool {
        self.status == PlanStatus::Solved
    }

    fn failed(status: PlanStatus, message: String, times: StageTimes) -> Self {
        Self {
            status,
            message,
            path: Vec::new(),
            trajectory: None,
            goal: None,
            times,
            samples: 0,
            stops_at_waypoints: false,
            recheck_samples: 0,
            refinements: 0,
            counts: PlanCounts::default(),
        }
    }
}

/// What a plan request reaches.
#[derive(Debug, Clone)]
pub enum Goal {
    /// One active configuration.
    Configuration(Vec<f64>),
    /// Any pose of a goal set of the IK link (base frame), reached through
    /// collision-free IK.
    Poses(Vec<Isometry3<f64>>),
}

/// One plan query: everything that varies between queries on one planner.
#[derive(Debug, Clone)]
pub struct PlanRequest {
    /// Start, in the planner's active space.
    pub start: Vec<f64>,
    /// Goal.
    pub goal: Goal,
    /// A full configuration (`dof_names` order) whose entries for the
    /// joints the planner does not move hold them for this query (a
    /// gripper's measured opening, say); None keeps the planner's.
    pub locked: Option<Vec<f64>>,
    /// Options.
    pub options: PlanOptions,
}

/// A motion planner for one robot, one sphere model and one world.
#[derive(Debug, Clone)]
pub struct Planner {
    checker: CollisionChecker,
    space: ActiveSpace,
    limits: KinematicLimits,
    link: usize,
}

impl Planner {
    /// A planner moving the model's planning-group DOFs (from the SRDF
    /// group chosen at load time, or the chain from the base to the end
    /// effector), with IK for `link` (default: the end effector).
    pub fn new(checker: CollisionChecker, link: Option<usize>) -> Result<Self> {
        let model = checker.model().clone();
        let space = ActiveSpace::new(&model, model.group_dofs())?;
        let limits = KinematicLimits::from_model(&model, &space.dofs);
        let link = link.unwrap_or(model.ee_link());
        IkSolver::new(&model, &space, link, None)?;
        Ok(Self {
            checker,
            space,
            limits,
            link,
        })
    }

    /// The robot model.
    pub fn model(&self) -> &Arc<RobotModel> {
        self.checker.model()
    }

    /// The collision checker.
    pub fn checker(&self) -> &CollisionChecker {
        &self.checker
    }

    /// The collision checker, to attach objects or change the margin.
    pub fn checker_mut(&mut self) -> &mut CollisionChecker {
        &mut self.checker
    }

    /// Replaces the world.
    pub fn update_world(&mut self, world: CollisionWorld) {
        self.checker.set_world(world);
    }

    /// The active space (planned joints, locked values).
    pub fn space(&self) -> &ActiveSpace {
        &self.space
    }

    /// Locks the non-planned DOFs at the values of a full configuration.
    pub fn set_locked(&mut self, full: &[f64]) -> Result<()> {
        self.model()
            .check_configuration("locked configuration", full)?;
        self.space.lock_from(full);
        Ok(())
    }

    /// The kinematic limits of the planned joints.
    pub fn limits(&self) -> &KinematicLimits {
        &self.limits
    }

    /// Replaces the kinematic limits (same length, positive).
    pub fn limits_mut(&mut self) -> &mut KinematicLimits {
        &mut self.limits
    }

    /// The IK link.
    pub fn ik_link(&self) -> usize {
        self.link
    }

    /// An IK solver for `link` (default: the planner's IK link), checking
    /// collisions with this planner's checker when asked.
    pub fn ik_solver(&self, link: Option<usize>) -> Result<IkSolver<'_>> {
        IkSolver::new(
            self.checker.model(),
            &self.space,
            link.unwrap_or(self.link),
            Some(&self.checker),
        )
    }

    fn check_active(&self, what: &str, q: &[f64]) -> Result<()> {
        if q.len() != self.space.len() {
            return Err(ferrobot_model::ModelError::Shape {
                what: what.into(),
                expected: format!(
                    "({},) planned joints {:?}",
                    self.space.len(),
                    self.space.names
                ),
                got: format!("({},)", q.len()),
            }
            .into());
        }
        check_finite(what, q)
    }

    fn in_collision(&self, space: &ActiveSpace, q: &[f64]) -> bool {
        self.checker.in_collision_unchecked(&space.expand(q))
    }

    fn explain(&self, space: &ActiveSpace, q: &[f64]) -> String {
        match self.checker.contacts(&space.expand(q)) {
            Ok(c) if !c.is_empty() => c
                .iter()
                .take(3)
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join("; "),
            _ => "in collision".into(),
        }
    }

    /// Plans from the active configuration `start` to the active
    /// configuration `goal`.
    pub fn plan(&self, start: &[f64], goal: &[f64], opts: &PlanOptions) -> Result<PlanResult> {
        self.plan_in(&self.space, start, goal, opts)
    }

    /// Plans from `start` to any pose of the goal set `goals` (base frame)
    /// of the IK link, through collision-free IK solutions.
    pub fn plan_to_poses(
        &self,
        start: &[f64],
        goals: &[Isometry3<f64>],
        opts: &PlanOptions,
    ) -> Result<PlanResult> {
        self.plan_to_poses_in(&self.space, start, goals, opts)
    }

    /// Answers one plan request: its start, goal, locked joints and options
    /// travel with the query, so concurrent queries with different locked
    /// joints share one planner (and its compiled robot and world) instead
    /// of each needing a copy.
    pub fn solve(&self, request: &PlanRequest) -> Result<PlanResult> {
        let local;
        let space = match &request.locked {
            Some(full) => {
                self.model()
                    .check_configuration("locked configuration", full)?;
                let mut s = self.space.clone();
                s.lock_from(full);
                local = s;
                &local
            }
            None => &self.space,
        };
        match &request.goal {
            Goal::Configuration(goal) => {
                self.plan_in(space, &request.start, goal, &request.options)
            }
            Goal::Poses(goals) => {
                self.plan_to_poses_in(space, &request.start, goals, &request.options)
            }
        }
    }

    fn plan_in(
        &self,
        space: &ActiveSpace,
        start: &[f64],
        goal: &[f64],
        opts: &PlanOptions,
    ) -> Result<PlanResult> {
        self.check_active("start", start)?;
        self.check_active("goal", goal)?;
        opts.validate()?;
        let began = Instant::now();
        let Some(goal) = self.limits.clamp_within(goal, LIMIT_TOLERANCE) else {
            return Ok(PlanResult::failed(
                PlanStatus::GoalOutOfLimits,
                format!(
                    "goal {goal:?} lies more than {LIMIT_TOLERANCE} outside the joint limits ({})",
                    self.limit_excess(goal)
                ),
                StageTimes::default(),
            ));
        };
        let goal = goal.as_slice();
        let start = match self.check_start(space, start, began) {
            Ok(s) => s,
            Err(r) => return Ok(*r),
        };
        let start = start.as_slice();
        if self.in_collision(space, goal) {
            return Ok(PlanResult::failed(
                PlanStatus::GoalInCollision,
                format!("goal in collision: {}", self.explain(space, goal)),
                StageTimes::default(),
            ));
        }
        Ok(self.search(space, start, &[goal.to_vec()], opts, began, 0.0))
    }

    fn plan_to_poses_in(
        &self,
        space: &ActiveSpace,
        start: &[f64],
        goals: &[Isometry3<f64>],
        opts: &PlanOptions,
    ) -> Result<PlanResult> {
        self.check_active("start", start)?;
        opts.validate()?;
        let began = Instant::now();
        let start = match self.check_start(space, start, began) {
            Ok(s) => s,
            Err(r) => return Ok(*r),
        };
        let start = start.as_slice();
        let solver = IkSolver::new(self.checker.model(), space, self.link, Some(&self.checker))?;
        let ik_opts = IkOptions {
            collision_free: true,
            ..opts.ik.clone()
        };
        let deadline = began + opts.rrt.time_limit;
        let solutions: Vec<IkSolution> = solver.solve_many_until(
            goals,
            &[start.to_vec()],
            &ik_opts,
            opts.goal_solutions,
            deadline,
        )?;
        let ik_time = began.elapsed().as_secs_f64();
        let mut goal_qs: Vec<Vec<f64>> = solutions
            .into_iter()
            .filter(|s| s.success)
            .map(|s| s.q)
            .collect();
        if goal_qs.is_empty() {
            let timed_out = Instant::now() >= deadline;
            return Ok(PlanResult::failed(
                if timed_out {
                    PlanStatus::Timeout
                } else {
                    PlanStatus::IkFailed
                },
                if timed_out {
                    format!(
                        "the time limit ({} s) passed before a collision-free IK solution for {} goal pose(s) was found",
                        opts.rrt.time_limit.as_secs_f64(),
                        goals.len()
                    )
                } else {
                    format!(
                        "no collision-free IK solution for {} goal pose(s) after {} seeds",
                        goals.len(),
                        ik_opts.num_seeds
                    )
                },
                StageTimes {
                    ik: ik_time,
                    total: ik_time,
                    ..StageTimes::default()
                },
            ));
        }
        // Nearest goal first: the direct connection is tried in this order.
        let dist =
            |q: &Vec<f64>| -> f64 { q.iter().zip(start).map(|(a, b)| (a - b) * (a - b)).sum() };
        goal_qs.sort_by(|a, b| dist(a).total_cmp(&dist(b)));
        Ok(self.search(space, start, &goal_qs, opts, began, ik_time))
    }

    /// The start clamped into the limits (within [`LIMIT_TOLERANCE`]) and
    /// free of collision, else the failed result.
    fn check_start(
        &self,
        space: &ActiveSpace,
        start: &[f64],
        began: Instant,
    ) -> std::result::Result<Vec<f64>, Box<PlanResult>> {
        let times = StageTimes {
            total: began.elapsed().as_secs_f64(),
            ..StageTimes::default()
        };
        let Some(start) = self.limits.clamp_within(start, LIMIT_TOLERANCE) else {
            return Err(Box::new(PlanResult::failed(
                PlanStatus::StartOutOfLimits,
                format!(
                    "start {start:?} lies more than {LIMIT_TOLERANCE} outside the joint limits ({})",
                    self.limit_excess(start)
                ),
                times,
            )));
        };
        if self.in_collision(space, &start) {
            return Err(Box::new(PlanResult::failed(
                PlanStatus::StartInCollision,
                format!("start in collision: {}", self.explain(space, &start)),
                times,
            )));
        }
        Ok(start)
    }

    /// Names the active joints of `q` outside their limits, with by how much.
    fn limit_excess(&self, q: &[f64]) -> String {
        let names = &self.space.names;
        q.iter()
            .enumerate()
            .filter_map(|(i, v)| {
                let (lo, hi) = (self.limits.lower[i], self.limits.upper[i]);
                let name = names.get(i).map(String::as_str).unwrap_or("?");
                if *v < lo {
                    Some(format!("{name} {v} < {lo}"))
                } else if *v > hi {
                    Some(format!("{name} {v} > {hi}"))
                } else {
                    None
                }
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn search(
        &self,
        space: &ActiveSpace,
        start: &[f64],
        goals: &[Vec<f64>],
        opts: &PlanOptions,
        began: Instant,
        ik_time: f64,
    ) -> PlanResult {
        let mut times = StageTimes {
            ik: ik_time,
            ..StageTimes::default()
        };
        // One deadline for the whole call (IK for pose goals included):
        // RRT-Connect, shortcutting, the check at the final resolution and
        // the trajectory's dense re-check all give up when it passes.
        let deadline = began + opts.rrt.time_limit;
        // Search and shortcut at the coarse resolution, then certify the
        // final edges continuously (every configuration free, not only the
        // samples; see `ferrobot_collision::certify`); a path that fails
        // there (rare) is searched again with certified edges.
        let coarse = opts.rrt.resolution * opts.coarse_factor.max(1.0);
        let mut counts = PlanCounts::default();
        let mut attempt = self.find_path(
            space,
            start,
            goals,
            opts,
            coarse,
            false,
            deadline,
            &mut times,
            &mut counts,
        );
        let mut unchecked = false;
        let mut tubes = Vec::new();
        let t = Instant::now();
        let certified = match &attempt.0 {
            Ok(path) => Some(self.certify_repairing(space, path, opts, deadline, &mut counts)),
            Err(_) => None,
        };
        if let Some(certified) = certified {
            let elapsed = t.elapsed().as_secs_f64();
            times.simplify += elapsed;
            times.certify += elapsed;
            match certified {
                // The path was found at samples only: it is not returned
                // uncertified.
                Certified::TimedOut => unchecked = true,
                Certified::Free(repaired, flags) => {
                    tubes = flags;
                    attempt.0 = Ok(repaired);
                }
                Certified::Collides => {
                    attempt = self.find_path(
                        space,
                        start,
                        goals,
                        opts,
                        opts.rrt.resolution,
                        true,
                        deadline,
                        &mut times,
                        &mut counts,
                    );
                    if let (Ok(path), _) = &attempt {
                        let t = Instant::now();
                        match self.certify_path(
                            space,
                            path,
                            opts.rrt.resolution,
                            deadline,
                            &mut counts,
                        ) {
                            Some(Some(flags)) => tubes = flags,
                            // Its edges were certified by the search: only
                            // the deadline can stop this.
                            _ => unchecked = true,
                        }
                        let elapsed = t.elapsed().as_secs_f64();
                        times.simplify += elapsed;
                        times.certify += elapsed;
                    }
                }
            }
        }
        let (found, stats) = attempt;
        let path = match found {
            Ok(_) if unchecked => {
                times.total = began.elapsed().as_secs_f64();
                let mut r = PlanResult::failed(
                    PlanStatus::Timeout,
                    format!(
                        "a path was found at the coarse resolution {coarse} but the time limit \
                         ({} s) passed while certifying it free (intervals of the resolution {})",
                        opts.rrt.time_limit.as_secs_f64(),
                        opts.rrt.resolution
                    ),
                    times,
                );
                r.samples = stats.samples;
                r.counts = counts;
                return r;
            }
            Ok(p) => p,
            Err(f) => {
                times.total = began.elapsed().as_secs_f64();
                let (status, what) = match f {
                    RrtFailure::Timeout => (PlanStatus::Timeout, "time limit"),
                    RrtFailure::SampleLimit => (PlanStatus::SampleLimit, "sample limit"),
                };
                let mut r = PlanResult::failed(
                    status,
                    format!("no path within the {what} ({} samples)", stats.samples),
                    times,
                );
                r.samples = stats.samples;
                r.counts = counts;
                return r;
            }
        };
        let t2 = Instant::now();
        let mut stops = false;
        let (mut recheck_samples, mut refinements) = (0, 0);
        let mut message = String::new();
        let trajectory = if opts.trajectory {
            let limits = self
                .limits
                .scaled(opts.velocity_scale, opts.acceleration_scale)
                .expect("scales validated by the caller");
            let out = self.smooth(space, &path, &tubes, &limits, opts, deadline);
            stops = out.fell_back;
            times.fit = out.fit;
            times.recheck = out.recheck;
            recheck_samples = out.samples;
            refinements = out.refinements;
            let traj = out.trajectory;
            if out.timed_out {
                message = format!(
                    "the time limit ({} s) passed while checking the smooth trajectory: it \
                     stops at every waypoint of the checked path instead",
                    opts.rrt.time_limit.as_secs_f64()
                );
            }
            Some(traj)
        } else {
            None
        };
        times.trajectory = t2.elapsed().as_secs_f64();
        times.total = began.elapsed().as_secs_f64();
        PlanResult {
            status: PlanStatus::Solved,
            message,
            goal: path.last().cloned(),
            path,
            trajectory,
            times,
            samples: stats.samples,
            stops_at_waypoints: stops,
            recheck_samples,
            refinements,
            counts,
        }
    }

    /// RRT-Connect and shortcutting with motion checks at `resolution`;
    /// stage times are added to `times`.
    #[allow(clippy::too_many_arguments)]
    fn find_path(
        &self,
        space: &ActiveSpace,
        start: &[f64],
        goals: &[Vec<f64>],
        opts: &PlanOptions,
        resolution: f64,
        certified: bool,
        deadline: Instant,
        times: &mut StageTimes,
        counts: &mut PlanCounts,
    ) -> (
        std::result::Result<Vec<Vec<f64>>, RrtFailure>,
        crate::rrt::RrtStats,
    ) {
        let t0 = Instant::now();
        let rrt = RrtOptions {
            resolution,
            ..opts.rrt.clone()
        };
        let (found, stats) = rrt_connect_until(
            &self.checker,
            space,
            start,
            goals,
            &rrt,
            deadline,
            certified,
        );
        times.planning += t0.elapsed().as_secs_f64();
        counts.rrt_checks += stats.motion_checks;
        if let Ok(path) = &found {
            counts.rrt_vertices += path.len();
        }
        let t1 = Instant::now();
        let found = found.map(|path| {
            if opts.simplify_path {
                let mut edges = Edges::new(&self.checker, space, resolution)
                    .until(deadline)
                    .certified(certified);
                let mut rng = SmallRng::seed_from_u64(opts.rrt.seed ^ 0x5EED);
                simplify(
                    &mut edges,
                    path,
                    &self.simplify_options(opts, certified),
                    &mut rng,
                    counts,
                )
            } else {
                path
            }
        });
        times.simplify += t1.elapsed().as_secs_f64();
        (found, stats)
    }

    /// The smooth trajectory through `path`, refined where it collides;
    /// falls back to stopping at every waypoint (which follows the checked
    /// path exactly, so needs no further check).
    fn smooth(
        &self,
        space: &ActiveSpace,
        path: &[Vec<f64>],
        tubes: &[bool],
        limits: &KinematicLimits,
        opts: &PlanOptions,
        deadline: Instant,
    ) -> Smoothed {
        let mut out = Smoothed::default();
        let mut waypoints = path.to_vec();
        // Per waypoint segment: certified with the tube of the re-check's
        // skipping tolerance (split segments keep their parent's flag).
        let mut tubes = tubes.to_vec();
        let polyline = |out: &mut Smoothed, timed_out: bool| {
            let t = Instant::now();
            let traj = parametrize_polyline(path, limits);
            out.fit += t.elapsed().as_secs_f64();
            out.fell_back = true;
            out.timed_out = timed_out;
            traj
        };
        for _ in 0..=opts.refinements {
            if Instant::now() >= deadline {
                let traj = polyline(&mut out, true);
                return Smoothed {
                    trajectory: traj,
                    ..out
                };
            }
            let t = Instant::now();
            let traj = parametrize(&waypoints, limits);
            out.fit += t.elapsed().as_secs_f64();
            let t = Instant::now();
            let found = self.first_collision_counted(
                space,
                &traj,
                opts.rrt.resolution,
                Some((&waypoints, &tubes)),
                Some(deadline),
                &mut out.samples,
            );
            out.recheck += t.elapsed().as_secs_f64();
            match found {
                Err(TimedOut) => {
                    let traj = polyline(&mut out, true);
                    return Smoothed {
                        trajectory: traj,
                        ..out
                    };
                }
                Ok(None) => {
                    return Smoothed {
                        trajectory: traj,
                        ..out
                    };
                }
                Ok(Some(seg)) => {
                    let mid: Vec<f64> = waypoints[seg]
                        .iter()
                        .zip(&waypoints[seg + 1])
                        .map(|(a, b)| 0.5 * (a + b))
                        .collect();
                    waypoints.insert(seg + 1, mid);
                    let flag = tubes[seg];
                    tubes.insert(seg + 1, flag);
                    out.refinements += 1;
                }
            }
        }
        let traj = polyline(&mut out, false);
        Smoothed {
            trajectory: traj,
            ..out
        }
    }

    /// Certifies `traj` free continuously, from intervals over which no
    /// joint moves more than `resolution` (see
    /// [`ferrobot_collision::certify`]), and returns the waypoint segment of
    /// the first piece that is not (it collides or passes within
    /// micrometres of a collision); early exit at the first such piece.
    pub fn first_collision(&self, traj: &Trajectory, resolution: f64) -> Option<usize> {
        // Without a deadline there is always an answer.
        self.first_collision_in(&self.space, traj, resolution, None)
            .unwrap_or(Some(0))
    }

    /// Whether every edge of `path` (active configurations, free end
    /// points) is free as [`Planner::plan`] certifies its final path: the
    /// world at every configuration of each edge (continuously), the robot
    /// free of itself at samples no more than `resolution` apart.
    pub fn path_certified(&self, path: &[Vec<f64>], resolution: f64) -> Result<bool> {
        ferrobot_model::ranges::RESOLUTION.check(resolution)?;
        for (k, q) in path.iter().enumerate() {
            self.check_active(&format!("path[{k}]"), q)?;
        }
        let far = Instant::now() + std::time::Duration::from_secs(3600);
        let certified = self.certify_path(
            &self.space,
            path,
            resolution,
            far,
            &mut PlanCounts::default(),
        );
        Ok(matches!(certified, Some(Some(_))))
    }

    /// [`Planner::first_collision`] that gives up when `deadline` passes
    /// (read between chunks of configurations).
    pub fn first_collision_until(
        &self,
        traj: &Trajectory,
        resolution: f64,
        deadline: Option<Instant>,
    ) -> std::result::Result<Option<usize>, TimedOut> {
        self.first_collision_in(&self.space, traj, resolution, deadline)
    }

    fn first_collision_in(
        &self,
        space: &ActiveSpace,
        traj: &Trajectory,
        resolution: f64,
        deadline: Option<Instant>,
    ) -> std::result::Result<Option<usize>, TimedOut> {
        self.first_collision_counted(space, traj, resolution, None, deadline, &mut 0)
    }

    /// Shortcutting options for edges checked at samples (`certified`
    /// false: the final path is certified afterwards, so parts of checked
    /// edges need no check of their own) or certified (true: the parts are
    /// certified on their own, since a part's certificate uses its own
    /// intervals and work budget, and a failure falls back to the vertex
    /// reduction, whose edges were certified whole).
    fn simplify_options(&self, opts: &PlanOptions, certified: bool) -> SimplifyOptions {
        SimplifyOptions {
            recheck_parts: opts.simplify.recheck_parts || certified,
            ..opts.simplify.clone()
        }
    }

    /// Certifies every edge of `path` (found and shortcut at samples) free
    /// continuously, like [`Planner::certify_path`]; an edge that is not
    /// free (it grazes an obstacle between the coarse samples) is replaced
    /// by a local RRT-Connect between its two end points with certified
    /// edges, shortcut with certified edges, instead of searching the whole
    /// problem again. [`Certified::Collides`] when a local search fails too.
    fn certify_repairing(
        &self,
        space: &ActiveSpace,
        path: &[Vec<f64>],
        opts: &PlanOptions,
        deadline: Instant,
        counts: &mut PlanCounts,
    ) -> Certified {
        let resolution = opts.rrt.resolution;
        let mut out = vec![path[0].clone()];
        let mut flags = Vec::with_capacity(path.len().saturating_sub(1));
        for (k, w) in path.windows(2).enumerate() {
            match self.certify_path(space, w, resolution, deadline, counts) {
                None => return Certified::TimedOut,
                Some(Some(f)) => {
                    flags.extend(f);
                    out.push(w[1].clone());
                }
                Some(None) => {
                    // Both end points are free (configurations of a checked
                    // path); search between them with certified edges.
                    let rrt = RrtOptions {
                        resolution,
                        seed: opts.rrt.seed ^ (0xEDCE << 16) ^ k as u64,
                        ..opts.rrt.clone()
                    };
                    let (found, _) = rrt_connect_until(
                        &self.checker,
                        space,
                        &w[0],
                        std::slice::from_ref(&w[1]),
                        &rrt,
                        deadline,
                        true,
                    );
                    let Ok(local) = found else {
                        return if Instant::now() >= deadline {
                            Certified::TimedOut
                        } else {
                            Certified::Collides
                        };
                    };
                    let local = if opts.simplify_path {
                        let mut edges = Edges::new(&self.checker, space, resolution)
                            .until(deadline)
                            .certified(true);
                        let mut rng = SmallRng::seed_from_u64(rrt.seed ^ 0x5EED);
                        simplify(
                            &mut edges,
                            local,
                            &self.simplify_options(opts, true),
                            &mut rng,
                            counts,
                        )
                    } else {
                        local
                    };
                    // Its edges are certified (or parts of certified edges);
                    // this adds the tubes.
                    match self.certify_path(space, &local, resolution, deadline, counts) {
                        Some(Some(f)) => {
                            counts.repairs += 1;
                            flags.extend(f)
                        }
                        None => return Certified::TimedOut,
                        Some(None) => return Certified::Collides,
                    }
                    out.extend(local.into_iter().skip(1));
                }
            }
        }
        Certified::Free(out, flags)
    }

    /// Certifies every edge of `path` free in one pass per interval: the
    /// edge is cut into intervals over which no DOF moves more than
    /// `resolution`, and each interval's midpoint is tested with the self
    /// pairs at the margin and the world at the margin grown by what the
    /// robot can move over half the interval (one kernel pass, see
    /// [`ferrobot_collision::certify`]; intervals that fail are split).
    /// So the world is free at every configuration of the edge and the
    /// robot free of itself at samples no more than `resolution` apart (the
    /// midpoints, and the edge's end points, which are free vertices of a
    /// checked path), with no separate motion check at samples (before:
    /// the motion check at samples, then the world with the tube of
    /// [`recheck::SKIP_DEVIATION`] x `resolution`, chunk by chunk; this
    /// costs 35-40 % less in the cage and clutter scene classes). Per edge,
    /// whether the tube around it was certified (`Some(Some(flags))`; always
    /// `false`: the tube is not certified any more, so the trajectory
    /// re-check tests the pieces near a segment that do not lie on it; a
    /// tube would test the self pairs at the margin grown by the tube, where
    /// the checker can miss a self-collision it finds at the margin, see
    /// `tests/certify_path.rs`), `Some(None)` when an edge is not free,
    /// `None` when `deadline` passed first.
    fn certify_path(
        &self,
        space: &ActiveSpace,
        path: &[Vec<f64>],
        resolution: f64,
        deadline: Instant,
        counts: &mut PlanCounts,
    ) -> Option<Option<Vec<bool>>> {
        let (a, b) = (&mut space.locked.clone(), &mut space.locked.clone());
        let mut flags = Vec::with_capacity(path.len().saturating_sub(1));
        for w in path.windows(2) {
            space.expand_into(&w[0], a);
            space.expand_into(&w[1], b);
            counts.certify_edges += 1;
            // The intervals of the whole edge: with the tube until a chunk
            // fails with it, then without; a chunk that fails the tube is
            // certified again without it, the chunks before it are not.
            let steps = crate::rrt::certify_steps(a, b, resolution);
            let free = crate::rrt::certify_segment_part(
                &self.checker,
                a,
                b,
                (0, steps, steps),
                0.0,
                Some(deadline),
                &mut counts.certify_tested,
            )?;
            if !free {
                counts.not_free += 1;
                return Some(None);
            }
            flags.push(false);
        }
        Some(Some(flags))
    }

    /// [`Planner::first_collision_in`] adding the configurations it tested
    /// to `tested`. Every piece of the trajectory is certified free
    /// continuously ([`ferrobot_collision::certify`]: intervals over which
    /// no joint moves more than `resolution`, each proven free with the
    /// spheres grown by what the robot can move over it, split where that
    /// fails). With `verified` (the waypoints `traj` was fitted through and,
    /// per segment, whether the tube of [`crate::recheck::SKIP_DEVIATION`] x
    /// `resolution` around it was certified), the pieces within that tube
    /// of such a segment are skipped and the others checked furthest first
    /// ([`crate::recheck`]).
    fn first_collision_counted(
        &self,
        space: &ActiveSpace,
        traj: &Trajectory,
        resolution: f64,
        verified: Option<(&[Vec<f64>], &[bool])>,
        deadline: Option<Instant>,
        tested: &mut usize,
    ) -> std::result::Result<Option<usize>, TimedOut> {
        let dim = traj.dim();
        let n = self.model().num_dof();
        let all = recheck::pieces(traj, resolution, verified.map(|v| v.0));
        let order = match verified {
            Some((_, tubes)) => {
                let mut order = recheck::to_check(&all, resolution);
                // Pieces near a segment whose tube was not certified are
                // checked too, unless they lie on it (up to rounding).
                order.extend(all.iter().filter(|p| {
                    p.deviation <= recheck::SKIP_DEVIATION * resolution
                        && p.deviation > recheck::ON_SEGMENT
                        && !tubes
                            .get(traj.segment_of[p.interval])
                            .copied()
                            .unwrap_or(false)
                }));
                order
            }
            None => all,
        };
        let mut q = vec![0.0; dim];
        let mut rate = vec![0.0; n];
        for piece in &order {
            let len = piece.s1 - piece.s0;
            for (&d, v) in space.dofs.iter().zip(recheck::joint_speeds(
                traj,
                piece.interval,
                piece.s0,
                piece.s1,
            )) {
                // |dq/du| over the piece, u in [0, 1].
                rate[d] = v * len * (1.0 + 1e-9) + 1e-12;
            }
            let mut point = |u: f64, full: &mut [f64]| {
                traj.position_on(piece.interval, piece.s0 + len * u, &mut q);
                space.expand_into(&q, full);
            };
            match self.checker.curve_certified_until(
                &mut point,
                &rate,
                piece.steps,
                0.0,
                deadline,
                tested,
            ) {
                Some(true) => {}
                Some(false) => return Ok(Some(traj.segment_of[piece.interval])),
                None => return Err(TimedOut),
            }
        }
        Ok(None)
    }
}
