//! Physics simulation for ferrobot on Rapier.
//!
//! A [`World`] holds a ground plane, rigid [`objects`] and robots built from
//! a [`ferrobot_model::RobotModel`] as multibody articulations with a fixed
//! base ([`robot`]): joint drives ([`drives`]), mimic joints as Rapier DOF
//! couplings, parallel grippers ([`gripper`]), link contacts filtered by the
//! model's allowed-collision matrix ([`hooks`]). Pinhole cameras render
//! depth, RGB and segmentation by ray casting the scene in parallel
//! ([`camera`]; intrinsics, conventions and back-projection are
//! `ferrobot-camera`'s). [`controllers`] has a joint PID with
//! anti-windup, a resolved-rate Cartesian controller and a trajectory
//! executor.
//!
//! Conventions: SI units, z up, poses as nalgebra `Isometry3<f64>` at the
//! API (Rapier's `f32` glam types stay inside). Stepping is deterministic:
//! the same inputs give the same states bit for bit.

pub mod calibration;
pub mod camera;
pub mod controllers;
pub mod convert;
pub mod drives;
pub mod error;
pub mod gripper;
pub mod hooks;
pub mod latency;
pub mod objects;
pub mod robot;
pub mod state;
pub mod trajectory;
pub mod world;

pub use camera::{Camera, CameraMount, DirectionalLight, Frame, Intrinsics, Lighting};
pub use controllers::{JointPid, ResolvedRate};
pub use drives::Drive;
pub use error::{Result, SimError};
pub use ferrobot_geometry::Shape;
pub use gripper::ParallelGripper;
pub use objects::ObjectDesc;
pub use robot::{Robot, RobotOptions};
pub use trajectory::{TrackingReport, execute_trajectory};
pub use world::{Object, SegLabel, World, WorldConfig};
