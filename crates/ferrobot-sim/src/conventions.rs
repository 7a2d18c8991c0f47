//! Camera conventions and back-projection.
//!
//! OpenCV / ROS optical frame: x right, y down, z forward (ferrobot's
//! cameras). OpenGL / USD (Isaac Sim) camera frame: x right, y up, looking
//! along -z. The two differ by a rotation of pi about x.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};

use crate::camera::Intrinsics;
use crate::error::{Result, SimError};

fn flip() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
}

/// The pose of an OpenGL/USD camera frame given the OpenCV frame pose.
pub fn opencv_to_opengl(pose: &Isometry3<f64>) -> Isometry3<f64> {
    pose * flip()
}

/// The pose of an OpenCV camera frame given the OpenGL/USD frame pose.
pub fn opengl_to_opencv(pose: &Isometry3<f64>) -> Isometry3<f64> {
    pose * flip().inverse()
}

/// The OpenCV camera pose at `eye` looking at `target`, with image "up"
/// towards `up` (world frame).
pub fn look_at(
    eye: &Point3<f64>,
    target: &Point3<f64>,
    up: &Vector3<f64>,
) -> Result<Isometry3<f64>> {
    let z = target - eye;
    if z.norm().is_nan() || z.norm() <= 1e-9 {
        return Err(SimError::InvalidArgument(
            "look_at: eye and target coincide".into(),
        ));
    }
    let z = z.normalize();
    let x = z.cross(up);
    if x.norm().is_nan() || x.norm() <= 1e-9 {
        return Err(SimError::InvalidArgument(
            "look_at: the up vector is parallel to the viewing direction".into(),
        ));
    }
    let x = x.normalize();
    let y = z.cross(&x);
    let m = nalgebra::Matrix3::from_columns(&[x, y, z]);
    let rot = UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(m));
    Ok(Isometry3::from_parts(eye.coords.into(), rot))
}

/// Back-projects a depth image (row-major, metres along the optical axis)
/// to camera-frame (OpenCV) points, one per valid pixel (finite depth > 0),
/// with the flat pixel index of each.
pub fn depth_to_points(depth: &[f32], intr: &Intrinsics) -> Result<(Vec<[f64; 3]>, Vec<usize>)> {
    intr.validate()?;
    if depth.len() != intr.width * intr.height {
        return Err(SimError::Shape {
            what: "depth".into(),
            expected: format!("({}, {})", intr.height, intr.width),
            got: format!("{} values", depth.len()),
        });
    }
    let mut pts = Vec::new();
    let mut idx = Vec::new();
    for (i, &d) in depth.iter().enumerate() {
        if !(d.is_finite() && d > 0.0) {
            continue;
        }
        let (u, v) = ((i % intr.width) as f64, (i / intr.width) as f64);
        let z = d as f64;
        pts.push([(u - intr.cx) / intr.fx * z, (v - intr.cy) / intr.fy * z, z]);
        idx.push(i);
    }
    Ok((pts, idx))
}
