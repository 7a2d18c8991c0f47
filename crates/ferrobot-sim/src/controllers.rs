//! Joint-space PID with anti-windup, and a Cartesian resolved-rate
//! controller through the damped Jacobian pseudo-inverse.

use ferrobot_model::RobotModel;
use nalgebra::{DMatrix, DVector, Isometry3, Vector3, Vector6};

use crate::error::{Result, SimError, check_finite, check_len};

/// A joint-space PID: `u = kp e + ki ∫e + kd ė`, `e = target − q`, with
/// the integral clamped to `±integral_limit` and conditional integration
/// (the integral stops growing while the output saturates at
/// `±output_limit` in the direction of the error).
#[derive(Debug, Clone, PartialEq)]
pub struct JointPid {
    /// Proportional gains.
    pub kp: Vec<f64>,
    /// Integral gains.
    pub ki: Vec<f64>,
    /// Derivative gains (on the velocity error).
    pub kd: Vec<f64>,
    /// Bound of each integral term's state (∫e).
    pub integral_limit: Vec<f64>,
    /// Bound of each output (inf: none).
    pub output_limit: Vec<f64>,
    integral: Vec<f64>,
}

impl JointPid {
    /// A PID for `kp.len()` joints; all vectors must have that length, gains
    /// >= 0, limits > 0 (inf allowed).
    pub fn new(
        kp: Vec<f64>,
        ki: Vec<f64>,
        kd: Vec<f64>,
        integral_limit: Vec<f64>,
        output_limit: Vec<f64>,
    ) -> Result<Self> {
        let n = kp.len();
        if n == 0 {
            return Err(SimError::InvalidArgument(
                "PID needs at least one joint".into(),
            ));
        }
        for (what, v) in [("ki", &ki), ("kd", &kd)] {
            check_len(what, v, n)?;
        }
        for (what, v) in [
            ("integral_limit", &integral_limit),
            ("output_limit", &output_limit),
        ] {
            if v.len() != n {
                return Err(SimError::Shape {
                    what: what.into(),
                    expected: format!("{n} values"),
                    got: format!("{} values", v.len()),
                });
            }
            if v.iter().any(|x| x.is_nan() || *x <= 0.0) {
                return Err(SimError::InvalidArgument(format!(
                    "{what} must be > 0 (inf allowed)"
                )));
            }
        }
        check_finite("kp", &kp)?;
        if kp.iter().chain(&ki).chain(&kd).any(|g| *g < 0.0) {
            return Err(SimError::InvalidArgument("PID gains must be >= 0".into()));
        }
        Ok(Self {
            integral: vec![0.0; n],
            kp,
            ki,
            kd,
            integral_limit,
            output_limit,
        })
    }

    /// The integral state.
    pub fn integral(&self) -> &[f64] {
        &self.integral
    }

    /// Clears the integral.
    pub fn reset(&mut self) {
        self.integral.iter_mut().for_each(|i| *i = 0.0);
    }

    /// One control update: efforts for positions `q`, velocities `qd`,
    /// targets and target velocities, over a period `dt`.
    pub fn update(
        &mut self,
        q: &[f64],
        qd: &[f64],
        target: &[f64],
        target_velocity: &[f64],
        dt: f64,
    ) -> Result<Vec<f64>> {
        let n = self.kp.len();
        check_len("q", q, n)?;
        check_len("qd", qd, n)?;
        check_len("target", target, n)?;
        check_len("target_velocity", target_velocity, n)?;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "dt must be > 0, got {dt}"
            )));
        }
        let mut out = vec![0.0; n];
        for i in 0..n {
            let e = target[i] - q[i];
            let de = target_velocity[i] - qd[i];
            let lim = self.integral_limit[i];
            let candidate = (self.integral[i] + e * dt).clamp(-lim, lim);
            let u = self.kp[i] * e + self.ki[i] * candidate + self.kd[i] * de;
            let max = self.output_limit[i];
            // Conditional integration: integrate unless saturated in the
            // direction the error pushes.
            if u.abs() <= max || u.signum() != e.signum() {
                self.integral[i] = candidate;
            }
            let u = self.kp[i] * e + self.ki[i] * self.integral[i] + self.kd[i] * de;
            out[i] = u.clamp(-max, max);
        }
        Ok(out)
    }
}

/// Cartesian resolved-rate control of a link: joint velocities
/// `q̇ = Jᵀ (J Jᵀ + λ² I)⁻¹ v` for the twist `v` that closes the pose error
/// (gains, then capped to the linear/angular speed limits), scaled down
/// uniformly to respect the joint velocity limits.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedRate {
    /// The controlled link (model index).
    pub link: usize,
    /// The DOFs used (others get zero velocity).
    pub dofs: Vec<usize>,
    /// Gain on the position error (1/s).
    pub linear_gain: f64,
    /// Gain on the orientation error (1/s).
    pub angular_gain: f64,
    /// Damping λ of the pseudo-inverse.
    pub damping: f64,
    /// Largest commanded linear speed (m/s).
    pub max_linear_speed: f64,
    /// Largest commanded angular speed (rad/s).
    pub max_angular_speed: f64,
}

/// A pose error: position error (m) and rotation error vector (rad), in the
/// base frame, target minus current.
pub fn pose_error(
    current: &Isometry3<f64>,
    target: &Isometry3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let dp = target.translation.vector - current.translation.vector;
    let dr = (target.rotation * current.rotation.inverse()).scaled_axis();
    (dp, dr)
}

impl ResolvedRate {
    /// A controller of the model's end effector over its planning-group
    /// DOFs: gains 5 /s, damping 0.05, 0.5 m/s and 1.5 rad/s.
    pub fn new(model: &RobotModel) -> Self {
        Self {
            link: model.ee_link(),
            dofs: model.group_dofs().to_vec(),
            linear_gain: 5.0,
            angular_gain: 5.0,
            damping: 0.05,
            max_linear_speed: 0.5,
            max_angular_speed: 1.5,
        }
    }

    /// Checks the settings against `model`.
    pub fn validate(&self, model: &RobotModel) -> Result<()> {
        if self.link >= model.links().len() {
            return Err(SimError::UnknownName(format!("no link {}", self.link)));
        }
        if let Some(d) = self.dofs.iter().find(|&&d| d >= model.num_dof()) {
            return Err(SimError::UnknownName(format!(
                "joint index {d} out of range"
            )));
        }
        for (n, v) in [
            ("linear_gain", self.linear_gain),
            ("angular_gain", self.angular_gain),
            ("max_linear_speed", self.max_linear_speed),
            ("max_angular_speed", self.max_angular_speed),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(SimError::InvalidArgument(format!(
                    "{n} must be > 0, got {v}"
                )));
            }
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "damping must be >= 0, got {}",
                self.damping
            )));
        }
        Ok(())
    }

    /// Joint velocities (all DOFs) driving the link towards `target` (base frame).
    pub fn compute(
        &self,
        model: &RobotModel,
        q: &[f64],
        target: &Isometry3<f64>,
    ) -> Result<Vec<f64>> {
        self.validate(model)?;
        if !crate::convert::pose_is_finite(target) {
            return Err(SimError::NonFinite("target pose is not finite".into()));
        }
        let current = model.fk(q, Some(self.link))?;
        let (dp, dr) = pose_error(&current, target);
        let mut v_lin = dp * self.linear_gain;
        let mut v_ang = dr * self.angular_gain;
        if v_lin.norm() > self.max_linear_speed {
            v_lin *= self.max_linear_speed / v_lin.norm();
        }
        if v_ang.norm() > self.max_angular_speed {
            v_ang *= self.max_angular_speed / v_ang.norm();
        }
        let twist = Vector6::new(v_lin.x, v_lin.y, v_lin.z, v_ang.x, v_ang.y, v_ang.z);
        let n = model.num_dof();
        let jfull = model.jacobian(q, Some(self.link))?;
        let k = self.dofs.len();
        let j = DMatrix::from_fn(6, k, |r, c| jfull[r * n + self.dofs[c]]);
        let jjt = &j * j.transpose() + DMatrix::identity(6, 6) * (self.damping * self.damping);
        let y = jjt
            .lu()
            .solve(&DVector::from_column_slice(twist.as_slice()))
            .ok_or_else(|| {
                SimError::InvalidArgument("singular Jacobian with zero damping".into())
            })?;
        let qd_sub = j.transpose() * y;
        let vmax = model.velocity_limits();
        let mut scale: f64 = 1.0;
        for (c, &d) in self.dofs.iter().enumerate() {
            if vmax[d].is_finite() && qd_sub[c].abs() > vmax[d] {
                scale = scale.min(vmax[d] / qd_sub[c].abs());
            }
        }
        let mut qd = vec![0.0; n];
        for (c, &d) in self.dofs.iter().enumerate() {
            qd[d] = qd_sub[c] * scale;
        }
        Ok(qd)
    }
}
