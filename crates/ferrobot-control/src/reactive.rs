//! The RMPflow-style reactive controller.
//!
//! Each policy (an RMP) is an acceleration `a` in a task space with
//! Jacobian `J` and a metric `M`. The policies are pulled back to the
//! controlled joints and combined by their metrics,
//!
//! ```text
//! qdd = (sum Jᵀ M J + λ I)⁻¹ sum Jᵀ M a
//! ```
//!
//! (solved by Cholesky; `λ` is `regularization`). The curvature term
//! `J̇ q̇` of the full RMPflow pullback is left out, as in most
//! implementations at control rates of hundreds of hertz. Policies:
//!
//! * end-effector position: soft-normalised attractor
//!   `a = -g x / (|x| + l) - b ẋ`, metric `(w_far + (w_near - w_far)
//!   exp(-|x|² / 2σ²)) I`, which stiffens near the target;
//! * end-effector orientation: the same on the rotation vector of
//!   `R_ee R_targetᵀ` with the angular-velocity Jacobian, its metric
//!   blending with the same position weight;
//! * world avoidance, one 1-D policy per (robot sphere, world shape) within
//!   `collision_distance`: on the signed distance `d` with Jacobian
//!   `nᵀ J_p` (n the distance gradient), velocity `ḋ = nᵀ(J_p q̇ - v_obs)`
//!   (obstacle velocity included when given), acceleration
//!   `g exp(-d/l) + brake ḋ² / (2 (d - margin))` (the second while
//!   approaching: the deceleration that stops before the margin), metric
//!   `μ (1 - d/D)² / (d/D + ε) (1 + max(-ḋ, 0) / v₀)`, which vanishes at
//!   `D` and grows with approach speed; its reach
//!   `D = min(collision_distance, collision_near + collision_horizon max(-ḋ, 0))`
//!   covers the distance the obstacle closes within the horizon, so an
//!   obstacle that is not closing in (passing, receding, or moving along
//!   with a fleeing arm) acts only within `collision_near`;
//! * self avoidance, the same per sphere pair of checked link pairs, its
//!   metric velocity-gated as in RMPflow (`self_rest_weight` of it kept
//!   when the pair is not approaching): approaches are braked, but a
//!   target next to another link is not held off at rest;
//! * velocity limits: damping of joints beyond a fraction of their limit;
//! * joint limits: no policy pushes away from them; instead everything is
//!   resolved in limit-aware coordinates `u` with `q = m + h tanh(u / h)`
//!   (`m` the middle of the range, `h` its half minus `limit_buffer`), where
//!   the limits are infinitely far away: a joint slows down as it nears a
//!   limit (the map's curvature brakes it) and a target at the edge of the
//!   range is approached without a standing offset;
//! * c-space (in `u`): a weak pull to the posture with joint damping
//!   (resolves redundancy and damps motion).
//!
//! The acceleration then goes through [`Core`]'s limits and integration.

use std::sync::Arc;

use ferrobot_collision::CollisionChecker;
use nalgebra::{Isometry3, Vector3};

use crate::config::ReactiveConfig;
use crate::core::{Core, StepInfo, StepOutput};
use crate::error::{ControlError, Result};
use crate::exact::{LinkClearance, world_shape};
use crate::guidance::{Action, Guidance, PlanAttempt, Update};
use crate::world::ControlWorld;

/// Acceleration and metric of a 1-D barrier on a distance `d` approached at
/// `dd` (negative when approaching).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Barrier {
    pub reach: f64,
    pub gain: f64,
    pub length: f64,
    pub brake: f64,
    pub margin: f64,
    pub metric: f64,
    pub eps: f64,
    pub speed: f64,
    /// Share of the metric kept when not approaching (1: none gated).
    pub rest: f64,
    /// Reach of the metric when not approaching; it grows by `horizon`
    /// times the closing speed, up to `reach` (`horizon` 0: always `reach`).
    pub near: f64,
    /// Seconds of closing speed added to `near` (see there).
    pub horizon: f64,
}

impl Barrier {
    #[inline]
    pub(crate) fn eval(&self, d: f64, dd: f64) -> (f64, f64) {
        let dc = d.max(-3.0 * self.length);
        let mut a = self.gain * (-dc / self.length).exp();
        let approach = (-dd).max(0.0);
        if approach > 0.0 {
            a += self.brake * approach * approach / (2.0 * (d - self.margin).max(1e-3));
        }
        let reach = if self.horizon > 0.0 {
            (self.near + self.horizon * approach).min(self.reach)
        } else {
            self.reach
        };
        let s = (d.max(0.0) / reach).min(1.0);
        let w = (1.0 - s) * (1.0 - s) / (s + self.eps);
        (a, self.metric * w * (self.rest + approach / self.speed))
    }
}

/// Summed metric and force of the pulled-back policies (k x k, k).
#[derive(Debug, Clone)]
struct System {
    k: usize,
    a: Vec<f64>,
    b: Vec<f64>,
}

impl System {
    fn new(k: usize) -> Self {
        Self {
            k,
            a: vec![0.0; k * k],
            b: vec![0.0; k],
        }
    }

    fn clear(&mut self) {
        self.a.fill(0.0);
        self.b.fill(0.0);
    }

    /// Adds a 1-D policy with row `j`, metric `m`, acceleration `acc`.
    #[inline]
    fn add_row(&mut self, j: &[f64], m: f64, acc: f64) {
        let k = self.k;
        for r in 0..k {
            if j[r] == 0.0 {
                continue;
            }
            let mj = m * j[r];
            self.b[r] += mj * acc;
            let row = &mut self.a[r * k..(r + 1) * k];
            for (x, jc) in row.iter_mut().zip(j) {
                *x += mj * jc;
            }
        }
    }

    /// Adds a 3-D policy with Jacobian `j` (3 x k), metric `m I`, acceleration `acc`.
    fn add_iso3(&mut self, j: &[f64], m: f64, acc: &Vector3<f64>) {
        let k = self.k;
        for r in 0..3 {
            self.add_row(&j[r * k..(r + 1) * k], m, acc[r]);
        }
    }

    /// Solves `(A + λ I) x = b` by Cholesky, in place of `b`.
    fn solve(&mut self, lambda: f64) -> Result<Vec<f64>> {
        let k = self.k;
        let a = &mut self.a;
        for i in 0..k {
            a[i * k + i] += lambda;
        }
        for j in 0..k {
            let mut s = a[j * k + j];
            for p in 0..j {
                s -= a[j * k + p] * a[j * k + p];
            }
            if !(s > 0.0 && s.is_finite()) {
                return Err(ControlError::InvalidArgument(
                    "the combined metric is not positive definite (increase regularization)".into(),
                ));
            }
            let l = s.sqrt();
            a[j * k + j] = l;
            for i in j + 1..k {
                let mut s = a[i * k + j];
                for p in 0..j {
                    s -= a[i * k + p] * a[j * k + p];
                }
                a[i * k + j] = s / l;
            }
        }
        let mut x = self.b.clone();
        for i in 0..k {
            let mut s = x[i];
            for p in 0..i {
                s -= a[i * k + p] * x[p];
            }
            x[i] = s / a[i * k + i];
        }
        for i in (0..k).rev() {
            let mut s = x[i];
            for p in i + 1..k {
                s -= a[p * k + i] * x[p];
            }
            x[i] = s / a[i * k + i];
        }
        Ok(x)
    }
}

/// Rotation vector (axis times angle) of `r`, in (-π, π].
pub(crate) fn rotation_vector(r: &nalgebra::UnitQuaternion<f64>) -> Vector3<f64> {
    r.scaled_axis()
}

/// The reactive (RMPflow-style) controller; see the module documentation.
#[derive(Debug, Clone)]
pub struct ReactiveController {
    core: Core,
    config: ReactiveConfig,
    sys: System,
    jp: Vec<f64>,
    jq: Vec<f64>,
    row: Vec<f64>,
    /// Velocity filter: rows (k each) and lower bounds of `row · v`.
    filter_rows: Vec<f64>,
    filter_bounds: Vec<f64>,
    /// Exact link geometry (meshes as convex hulls) for the filter's
    /// second stage; None when a link's hull cannot be made.
    exact: Option<Arc<LinkClearance>>,
    /// Exact link-pair distances computed this step.
    exact_cache: Vec<((usize, usize), f64)>,
    /// Link pairs the exact layer watches (see [`exact_link_pairs`]).
    exact_pairs: Vec<(usize, usize)>,
    /// Per world part (`ControlWorld::parts` order): its parry shape and
    /// the shape's pose in the part frame, None for shapes the exact layer
    /// cannot measure (meshes, clouds: the spheres alone watch those).
    world_shapes: Vec<Option<(parry3d::shape::SharedShape, Isometry3<f64>)>>,
    warp: Vec<Warp>,
    /// Global guidance: joint-space waypoints (full DOF vectors) still to pass.
    waypoints: std::collections::VecDeque<Vec<f64>>,
    /// Progress watch: best error so far, time since it last improved, and
    /// the target it watches.
    stall_best: f64,
    stall_since: f64,
    watched: Option<Isometry3<f64>>,
    /// Time (s) a guided arm has been at rest.
    guided_rest: f64,
    /// The planner side of global guidance.
    guidance: Guidance,
    /// Whether the velocity filter changed the previous step's velocity
    /// (the stall watch's `stall_filtered`).
    last_filter_active: bool,
    /// Whether a world avoidance policy acted at the previous step (an
    /// obstacle within `collision_distance`; the stall watch's
    /// `stall_unforced`).
    last_world_near: bool,
}

/// One joint's limit-aware coordinate: `dq/du`, the curvature term, `u`,
/// the posture's `u` and `du/dt`.
#[derive(Debug, Clone, Copy, Default)]
struct Warp {
    s: f64,
    kappa: f64,
    u: f64,
    u_posture: f64,
    ud: f64,
    /// Middle and half range of the map (half 0: the identity, no limits).
    mid: f64,
    half: f64,
}

impl Warp {
    /// `u` of a joint value `q`.
    fn u_of(&self, q: f64) -> f64 {
        if self.half > 0.0 {
            let lim = 1.0 - 1e-9;
            self.half * ((q - self.mid) / self.half).clamp(-lim, lim).atanh()
        } else {
            q
        }
    }
}

impl ReactiveController {
    /// A controller for the robot, spheres, self-collision pairs and world
    /// of `checker`, driving its planning group with `ee_link` as the end
    /// effector (default: the model's).
    pub fn new(
        checker: &CollisionChecker,
        ee_link: Option<&str>,
        config: ReactiveConfig,
    ) -> Result<Self> {
        config.validate_all()?;
        let core = Core::new(checker, ee_link)?;
        let k = core.active.len();
        let guidance = Guidance::new(checker, core.ee_link);
        let exact = LinkClearance::new(checker.model().clone())
            .ok()
            .map(Arc::new);
        let exact_pairs = match &exact {
            Some(lc) => exact_link_pairs(checker, lc, core.self_link_pairs()),
            None => Vec::new(),
        };
        Ok(Self {
            core,
            config,
            sys: System::new(k),
            jp: vec![0.0; 3 * k],
            jq: vec![0.0; 3 * k],
            row: vec![0.0; k],
            filter_rows: Vec::new(),
            filter_bounds: Vec::new(),
            exact,
            exact_cache: Vec::new(),
            exact_pairs,
            world_shapes: Vec::new(),
            warp: vec![Warp::default(); k],
            waypoints: Default::default(),
            stall_best: f64::INFINITY,
            stall_since: 0.0,
            watched: None,
            guided_rest: 0.0,
            guidance,
            last_filter_active: false,
            last_world_near: false,
        })
    }

    /// The gains.
    pub fn config(&self) -> &ReactiveConfig {
        &self.config
    }

    /// Replaces the gains (validated first).
    pub fn set_config(&mut self, config: ReactiveConfig) -> Result<()> {
        config.validate_all()?;
        self.config = config;
        Ok(())
    }

    /// Replaces the world (objects at rest).
    pub fn set_world(&mut self, world: ferrobot_collision::CollisionWorld) -> Result<()> {
        self.core.world = ControlWorld::new(world);
        self.world_shapes.clear();
        Ok(())
    }

    /// Global guidance: joint-space waypoints (each a full DOF vector, or
    /// one value per controlled DOF with the others taken from the
    /// posture) that the controller follows, in its limit-aware
    /// coordinates and with every avoidance policy still active, before it
    /// hands back to the end-effector target. Typically a collision-free
    /// path from a planner to an IK solution of the target, requested when
    /// a step reports `stalled` (a local minimum). Replaces any waypoints
    /// left; an empty list clears them.
    pub fn set_waypoints(&mut self, rows: &[Vec<f64>]) -> Result<()> {
        let n = self.core.model.num_dof();
        let k = self.core.active.len();
        let base = self
            .core
            .posture
            .clone()
            .unwrap_or_else(|| self.core.model.neutral_configuration());
        let mut out = std::collections::VecDeque::with_capacity(rows.len());
        for (i, row) in rows.iter().enumerate() {
            let full = if row.len() == n {
                row.clone()
            } else if row.len() == k {
                let mut f = base.clone();
                for (&d, &v) in self.core.active.iter().zip(row) {
                    f[d] = v;
                }
                f
            } else {
                return Err(ControlError::InvalidArgument(format!(
                    "waypoints: row {i} has {} values; expected {n} (dof_names) or {k} (controlled joints)",
                    row.len()
                )));
            };
            self.core
                .model
                .check_configuration(&format!("waypoints[{i}]"), &full)?;
            out.push_back(full);
        }
        self.waypoints = out;
        self.stall_since = 0.0;
        Ok(())
    }

    /// The link pairs (link indices, smaller first) whose exact geometry
    /// the velocity filter watches (with `exact_filter`): the checker's
    /// self-collision pairs plus those the sampled analysis dropped (never
    /// or always in contact by the spheres).
    pub fn exact_link_pairs(&self) -> &[(usize, usize)] {
        &self.exact_pairs
    }

    /// Drops the waypoints: back to the end-effector target.
    pub fn clear_waypoints(&mut self) {
        self.waypoints.clear();
    }

    /// Waypoints still to pass.
    pub fn waypoints_remaining(&self) -> usize {
        self.waypoints.len()
    }

    /// The outcome of the last global-guidance plan attempt, if any.
    pub fn guidance_last_plan(&self) -> Option<&PlanAttempt> {
        self.guidance.last.as_ref()
    }

    /// Why global guidance is unavailable for this robot (no planner could
    /// be built for its group and end effector), if it is.
    pub fn guidance_error(&self) -> Option<&str> {
        self.guidance.error.as_deref()
    }

    /// One control step from the measured state `(q, qd)` (full DOF
    /// vectors) over `dt` seconds (0 < dt <= 1).
    pub fn step(&mut self, q: &[f64], qd: &[f64], dt: f64) -> Result<StepOutput> {
        self.core.check_step(q, qd, dt)?;
        let cfg = self.config.clone();
        let core = &mut self.core;
        core.forward(q);
        let k = core.active.len();
        let sys = &mut self.sys;
        sys.clear();
        let qda: Vec<f64> = core.active.iter().map(|&d| qd[d]).collect();
        let dot = |j: &[f64]| -> f64 { j.iter().zip(&qda).map(|(a, b)| a * b).sum() };
        let mut info = StepInfo {
            world_clearance: f64::INFINITY,
            self_clearance: f64::INFINITY,
            ..Default::default()
        };
        // End-effector target (handed over to the waypoints while guided).
        let guided = !self.waypoints.is_empty();
        if let Some(t) = core.target {
            let target_weight = if guided { 0.0 } else { 1.0 };
            let ee = core.poses[core.ee_link];
            let p = ee.translation.vector;
            core.point_jacobian(core.ee_link, &p.into(), &mut self.jp);
            let x = p - t.pose.translation.vector;
            let v = Vector3::new(
                dot(&self.jp[..k]),
                dot(&self.jp[k..2 * k]),
                dot(&self.jp[2 * k..]),
            );
            let nx = x.norm();
            let near = (-nx * nx / (2.0 * cfg.target_metric_radius.powi(2))).exp();
            let acc = -x * (cfg.target_gain / (nx + cfg.target_length)) - v * cfg.target_damping;
            let m = target_weight
                * (cfg.target_metric_far + (cfg.target_metric_near - cfg.target_metric_far) * near);
            sys.add_iso3(&self.jp, m, &acc);
            if t.orientation && cfg.orientation_gain > 0.0 {
                core.angular_jacobian(core.ee_link, &mut self.jq);
                let e = rotation_vector(&(ee.rotation * t.pose.rotation.inverse()));
                let w = Vector3::new(
                    dot(&self.jq[..k]),
                    dot(&self.jq[k..2 * k]),
                    dot(&self.jq[2 * k..]),
                );
                let ne = e.norm();
                let acc = -e * (cfg.orientation_gain / (ne + cfg.orientation_length))
                    - w * cfg.orientation_damping;
                let m = target_weight
                    * (cfg.orientation_metric_far
                        + (cfg.orientation_metric_near - cfg.orientation_metric_far) * near);
                sys.add_iso3(&self.jq, m, &acc);
            }
            let (dp, dr) = core.target_errors();
            info.position_error = dp;
            info.rotation_error = dr;
            // Progress watch.
            if self.watched != Some(t.pose) {
                self.watched = Some(t.pose);
                self.stall_best = f64::INFINITY;
                self.stall_since = 0.0;
            }
            let e = dp + if dr.is_finite() { 0.1 * dr } else { 0.0 };
            let moving = qda.iter().any(|v| v.abs() > cfg.stall_speed);
            // A guided arm at rest for `stall_time` cannot follow its path
            // (the avoidance policies hold it off): the waypoints are
            // dropped and the end-effector target takes over again, so the
            // stall watch can ask for another plan.
            if guided && !moving {
                self.guided_rest += dt;
                if self.guided_rest >= cfg.stall_time {
                    self.waypoints.clear();
                    self.guided_rest = 0.0;
                }
            } else {
                self.guided_rest = 0.0;
            }
            // Motion the velocity filter shaped (the arm pressed against a
            // hold, sliding or jittering there) is not evasion: only the
            // error's progress resets the watch then.
            // Nor is motion with no obstacle near (`stall_unforced`): a
            // crawl without progress is a stall too.
            let evading = moving
                && !(cfg.stall_filtered != 0.0 && self.last_filter_active)
                && (cfg.stall_unforced == 0.0 || self.last_world_near);
            if guided || evading {
                self.stall_since = 0.0;
            } else if e < self.stall_best - cfg.stall_progress {
                self.stall_best = e;
                self.stall_since = 0.0;
            } else {
                self.stall_since += dt;
            }
            info.stalled = !guided && e > cfg.stall_progress && self.stall_since >= cfg.stall_time;
        } else {
            info.position_error = f64::NAN;
            info.rotation_error = f64::NAN;
        }
        // World avoidance.
        let world_barrier = Barrier {
            reach: cfg.collision_distance,
            gain: cfg.collision_gain,
            length: cfg.collision_length,
            brake: cfg.collision_brake,
            margin: cfg.collision_margin,
            metric: cfg.collision_metric,
            eps: cfg.collision_metric_eps,
            speed: cfg.collision_speed,
            rest: 1.0,
            near: cfg.collision_near,
            horizon: cfg.collision_horizon,
        };
        self.filter_rows.clear();
        self.filter_bounds.clear();
        for si in 0..core.spheres.len() {
            let s = core.spheres[si];
            let c = core.centers[si];
            let mut have_j = false;
            for part in core.world.parts() {
                if !ControlWorld::near(part, &c, s.radius, cfg.collision_distance) {
                    continue;
                }
                let (d, n) = ControlWorld::exact_distance(part, &c);
                let d = d - s.radius;
                info.world_clearance = info.world_clearance.min(d);
                if d >= cfg.collision_distance {
                    continue;
                }
                if !have_j {
                    core.point_jacobian(s.link, &c, &mut self.jp);
                    have_j = true;
                }
                for (col, r) in self.row.iter_mut().enumerate() {
                    *r = n.x * self.jp[col] + n.y * self.jp[k + col] + n.z * self.jp[2 * k + col];
                }
                let vo = core.world.point_velocity(part.object, &c);
                let dd = dot(&self.row) - n.dot(&vo);
                if d < cfg.collision_filter_distance {
                    // Velocity filter: d stays >= min(d, collision_hold)
                    // at the next step, the obstacle's motion included.
                    self.filter_rows.extend_from_slice(&self.row);
                    self.filter_bounds
                        .push(n.dot(&vo) - (d - cfg.collision_hold).max(0.0) / dt);
                }
                let (acc, m) = world_barrier.eval(d, dd);
                sys.add_row(&self.row, m, acc);
                info.active_avoidance += 1;
            }
        }
        // Self avoidance.
        let self_barrier = Barrier {
            reach: cfg.self_distance,
            gain: cfg.self_gain,
            metric: cfg.self_metric,
            rest: cfg.self_rest_weight,
            horizon: 0.0,
            ..world_barrier
        };
        self.exact_cache.clear();
        let look = cfg.self_distance.max(cfg.self_filter_distance);
        let exact_on = cfg.exact_filter != 0.0 && self.exact.is_some();
        for &(i, j) in &core.self_pairs {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = (&core.spheres[i], &core.spheres[j]);
            let delta = core.centers[i] - core.centers[j];
            let reach = look + a.radius + b.radius;
            let len2 = delta.norm_squared();
            if len2 >= reach * reach {
                continue;
            }
            let len = len2.sqrt();
            let d = len - a.radius - b.radius;
            let n = if len > 1e-12 {
                delta / len
            } else {
                Vector3::z()
            };
            core.point_jacobian(a.link, &core.centers[i], &mut self.jp);
            core.point_jacobian(b.link, &core.centers[j], &mut self.jq);
            for (col, r) in self.row.iter_mut().enumerate() {
                *r = (0..3)
                    .map(|x| n[x] * (self.jp[x * k + col] - self.jq[x * k + col]))
                    .sum();
            }
            // The velocity filter keeps d >= self_hold at the next step.
            // Spheres protrude beyond the links: a pair whose spheres are
            // already closer than that enters the filter only if the links'
            // exact geometry is within self_hold too (the checker's own
            // two-stage verdict), so targets with overlapping spheres but
            // separate links stay reachable.
            let gap = d - cfg.self_hold;
            // With the exact layer on, the links' own geometry is filtered
            // below (a pair per link pair); the sphere pair is not.
            let exact_pair = exact_on
                && self
                    .exact
                    .as_ref()
                    .is_some_and(|lc| lc.has_geometry(a.link) && lc.has_geometry(b.link));
            let exact_apart = exact_pair
                || gap <= 0.0
                    && self.exact.as_ref().is_some_and(|lc| {
                        let key = (a.link, b.link);
                        let dist = match self.exact_cache.iter().find(|c| c.0 == key) {
                            Some(c) => c.1,
                            None => {
                                let v = lc
                                    .link_pair_distance(&core.poses, a.link, b.link)
                                    .unwrap_or(0.0);
                                self.exact_cache.push((key, v));
                                v
                            }
                        };
                        dist > cfg.self_hold
                    });
            if d < cfg.self_filter_distance && !exact_apart {
                self.filter_rows.extend_from_slice(&self.row);
                self.filter_bounds.push(-gap.max(0.0) / dt);
            }
            if d >= cfg.self_distance {
                continue;
            }
            info.self_clearance = info.self_clearance.min(d);
            let dd = dot(&self.row);
            let (acc, m) = self_barrier.eval(d, dd);
            sys.add_row(&self.row, m, acc);
            info.active_avoidance += 1;
        }
        // Exact layer of the velocity filter: the links' own geometry.
        if exact_on && let Some(lc) = self.exact.as_ref() {
            let policy_on = cfg.exact_policy != 0.0;
            let fd = cfg.self_filter_distance;
            if fd > 0.0 {
                for &(la, lb) in &self.exact_pairs {
                    let (Some((ca, ra)), Some((cb, rb))) = (lc.bound(la), lc.bound(lb)) else {
                        continue;
                    };
                    let gap = (core.poses[la] * ca - core.poses[lb] * cb).norm() - ra - rb;
                    if gap >= fd {
                        continue;
                    }
                    let Some(c) = lc.link_pair_contact(&core.poses, la, lb, fd) else {
                        continue;
                    };
                    if c.distance >= fd {
                        continue;
                    }
                    // d(distance)/dt = -n · (v_a(p_a) - v_b(p_b)), n from a to b.
                    core.point_jacobian(la, &c.point_a, &mut self.jp);
                    core.point_jacobian(lb, &c.point_b, &mut self.jq);
                    for (col, r) in self.row.iter_mut().enumerate() {
                        *r = -(0..3)
                            .map(|x| c.normal[x] * (self.jp[x * k + col] - self.jq[x * k + col]))
                            .sum::<f64>();
                    }
                    info.self_clearance = info.self_clearance.min(c.distance);
                    if policy_on && c.distance < cfg.self_distance {
                        // The self barrier on the exact distance (see
                        // `exact_policy`).
                        let (acc, m) = self_barrier.eval(c.distance, dot(&self.row));
                        sys.add_row(&self.row, m, acc);
                        info.active_avoidance += 1;
                    }
                    self.filter_rows.extend_from_slice(&self.row);
                    self.filter_bounds
                        .push(-(c.distance - cfg.self_hold).max(0.0) / dt);
                }
            }
            let fw = cfg.collision_filter_distance;
            let parts = core.world.parts();
            if fw > 0.0 && !parts.is_empty() {
                if self.world_shapes.len() != parts.len() {
                    self.world_shapes = parts.iter().map(|p| world_shape(&p.shape)).collect();
                }
                for l in 0..core.poses.len() {
                    let Some((cl, rl)) = lc.bound(l) else {
                        continue;
                    };
                    // Only links that the controlled joints move.
                    if core.link_dofs(l) == 0 {
                        continue;
                    }
                    let centre = core.poses[l] * cl;
                    for (part, shape) in parts.iter().zip(&self.world_shapes) {
                        let Some((shape, fix)) = shape else {
                            continue;
                        };
                        if !ControlWorld::near(part, &centre, rl, fw) {
                            continue;
                        }
                        let Some(c) =
                            lc.link_shape_contact(l, &core.poses[l], shape, &(part.pose * fix), fw)
                        else {
                            continue;
                        };
                        if c.distance >= fw {
                            continue;
                        }
                        core.point_jacobian(l, &c.point_a, &mut self.jp);
                        // n points from the obstacle to the link.
                        let n = -c.normal;
                        for (col, r) in self.row.iter_mut().enumerate() {
                            *r = n.x * self.jp[col]
                                + n.y * self.jp[k + col]
                                + n.z * self.jp[2 * k + col];
                        }
                        let vo = core.world.point_velocity(part.object, &c.point_b);
                        info.world_clearance = info.world_clearance.min(c.distance);
                        if policy_on {
                            // The world barrier on the exact distance (see
                            // `exact_policy`), the obstacle's motion included.
                            let dd = dot(&self.row) - n.dot(&vo);
                            let (acc, m) = world_barrier.eval(c.distance, dd);
                            sys.add_row(&self.row, m, acc);
                            info.active_avoidance += 1;
                        }
                        self.filter_rows.extend_from_slice(&self.row);
                        self.filter_bounds
                            .push(n.dot(&vo) - (c.distance - cfg.collision_hold).max(0.0) / dt);
                    }
                }
            }
        }
        // Velocity limits (joint space).
        let posture = core.posture.clone().expect("set by check_step");
        for (col, &vi) in qda.iter().enumerate() {
            let vmax = core.velocity_limit(col, cfg.velocity_scale, cfg.default_velocity_limit);
            let over = vi.abs() / vmax - cfg.velocity_soft_fraction;
            if over > 0.0 {
                let kk = col * k + col;
                let m = cfg.velocity_gain * over / (1.0 - cfg.velocity_soft_fraction).max(1e-3);
                sys.a[kk] += m;
                sys.b[col] += m * (-cfg.velocity_gain * vi);
            }
        }
        // Joint limits: everything above is pulled back into limit-aware
        // coordinates u (q = m + h tanh(u / h), so dq/du = s = 1 - t², t =
        // (q - m) / h), where the limits are infinitely far: with
        // qdd = S udd + kappa, A_u = S A S and b_u = S (b - A kappa). The
        // curvature kappa = -2 t qd² / (h s) (about -qd² / delta at a distance
        // delta from the edge) is kept while a joint approaches its limit,
        // where it brakes, and left out when it leaves (like J̇q̇ elsewhere).
        let warp = &mut self.warp;
        for (col, &dof) in core.active.iter().enumerate() {
            let (lo, hi) = (core.lower_limit(col), core.upper_limit(col));
            let half = 0.5 * (hi - lo) - cfg.limit_buffer;
            let w = if lo.is_finite() && hi.is_finite() && half > 1e-6 {
                let mid = 0.5 * (hi + lo);
                let lim = 1.0 - 1e-9;
                let t = ((q[dof] - mid) / half).clamp(-lim, lim);
                let tp = ((posture[dof] - mid) / half).clamp(-lim, lim);
                let sc = 1.0 - t * t;
                let vi = qda[col];
                let kappa = if t * vi > 0.0 {
                    -2.0 * t * vi * vi / (half * sc)
                } else {
                    0.0
                };
                Warp {
                    s: sc,
                    kappa,
                    u: half * t.atanh(),
                    u_posture: half * tp.atanh(),
                    ud: vi / sc,
                    mid,
                    half,
                }
            } else {
                Warp {
                    s: 1.0,
                    kappa: 0.0,
                    u: q[dof],
                    u_posture: posture[dof],
                    ud: qda[col],
                    mid: 0.0,
                    half: 0.0,
                }
            };
            warp[col] = w;
        }
        for r in 0..k {
            let ak: f64 = (0..k).map(|c| sys.a[r * k + c] * warp[c].kappa).sum();
            sys.b[r] = warp[r].s * (sys.b[r] - ak);
        }
        for r in 0..k {
            for c in 0..k {
                sys.a[r * k + c] *= warp[r].s * warp[c].s;
            }
        }
        // C-space policy in the limit-aware coordinates: a weak pull to the
        // posture with damping (resolves redundancy).
        for (col, w) in warp.iter().enumerate() {
            let m = cfg.posture_metric;
            sys.a[col * k + col] += m;
            sys.b[col] += m * (cfg.posture_gain * (w.u_posture - w.u) - cfg.joint_damping * w.ud);
        }
        // Global guidance: a joint-space attractor (in u) to the next
        // waypoint; passed waypoints are dropped, the last one ends it.
        while let Some(wp) = self.waypoints.front() {
            let gap = core
                .active
                .iter()
                .map(|&d| (q[d] - wp[d]).abs())
                .fold(0.0, f64::max);
            let last = self.waypoints.len() == 1;
            if gap < cfg.waypoint_tolerance {
                self.waypoints.pop_front();
                if last {
                    self.stall_best = f64::INFINITY;
                    self.stall_since = 0.0;
                }
            } else {
                break;
            }
        }
        if let Some(wp) = self.waypoints.front() {
            let du: Vec<f64> = core
                .active
                .iter()
                .zip(warp.iter())
                .map(|(&d, w)| w.u_of(wp[d]) - w.u)
                .collect();
            let norm = du.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
            let m = cfg.waypoint_metric;
            for (col, (x, w)) in du.iter().zip(warp.iter()).enumerate() {
                sys.a[col * k + col] += m;
                sys.b[col] += m
                    * (cfg.waypoint_gain * x / (norm + cfg.waypoint_length)
                        - cfg.waypoint_damping * w.ud);
            }
        }
        let mut qdd = sys.solve(cfg.regularization)?;
        for (a, w) in qdd.iter_mut().zip(warp.iter()) {
            *a = w.s * *a + w.kappa;
        }
        // Global guidance: stall -> plan -> waypoints (see crate::guidance).
        let reached = info.position_error < cfg.reach_position_tolerance
            && (info.rotation_error.is_nan() || info.rotation_error < cfg.reach_rotation_tolerance);
        let (status, action) = self.guidance.update(Update {
            q,
            active: &core.active,
            dt,
            target: core.target.map(|t| (t.pose, t.orientation)),
            ee_pose: core.poses[core.ee_link],
            world: core.world.world(),
            stalled: info.stalled,
            guided: !self.waypoints.is_empty(),
            reached,
            max_plans: cfg.guidance_plans as usize,
            retry: cfg.guidance_retry,
            time_limit: cfg.guidance_time_limit,
            blocking: cfg.guidance_blocking != 0.0,
        });
        if let Action::Follow(path) = action {
            // The path starts at (about) the current state; the waypoint
            // attractor takes over from the next step.
            self.set_waypoints(&path)?;
        }
        info.guidance = status;
        info.guidance_plans = self.guidance.plans;
        info.waypoints_remaining = self.waypoints.len();
        let out = self.core.integrate(
            q,
            qd,
            &mut qdd,
            dt,
            cfg.max_acceleration,
            cfg.velocity_scale,
            cfg.default_velocity_limit,
            Some((&self.filter_rows, &self.filter_bounds)),
            &mut info,
        );
        self.last_filter_active = out.info.filter_active;
        self.last_world_near = out.info.world_clearance < cfg.collision_distance;
        Ok(out)
    }
}

/// The link pairs the exact layer of the velocity filter watches: the
/// checker's self-collision link pairs, plus every pair that only the
/// sampled analysis (`AnalyzeCollisions::analyze`: reasons `Never` and
/// `Always` in the checker's matrix) excluded. That analysis only looks at
/// pairs the checker's own matrix (SRDF, adjacent and rigid pairs: the
/// judges' and the planner's) still checks, and it samples the *spheres*:
/// a statistical "never" says nothing about the configurations a
/// controller visits, and spheres "always" overlapping say nothing about
/// the links (the Panda's `panda_link5` and `panda_link7` spheres overlap
/// in every sample while the links are about 12 mm apart, and an episode
/// of the benchmark pressed them 1.6 mm into contact). The exact layer is
/// cheap (a bounding-ball test per pair), so it keeps the checker's full
/// matrix. Only pairs of links with exact geometry, at least one of them
/// moved by the controlled joints.
fn exact_link_pairs(
    checker: &CollisionChecker,
    lc: &LinkClearance,
    checked: &[(usize, usize)],
) -> Vec<(usize, usize)> {
    let model = checker.model();
    let mut pairs: Vec<(usize, usize)> = checked.to_vec();
    pairs.extend(
        checker
            .allowed_collisions()
            .pairs()
            .filter(|&(_, _, reason)| reason == "Never" || reason == "Always")
            .map(|(a, b, _)| (a.min(b), a.max(b))),
    );
    let moved = |l: usize| {
        model
            .path_to(l)
            .into_iter()
            .any(|j| model.joints()[j].kind.is_movable())
    };
    pairs.retain(|&(a, b)| {
        lc.has_geometry(a) && lc.has_geometry(b) && a != b && (moved(a) || moved(b))
    });
    pairs
        .iter_mut()
        .for_each(|p| *p = (p.0.min(p.1), p.0.max(p.1)));
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

impl crate::core::ControllerCore for ReactiveController {
    fn core(&self) -> &Core {
        &self.core
    }

    fn core_mut(&mut self) -> &mut Core {
        &mut self.core
    }
}
