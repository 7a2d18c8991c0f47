//! Motion planning for ferrobot: what cuRobo's `IKSolver` and `MotionGen`
//! do on a GPU, on a CPU, for any robot loaded at run time.
//!
//! Pipeline of [`Planner::plan`]: goal poses go through multi-seed IK goal
//! sets ([`ik`]); RRT-Connect ([`rrt`]) finds a path with vectorised motion
//! checks; [`simplify`] shortens it; [`spline`] fits the minimum-acceleration
//! C2 trajectory through it, re-validated densely against collision, and
//! [`timing`] stretches time until velocity, acceleration and jerk limits
//! hold. Configurations are in the planner's *active space* (the DOFs of the
//! planning group, see [`space`]); [`joint_order`] maps other orders to it.

pub mod error;
pub mod ik;
pub mod joint_order;
pub mod limits;
pub mod planner;
pub mod recheck;
pub mod rrt;
pub mod simplify;
pub mod space;
pub mod spline;
pub mod timing;

pub use error::{PlanningError, Result};
pub use ik::{IkOptions, IkSolution, IkSolver};
pub use joint_order::{Configuration, JointOrder};
pub use limits::KinematicLimits;
pub use planner::{
    Goal, PlanCounts, PlanOptions, PlanRequest, PlanResult, PlanStatus, Planner, StageTimes,
    TimedOut,
};
pub use space::ActiveSpace;
pub use spline::Trajectory;
