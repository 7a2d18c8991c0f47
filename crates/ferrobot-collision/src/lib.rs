//! Collision checking for ferrobot: sphere models of robots (automatic,
//! from a spherized URDF or cuRobo's YAML), a world of primitives, meshes
//! and point clouds, an allowed-collision matrix, and fast batched checks,
//! motion checks and signed distances with gradients.
//!
//! The hot path ([`kernel`]) is written once over [`lanes::Lanes`]: one
//! `f32` for a single configuration, eight `f32` SIMD lanes for batches and
//! motions, with bit-identical results per configuration.

pub mod acm;
pub mod body_centres;
pub mod certify;
pub mod checker;
pub mod compiled;
pub mod dispatch;
pub mod distance;
pub mod error;
pub mod exact;
pub mod kernel;
pub mod lanes;
pub mod moveit;
pub mod pair_bounds;
pub mod pair_map;
pub mod robot_spheres;
pub mod single;
pub mod sphere;
pub mod spherize;
pub mod spherize_cache;
pub mod urdf_check;
pub mod world;
pub mod world_grid;

pub use acm::{AllowedCollisions, AnalysisReport, AnalyzeCollisions};
pub use checker::{CollisionChecker, Contact, RobotCollisionModel};
pub use dispatch::SimdLevel;
pub use error::{CollisionError, Result};
pub use ferrobot_geometry::{Mesh, PointCloud, Shape};
pub use robot_spheres::RobotSpheres;
pub use sphere::Sphere;
pub use world::{CollisionWorld, WorldObject};
