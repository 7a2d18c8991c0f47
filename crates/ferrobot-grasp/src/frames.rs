//! Frames: camera conventions, camera to world, world to robot base, and
//! moving grasps between frames.
//!
//! Back-projected clouds are in the OpenCV optical frame (x right, y down,
//! z forward). A camera pose is given in world coordinates for the frame of
//! its [`CameraConvention`].

use nalgebra::{Isometry3, Matrix3, Rotation3, UnitQuaternion};

use crate::error::{GraspError, Result};
use crate::grasp::GraspGroup;

/// Axis convention of a camera frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraConvention {
    /// OpenCV / ROS optical frame: x right, y down, z forward.
    OpenCv,
    /// OpenGL / USD (Isaac Sim): x right, y up, z backward (looks along -z).
    OpenGl,
    /// ROS body frame (REP 103, `camera_link`): x forward, y left, z up.
    Ros,
}

impl CameraConvention {
    /// Parses "opencv" (also "ros_optical"), "opengl" (also "usd") or "ros".
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "opencv" | "ros_optical" | "optical" => Ok(Self::OpenCv),
            "opengl" | "usd" => Ok(Self::OpenGl),
            "ros" | "world" => Ok(Self::Ros),
            other => Err(GraspError::InvalidArgument(format!(
                "unknown camera convention '{other}'; known: opencv (ros_optical), opengl (usd), ros"
            ))),
        }
    }

    /// Rotation taking OpenCV optical coordinates to this convention's.
    pub fn from_opencv(self) -> Rotation3<f64> {
        let m = match self {
            Self::OpenCv => Matrix3::identity(),
            Self::OpenGl => Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
            Self::Ros => Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0),
        };
        Rotation3::from_matrix_unchecked(m)
    }
}

/// The transform taking OpenCV-optical camera coordinates to world
/// coordinates, given the camera's pose in the world in `convention`.
pub fn camera_to_world(
    camera_pose: &Isometry3<f64>,
    convention: CameraConvention,
) -> Isometry3<f64> {
    let r = UnitQuaternion::from_rotation_matrix(&convention.from_opencv());
    camera_pose * Isometry3::from_parts(nalgebra::Translation3::identity(), r)
}

/// The transform taking world coordinates to the robot base frame, given
/// the base's pose in the world.
pub fn world_to_base(base_pose: &Isometry3<f64>) -> Isometry3<f64> {
    base_pose.inverse()
}

/// Applies `t` to every grasp: rotation `R -> t.R · R`, translation
/// `p -> t · p`. Widths, depths and scores are unchanged.
pub fn transform_group(group: &mut GraspGroup, t: &Isometry3<f64>) {
    let r = t.rotation.to_rotation_matrix();
    for g in &mut group.grasps {
        g.rotation = r.matrix() * g.rotation;
        g.translation = t.transform_vector(&g.translation) + t.translation.vector;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Translation3, Vector3};

    #[test]
    fn camera_looking_down_at_the_origin() {
        // OpenGL camera 1 m above the origin looking down (-z_gl = -z_world):
        // identity orientation. A point 1 m in front (OpenCV z = 1) is the origin.
        let pose =
            Isometry3::from_parts(Translation3::new(0.0, 0.0, 1.0), UnitQuaternion::identity());
        let t = camera_to_world(&pose, CameraConvention::OpenGl);
        assert!((t * Point3::new(0.0, 0.0, 1.0) - Point3::origin()).norm() < 1e-12);
        // OpenCV x right is world x; y down is world -y.
        assert!((t * Point3::new(0.0, 1.0, 1.0) - Point3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
        // ROS body frame: x forward. Looking down means pitch +90° about y.
        let rpose = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 1.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2),
        );
        let t = camera_to_world(&rpose, CameraConvention::Ros);
        assert!((t * Point3::new(0.0, 0.0, 1.0) - Point3::origin()).norm() < 1e-12);
        let b = world_to_base(&rpose);
        assert!((b * Point3::new(0.0, 0.0, 1.0)).coords.norm() < 1e-12);
        assert!(CameraConvention::parse("nope").is_err());
    }
}
