//! Camera frame conventions and the poses between them.
//!
//! - OpenCV / ROS optical (`camera_optical_frame`): x right, y down, z forward.
//!   Every ferrobot camera and back-projected cloud uses it.
//! - OpenGL / USD (Isaac Sim's "usd" axes): x right, y up, looking along -z.
//! - ROS body (REP 103, `camera_link`, Isaac Sim's "world" axes): x forward,
//!   y left, z up.
//!
//! A camera pose "in convention C" is the world pose of the frame whose axes
//! follow C; all of them share the camera's origin.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::error::CameraError;

/// Axis convention of a camera frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Convention {
    /// OpenCV / ROS optical frame: x right, y down, z forward.
    OpenCv,
    /// OpenGL / USD: x right, y up, z backward (looks along -z).
    OpenGl,
    /// ROS body frame (REP 103): x forward, y left, z up.
    Ros,
}

impl Convention {
    /// Parses "opencv" (also "ros_optical", "optical"), "opengl" (also
    /// "usd") or "ros" (also "world", Isaac Sim's name), case-insensitive.
    pub fn parse(s: &str) -> Result<Self, CameraError> {
        match s.to_ascii_lowercase().as_str() {
            "opencv" | "ros_optical" | "optical" => Ok(Self::OpenCv),
            "opengl" | "usd" => Ok(Self::OpenGl),
            "ros" | "world" => Ok(Self::Ros),
            other => Err(CameraError::InvalidArgument(format!(
                "unknown camera convention '{other}'; known: opencv (ros_optical), opengl (usd), ros (world)"
            ))),
        }
    }

    /// The rotation taking OpenCV optical coordinates of a point to this
    /// convention's coordinates of the same point.
    pub fn from_opencv(self) -> Rotation3<f64> {
        let m = match self {
            Self::OpenCv => Matrix3::identity(),
            Self::OpenGl => Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
            Self::Ros => Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        };
        Rotation3::from_matrix_unchecked(m)
    }
}

fn turn(r: Rotation3<f64>) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_rotation_matrix(&r),
    )
}

/// The pose in convention `to` of a camera whose pose in convention `from`
/// is `pose` (same origin, axes permuted).
pub fn convert_pose(pose: &Isometry3<f64>, from: Convention, to: Convention) -> Isometry3<f64> {
    pose * turn(from.from_opencv()) * turn(to.from_opencv().inverse())
}

/// The OpenGL/USD camera pose of an OpenCV camera pose.
pub fn opencv_to_opengl(pose: &Isometry3<f64>) -> Isometry3<f64> {
    convert_pose(pose, Convention::OpenCv, Convention::OpenGl)
}

/// The OpenCV camera pose of an OpenGL/USD camera pose.
pub fn opengl_to_opencv(pose: &Isometry3<f64>) -> Isometry3<f64> {
    convert_pose(pose, Convention::OpenGl, Convention::OpenCv)
}

/// The transform taking OpenCV-optical camera coordinates to world
/// coordinates, given the camera's world pose in `convention` (the OpenCV
/// pose of the camera).
pub fn camera_to_world(camera_pose: &Isometry3<f64>, convention: Convention) -> Isometry3<f64> {
    convert_pose(camera_pose, convention, Convention::OpenCv)
}

/// The OpenCV camera pose at `eye` looking at `target`, with image "up"
/// (-y) towards `up` (world frame). Fails when eye and target coincide or
/// `up` is parallel to the viewing direction.
pub fn look_at(
    eye: &Point3<f64>,
    target: &Point3<f64>,
    up: &Vector3<f64>,
) -> Result<Isometry3<f64>, CameraError> {
    let z = target - eye;
    if z.norm().is_nan() || z.norm() <= 1e-9 {
        return Err(CameraError::InvalidArgument(
            "look_at: eye and target coincide".into(),
        ));
    }
    let z = z.normalize();
    let x = z.cross(up);
    if x.norm().is_nan() || x.norm() <= 1e-9 {
        return Err(CameraError::InvalidArgument(
            "look_at: the up vector is parallel to the viewing direction".into(),
        ));
    }
    let x = x.normalize();
    let y = z.cross(&x);
    let m = Matrix3::from_columns(&[x, y, z]);
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
    Ok(Isometry3::from_parts(eye.coords.into(), rot))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_looking_down_at_the_origin() {
        // OpenGL camera 1 m above the origin looking down (-z_gl = -z_world):
        // identity orientation. A point 1 m in front (OpenCV z = 1) is the origin.
        let pose =
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 1.0), UnitQuaternion::identity());
        let t = camera_to_world(&pose, Convention::OpenGl);
        assert!((t * Point3::new(0.0, 0.0, 1.0) - Point3::origin()).norm() < 1e-12);
        // OpenCV x right is world x; y down is world -y.
        assert!((t * Point3::new(0.0, 1.0, 1.0) - Point3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        // ROS body frame: x forward. Looking down means pitch +90° about y.
        let rpose = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 1.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2),
        );
        let t = camera_to_world(&rpose, Convention::Ros);
        assert!((t * Point3::new(0.0, 0.0, 1.0) - Point3::origin()).norm() < 1e-12);
        assert!(Convention::parse("nope").is_err());
        // Round trips.
        let p = look_at(
            &Point3::new(1.0, 2.0, 3.0),
            &Point3::origin(),
            &Vector3::z(),
        )
        .unwrap();
        for c in [Convention::OpenCv, Convention::OpenGl, Convention::Ros] {
            let back = convert_pose(
                &convert_pose(&p, Convention::OpenCv, c),
                c,
                Convention::OpenCv,
            );
            assert!((back.to_homogeneous() - p.to_homogeneous()).norm() < 1e-12);
        }
    }
}
