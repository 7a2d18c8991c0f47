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
//!   `D` and grows with approach speed;
//! * self avoidance, the same per sphere pair of checked link pairs;
//! * joint limits, the same barrier on the distance to each limit;
//! * velocity limits: damping of joints beyond a fraction of their limit;
//! * c-space: a weak pull to the posture with joint damping (resolves
//!   redundancy and damps motion).
//!
//! The acceleration then goes through [`Core`]'s limits and integration.

use std::sync::Arc;

use ferrobot_collision::CollisionChecker;
use ferrobot_model::RobotModel;
use nalgebra::{Isometry3, Vector3};

use crate::config::ReactiveConfig;
use crate::core::{Core, StepInfo, StepOutput};
use crate::error::{ControlError, Result};
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
        let s = (d.max(0.0) / self.reach).min(1.0);
        let w = (1.0 - s) * (1.0 - s) / (s + self.eps);
        (a, self.metric * w * (1.0 + approach / self.speed))
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
        config.validate()?;
        let core = Core::new(checker, ee_link)?;
        let k = core.active.len();
        Ok(Self {
            core,
            config,
            sys: System::new(k),
            jp: vec![0.0; 3 * k],
            jq: vec![0.0; 3 * k],
            row: vec![0.0; k],
        })
    }

    /// The shared core (target, posture, world, geometry).
    pub fn core(&self) -> &Core {
        &self.core
    }

    /// The shared core, mutable.
    pub fn core_mut(&mut self) -> &mut Core {
        &mut self.core
    }

    /// The model.
    pub fn model(&self) -> &Arc<RobotModel> {
        self.core.model()
    }

    /// The gains.
    pub fn config(&self) -> &ReactiveConfig {
        &self.config
    }

    /// Replaces the gains (validated first).
    pub fn set_config(&mut self, config: ReactiveConfig) -> Result<()> {
        config.validate()?;
        self.config = config;
        Ok(())
    }

    /// Replaces the world (objects at rest).
    pub fn set_world(&mut self, world: ferrobot_collision::CollisionWorld) -> Result<()> {
        self.core.world = ControlWorld::new(world);
        Ok(())
    }

    /// Moves one world object, with its velocity if known.
    pub fn set_obstacle_pose(
        &mut self,
        name: &str,
        pose: Isometry3<f64>,
        velocity: Option<[f64; 6]>,
    ) -> Result<()> {
        self.core.world.set_pose(name, pose, velocity)
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
        // End-effector target.
        if let Some(t) = core.target {
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
            let m = cfg.target_metric_far + (cfg.target_metric_near - cfg.target_metric_far) * near;
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
                let m = cfg.orientation_metric_far
                    + (cfg.orientation_metric_near - cfg.orientation_metric_far) * near;
                sys.add_iso3(&self.jq, m, &acc);
            }
            let (dp, dr) = core.target_errors();
            info.position_error = dp;
            info.rotation_error = dr;
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
        };
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
            ..world_barrier
        };
        for &(i, j) in &core.self_pairs {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = (&core.spheres[i], &core.spheres[j]);
            let delta = core.centers[i] - core.centers[j];
            let reach = cfg.self_distance + a.radius + b.radius;
            let len2 = delta.norm_squared();
            if len2 >= reach * reach {
                continue;
            }
            let len = len2.sqrt();
            let d = len - a.radius - b.radius;
            info.self_clearance = info.self_clearance.min(d);
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
            let dd = dot(&self.row);
            let (acc, m) = self_barrier.eval(d, dd);
            sys.add_row(&self.row, m, acc);
            info.active_avoidance += 1;
        }
        // Joint limits, velocity limits, c-space.
        let limit_barrier = Barrier {
            reach: cfg.limit_distance,
            gain: cfg.limit_gain,
            length: cfg.limit_distance / 4.0,
            metric: cfg.limit_metric,
            margin: 0.0,
            ..world_barrier
        };
        let posture = core.posture.clone().expect("set by check_step");
        for (col, &dof) in core.active.iter().enumerate() {
            let (qi, vi) = (q[dof], qda[col]);
            let kk = col * k + col;
            let lo = core.lower_limit(col);
            let hi = core.upper_limit(col);
            if lo.is_finite() && qi - lo < cfg.limit_distance {
                let (acc, m) = limit_barrier.eval(qi - lo, vi);
                sys.a[kk] += m;
                sys.b[col] += m * acc;
            }
            if hi.is_finite() && hi - qi < cfg.limit_distance {
                let (acc, m) = limit_barrier.eval(hi - qi, -vi);
                sys.a[kk] += m;
                sys.b[col] -= m * acc;
            }
            let vmax = core.velocity_limit(col, cfg.velocity_scale, cfg.default_velocity_limit);
            let over = vi.abs() / vmax - cfg.velocity_soft_fraction;
            if over > 0.0 {
                let m = cfg.velocity_gain * over / (1.0 - cfg.velocity_soft_fraction).max(1e-3);
                sys.a[kk] += m;
                sys.b[col] += m * (-cfg.velocity_gain * vi);
            }
            let m = cfg.posture_metric;
            sys.a[kk] += m;
            sys.b[col] += m * (cfg.posture_gain * (posture[dof] - qi) - cfg.joint_damping * vi);
        }
        let mut qdd = sys.solve(cfg.regularization)?;
        Ok(core.integrate(
            q,
            qd,
            &mut qdd,
            dt,
            cfg.max_acceleration,
            cfg.velocity_scale,
            cfg.default_velocity_limit,
            &mut info,
        ))
    }
}
