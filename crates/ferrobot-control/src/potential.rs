//! A potential-field controller over voxelised distance fields (a cost
//! map): the classical attractive/repulsive potentials of Khatib, mapped to
//! joint space by Jacobian transposes.
//!
//! * attraction of the end-effector position, quadratic within
//!   `attract_radius` and conic beyond (force `-k x`, its magnitude capped
//!   at `k r`); the same on the orientation's rotation vector;
//! * repulsion of every robot sphere from the world,
//!   `U = eta/2 (1/d - 1/d0)²` for `d < d0`, its force
//!   `eta (1/d - 1/d0) / d² ∇d` with `d` and `∇d` read from the voxel field
//!   of each world shape (trilinear interpolation; each shape's field is
//!   built once in its own frame, so moving an object costs nothing);
//! * the same repulsion between robot spheres of checked link pairs
//!   (exact sphere distances) and from the joint limits;
//! * `qdd = sum Jᵀ F - damping qd + posture_gain (posture - q)`,
//!   then [`Core`]'s limits and integration.
//!
//! Unlike the reactive controller nothing weighs the terms against each
//! other: forces simply add, which is what produces the local minima and
//! oscillations this controller is known for.

use ferrobot_collision::{CollisionChecker, CollisionWorld};
use nalgebra::Vector3;

use crate::config::PotentialFieldConfig;
use crate::core::{Core, StepInfo, StepOutput};
use crate::error::Result;
use crate::world::ControlWorld;

/// Magnitude of the repulsive force `eta (1/d - 1/d0) / d²` (0 beyond `d0`).
#[inline]
fn repulse(eta: f64, d: f64, d0: f64, dmin: f64) -> f64 {
    if d >= d0 {
        return 0.0;
    }
    let d = d.max(dmin);
    eta * (1.0 / d - 1.0 / d0) / (d * d)
}

/// The potential-field controller; see the module documentation.
#[derive(Debug, Clone)]
pub struct PotentialFieldController {
    core: Core,
    config: PotentialFieldConfig,
    jp: Vec<f64>,
    jq: Vec<f64>,
}

impl PotentialFieldController {
    /// A controller for the robot, spheres, self-collision pairs and world
    /// of `checker`; builds one voxel field per world shape.
    pub fn new(
        checker: &CollisionChecker,
        ee_link: Option<&str>,
        config: PotentialFieldConfig,
    ) -> Result<Self> {
        config.validate_all()?;
        let mut core = Core::new(checker, ee_link)?;
        core.world
            .build_fields(config.field_resolution, config.field_padding)?;
        let k = core.active.len();
        Ok(Self {
            core,
            config,
            jp: vec![0.0; 3 * k],
            jq: vec![0.0; 3 * k],
        })
    }

    /// The gains.
    pub fn config(&self) -> &PotentialFieldConfig {
        &self.config
    }

    /// Replaces the gains (validated; fields rebuilt when their resolution
    /// or padding changed).
    pub fn set_config(&mut self, config: PotentialFieldConfig) -> Result<()> {
        config.validate_all()?;
        if config.field_resolution != self.config.field_resolution
            || config.field_padding != self.config.field_padding
        {
            self.core
                .world
                .build_fields(config.field_resolution, config.field_padding)?;
        }
        self.config = config;
        Ok(())
    }

    /// Replaces the world and builds its fields.
    pub fn set_world(&mut self, world: CollisionWorld) -> Result<()> {
        let mut w = ControlWorld::new(world);
        w.build_fields(self.config.field_resolution, self.config.field_padding)?;
        self.core.world = w;
        Ok(())
    }

    /// One control step from the measured state; see
    /// [`crate::ReactiveController::step`].
    pub fn step(&mut self, q: &[f64], qd: &[f64], dt: f64) -> Result<StepOutput> {
        self.core.check_step(q, qd, dt)?;
        let cfg = self.config.clone();
        let core = &mut self.core;
        core.forward(q);
        let k = core.active.len();
        let mut tau = vec![0.0; k];
        let mut info = StepInfo {
            world_clearance: f64::INFINITY,
            self_clearance: f64::INFINITY,
            position_error: f64::NAN,
            rotation_error: f64::NAN,
            ..Default::default()
        };
        let add_force = |tau: &mut [f64], j: &[f64], f: &Vector3<f64>| {
            for (c, t) in tau.iter_mut().enumerate() {
                *t += f.x * j[c] + f.y * j[k + c] + f.z * j[2 * k + c];
            }
        };
        if let Some(t) = core.target {
            let ee = core.poses[core.ee_link];
            let p = ee.translation.vector;
            core.point_jacobian(core.ee_link, &p.into(), &mut self.jp);
            let x = p - t.pose.translation.vector;
            let f = -x * cfg.attract_gain * (cfg.attract_radius / x.norm().max(cfg.attract_radius));
            add_force(&mut tau, &self.jp, &f);
            if t.orientation && cfg.orientation_gain > 0.0 {
                core.angular_jacobian(core.ee_link, &mut self.jq);
                let e = (ee.rotation * t.pose.rotation.inverse()).scaled_axis();
                let f = -e
                    * cfg.orientation_gain
                    * (cfg.orientation_radius / e.norm().max(cfg.orientation_radius));
                add_force(&mut tau, &self.jq, &f);
            }
            let (dp, dr) = core.target_errors();
            info.position_error = dp;
            info.rotation_error = dr;
        }
        for si in 0..core.spheres.len() {
            let s = core.spheres[si];
            let c = core.centers[si];
            let mut f = Vector3::zeros();
            for part in core.world.parts() {
                if !ControlWorld::near(part, &c, s.radius, cfg.repulse_distance) {
                    continue;
                }
                let Some((d, g)) = ControlWorld::field_distance(part, &c) else {
                    continue;
                };
                let d = d - s.radius;
                info.world_clearance = info.world_clearance.min(d);
                let m = repulse(cfg.repulse_gain, d, cfg.repulse_distance, cfg.min_distance);
                if m > 0.0 {
                    f += g * m;
                    info.active_avoidance += 1;
                }
            }
            if f != Vector3::zeros() {
                core.point_jacobian(s.link, &c, &mut self.jp);
                add_force(&mut tau, &self.jp, &f);
            }
        }
        for &(i, j) in &core.self_pairs {
            let (i, j) = (i as usize, j as usize);
            let (a, b) = (core.spheres[i], core.spheres[j]);
            let delta = core.centers[i] - core.centers[j];
            let reach = cfg.self_distance + a.radius + b.radius;
            if delta.norm_squared() >= reach * reach {
                continue;
            }
            let len = delta.norm();
            let d = len - a.radius - b.radius;
            info.self_clearance = info.self_clearance.min(d);
            let n = if len > 1e-12 {
                delta / len
            } else {
                Vector3::z()
            };
            let m = repulse(cfg.self_gain, d, cfg.self_distance, cfg.min_distance);
            if m > 0.0 {
                info.active_avoidance += 1;
                core.point_jacobian(a.link, &core.centers[i], &mut self.jp);
                add_force(&mut tau, &self.jp, &(n * m));
                core.point_jacobian(b.link, &core.centers[j], &mut self.jq);
                add_force(&mut tau, &self.jq, &(-n * m));
            }
        }
        let posture = core.posture.clone().expect("set by check_step");
        let mut qdd = vec![0.0; k];
        for (col, &dof) in core.active.iter().enumerate() {
            let qi = q[dof];
            let mut a = tau[col] - cfg.damping * qd[dof] + cfg.posture_gain * (posture[dof] - qi);
            let lo = core.lower_limit(col);
            let hi = core.upper_limit(col);
            if lo.is_finite() {
                a += repulse(
                    cfg.limit_gain,
                    qi - lo,
                    cfg.limit_distance,
                    cfg.min_distance,
                );
            }
            if hi.is_finite() {
                a -= repulse(
                    cfg.limit_gain,
                    hi - qi,
                    cfg.limit_distance,
                    cfg.min_distance,
                );
            }
            qdd[col] = a;
        }
        Ok(core.integrate(
            q,
            qd,
            &mut qdd,
            dt,
            cfg.max_acceleration,
            cfg.velocity_scale,
            cfg.default_velocity_limit,
            None,
            &mut info,
        ))
    }
}

impl crate::core::ControllerCore for PotentialFieldController {
    fn core(&self) -> &Core {
        &self.core
    }

    fn core_mut(&mut self) -> &mut Core {
        &mut self.core
    }
}
