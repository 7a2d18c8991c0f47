//! The top layer of ferrobot: what joins the simulation, the collision
//! world and the planner in a pick-and-place pipeline.
//!
//! The pipeline's orchestration (perceive, detect grasps, plan, execute)
//! lives in the Python package `ferrobot.pipeline`; the pieces that do
//! real work on the scene live here.

pub mod scene_sync;

pub use scene_sync::{SceneSync, SyncOptions, SyncStats, collision_world_from_sim};
