//! Parallel grippers: which DOFs close the fingers, their open and closed
//! positions, and `open` / `close(force)` through the drives.

use ferrobot_model::RobotModel;

use crate::error::{Result, SimError};
use crate::robot::Robot;
use crate::state::PhysState;

/// A parallel gripper: finger DOFs with open and closed positions. Mimic
/// fingers follow their driver through the physics, so only independent
/// DOFs are listed.
#[derive(Debug, Clone, PartialEq)]
pub struct ParallelGripper {
    /// DOF indices of the finger joints.
    pub dofs: Vec<usize>,
    /// Position of each finger DOF when open.
    pub open: Vec<f64>,
    /// Position of each finger DOF when closed (on nothing).
    pub closed: Vec<f64>,
}

/// Stiffness used while closing: stiff enough that the finger force
/// saturates at the requested force as soon as the fingers touch.
pub const CLOSE_STIFFNESS: f64 = 1.0e5;
/// Damping while closing or opening.
pub const GRIPPER_DAMPING: f64 = 1.0e2;

impl ParallelGripper {
    /// The Franka hand (bundled Panda or pybullet's `panda.urdf`): DOFs named
    /// `panda_finger_joint*`, open at the upper limit, closed at the lower.
    pub fn detect(model: &RobotModel) -> Option<Self> {
        let dofs: Vec<usize> = model
            .dof_names()
            .iter()
            .enumerate()
            .filter(|(_, n)| n.starts_with("panda_finger_joint"))
            .map(|(i, _)| i)
            .collect();
        if dofs.is_empty() {
            return None;
        }
        let (lo, hi) = (model.lower_limits(), model.upper_limits());
        Some(Self {
            open: dofs.iter().map(|&d| hi[d]).collect(),
            closed: dofs.iter().map(|&d| lo[d]).collect(),
            dofs,
        })
    }

    /// A gripper from DOF names with open and closed positions.
    pub fn new(
        model: &RobotModel,
        joints: &[String],
        open: &[f64],
        closed: &[f64],
    ) -> Result<Self> {
        if joints.is_empty() || joints.len() != open.len() || joints.len() != closed.len() {
            return Err(SimError::Shape {
                what: "gripper".into(),
                expected: "as many open and closed positions as finger joints (at least one)"
                    .into(),
                got: format!(
                    "{} joints, {} open, {} closed",
                    joints.len(),
                    open.len(),
                    closed.len()
                ),
            });
        }
        crate::error::check_finite("gripper open positions", open)?;
        crate::error::check_finite("gripper closed positions", closed)?;
        let dofs = joints
            .iter()
            .map(|j| model.dof(j).map_err(SimError::from))
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            dofs,
            open: open.to_vec(),
            closed: closed.to_vec(),
        })
    }
}

impl Robot {
    /// Sets (or replaces) the gripper description.
    pub fn set_gripper(&mut self, gripper: ParallelGripper) {
        self.gripper = Some(gripper);
    }

    fn gripper_or_err(&self) -> Result<ParallelGripper> {
        self.gripper.clone().ok_or_else(|| {
            SimError::InvalidArgument(format!(
                "robot '{}' has no gripper: describe one with set_gripper(joint_names, open, closed)",
                self.name
            ))
        })
    }

    /// Drives the fingers to their open positions (force limited by `force`,
    /// default the joints' effort limits).
    pub fn open_gripper(&mut self, state: &mut PhysState, force: Option<f64>) -> Result<()> {
        let g = self.gripper_or_err()?;
        self.drive_fingers(state, &g.dofs, &g.open, force)
    }

    /// Closes the fingers, squeezing with `force` (N per finger; default
    /// the joints' effort limits) once they touch something.
    pub fn close_gripper(&mut self, state: &mut PhysState, force: Option<f64>) -> Result<()> {
        let g = self.gripper_or_err()?;
        self.drive_fingers(state, &g.dofs, &g.closed, force)
    }

    fn drive_fingers(
        &mut self,
        state: &mut PhysState,
        dofs: &[usize],
        targets: &[f64],
        force: Option<f64>,
    ) -> Result<()> {
        if let Some(f) = force
            && !(f.is_finite() && f > 0.0)
        {
            return Err(SimError::InvalidArgument(format!(
                "gripper force must be finite and > 0, got {f}"
            )));
        }
        for (&d, &t) in dofs.iter().zip(targets) {
            let effort = self.model.effort_limits()[d];
            let drive = &mut self.drives[d];
            drive.stiffness = CLOSE_STIFFNESS;
            drive.damping = GRIPPER_DAMPING;
            drive.max_force = force.unwrap_or(if effort > 0.0 { effort } else { f64::INFINITY });
            drive.target_position = t;
            drive.target_velocity = 0.0;
        }
        self.apply_drives(state);
        Ok(())
    }

    /// Current gripper opening: the finger DOF positions.
    pub fn gripper_positions(&self, state: &PhysState) -> Result<Vec<f64>> {
        let g = self.gripper_or_err()?;
        let q = self.joint_positions(state);
        Ok(g.dofs.iter().map(|&d| q[d]).collect())
    }
}
