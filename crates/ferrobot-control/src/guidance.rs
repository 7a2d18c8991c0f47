//! Global guidance of the reactive controller: stall detection and the
//! hand-off to a motion planner.
//!
//! A reactive controller is local: in a local minimum (an obstacle or
//! another link between the arm and its target, a joint limit on the way)
//! it comes to rest away from the target. The controller watches its
//! progress (`stall_*` gains of [`crate::ReactiveConfig`]) and, when a step
//! reports `stalled`, `Guidance` asks ferrobot's planner for a
//! collision-free path to a collision-free IK solution of the target, on the
//! obstacles' poses at that moment, and hands it to the controller as
//! joint-space waypoints (followed in the limit-aware coordinates with every
//! avoidance policy on); passing the last waypoint hands back to the
//! end-effector target. Attempts per target are bounded (`guidance_plans`)
//! and spaced (`guidance_retry`); a new target resets the budget.
//!
//! Planning runs either inside the step that detected the stall
//! (`guidance_blocking = 1`: deterministic, for simulator loops; that step
//! takes up to `guidance_time_limit`) or on a background thread
//! (`guidance_blocking = 0`, for a real robot's state stream: the control
//! loop keeps running, and avoiding, while the planner works; the status
//! is `planning` meanwhile). Either way the controller's clock is the sum of
//! the `dt` passed to `step`, so the same code serves both.
//!
//! Every step reports a [`GuidanceStatus`] in [`crate::StepInfo`].

use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use ferrobot_collision::{CollisionChecker, CollisionWorld};
use ferrobot_planning::{Goal, PlanOptions, PlanRequest, Planner};
use nalgebra::Isometry3;

/// What the guided controller is doing, reported every step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GuidanceStatus {
    /// Guidance is disabled (`guidance_plans = 0`) or has no planner for
    /// this robot (see [`crate::ReactiveController::guidance_error`]).
    #[default]
    Off,
    /// No end-effector target: the controller holds its posture.
    Idle,
    /// Moving towards the target (the local policies are in charge).
    Tracking,
    /// Within the reach tolerances of the target.
    Reached,
    /// At rest away from the target; a plan will be tried once
    /// `guidance_retry` has passed since the last attempt (or the last
    /// attempt failed and the next one is due later).
    Stalled,
    /// A plan is being computed on a background thread.
    Planning,
    /// Following a planned path's waypoints.
    Guided,
    /// Stalled and every attempt for this target has been used: the caller
    /// should intervene (a new target, a different approach).
    Exhausted,
}

impl GuidanceStatus {
    /// A short snake_case name (used by the Python API and logs).
    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Idle => "idle",
            Self::Tracking => "tracking",
            Self::Reached => "reached",
            Self::Stalled => "stalled",
            Self::Planning => "planning",
            Self::Guided => "guided",
            Self::Exhausted => "exhausted",
        }
    }
}

/// The outcome of one plan attempt.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanAttempt {
    /// The planner's status name (`solved`, `timeout`, `ik_failed`, ...),
    /// or `error` when the planner refused the request.
    pub status: String,
    /// The planner's message (empty when solved without a note).
    pub message: String,
    /// Waypoints handed to the controller (0 unless solved).
    pub waypoints: usize,
    /// Wall time of the attempt (s).
    pub seconds: f64,
}

type Job = JoinHandle<(Isometry3<f64>, PlanAttempt, Vec<Vec<f64>>)>;

/// The planner side of global guidance (see the module documentation).
#[derive(Debug)]
pub(crate) struct Guidance {
    planner: Option<Arc<Planner>>,
    /// Why there is no planner.
    pub(crate) error: Option<String>,
    /// The target whose budget is being spent.
    target: Option<Isometry3<f64>>,
    /// Attempts for this target.
    pub(crate) plans: usize,
    /// Controller clock (s) and the clock at the last attempt.
    clock: f64,
    last_attempt: f64,
    pending: Option<Job>,
    pub(crate) last: Option<PlanAttempt>,
}

impl Clone for Guidance {
    /// A clone shares the planner; a plan still running on a thread stays
    /// with the original.
    fn clone(&self) -> Self {
        Self {
            planner: self.planner.clone(),
            error: self.error.clone(),
            target: self.target,
            plans: self.plans,
            clock: self.clock,
            last_attempt: self.last_attempt,
            pending: None,
            last: self.last.clone(),
        }
    }
}

/// What [`Guidance::update`] asks the controller to do.
pub(crate) enum Action {
    /// Nothing.
    None,
    /// Follow these waypoints (rows over the controlled DOFs).
    Follow(Vec<Vec<f64>>),
}

/// The inputs of one guidance update.
pub(crate) struct Update<'a> {
    pub q: &'a [f64],
    pub active: &'a [usize],
    pub dt: f64,
    pub target: Option<(Isometry3<f64>, bool)>,
    pub ee_pose: Isometry3<f64>,
    pub world: &'a CollisionWorld,
    pub stalled: bool,
    pub guided: bool,
    pub reached: bool,
    pub max_plans: usize,
    pub retry: f64,
    pub time_limit: f64,
    pub blocking: bool,
}

impl Guidance {
    /// A planner on `checker`'s robot, spheres and allowed collisions, with
    /// IK for `ee_link`.
    pub(crate) fn new(checker: &CollisionChecker, ee_link: usize) -> Self {
        let (planner, error) = match Planner::new(checker.clone(), Some(ee_link)) {
            Ok(p) => (Some(Arc::new(p)), None),
            Err(e) => (None, Some(format!("no planner for global guidance: {e}"))),
        };
        Self {
            planner,
            error,
            target: None,
            plans: 0,
            clock: 0.0,
            last_attempt: f64::NEG_INFINITY,
            pending: None,
            last: None,
        }
    }

    fn reset(&mut self, target: Option<Isometry3<f64>>) {
        self.target = target;
        self.plans = 0;
        self.last_attempt = f64::NEG_INFINITY;
        self.pending = None; // a running plan finishes on its own; its result is dropped
    }

    /// One plan request from `q` to `goal`; never fails (a refused request
    /// is reported as an attempt with status `error`).
    fn attempt(
        planner: &Planner,
        q: &[f64],
        active: &[usize],
        goal: Isometry3<f64>,
        world: CollisionWorld,
        time_limit: f64,
    ) -> (PlanAttempt, Vec<Vec<f64>>) {
        let began = std::time::Instant::now();
        let mut planner = planner.clone();
        planner.update_world(world);
        let options = PlanOptions {
            trajectory: false,
            rrt: ferrobot_planning::rrt::RrtOptions {
                time_limit: Duration::from_secs_f64(time_limit),
                ..Default::default()
            },
            ..Default::default()
        };
        let request = PlanRequest {
            start: active.iter().map(|&d| q[d]).collect(),
            goal: Goal::Poses(vec![goal]),
            locked: Some(q.to_vec()),
            options,
        };
        let (attempt, path) = match planner.solve(&request) {
            Ok(r) => {
                let path = if r.success() { r.path } else { Vec::new() };
                (
                    PlanAttempt {
                        status: r.status.name().to_string(),
                        message: r.message,
                        waypoints: path.len(),
                        seconds: 0.0,
                    },
                    path,
                )
            }
            Err(e) => (
                PlanAttempt {
                    status: "error".into(),
                    message: e.to_string(),
                    waypoints: 0,
                    seconds: 0.0,
                },
                Vec::new(),
            ),
        };
        (
            PlanAttempt {
                seconds: began.elapsed().as_secs_f64(),
                ..attempt
            },
            path,
        )
    }

    /// Advances the clock by `u.dt`, collects a finished background plan,
    /// starts a new attempt when the controller is stalled and the budget
    /// allows, and says what the step's status is.
    pub(crate) fn update(&mut self, u: Update<'_>) -> (GuidanceStatus, Action) {
        let Some(planner) = self.planner.clone() else {
            return (GuidanceStatus::Off, Action::None);
        };
        if u.max_plans == 0 {
            self.reset(None);
            return (GuidanceStatus::Off, Action::None);
        }
        self.clock += u.dt;
        let Some((pose, orientation)) = u.target else {
            self.reset(None);
            return (GuidanceStatus::Idle, Action::None);
        };
        if self.target != Some(pose) {
            self.reset(Some(pose));
        }
        // The goal of the IK: the target pose, or, when only the position
        // is controlled, the target position with the current orientation.
        let goal = if orientation {
            pose
        } else {
            Isometry3::from_parts(pose.translation, u.ee_pose.rotation)
        };
        let mut action = Action::None;
        if self.pending.as_ref().is_some_and(|h| h.is_finished()) {
            let job = self.pending.take().expect("checked");
            match job.join() {
                Ok((for_target, attempt, path)) => {
                    if for_target == pose && !path.is_empty() {
                        action = Action::Follow(path);
                    }
                    self.last = Some(attempt);
                }
                Err(_) => {
                    self.last = Some(PlanAttempt {
                        status: "error".into(),
                        message: "the planning thread panicked".into(),
                        waypoints: 0,
                        seconds: 0.0,
                    });
                }
            }
        }
        if matches!(action, Action::Follow(_)) {
            return (GuidanceStatus::Guided, action);
        }
        if u.reached {
            return (GuidanceStatus::Reached, Action::None);
        }
        if u.guided {
            return (GuidanceStatus::Guided, Action::None);
        }
        if self.pending.is_some() {
            return (GuidanceStatus::Planning, Action::None);
        }
        if !u.stalled {
            return (GuidanceStatus::Tracking, Action::None);
        }
        if self.plans >= u.max_plans {
            return (GuidanceStatus::Exhausted, Action::None);
        }
        if self.clock - self.last_attempt < u.retry {
            return (GuidanceStatus::Stalled, Action::None);
        }
        self.plans += 1;
        self.last_attempt = self.clock;
        let world = u.world.clone();
        if u.blocking {
            let (attempt, path) = Self::attempt(&planner, u.q, u.active, goal, world, u.time_limit);
            self.last = Some(attempt);
            if path.is_empty() {
                (GuidanceStatus::Stalled, Action::None)
            } else {
                (GuidanceStatus::Guided, Action::Follow(path))
            }
        } else {
            let q = u.q.to_vec();
            let active = u.active.to_vec();
            let time_limit = u.time_limit;
            self.pending = Some(std::thread::spawn(move || {
                let (attempt, path) = Self::attempt(&planner, &q, &active, goal, world, time_limit);
                (pose, attempt, path)
            }));
            (GuidanceStatus::Planning, Action::None)
        }
    }
}
