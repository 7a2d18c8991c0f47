//! The only home of camera concepts in ferrobot: pinhole intrinsics with
//! the image size and depth units ([`Intrinsics`], one validation), frame
//! conventions (OpenCV / ROS optical, OpenGL / USD, ROS body) and the poses
//! between them, `look_at`, and depth back-projection with one policy for
//! missing depth ([`backproject`]: 0 and +inf are missing and skipped; NaN,
//! -inf and negative depths are errors; pixels are (row, column)).
//!
//! The simulator's cameras (rendering stays in `ferrobot-sim`), the grasp
//! detector's RGB-D input and the Python module `ferrobot.camera` all use it.
//!
//! Camera frame: OpenCV (x right, y down, z forward); pixel (u, v) is
//! column u, row v, with pixel centres at integer coordinates.

mod backproject;
pub mod conventions;
mod error;
mod intrinsics;

pub use backproject::{BackProjected, backproject, for_each_point, is_missing};
pub use conventions::{
    Convention, camera_to_world, convert_pose, look_at, opencv_to_opengl, opengl_to_opencv,
};
pub use error::CameraError;
pub use intrinsics::Intrinsics;
