//! The cloneable physics state: every Rapier set a step reads and writes.

use rapier3d::prelude::{
    BroadPhaseBvh, CCDSolver, ColliderSet, ImpulseJointSet, IslandManager, MultibodyJointSet,
    NarrowPhase, RigidBodySet, SoftBodySet,
};

/// All Rapier sets of a world. Cloning it is a snapshot (used by
/// `World::reset`); stepping the same state with the same inputs gives the
/// same result bit for bit.
#[derive(Clone, Default)]
pub struct PhysState {
    /// Sleeping/awake islands.
    pub islands: IslandManager,
    /// Broad phase.
    pub broad_phase: BroadPhaseBvh,
    /// Narrow phase (contact manifolds, warm-start impulses).
    pub narrow_phase: NarrowPhase,
    /// Rigid bodies.
    pub bodies: RigidBodySet,
    /// Colliders.
    pub colliders: ColliderSet,
    /// Impulse joints (unused by robots; kept for completeness).
    pub impulse_joints: ImpulseJointSet,
    /// Multibody joints: the robots' articulations.
    pub multibody_joints: MultibodyJointSet,
    /// Soft bodies (unused).
    pub soft_bodies: SoftBodySet,
    /// Continuous collision detection.
    pub ccd: CCDSolver,
}
