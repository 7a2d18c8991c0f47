//! Non-maximum suppression of grasps (graspnetAPI's defaults: 0.03 m, 30°).

use nalgebra::Matrix3;

use crate::grasp::Grasp;

/// Angle in radians between two grasp orientations, treating a half turn
/// about the approach axis (swapping the fingers) as the same grasp.
pub fn rotation_distance(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let angle = |m: Matrix3<f64>| ((m.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
    let rel = a.transpose() * b;
    // Half turn about x: diag(1, -1, -1).
    let flipped = Matrix3::new(
        rel[(0, 0)],
        -rel[(0, 1)],
        -rel[(0, 2)],
        rel[(1, 0)],
        -rel[(1, 1)],
        -rel[(1, 2)],
        rel[(2, 0)],
        -rel[(2, 1)],
        -rel[(2, 2)],
    );
    angle(rel).min(angle(flipped))
}

/// Indices of the grasps kept by greedy non-maximum suppression, best score
/// first: a grasp is dropped when a better kept grasp is within
/// `translation` metres and `rotation` radians of it.
pub fn nms(grasps: &[Grasp], translation: f64, rotation: f64) -> Vec<usize> {
    nms_filtered(grasps, translation, rotation, |_| true)
}

/// [`nms`] with a test run lazily, best score first, on each grasp that
/// is not suppressed: a grasp failing `accept` is dropped and suppresses
/// nothing (so a better grasp that fails, e.g. a hand body in collision,
/// does not hide a valid neighbour). `accept` runs only on grasps that
/// would otherwise be kept, which is what makes an expensive test cheap.
pub fn nms_filtered(
    grasps: &[Grasp],
    translation: f64,
    rotation: f64,
    mut accept: impl FnMut(usize) -> bool,
) -> Vec<usize> {
    let mut order: Vec<usize> = (0..grasps.len()).collect();
    order.sort_by(|&a, &b| grasps[b].score.total_cmp(&grasps[a].score));
    let t2 = translation * translation;
    let mut kept: Vec<usize> = Vec::new();
    for i in order {
        let g = &grasps[i];
        let suppressed = kept.iter().any(|&k| {
            let h = &grasps[k];
            (h.translation - g.translation).norm_squared() < t2
                && rotation_distance(&h.rotation, &g.rotation) < rotation
        });
        if !suppressed && accept(i) {
            kept.push(i);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    fn g(score: f64, x: f64, angle: f64) -> Grasp {
        Grasp {
            score,
            width: 0.05,
            height: 0.02,
            depth: 0.02,
            rotation: *Rotation3::from_axis_angle(&Vector3::z_axis(), angle).matrix(),
            translation: Vector3::new(x, 0.0, 0.0),
            object_id: -1,
        }
    }

    #[test]
    fn suppresses_near_and_similar_only() {
        let gs = [
            g(0.5, 0.0, 0.0),
            g(0.9, 0.01, 0.1),
            g(0.8, 0.05, 0.0),
            g(0.7, 0.0, 1.0),
        ];
        assert_eq!(nms(&gs, 0.03, 30f64.to_radians()), vec![1, 2, 3]);
        let flip = Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI);
        assert!(rotation_distance(&Matrix3::identity(), flip.matrix()) < 1e-9);
    }
}
