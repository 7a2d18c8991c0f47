//! Pinhole intrinsics.

use nalgebra::Point3;

use crate::error::CameraError;

/// Pinhole intrinsics in pixels: focal lengths and principal point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    /// Focal length along u (columns), in pixels.
    pub fx: f64,
    /// Focal length along v (rows), in pixels.
    pub fy: f64,
    /// Principal point u, in pixels.
    pub cx: f64,
    /// Principal point v, in pixels.
    pub cy: f64,
}

impl Pinhole {
    /// Checks that the focal lengths are finite and positive and the
    /// principal point finite.
    pub fn validate(&self) -> Result<(), CameraError> {
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if v.is_nan() || v.is_infinite() {
                return Err(CameraError::NonFinite(format!(
                    "intrinsics {name} must be finite, got {v}"
                )));
            }
            if v <= 0.0 {
                return Err(CameraError::InvalidArgument(format!(
                    "intrinsics {name} must be > 0, got {v}"
                )));
            }
        }
        for (name, v) in [("cx", self.cx), ("cy", self.cy)] {
            if !v.is_finite() {
                return Err(CameraError::NonFinite(format!(
                    "intrinsics {name} must be finite, got {v}"
                )));
            }
        }
        Ok(())
    }

    /// The camera-frame point at depth `z` (along the optical axis) seen at
    /// pixel column `u`, row `v`: ((u - cx) / fx · z, (v - cy) / fy · z, z).
    #[inline]
    pub fn unproject(&self, u: f64, v: f64, z: f64) -> Point3<f64> {
        Point3::new((u - self.cx) / self.fx * z, (v - self.cy) / self.fy * z, z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unproject_formula_and_validation() {
        let k = Pinhole {
            fx: 100.0,
            fy: 200.0,
            cx: 1.0,
            cy: 0.5,
        };
        let p = k.unproject(3.0, 2.5, 2.0);
        assert_eq!(p, Point3::new(0.04, 0.02, 2.0));
        assert!(k.validate().is_ok());
        assert!(matches!(
            Pinhole { fx: 0.0, ..k }.validate(),
            Err(CameraError::InvalidArgument(_))
        ));
        assert!(matches!(
            Pinhole { cy: f64::NAN, ..k }.validate(),
            Err(CameraError::NonFinite(_))
        ));
    }
}
