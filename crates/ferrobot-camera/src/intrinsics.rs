//! Pinhole intrinsics with the image size and the depth units: the one
//! camera model of ferrobot (simulated cameras, grasp detection from RGB-D,
//! the Python `ferrobot.camera` module).

use nalgebra::{Matrix3, Point3};

use crate::error::CameraError;

/// Pinhole intrinsics of a `width` x `height` image (OpenCV optical frame:
/// x right, y down, z forward; pixel (u, v) is column u, row v, pixel
/// centres at integer coordinates) and the units of its depth images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Image width in pixels, in `1..=MAX_SIZE`.
    pub width: usize,
    /// Image height in pixels, in `1..=MAX_SIZE`.
    pub height: usize,
    /// Focal length along u (columns), in pixels, finite and > 0.
    pub fx: f64,
    /// Focal length along v (rows), in pixels, finite and > 0.
    pub fy: f64,
    /// Principal point u, in pixels, finite.
    pub cx: f64,
    /// Principal point v, in pixels, finite.
    pub cy: f64,
    /// Raw depth units per metre, finite and > 0: z = depth / depth_scale
    /// (1 for depth in metres, as rendered; 1000 for millimetre sensors).
    pub depth_scale: f64,
}

fn focal(what: &str, v: f64) -> Result<(), CameraError> {
    if !v.is_finite() {
        return Err(CameraError::NonFinite(format!(
            "{what} must be finite, got {v}"
        )));
    }
    if v <= 0.0 {
        return Err(CameraError::InvalidArgument(format!(
            "{what} must be positive, got {v}"
        )));
    }
    Ok(())
}

impl Intrinsics {
    /// Largest image side accepted (pixels).
    pub const MAX_SIZE: usize = 16384;

    /// Validated intrinsics with depth in metres (`depth_scale` 1).
    pub fn new(
        width: usize,
        height: usize,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
    ) -> Result<Self, CameraError> {
        let k = Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            depth_scale: 1.0,
        };
        k.validate()?;
        Ok(k)
    }

    /// Centred intrinsics from a horizontal field of view `fov_x` (rad, in
    /// (0, pi)): f = width / 2 / tan(fov_x / 2), square pixels.
    pub fn from_fov(width: usize, height: usize, fov_x: f64) -> Result<Self, CameraError> {
        if !(fov_x.is_finite() && fov_x > 0.0 && fov_x < std::f64::consts::PI) {
            return Err(CameraError::InvalidArgument(format!(
                "field of view must be in (0, pi), got {fov_x}"
            )));
        }
        let f = width as f64 / 2.0 / (fov_x / 2.0).tan();
        Self::new(
            width,
            height,
            f,
            f,
            (width as f64 - 1.0) / 2.0,
            (height as f64 - 1.0) / 2.0,
        )
    }

    /// The same intrinsics with depth in `depth_scale` raw units per metre.
    pub fn with_depth_scale(self, depth_scale: f64) -> Result<Self, CameraError> {
        let k = Self {
            depth_scale,
            ..self
        };
        k.validate()?;
        Ok(k)
    }

    /// The one validation: size in `1..=MAX_SIZE`, focal lengths and depth
    /// scale finite and positive, principal point finite. Non-finite values
    /// are [`CameraError::NonFinite`], the rest [`CameraError::InvalidArgument`].
    pub fn validate(&self) -> Result<(), CameraError> {
        let ok = |n: usize| (1..=Self::MAX_SIZE).contains(&n);
        if !(ok(self.width) && ok(self.height)) {
            return Err(CameraError::InvalidArgument(format!(
                "camera image size must be between 1 and {} pixels, got {}x{}",
                Self::MAX_SIZE,
                self.width,
                self.height
            )));
        }
        focal("intrinsics fx", self.fx)?;
        focal("intrinsics fy", self.fy)?;
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(CameraError::NonFinite(format!(
                    "intrinsics {name} must be finite, got {v}"
                )));
            }
        }
        focal("depth scale", self.depth_scale)
    }

    /// The 3x3 matrix K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]].
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// The camera-frame point at depth `z` (metres along the optical axis)
    /// seen at pixel column `u`, row `v`: ((u - cx) / fx · z, (v - cy) / fy · z, z).
    #[inline]
    pub fn unproject(&self, u: f64, v: f64, z: f64) -> Point3<f64> {
        Point3::new((u - self.cx) / self.fx * z, (v - self.cy) / self.fy * z, z)
    }

    /// The pixel `(u, v)` (column, row) at which the camera-frame point `p`
    /// is seen: (fx · x / z + cx, fy · y / z + cy); None behind the camera
    /// (z <= 0). Inverse of [`Intrinsics::unproject`].
    #[inline]
    pub fn project(&self, p: &Point3<f64>) -> Option<(f64, f64)> {
        (p.z > 0.0).then(|| (self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unproject_project_and_validation() {
        let k = Intrinsics::new(4, 3, 100.0, 200.0, 1.0, 0.5).unwrap();
        let p = k.unproject(3.0, 2.5, 2.0);
        assert_eq!(p, Point3::new(0.04, 0.02, 2.0));
        let (u, v) = k.project(&p).unwrap();
        assert!((u - 3.0).abs() < 1e-12 && (v - 2.5).abs() < 1e-12);
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
        assert!(matches!(
            Intrinsics { fx: 0.0, ..k }.validate(),
            Err(CameraError::InvalidArgument(_))
        ));
        assert!(matches!(
            Intrinsics { cy: f64::NAN, ..k }.validate(),
            Err(CameraError::NonFinite(_))
        ));
        assert!(Intrinsics { width: 0, ..k }.validate().is_err());
        assert!(k.with_depth_scale(-1.0).is_err());
        let f = Intrinsics::from_fov(640, 480, std::f64::consts::FRAC_PI_2).unwrap();
        assert!((f.fx - 320.0).abs() < 1e-9 && f.cx == 319.5);
    }
}
