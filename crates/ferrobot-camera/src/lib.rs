//! The pinhole camera model shared by ferrobot's simulator (rendered depth
//! to points) and grasp detector (RGB-D input to a cloud): intrinsics and
//! depth back-projection, in one place so both agree on the convention.
//!
//! Camera frame: OpenCV (x right, y down, z forward); pixel (u, v) is
//! column u, row v, with pixel centres at integer coordinates.

mod backproject;
mod error;
mod pinhole;

pub use backproject::{BackProjected, backproject};
pub use error::CameraError;
pub use pinhole::Pinhole;
