//! Robot models for ferrobot.
//!
//! Loads URDF (with urdf-rs) and SRDF into a [`RobotModel`]: a kinematic
//! tree of [`Link`]s and [`Joint`]s (revolute, continuous, prismatic, fixed,
//! mimic), limits, collision and visual [`Geometry`] with meshes loaded, and
//! the semantic information of an SRDF. Forward kinematics and geometric
//! Jacobians run on compiled [`KinematicChain`]s; batched FK runs on rayon.
//!
//! Conventions: SI units; poses as `[x, y, z, qw, qx, qy, qz]` or 4x4
//! matrices; everything expressed in the base link's frame.

pub mod acm;
pub mod chain;
pub mod check;
pub mod error;
pub mod geometry;
pub mod gripper;
mod groups;
pub mod joint;
pub mod kinematics;
pub mod link;
pub mod model;
pub mod ranges;
pub mod resolve;
pub mod robots;
pub mod srdf;
pub mod urdf;
pub mod xml;

pub use acm::AllowedCollisions;
pub use chain::KinematicChain;
pub use error::{ModelError, Result, SourceLocation};
pub use ferrobot_geometry::{Hull, Mesh, MeshSource, TriMesh};
pub use geometry::{Geometry, Inertial, Shape};
pub use gripper::{FingerGeometry, Gripper, HandExtents, OpeningMap};
pub use joint::{Joint, JointCoupling, JointKind, JointLimits, Mimic};
pub use kinematics::{pose_to_array, pose_to_matrix};
pub use link::Link;
/// Triangle meshes (the geometry crate's, re-exported).
pub mod mesh {
    pub use ferrobot_geometry::TriMesh;
}
pub use model::{LoadOptions, RobotModel, SrdfSource};
pub use srdf::Srdf;
