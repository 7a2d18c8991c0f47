//! The planner's active space: the DOFs of the planning group, in DOF order.
//! The other DOFs (a gripper's fingers, say) are locked at given values.

use ferrobot_model::RobotModel;

use crate::error::{PlanningError, Result};
use crate::limits::KinematicLimits;

/// Active DOFs of a planner and the values of the locked ones.
#[derive(Debug, Clone)]
pub struct ActiveSpace {
    /// Model DOF index of each active DOF (increasing).
    pub dofs: Vec<usize>,
    /// A full configuration holding the locked DOFs' values (the active
    /// entries are overwritten by [`ActiveSpace::expand_into`]).
    pub locked: Vec<f64>,
    /// Names of the active DOFs (the planner's joint order).
    pub names: Vec<String>,
    /// Sampling box: the position limits, with `[-pi, pi]` for unbounded
    /// (continuous) joints.
    pub sample_lower: Vec<f64>,
    /// Upper corner of the sampling box.
    pub sample_upper: Vec<f64>,
}

impl ActiveSpace {
    /// The active space of `dofs` (model DOF indices, increasing), other DOFs
    /// locked at the model's neutral configuration.
    pub fn new(model: &RobotModel, dofs: &[usize]) -> Result<Self> {
        if dofs.is_empty() {
            return Err(PlanningError::InvalidArgument(
                "the planning group has no movable joint".into(),
            ));
        }
        if let Some(&d) = dofs.iter().find(|&&d| d >= model.num_dof()) {
            return Err(PlanningError::InvalidArgument(format!(
                "DOF index {d} out of range (the robot has {})",
                model.num_dof()
            )));
        }
        let limits = KinematicLimits::from_model(model, dofs);
        let bound = |v: f64, fallback: f64| if v.is_finite() { v } else { fallback };
        Ok(Self {
            dofs: dofs.to_vec(),
            locked: model.neutral_configuration(),
            names: dofs.iter().map(|&d| model.dof_names()[d].clone()).collect(),
            sample_lower: limits
                .lower
                .iter()
                .map(|&v| bound(v, -std::f64::consts::PI))
                .collect(),
            sample_upper: limits
                .upper
                .iter()
                .map(|&v| bound(v, std::f64::consts::PI))
                .collect(),
        })
    }

    /// Number of active DOFs.
    pub fn len(&self) -> usize {
        self.dofs.len()
    }

    /// Whether there are no active DOFs.
    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// Writes the full configuration of active `q` into `out`.
    #[inline]
    pub fn expand_into(&self, q: &[f64], out: &mut [f64]) {
        out.copy_from_slice(&self.locked);
        for (&d, &v) in self.dofs.iter().zip(q) {
            out[d] = v;
        }
    }

    /// The full configuration of active `q`.
    pub fn expand(&self, q: &[f64]) -> Vec<f64> {
        let mut out = self.locked.clone();
        self.expand_into(q, &mut out);
        out
    }

    /// The active part of a full configuration.
    pub fn restrict(&self, full: &[f64]) -> Vec<f64> {
        self.dofs.iter().map(|&d| full[d]).collect()
    }

    /// Locks the non-active DOFs at the values of the full configuration `full`.
    pub fn lock_from(&mut self, full: &[f64]) {
        self.locked.copy_from_slice(full);
    }
}
