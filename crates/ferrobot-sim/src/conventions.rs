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
/// with the flat pixel index of each (the shared [`ferrobot_camera::backproject`]).
pub fn depth_to_points(depth: &[f32], intr: &Intrinsics) -> Result<(Vec<[f64; 3]>, Vec<usize>)> {
    intr.validate()?;
    if depth.len() != intr.width * intr.height {
        return Err(SimError::Shape {
            what: "depth".into(),
            expected: format!("({}, {})", intr.height, intr.width),
            got: format!("{} values", depth.len()),
        });
    }
    let pinhole = ferrobot_camera::Pinhole {
        fx: intr.fx,
        fy: intr.fy,
        cx: intr.cx,
        cy: intr.cy,
    };
    let bp = ferrobot_camera::backproject(depth, intr.width, &pinhole, 1.0, |_| true)
        .map_err(|e| SimError::InvalidArgument(e.to_string()))?;
    let pts = bp.points.iter().map(|p| [p.x, p.y, p.z]).collect();
    Ok((pts, bp.pixels))
}
