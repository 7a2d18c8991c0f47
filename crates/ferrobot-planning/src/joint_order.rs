//! Joint orders other than the planner's: a simulator that lists its DOFs in
//! another order (as Isaac Sim's often differs from cuRobo's), or includes
//! joints the planner does not move (fingers, mimic joints), works without
//! glue code.

use ferrobot_model::{JointCoupling, ModelError, RobotModel};

use crate::error::{PlanningError, Result};
use crate::space::ActiveSpace;

/// Where each entry of a user's joint vector comes from or goes to.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    /// An active DOF (index in the active space).
    Active(usize),
    /// A model DOF that is not active (locked).
    Locked(usize),
    /// A mimic joint: `multiplier * q[dof] + offset`.
    Mimic(usize, f64, f64),
    /// A fixed joint (always 0).
    Fixed,
}

/// A mapping between a named joint order and the planner's active order.
#[derive(Debug, Clone)]
pub struct JointOrder {
    names: Vec<String>,
    slots: Vec<Slot>,
    /// For each active DOF, its position in the user's order.
    active_at: Vec<usize>,
}

impl JointOrder {
    /// The order `names` for `space` of `model`. Every name must be a joint
    /// of the model, no name may repeat, and every active DOF must appear.
    pub fn new(model: &RobotModel, space: &ActiveSpace, names: &[String]) -> Result<Self> {
        let mut slots = Vec::with_capacity(names.len());
        let mut active_at = vec![usize::MAX; space.len()];
        for (i, name) in names.iter().enumerate() {
            if names[..i].contains(name) {
                return Err(PlanningError::InvalidArgument(format!(
                    "joint_names lists '{name}' twice"
                )));
            }
            let j = model.joint(name)?;
            let slot = match model.joints()[j].coupling {
                JointCoupling::Dof(d) => match space.dofs.iter().position(|&a| a == d) {
                    Some(a) => {
                        active_at[a] = i;
                        Slot::Active(a)
                    }
                    None => Slot::Locked(d),
                },
                JointCoupling::Mimic {
                    dof,
                    multiplier,
                    offset,
                } => Slot::Mimic(dof, multiplier, offset),
                JointCoupling::Fixed => Slot::Fixed,
            };
            slots.push(slot);
        }
        if let Some(a) = active_at.iter().position(|&p| p == usize::MAX) {
            return Err(PlanningError::InvalidArgument(format!(
                "joint_names lacks the planned joint '{}' (planned joints: {})",
                space.names[a],
                space.names.join(", ")
            )));
        }
        Ok(Self {
            names: names.to_vec(),
            slots,
            active_at,
        })
    }

    /// The names of this order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether the order is empty.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The active configuration held by `values` (in this order). Entries of
    /// joints the planner does not move are ignored.
    pub fn to_active(&self, what: &str, values: &[f64]) -> Result<Vec<f64>> {
        if values.len() != self.len() {
            return Err(ModelError::Shape {
                what: what.into(),
                expected: format!("({},) in joint_names order", self.len()),
                got: format!("({},)", values.len()),
            }
            .into());
        }
        Ok(self.active_at.iter().map(|&i| values[i]).collect())
    }

    /// The model DOFs that `values` (in this order) hold for joints the
    /// planner does not move, as (dof index, value) pairs.
    pub fn locked_values(&self, values: &[f64]) -> Vec<(usize, f64)> {
        self.slots
            .iter()
            .zip(values)
            .filter_map(|(s, &v)| match *s {
                Slot::Locked(d) => Some((d, v)),
                _ => None,
            })
            .collect()
    }

    /// Values in this order for the active configuration `q`, the locked
    /// values taken from `space`.
    pub fn from_active(&self, space: &ActiveSpace, q: &[f64]) -> Vec<f64> {
        let full = space.expand(q);
        self.slots
            .iter()
            .map(|s| match *s {
                Slot::Active(a) => q[a],
                Slot::Locked(d) => full[d],
                Slot::Mimic(d, m, o) => m * full[d] + o,
                Slot::Fixed => 0.0,
            })
            .collect()
    }

    /// Derivative entries (velocities, accelerations) in this order: active
    /// DOFs from `dq`, mimic joints scaled, locked and fixed joints 0.
    pub fn derivative_from_active(&self, space: &ActiveSpace, dq: &[f64]) -> Vec<f64> {
        self.slots
            .iter()
            .map(|s| match *s {
                Slot::Active(a) => dq[a],
                Slot::Mimic(d, m, _) => space
                    .dofs
                    .iter()
                    .position(|&x| x == d)
                    .map_or(0.0, |a| m * dq[a]),
                Slot::Locked(_) | Slot::Fixed => 0.0,
            })
            .collect()
    }
}
