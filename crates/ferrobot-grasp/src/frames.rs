//! Frames: world to robot base, and moving grasps between frames. Camera
//! conventions and camera-to-world transforms are `ferrobot-camera`'s
//! (`ferrobot_camera::conventions`).

use nalgebra::Isometry3;

use crate::grasp::GraspGroup;

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
    use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};

    #[test]
    fn base_frame_and_grasp_transform() {
        let base = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 1.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), std::f64::consts::FRAC_PI_2),
        );
        let b = world_to_base(&base);
        assert!((b * Point3::new(0.0, 0.0, 1.0)).coords.norm() < 1e-12);
    }
}
