//! Links: bodies of the kinematic tree with their geometry and mass.

use crate::geometry::{Geometry, Inertial};

/// A link of the kinematic tree.
#[derive(Debug, Clone)]
pub struct Link {
    /// Name as in the URDF.
    pub name: String,
    /// Index (in the model's `joints`) of the joint whose child this link is;
    /// `None` for the root.
    pub parent_joint: Option<usize>,
    /// Indices of the joints whose parent this link is, in URDF order.
    pub child_joints: Vec<usize>,
    /// Collision geometry, in the link frame.
    pub collisions: Vec<Geometry>,
    /// Visual geometry, in the link frame.
    pub visuals: Vec<Geometry>,
    /// Mass properties.
    pub inertial: Inertial,
}
