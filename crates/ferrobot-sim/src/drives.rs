//! Joint drives: velocity-capped PD position servos with a force limit.
//!
//! A drive holds a commanded position target `c` (what
//! [`Robot::set_position_targets`], the trajectory runner and the gripper
//! set) and its servo **setpoint** `s`, the position the PD law acts on:
//!
//! ```text
//! force = clamp(stiffness · (s − q) + damping · (ṡ − q̇), ±max_force)
//! ```
//!
//! (Isaac Sim's articulation drive law, with `s` in place of the target).
//! Every step of length `dt` the setpoint moves toward the command by at
//! most `max_velocity · dt` (the joint's URDF velocity limit), and `ṡ` is
//! the setpoint's own speed while it moves (the commanded velocity target
//! once it has arrived). So a position command never asks the joint to move
//! faster than its limit: a free joint commanded from `a` to `b` travels at
//! the limit and arrives after `|b − a| / max_velocity` (plus the PD's lag),
//! as a position-controlled gripper or arm servo with a speed setting does
//! (PyBullet's position control caps its velocity demand at the joint's
//! `maxVelocity`; PhysX articulations cap the joint speed at
//! `maxJointVelocity`). A command that already moves slower than the limit
//! (a planned trajectory within the limits) is passed through unchanged.
//!
//! While the setpoint is still travelling it may not lead the joint by more
//! than the drive's reach `max_force / stiffness` (anti-windup): a blocked
//! joint — fingers closed on an object — stops its setpoint at the reach,
//! where the drive pushes with exactly `max_force` (the squeeze at rest is
//! the effort cap), and a new command starts from there instead of first
//! unwinding a setpoint buried inside the object. The force limit is the
//! URDF effort limit unless set otherwise (the gripper's squeeze force).

use ferrobot_model::Joint;
use rapier3d::prelude::MotorModel;

use crate::error::{Result, SimError};
use crate::latency::CommandKind;
use crate::robot::Robot;
use crate::state::PhysState;

/// The drive of one DOF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drive {
    /// Position gain (N·m/rad or N/m).
    pub stiffness: f64,
    /// Velocity gain (N·m·s/rad or N·s/m).
    pub damping: f64,
    /// Largest force or torque the drive applies (N·m or N; inf: none).
    pub max_force: f64,
    /// Position target (rad or m).
    pub target_position: f64,
    /// Velocity target (rad/s or m/s).
    pub target_velocity: f64,
    /// Largest speed (rad/s or m/s) of the servo setpoint: the URDF
    /// velocity limit (inf: none stated, the setpoint jumps to the target).
    pub max_velocity: f64,
    /// The servo setpoint the PD law acts on now (rad or m): the target,
    /// or on its way there at most `max_velocity` per second.
    pub setpoint: f64,
    /// The setpoint's velocity (rad/s or m/s) used as the PD's velocity
    /// target: its speed while it travels, `target_velocity` once there.
    pub setpoint_velocity: f64,
}

/// Default gains of a revolute DOF.
pub const REVOLUTE_STIFFNESS: f64 = 1.0e4;
/// Default damping of a revolute DOF.
pub const REVOLUTE_DAMPING: f64 = 1.0e2;
/// Default gains of a prismatic DOF.
pub const PRISMATIC_STIFFNESS: f64 = 1.0e4;
/// Default damping of a prismatic DOF.
pub const PRISMATIC_DAMPING: f64 = 1.0e2;

impl Drive {
    /// The default drive of `joint`, holding position `q`: stiff PD gains
    /// and the URDF effort limit as the force limit.
    pub fn default_for(joint: &Joint, q: f64) -> Self {
        let (stiffness, damping) = if joint.kind.is_rotational() {
            (REVOLUTE_STIFFNESS, REVOLUTE_DAMPING)
        } else {
            (PRISMATIC_STIFFNESS, PRISMATIC_DAMPING)
        };
        let effort = joint.limits.effort;
        let velocity = joint.limits.velocity;
        Self {
            stiffness,
            damping,
            max_force: if effort > 0.0 { effort } else { f64::INFINITY },
            target_position: q,
            target_velocity: 0.0,
            // A zero limit in a URDF means "not stated" (as for effort).
            max_velocity: if velocity > 0.0 {
                velocity
            } else {
                f64::INFINITY
            },
            setpoint: q,
            setpoint_velocity: 0.0,
        }
    }

    /// Whether the setpoint is still on its way to the target.
    pub fn travelling(&self) -> bool {
        self.setpoint != self.target_position
    }

    /// Moves the setpoint one step of `dt` toward the target (see the
    /// module documentation), given the joint's position `q` and speed
    /// `qd`: at most `max_velocity · dt`, and no farther than the drive's
    /// reach `max_force / stiffness + max_velocity · dt` ahead of `q` while
    /// it travels.
    pub fn advance(&mut self, dt: f64, q: f64, qd: f64) {
        if !self.travelling() {
            self.setpoint_velocity = self.target_velocity;
            return;
        }
        let step = self.max_velocity * dt;
        let gap = self.target_position - self.setpoint;
        if gap.abs() <= step {
            self.setpoint = self.target_position;
            self.setpoint_velocity = self.target_velocity;
            return;
        }
        let next = self.setpoint + step.copysign(gap);
        // The lead a moving joint needs (one step's travel) plus what the
        // full force holds against the spring.
        let reach = if self.stiffness > 0.0 {
            self.max_force / self.stiffness + step
        } else {
            f64::INFINITY
        };
        // The reach bounds only the lead in the direction of travel: a
        // setpoint behind the joint (pushed past it) is left where the
        // profile puts it.
        let (lo, hi) = if gap > 0.0 {
            (f64::NEG_INFINITY, q + reach)
        } else {
            (q - reach, f64::INFINITY)
        };
        if next > hi || next < lo {
            // Blocked: the setpoint rides at the reach, moving with the
            // joint, and the drive pushes with exactly max_force. It never
            // moves backwards along the profile.
            let held = next.clamp(lo, hi);
            let held = if gap > 0.0 {
                held.max(self.setpoint)
            } else {
                held.min(self.setpoint)
            };
            self.setpoint = held;
            self.setpoint_velocity = qd;
        } else {
            self.setpoint = next;
            self.setpoint_velocity = self.max_velocity.copysign(gap);
        }
    }
}

/// Checks DOF indices and returns them (all DOFs when `None`).
pub fn resolve_indices(robot: &Robot, indices: Option<&[usize]>) -> Result<Vec<usize>> {
    let n = robot.num_dof();
    match indices {
        None => Ok((0..n).collect()),
        Some(ix) => {
            if let Some(&bad) = ix.iter().find(|&&i| i >= n) {
                return Err(SimError::UnknownName(format!(
                    "joint index {bad} out of range: robot '{}' has {n} DOFs ({})",
                    robot.name(),
                    robot.model().dof_names().join(", ")
                )));
            }
            let mut seen = vec![false; n];
            for &i in ix {
                if std::mem::replace(&mut seen[i], true) {
                    return Err(SimError::InvalidArgument(format!(
                        "joint index {i} given twice"
                    )));
                }
            }
            Ok(ix.to_vec())
        }
    }
}

fn values<'a>(what: &str, v: &'a [f64], n: usize) -> Result<&'a [f64]> {
    crate::error::check_len(what, v, n)?;
    Ok(v)
}

impl Robot {
    /// Writes every drive into the Rapier joint motors.
    pub(crate) fn apply_drives(&self, state: &mut PhysState) {
        let Some(mb) = self.multibody_mut(state) else {
            return;
        };
        for (d, drive) in self.dofs.iter().zip(&self.drives) {
            let axis = d.axis();
            let data = &mut mb.link_mut(d.link.id).expect("link").joint.data;
            data.set_motor_model(axis, MotorModel::ForceBased);
            data.set_motor(
                axis,
                drive.setpoint as f32,
                drive.setpoint_velocity as f32,
                drive.stiffness as f32,
                drive.damping as f32,
            );
            // Rapier solves a motor with zero gains as a rigid velocity
            // lock; a drive without gains must exert nothing.
            let max_force =
                if (drive.stiffness == 0.0 && drive.damping == 0.0) || drive.max_force == 0.0 {
                    0.0
                } else if drive.max_force.is_finite() {
                    drive.max_force as f32
                } else {
                    f32::MAX
                };
            data.set_motor_max_force(axis, max_force);
        }
    }

    /// Moves every drive's servo setpoint one step of `dt` toward its
    /// target ([`Drive::advance`]) and writes the changed setpoints into the
    /// Rapier motors. Called by the world before each step, after the
    /// commands due then.
    pub(crate) fn advance_drives(&mut self, state: &mut PhysState, dt: f64) {
        let joints = if self.drives.iter().any(Drive::travelling) {
            Some((self.joint_positions(state), self.joint_velocities(state)))
        } else {
            None
        };
        let mut changed = false;
        for (i, d) in self.drives.iter_mut().enumerate() {
            let before = (d.setpoint, d.setpoint_velocity);
            match &joints {
                Some((q, qd)) => d.advance(dt, q[i], qd[i]),
                None => d.setpoint_velocity = d.target_velocity,
            }
            changed |= (d.setpoint, d.setpoint_velocity) != before;
        }
        if changed {
            self.apply_drives(state);
        }
    }

    /// Sets position targets for the DOFs `indices` (all when `None`).
    pub fn set_position_targets(
        &mut self,
        state: &mut PhysState,
        targets: &[f64],
        indices: Option<&[usize]>,
    ) -> Result<()> {
        let ix = resolve_indices(self, indices)?;
        let t = values("position targets", targets, ix.len())?;
        if let Some((ix, t)) = self.latency.defer(CommandKind::Position, ix, t.to_vec()) {
            self.apply_command(state, CommandKind::Position, &ix, &t);
        }
        Ok(())
    }

    /// Sets velocity targets for the DOFs `indices` (all when `None`).
    pub fn set_velocity_targets(
        &mut self,
        state: &mut PhysState,
        targets: &[f64],
        indices: Option<&[usize]>,
    ) -> Result<()> {
        let ix = resolve_indices(self, indices)?;
        let t = values("velocity targets", targets, ix.len())?;
        if let Some((ix, t)) = self.latency.defer(CommandKind::Velocity, ix, t.to_vec()) {
            self.apply_command(state, CommandKind::Velocity, &ix, &t);
        }
        Ok(())
    }

    /// Sets the efforts (N·m or N) applied every step to the DOFs
    /// `indices` (all when `None`), on top of the drives.
    pub fn set_efforts(&mut self, efforts: &[f64], indices: Option<&[usize]>) -> Result<()> {
        let ix = resolve_indices(self, indices)?;
        let e = values("efforts", efforts, ix.len())?;
        if let Some((ix, e)) = self.latency.defer(CommandKind::Effort, ix, e.to_vec()) {
            for (&i, &v) in ix.iter().zip(&e) {
                self.efforts[i] = v;
            }
        }
        Ok(())
    }

    /// Applies a (validated) command now.
    fn apply_command(
        &mut self,
        state: &mut PhysState,
        kind: CommandKind,
        ix: &[usize],
        values: &[f64],
    ) {
        for (&i, &v) in ix.iter().zip(values) {
            match kind {
                CommandKind::Position => self.drives[i].target_position = v,
                CommandKind::Velocity => self.drives[i].target_velocity = v,
                CommandKind::Effort => self.efforts[i] = v,
            }
        }
        if kind != CommandKind::Effort {
            self.apply_drives(state);
        }
    }

    /// The command latency (s): drive targets and efforts set at world
    /// time `t` take effect at the first step starting at or after
    /// `t + latency`.
    pub fn command_latency(&self) -> f64 {
        self.latency.delay()
    }

    /// Sets the command latency (finite, in [0, 10] s); commands already
    /// waiting keep their due times.
    pub fn set_command_latency(&mut self, delay: f64) -> Result<()> {
        self.latency.set_delay(delay)
    }

    /// Commands waiting in the latency buffer.
    pub fn pending_commands(&self) -> usize {
        self.latency.pending()
    }

    /// Applies the commands due at world time `t` (called by the world
    /// before each step) and sets the robot's clock to `t`.
    pub(crate) fn apply_due_commands(&mut self, state: &mut PhysState, t: f64) {
        self.latency.clock = t;
        for (kind, ix, v) in self.latency.due(t) {
            self.apply_command(state, kind, &ix, &v);
        }
    }

    /// The efforts (N·m or N) set with [`Robot::set_efforts`], per DOF.
    pub fn efforts(&self) -> &[f64] {
        &self.efforts
    }

    /// Sets drive gains and force limits for the DOFs `indices` (all when
    /// `None`). Gains must be >= 0, force limits >= 0 (0: a passive joint,
    /// as Isaac Sim's `max_force = 0`; inf: unlimited).
    pub fn set_drive_gains(
        &mut self,
        state: &mut PhysState,
        stiffness: &[f64],
        damping: &[f64],
        max_force: Option<&[f64]>,
        indices: Option<&[usize]>,
    ) -> Result<()> {
        let ix = resolve_indices(self, indices)?;
        values("stiffness", stiffness, ix.len())?;
        values("damping", damping, ix.len())?;
        if let Some(m) = max_force {
            if m.len() != ix.len() {
                return Err(SimError::Shape {
                    what: "max_force".into(),
                    expected: format!("{} values", ix.len()),
                    got: format!("{} values", m.len()),
                });
            }
            if let Some(v) = m.iter().find(|v| v.is_nan() || **v < 0.0) {
                return Err(SimError::InvalidArgument(format!(
                    "max_force must be >= 0 (0: passive, the joint moves only when pushed or coupled; inf: unlimited), got {v}"
                )));
            }
        }
        if let Some(v) = stiffness.iter().chain(damping).find(|v| **v < 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "drive stiffness and damping must be >= 0, got {v}"
            )));
        }
        for (k, &i) in ix.iter().enumerate() {
            let d = &mut self.drives[i];
            d.stiffness = stiffness[k];
            d.damping = damping[k];
            if let Some(m) = max_force {
                d.max_force = m[k];
            }
        }
        self.apply_drives(state);
        Ok(())
    }
}
