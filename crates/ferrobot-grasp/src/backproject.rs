//! Back-projection of a depth image to a point cloud: `ferrobot-camera`'s
//! one function (and its policy for missing depth) with the grasp
//! detector's workspace limits.

use ferrobot_camera::CameraError;
use nalgebra::Point3;

use crate::error::{GraspError, Result};

pub use ferrobot_camera::{BackProjected, Intrinsics};

impl From<CameraError> for GraspError {
    fn from(e: CameraError) -> Self {
        match e {
            CameraError::InvalidArgument(m) => GraspError::InvalidArgument(m),
            CameraError::NonFinite(m) => GraspError::NonFinite(m),
            CameraError::Shape(m) => GraspError::Shape(m),
        }
    }
}

/// Workspace limits `[xmin, xmax, ymin, ymax, zmin, zmax]` (inclusive) in the
/// cloud's frame; points outside are dropped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace(pub [f64; 6]);

impl Workspace {
    /// Checks the limits are finite (infinite bounds are allowed) and each
    /// minimum is at most its maximum.
    pub fn validate(&self) -> Result<()> {
        let l = &self.0;
        if l.iter().any(|v| v.is_nan()) {
            return Err(GraspError::NonFinite(format!(
                "workspace limits contain NaN: {l:?}"
            )));
        }
        for (axis, k) in ["x", "y", "z"].iter().zip([0, 2, 4]) {
            if l[k] > l[k + 1] {
                return Err(GraspError::InvalidArgument(format!(
                    "workspace limits: {axis}min {} > {axis}max {}",
                    l[k],
                    l[k + 1]
                )));
            }
        }
        Ok(())
    }

    /// Whether `p` lies within the limits.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        let l = &self.0;
        p.x >= l[0] && p.x <= l[1] && p.y >= l[2] && p.y <= l[3] && p.z >= l[4] && p.z <= l[5]
    }
}

/// Back-projects a depth image (row-major, `intrinsics.height` x
/// `intrinsics.width`) with [`ferrobot_camera::backproject`]: z = depth /
/// depth_scale, x = (u - cx) / fx · z, y = (v - cy) / fy · z for column u,
/// row v. Depth 0 or +inf is missing and skipped; NaN, -inf or negative
/// depths are errors. Points outside `workspace` are dropped.
pub fn backproject(
    depth: &[f64],
    intrinsics: &Intrinsics,
    workspace: Option<&Workspace>,
) -> Result<BackProjected> {
    if let Some(w) = workspace {
        w.validate()?;
    }
    Ok(ferrobot_camera::backproject(depth, intrinsics, |p| {
        workspace.is_none_or(|w| w.contains(p))
    })?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formula_skips_and_workspace() {
        let k = Intrinsics::new(2, 2, 100.0, 200.0, 1.0, 0.5)
            .unwrap()
            .with_depth_scale(1000.0)
            .unwrap();
        let depth = [0.0, 500.0, 1000.0, 2000.0];
        let b = backproject(&depth, &k, None).unwrap();
        assert_eq!(b.pixels, vec![(0, 1), (1, 0), (1, 1)]);
        let p = b.points[2]; // v = 1, u = 1, z = 2
        assert!((p - Point3::new(0.0, 0.5 / 200.0 * 2.0, 2.0)).norm() < 1e-12);
        let w = Workspace([-1.0, 1.0, -1.0, 1.0, 0.0, 1.5]);
        assert_eq!(
            backproject(&depth, &k, Some(&w)).unwrap().pixels,
            vec![(0, 1), (1, 0)]
        );
        let one = Intrinsics {
            width: 1,
            height: 1,
            ..k
        };
        assert!(matches!(
            backproject(&[f64::NAN], &one, None),
            Err(GraspError::NonFinite(_))
        ));
        assert!(matches!(
            backproject(&depth, &Intrinsics { width: 1, ..k }, None),
            Err(GraspError::Shape(_))
        ));
    }
}
