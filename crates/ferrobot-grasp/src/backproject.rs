//! Back-projection of a depth image to a point cloud (through the shared
//! pinhole model of `ferrobot-camera`), with the grasp detector's input
//! checks and workspace limits.

use ferrobot_camera::{CameraError, Pinhole};
use nalgebra::Point3;

use crate::error::{GraspError, Result, positive};

pub use ferrobot_camera::BackProjected;

/// Pinhole intrinsics of a depth camera (OpenCV convention: x right, y down,
/// z forward) and the depth scale (raw depth units per metre, e.g. 1000 for
/// millimetre depth images, 1 for metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along u, in pixels.
    pub fx: f64,
    /// Focal length along v, in pixels.
    pub fy: f64,
    /// Principal point u, in pixels.
    pub cx: f64,
    /// Principal point v, in pixels.
    pub cy: f64,
    /// Raw depth units per metre: z = depth / scale.
    pub scale: f64,
}

impl Intrinsics {
    /// Checks that focal lengths and scale are positive and all values finite.
    pub fn validate(&self) -> Result<()> {
        positive("intrinsics fx", self.fx)?;
        positive("intrinsics fy", self.fy)?;
        positive("depth scale", self.scale)?;
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(GraspError::NonFinite(format!(
                    "intrinsics {name} must be finite, got {v}"
                )));
            }
        }
        Ok(())
    }

    /// The pinhole part (focal lengths and principal point).
    pub fn pinhole(&self) -> Pinhole {
        Pinhole {
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
        }
    }
}

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

/// Back-projects a `height` x `width` depth image (row-major) through
/// `intrinsics`: z = depth / scale, x = (u - cx) / fx · z,
/// y = (v - cy) / fy · z, for pixel column u and row v.
///
/// A depth of 0 means "no reading" and the pixel is skipped; NaN, infinite
/// or negative depths are errors. Points outside `workspace` are dropped.
/// The arithmetic is [`ferrobot_camera::backproject`], shared with the
/// simulator's cameras.
pub fn backproject(
    depth: &[f64],
    height: usize,
    width: usize,
    intrinsics: &Intrinsics,
    workspace: Option<&Workspace>,
) -> Result<BackProjected> {
    intrinsics.validate()?;
    if let Some(w) = workspace {
        w.validate()?;
    }
    if depth.len() != height * width {
        return Err(GraspError::Shape(format!(
            "depth image: {} values for a {height}x{width} image",
            depth.len()
        )));
    }
    if let Some(i) = depth.iter().position(|d| !d.is_finite()) {
        return Err(GraspError::NonFinite(format!(
            "depth image: non-finite value {} at pixel (row {}, column {})",
            depth[i],
            i / width.max(1),
            i % width.max(1)
        )));
    }
    if let Some(i) = depth.iter().position(|d| *d < 0.0) {
        return Err(GraspError::InvalidArgument(format!(
            "depth image: negative depth {} at pixel (row {}, column {})",
            depth[i],
            i / width.max(1),
            i % width.max(1)
        )));
    }
    if depth.is_empty() {
        return Ok(BackProjected::default());
    }
    Ok(ferrobot_camera::backproject(
        depth,
        width,
        &intrinsics.pinhole(),
        intrinsics.scale,
        |p| workspace.is_none_or(|w| w.contains(p)),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formula_and_skips() {
        let k = Intrinsics {
            fx: 100.0,
            fy: 200.0,
            cx: 1.0,
            cy: 0.5,
            scale: 1000.0,
        };
        let depth = [0.0, 500.0, 1000.0, 2000.0];
        let b = backproject(&depth, 2, 2, &k, None).unwrap();
        assert_eq!(b.pixels, vec![1, 2, 3]);
        let p = b.points[2]; // v = 1, u = 1, z = 2
        assert!((p - Point3::new(0.0, 0.5 / 200.0 * 2.0, 2.0)).norm() < 1e-12);
        let w = Workspace([-1.0, 1.0, -1.0, 1.0, 0.0, 1.5]);
        assert_eq!(
            backproject(&depth, 2, 2, &k, Some(&w)).unwrap().pixels,
            vec![1, 2]
        );
        assert!(matches!(
            backproject(&[f64::NAN], 1, 1, &k, None),
            Err(GraspError::NonFinite(_))
        ));
        let bad = Intrinsics { fx: 0.0, ..k };
        assert!(backproject(&depth, 2, 2, &bad, None).is_err());
        assert!(matches!(
            backproject(&depth, 1, 2, &k, None),
            Err(GraspError::Shape(_))
        ));
    }
}
