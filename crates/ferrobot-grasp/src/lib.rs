//! Analytic 6-DoF parallel-jaw grasp detection for ferrobot.
//!
//! The pipeline ([`detect::detect`]): an RGB-D frame is back-projected to a
//! point cloud ([`backproject()`]), cropped to a workspace, voxel-downsampled
//! ([`voxel`]; [`detect::detect_rgbd`] puts the pixels straight into the
//! voxel grid), given normals from a kd-tree neighbourhood ([`normals`]);
//! hands are searched in the local frame of seed points over approach
//! rotations ([`candidates`]), checked for collision with the gripper's
//! geometry ([`gripper`]), scored by two-contact force closure at a friction
//! coefficient, contact support and approach direction ([`quality`]) and
//! kept above the support plane if one is found ([`plane`]), then
//! thinned by non-maximum suppression ([`nms`]) and sorted into a
//! [`grasp::GraspGroup`].
//!
//! Gripper frame (graspnetAPI's): x is the approach direction (from the palm
//! towards the fingertips), y the closing direction (the line between the
//! fingers), z = x × y. The grasp translation is the hand's centre point on
//! the surface; the fingertips reach `depth` beyond it along x.

pub mod approaches;
pub mod backproject;
pub mod candidates;
pub mod detect;
pub mod error;
pub mod frames;
pub mod grasp;
pub mod gripper;
pub mod mass;
pub mod nms;
pub mod normals;
pub mod plane;
pub mod quality;
pub mod seeds;
pub mod voxel;

pub use backproject::{Intrinsics, Workspace, backproject};
pub use detect::{DetectOptions, detect};
pub use error::{GraspError, Result};
pub use grasp::{Grasp, GraspGroup};
pub use gripper::GripperGeometry;
pub use normals::SurfaceCloud;
