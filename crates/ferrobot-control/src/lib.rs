//! Reactive motion control for ferrobot.
//!
//! Two controllers share one kinematic core ([`core::Core`]: the robot's
//! collision spheres, point Jacobians, joint and velocity limits and the
//! integration of accelerations into position/velocity targets for a
//! position-driven robot):
//!
//! * [`ReactiveController`]: Riemannian motion policies in the manner of
//!   RMPflow. Each policy is an acceleration in its own task space with a
//!   metric saying how much it matters; they are pulled back to joint space
//!   (`sum Jᵀ M J`, `sum Jᵀ M a`) and resolved with a damped solve.
//! * [`PotentialFieldController`]: a classical attractive/repulsive
//!   potential field whose obstacle term reads a voxelised signed distance
//!   field of the world (trilinear lookup of distance and gradient).
//!
//! Both take `step(q, qd, dt) -> (q_target, qd_target, qdd)`, so they run in
//! a closed loop with the simulator or a real robot's state stream.
//!
//! The reactive controller also carries its own global guidance
//! ([`guidance`]): it detects when it has stalled in a local minimum, asks
//! ferrobot's planner for a path to a collision-free IK solution of the
//! target and follows it, reporting a [`GuidanceStatus`] every step; and a
//! self-collision velocity filter (`ReactiveConfig::self_hold`) that keeps
//! checked sphere pairs apart whatever the policies ask.

pub mod config;
pub mod core;
pub mod error;
pub mod exact;
pub mod faults;
pub mod field;
pub mod guidance;
pub mod potential;
pub mod reactive;
pub mod world;

pub use config::{PotentialFieldConfig, ReactiveConfig};
pub use core::{ControllerCore, Core, StepInfo, StepOutput};
pub use error::{ControlError, Result};
pub use exact::{LinkClearance, ObjectClearance};
pub use faults::{Arbiter, Conflict, DepthNoise, DepthNoiseParams, EncoderNoise};
pub use field::VoxelField;
pub use guidance::{GuidanceStatus, PlanAttempt};
pub use potential::PotentialFieldController;
pub use reactive::ReactiveController;
pub use world::ControlWorld;
