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

/// A configuration as a caller gave it, read for `space`: the active
/// configuration, and the full configuration (`dof_names` order) when the
/// caller's values also set joints the planner does not move to values
/// other than `space`'s locked ones (a request then carries them as its
/// locked joints).
#[derive(Debug, Clone, PartialEq)]
pub struct Configuration {
    /// The planned joints, in the planner's order.
    pub active: Vec<f64>,
    /// The full configuration, when it overrides locked joints.
    pub full: Option<Vec<f64>>,
}

impl Configuration {
    /// Reads `values` (the argument `what`): in `order` if given (entries
    /// of joints the planner does not move set them where they differ from
    /// the locked values); else a full vector in `dof_names` order (which
    /// sets the locked joints) or the planned joints in the planner's order.
    pub fn read(
        model: &RobotModel,
        space: &ActiveSpace,
        order: Option<&JointOrder>,
        what: &str,
        values: &[f64],
    ) -> Result<Self> {
        if let Some(o) = order {
            let active = o.to_active(what, values)?;
            let locked = o.locked_values(values);
            let full = if locked.iter().any(|&(d, x)| x != space.locked[d]) {
                let mut full = space.expand(&active);
                for (d, x) in locked {
                    full[d] = x;
                }
                Some(full)
            } else {
                None
            };
            return Ok(Self { active, full });
        }
        let n = model.num_dof();
        if values.len() == space.len() {
            Ok(Self {
                active: values.to_vec(),
                full: None,
            })
        } else if values.len() == n {
            Ok(Self {
                active: space.restrict(values),
                full: Some(values.to_vec()),
            })
        } else {
            Err(ModelError::Shape {
                what: what.into(),
                expected: format!(
                    "({n},) in dof_names order or ({},) in planner joint_names order {:?}",
                    space.len(),
                    space.names
                ),
                got: format!("({},)", values.len()),
            }
            .into())
        }
    }

    /// The full configuration: the given one, or the active one with the
    /// locked joints at `space`'s values.
    pub fn into_full(self, space: &ActiveSpace) -> Vec<f64> {
        match self.full {
            Some(f) => f,
            None => space.expand(&self.active),
        }
    }

    /// The locked joints this configuration sets for a query: its full
    /// configuration if that differs from `space`'s locked values.
    pub fn locked_override(&self, space: &ActiveSpace) -> Option<Vec<f64>> {
        self.full.clone().filter(|f| *f != space.locked)
    }
}
