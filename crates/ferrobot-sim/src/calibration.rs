//! Calibration support: run-time changes of a simulated robot's inertial
//! parameters and joint friction, the efforts its drives apply, the model's
//! gravity torques and regressors, and least-squares identification of a
//! payload, per-link mass offsets and joint friction from measurements.
//!
//! Measurements can come from a real robot's logs (joint torques held at
//! static configurations; efforts along constant-velocity sweeps) or from
//! the simulator through [`Robot::applied_efforts`].

use ferrobot_model::{Inertial, RobotModel};
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Vector3};
use rapier3d::math::{Matrix, Vector};
use rapier3d::prelude::MassProperties;

use crate::convert::to_pose;
use crate::error::{Result, SimError, check_finite, check_len};
use crate::robot::Robot;
use crate::state::PhysState;

/// Minimum mass and inertia of a movable body (as when the robot is built).
const MIN_MASS: f32 = 1e-2;
const MIN_INERTIA: f32 = 1e-5;

/// Mass properties of a link's inertial, in the frame `offset` maps the link
/// frame into (the body frame). The one conversion used when a robot is built
/// and when its inertials change at run time.
pub(crate) fn mass_props(inertial: &Inertial, offset: &Isometry3<f64>) -> MassProperties {
    let m = Matrix3::from_fn(|r, c| inertial.inertia[r][c]);
    let mat = Matrix::from_cols_array(&[
        m[(0, 0)] as f32,
        m[(1, 0)] as f32,
        m[(2, 0)] as f32,
        m[(0, 1)] as f32,
        m[(1, 1)] as f32,
        m[(2, 1)] as f32,
        m[(0, 2)] as f32,
        m[(1, 2)] as f32,
        m[(2, 2)] as f32,
    ]);
    MassProperties::with_inertia_matrix(Vector::ZERO, inertial.mass as f32, mat)
        .transform_by(&to_pose(&(offset * inertial.origin)))
}

impl Robot {
    /// The mass properties the simulator uses for model link `link`.
    pub fn link_inertial(&self, link: usize) -> Result<&Inertial> {
        self.model
            .links()
            .get(link)
            .map(|l| &l.inertial)
            .ok_or_else(|| SimError::UnknownName(format!("link index {link} out of range")))
    }

    /// Replaces the mass properties of model link `link` at run time: mass
    /// (kg, >= 0), the pose of its centre-of-mass frame in the link frame and
    /// the inertia about the centre of mass in that frame (kg·m², symmetric,
    /// positive definite, triangle inequality). The Rapier body carrying the
    /// link (links fixed to each other share one) gets the sum of its links'
    /// mass properties; the next step uses them. The robot keeps its own copy
    /// of the model, so `model()` reports the new values.
    pub fn set_link_inertial(
        &mut self,
        state: &mut PhysState,
        link: usize,
        inertial: Inertial,
    ) -> Result<()> {
        let mut model: RobotModel = (*self.model).clone();
        model.set_link_inertial(link, inertial)?;
        self.model = std::sync::Arc::new(model);
        let body = self.link_body[link].0;
        if body == self.root {
            return Ok(());
        }
        let mut mp = MassProperties::default();
        for (l, (b, offset)) in self.link_body.iter().enumerate() {
            let inertial = &self.model.links()[l].inertial;
            if *b == body && inertial.mass > 0.0 {
                mp += mass_props(inertial, offset);
            }
        }
        if mp.mass() < MIN_MASS {
            mp = MassProperties::new(mp.local_com, MIN_MASS, Vector::splat(MIN_INERTIA));
        }
        let pi = mp.principal_inertia();
        if pi.min_element() < MIN_INERTIA {
            mp = MassProperties::with_principal_inertia_frame(
                mp.local_com,
                mp.mass(),
                pi.max(Vector::splat(MIN_INERTIA)),
                mp.principal_inertia_local_frame,
            );
        }
        state.bodies[body].set_additional_mass_properties(mp, true);
        Ok(())
    }

    /// Viscous damping (N·m·s/rad or N·s/m) and dry (Coulomb) friction (N·m
    /// or N) of DOF `dof` in the simulator (initially the URDF's
    /// `<dynamics damping friction>`).
    pub fn joint_dynamics(&self, state: &PhysState, dof: usize) -> Result<(f64, f64)> {
        let d = self.dof_art(dof)?;
        let mb = self
            .multibody(state)
            .ok_or_else(|| SimError::InvalidArgument("the robot has no movable joints".into()))?;
        let id = mb.link(d.link.id).expect("link").assembly_id();
        Ok((mb.damping()[id] as f64, mb.frictions()[id] as f64))
    }

    /// Sets the viscous damping and dry friction of DOF `dof` (both >= 0,
    /// finite): the simulator's joint friction torque is then
    /// `-damping · q̇` plus a dry friction of at most `friction` opposing
    /// motion (MuJoCo's `damping` and `frictionloss`).
    pub fn set_joint_dynamics(
        &mut self,
        state: &mut PhysState,
        dof: usize,
        damping: f64,
        friction: f64,
    ) -> Result<()> {
        for (what, v) in [("damping", damping), ("friction", friction)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SimError::InvalidArgument(format!(
                    "{what} must be finite and >= 0, got {v}"
                )));
            }
        }
        let d = self.dof_art(dof)?;
        let mb = self
            .multibody_mut(state)
            .ok_or_else(|| SimError::InvalidArgument("the robot has no movable joints".into()))?;
        let id = mb.link(d.link.id).expect("link").assembly_id();
        mb.damping_mut()[id] = damping as f32;
        mb.frictions_mut()[id] = friction as f32;
        Ok(())
    }

    fn dof_art(&self, dof: usize) -> Result<crate::robot::ArtJoint> {
        self.dofs.get(dof).copied().ok_or_else(|| {
            SimError::UnknownName(format!(
                "joint index {dof} out of range: robot '{}' has {} DOFs",
                self.name,
                self.dofs.len()
            ))
        })
    }

    /// The effort (N·m or N) each DOF's drive applies now, plus the effort
    /// set with [`Robot::set_efforts`]: the drive law
    /// `clamp(stiffness·(s − q) + damping·(ṡ − q̇), ±max_force)` (`s`, `ṡ`:
    /// the servo setpoint and its speed, [`crate::drives`]) at the
    /// current joint state. At a static equilibrium, or at constant
    /// velocity, this is the force the simulator's implicit motor applies;
    /// during fast transients the motor's impulse also reflects the change
    /// within the step.
    pub fn applied_efforts(&self, state: &PhysState) -> Vec<f64> {
        let q = self.joint_positions(state);
        let qd = self.joint_velocities(state);
        self.drives
            .iter()
            .zip(q.iter().zip(&qd))
            .zip(&self.efforts)
            .map(|((d, (q, qd)), e)| {
                let drive = if d.stiffness == 0.0 && d.damping == 0.0 {
                    0.0
                } else {
                    let f = d.stiffness * (d.setpoint - q) + d.damping * (d.setpoint_velocity - qd);
                    f.clamp(-d.max_force, d.max_force)
                };
                drive + e
            })
            .collect()
    }
}

/// Checks a gravity vector.
fn check_gravity(gravity: &Vector3<f64>) -> Result<()> {
    check_finite("gravity", gravity.as_slice())
}

/// The Jacobian (3 x n, column-major in nalgebra) of the linear velocity of
/// the point `p` (base frame) attached to `link`, and the angular part.
fn point_jacobian(
    model: &RobotModel,
    q: &[f64],
    link: usize,
    p: &Vector3<f64>,
    origin: &Vector3<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>)> {
    let n = model.num_dof();
    let j = model.jacobian(q, Some(link))?;
    let mut jv = DMatrix::zeros(3, n);
    let mut jw = DMatrix::zeros(3, n);
    let r = p - origin;
    for k in 0..n {
        let v = Vector3::new(j[k], j[n + k], j[2 * n + k]);
        let w = Vector3::new(j[3 * n + k], j[4 * n + k], j[5 * n + k]);
        let vp = v + w.cross(&r);
        for i in 0..3 {
            jv[(i, k)] = vp[i];
            jw[(i, k)] = w[i];
        }
    }
    Ok((jv, jw))
}

/// The joint efforts that hold `model` still at `q` against `gravity`
/// (m/s², expressed in the base frame): `g(q) = −Σ_links J_com(q)ᵀ m g`, as
/// Pinocchio's `computeGeneralizedGravity`. Mimic joints add their share to
/// their driver's entry.
pub fn gravity_torques(model: &RobotModel, q: &[f64], gravity: &Vector3<f64>) -> Result<Vec<f64>> {
    check_gravity(gravity)?;
    let poses = model.fk_all(q)?;
    let mut tau = DVector::zeros(model.num_dof());
    for (l, link) in model.links().iter().enumerate() {
        let m = link.inertial.mass;
        if m <= 0.0 {
            continue;
        }
        let com = (poses[l] * link.inertial.origin).translation.vector;
        let (jv, _) = point_jacobian(model, q, l, &com, &poses[l].translation.vector)?;
        tau -= jv.transpose() * (gravity * m);
    }
    Ok(tau.iter().copied().collect())
}

/// The payload regressor of `link` at `q`: the (n x 4) matrix `Y` with
/// `efforts = Y · [m, m·cx, m·cy, m·cz]` the joint efforts holding a point
/// mass `m` at `c` (link frame) against `gravity` (base frame). Row-major.
pub fn payload_regressor(
    model: &RobotModel,
    q: &[f64],
    link: usize,
    gravity: &Vector3<f64>,
) -> Result<Vec<f64>> {
    check_gravity(gravity)?;
    let n = model.num_dof();
    let pose = model.fk_all(q)?[link];
    let o = pose.translation.vector;
    let (jv, jw) = point_jacobian(model, q, link, &o, &o)?;
    let mut y = vec![0.0; n * 4];
    let col0 = -(jv.transpose() * gravity);
    for i in 0..n {
        y[i * 4] = col0[i];
    }
    for k in 0..3 {
        let e = pose.rotation * Vector3::ith(k, 1.0);
        let col = -(jw.transpose() * e.cross(gravity));
        for i in 0..n {
            y[i * 4 + 1 + k] = col[i];
        }
    }
    Ok(y)
}

/// A least-squares fit's quality.
#[derive(Debug, Clone, PartialEq)]
pub struct FitQuality {
    /// Root-mean-square residual (N·m or N).
    pub rms_residual: f64,
    /// Condition number of the regressor (large: some parameters are not
    /// excited by the measured configurations).
    pub condition: f64,
    /// Number of equations used.
    pub equations: usize,
}

fn solve(a: DMatrix<f64>, b: DVector<f64>) -> Result<(DVector<f64>, FitQuality)> {
    let equations = a.nrows();
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smax.is_nan() || smax <= 0.0 || smin <= smax * 1e-12 {
        return Err(SimError::InvalidArgument(format!(
            "the measurements do not determine the parameters (regressor rank deficient, \
             singular values {:.3e}..{:.3e}): use more varied configurations or speeds",
            smin, smax
        )));
    }
    let x = svd
        .solve(&b, smax * 1e-12)
        .map_err(|e| SimError::InvalidArgument(format!("least squares failed: {e}")))?;
    let r = &a * &x - b;
    Ok((
        x,
        FitQuality {
            rms_residual: (r.norm_squared() / equations as f64).sqrt(),
            condition: smax / smin,
            equations,
        },
    ))
}

fn check_measurements(model: &RobotModel, qs: &[f64], efforts: &[f64]) -> Result<usize> {
    let n = model.num_dof();
    if n == 0 || !qs.len().is_multiple_of(n) || qs.is_empty() {
        return Err(SimError::Shape {
            what: "qs".into(),
            expected: format!("(N, {n})"),
            got: format!("{} values", qs.len()),
        });
    }
    let count = qs.len() / n;
    check_len("efforts", efforts, count * n)?;
    check_finite("qs", qs)?;
    Ok(count)
}

/// An identified payload.
#[derive(Debug, Clone, PartialEq)]
pub struct Payload {
    /// Mass (kg).
    pub mass: f64,
    /// Centre of mass in the link frame (m).
    pub com: Vector3<f64>,
    /// Fit quality.
    pub fit: FitQuality,
}

/// Identifies a payload rigidly attached to `link` from static joint
/// efforts: `efforts[k]` (N·m or N) held the robot still at `qs[k]` (both
/// `(N, num_dof)` row-major, DOF order). The model's own gravity torques
/// are subtracted; the rest is fitted by linear least squares on the
/// payload regressor (efforts are linear in `m` and `m·c`). `dofs` selects
/// the equations used (default: all DOFs).
pub fn identify_payload(
    model: &RobotModel,
    link: usize,
    qs: &[f64],
    efforts: &[f64],
    gravity: &Vector3<f64>,
    dofs: Option<&[usize]>,
) -> Result<Payload> {
    let count = check_measurements(model, qs, efforts)?;
    let n = model.num_dof();
    if link >= model.links().len() {
        return Err(SimError::UnknownName(format!(
            "link index {link} out of range"
        )));
    }
    let rows: Vec<usize> = dofs.map_or_else(|| (0..n).collect(), <[usize]>::to_vec);
    if let Some(bad) = rows.iter().find(|&&d| d >= n) {
        return Err(SimError::UnknownName(format!(
            "dof index {bad} out of range"
        )));
    }
    let mut a = DMatrix::zeros(count * rows.len(), 4);
    let mut b = DVector::zeros(count * rows.len());
    for k in 0..count {
        let q = &qs[k * n..(k + 1) * n];
        let y = payload_regressor(model, q, link, gravity)?;
        let g = gravity_torques(model, q, gravity)?;
        for (r, &d) in rows.iter().enumerate() {
            let row = k * rows.len() + r;
            for c in 0..4 {
                a[(row, c)] = y[d * 4 + c];
            }
            b[row] = efforts[k * n + d] - g[d];
        }
    }
    let (x, fit) = solve(a, b)?;
    if x[0].abs() < 1e-9 {
        return Err(SimError::InvalidArgument(
            "the identified payload mass is zero: its centre of mass is undefined".into(),
        ));
    }
    Ok(Payload {
        mass: x[0],
        com: Vector3::new(x[1], x[2], x[3]) / x[0],
        fit,
    })
}

/// Identifies mass offsets (kg) of `links` (centres of mass kept where the
/// model has them) from static efforts, as [`identify_payload`]: efforts
/// minus the model's gravity torques, fitted on `−J_com,lᵀ g` per link.
pub fn identify_link_masses(
    model: &RobotModel,
    links: &[usize],
    qs: &[f64],
    efforts: &[f64],
    gravity: &Vector3<f64>,
) -> Result<(Vec<f64>, FitQuality)> {
    let count = check_measurements(model, qs, efforts)?;
    let n = model.num_dof();
    if links.is_empty() {
        return Err(SimError::InvalidArgument(
            "links: at least one link is needed".into(),
        ));
    }
    if let Some(bad) = links.iter().find(|&&l| l >= model.links().len()) {
        return Err(SimError::UnknownName(format!(
            "link index {bad} out of range"
        )));
    }
    let mut a = DMatrix::zeros(count * n, links.len());
    let mut b = DVector::zeros(count * n);
    for k in 0..count {
        let q = &qs[k * n..(k + 1) * n];
        let poses = model.fk_all(q)?;
        let g = gravity_torques(model, q, gravity)?;
        for (c, &l) in links.iter().enumerate() {
            let com = (poses[l] * model.links()[l].inertial.origin)
                .translation
                .vector;
            let (jv, _) = point_jacobian(model, q, l, &com, &poses[l].translation.vector)?;
            let col = -(jv.transpose() * gravity);
            for d in 0..n {
                a[(k * n + d, c)] = col[d];
            }
        }
        for d in 0..n {
            b[k * n + d] = efforts[k * n + d] - g[d];
        }
    }
    let (x, fit) = solve(a, b)?;
    Ok((x.iter().copied().collect(), fit))
}

/// Fits `effort = coulomb · sign(velocity) + viscous · velocity` (one
/// joint) by linear least squares. Samples with |velocity| below
/// `min_speed` are ignored (sign undefined). Returns (coulomb, viscous, fit).
pub fn identify_friction(
    velocities: &[f64],
    efforts: &[f64],
    min_speed: f64,
) -> Result<(f64, f64, FitQuality)> {
    check_len("efforts", efforts, velocities.len())?;
    check_finite("velocities", velocities)?;
    if !(min_speed.is_finite() && min_speed >= 0.0) {
        return Err(SimError::InvalidArgument(format!(
            "min_speed must be finite and >= 0, got {min_speed}"
        )));
    }
    let used: Vec<(f64, f64)> = velocities
        .iter()
        .zip(efforts)
        .filter(|(v, _)| v.abs() > min_speed)
        .map(|(v, e)| (*v, *e))
        .collect();
    if used.len() < 2 {
        return Err(SimError::InvalidArgument(
            "velocities: at least two samples faster than min_speed are needed".into(),
        ));
    }
    let a = DMatrix::from_fn(used.len(), 2, |r, c| {
        if c == 0 {
            used[r].0.signum()
        } else {
            used[r].0
        }
    });
    let b = DVector::from_iterator(used.len(), used.iter().map(|u| u.1));
    let (x, fit) = solve(a, b)?;
    Ok((x[0], x[1], fit))
}
