//! Parallel grippers: which DOFs close the fingers, their open and closed
//! positions, and `open` / `close(force)` / `set_opening(width)` through the
//! drives. A gripper found in the model ([`ferrobot_model::Gripper`], the one
//! gripper description) drives its one driver joint; its mimic followers are
//! passive and move only through the multibody's DOF couplings.

use ferrobot_model::{Gripper, RobotModel};

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
    /// The gripper description, when known (openings in metres, forces
    /// converted to driver efforts through its opening map).
    pub description: Option<Gripper>,
}

/// Stiffness used while closing: stiff enough that the finger force
/// saturates at the requested force as soon as the fingers touch. The
/// fingers travel at the driver joint's velocity limit (the drive's
/// setpoint moves at most that fast, [`crate::drives`]), so they touch at
/// that speed, and squeeze with the force limit once at rest.
pub const CLOSE_STIFFNESS: f64 = 1.0e5;
/// Damping while closing or opening.
pub const GRIPPER_DAMPING: f64 = 1.0e2;

impl ParallelGripper {
    /// The gripper of `model` ([`Gripper::from_model`]: the Panda hand, the
    /// Robotiq 2F-85 or one built from the SRDF end effector), driven by its
    /// driver DOF; `None` when the model has none.
    pub fn detect(model: &RobotModel) -> Option<Self> {
        let g = Gripper::from_model(model).ok()?;
        Self::from_gripper(model, g).ok()
    }

    /// The simulated gripper of description `gripper` on `model`.
    pub fn from_gripper(model: &RobotModel, gripper: Gripper) -> Result<Self> {
        gripper.check_model(model)?;
        let dof = model.dof(&gripper.driver)?;
        Ok(Self {
            dofs: vec![dof],
            open: vec![gripper.open_position],
            closed: vec![gripper.closed_position],
            description: Some(gripper),
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
            description: None,
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
        let effort = self.finger_effort(&g, force)?;
        self.drive_fingers(state, &g.dofs, &g.open, effort)
    }

    /// Closes the fingers, squeezing with `force` (N per finger; default
    /// the joints' effort limits) once they touch something.
    pub fn close_gripper(&mut self, state: &mut PhysState, force: Option<f64>) -> Result<()> {
        let g = self.gripper_or_err()?;
        let effort = self.finger_effort(&g, force)?;
        self.drive_fingers(state, &g.dofs, &g.closed, effort)
    }

    /// Drives the fingers to `opening` (m between the pads' inner faces; the
    /// gripper's range, see [`Gripper::driver_position`]), squeezing with at
    /// most `force` N per finger. Needs a gripper description.
    pub fn set_gripper_opening(
        &mut self,
        state: &mut PhysState,
        opening: f64,
        force: Option<f64>,
    ) -> Result<()> {
        let g = self.gripper_or_err()?;
        let d = self.description_or_err(&g)?;
        let target = vec![d.driver_position(opening)?];
        let effort = self.finger_effort(&g, force)?;
        self.drive_fingers(state, &g.dofs, &target, effort)
    }

    /// Drives the gripper's driver joint to `position` (rad or m, within the
    /// gripper's open and closed positions), force limited by `force` N per
    /// finger.
    pub fn set_gripper_driver(
        &mut self,
        state: &mut PhysState,
        position: f64,
        force: Option<f64>,
    ) -> Result<()> {
        let g = self.gripper_or_err()?;
        if g.dofs.len() != 1 {
            return Err(SimError::InvalidArgument(format!(
                "robot '{}''s gripper has {} finger DOFs, not one driver",
                self.name,
                g.dofs.len()
            )));
        }
        let (lo, hi) = (g.open[0].min(g.closed[0]), g.open[0].max(g.closed[0]));
        if !(position >= lo && position <= hi) {
            return Err(SimError::InvalidArgument(format!(
                "gripper driver position must be in [{lo}, {hi}], got {position}"
            )));
        }
        let effort = self.finger_effort(&g, force)?;
        self.drive_fingers(state, &g.dofs, &[position], effort)
    }

    /// Current opening (m) of a described gripper, from its driver.
    pub fn gripper_opening(&self, state: &PhysState) -> Result<f64> {
        let g = self.gripper_or_err()?;
        let d = self.description_or_err(&g)?;
        Ok(d.opening(self.joint_positions(state)[g.dofs[0]]))
    }

    fn description_or_err<'a>(&self, g: &'a ParallelGripper) -> Result<&'a Gripper> {
        g.description.as_ref().ok_or_else(|| {
            SimError::InvalidArgument(format!(
                "robot '{}''s gripper has no description (opening map): it was given by joint positions",
                self.name
            ))
        })
    }

    /// Per-DOF force limits for a squeeze of `force` N per finger: the
    /// description's driver effort ([`Gripper::driver_effort`], at the
    /// middle of the driver's range), else `force` itself.
    fn finger_effort(&self, g: &ParallelGripper, force: Option<f64>) -> Result<Option<f64>> {
        let Some(f) = force else { return Ok(None) };
        if !(f.is_finite() && f > 0.0) {
            return Err(SimError::InvalidArgument(format!(
                "gripper force must be finite and > 0, got {f}"
            )));
        }
        Ok(Some(match &g.description {
            Some(d) => {
                let q = 0.5 * (d.open_position + d.closed_position);
                d.driver_effort(f, q)
            }
            None => f,
        }))
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
