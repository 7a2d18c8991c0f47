//! Back-projection of a depth image to camera-frame points.

use nalgebra::Point3;

use crate::error::CameraError;
use crate::pinhole::Pinhole;

/// The points back-projected from a depth image.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BackProjected {
    /// Points in the camera frame (OpenCV convention), metres.
    pub points: Vec<Point3<f64>>,
    /// For each point, the flat pixel index `v * width + u` it came from.
    pub pixels: Vec<usize>,
}

/// Back-projects a row-major depth image `width` pixels wide through
/// `pinhole`: z = depth / `scale`, x = (u - cx) / fx · z,
/// y = (v - cy) / fy · z, for pixel column u and row v.
///
/// Pixels without a reading are skipped: depth 0, negative, NaN or infinite
/// (callers that must reject NaN or negative depths check before). Points
/// for which `keep` is false are dropped (e.g. outside a workspace).
/// `depth` may be `f32` (rendered images) or `f64`.
pub fn backproject<D: Copy + Into<f64>>(
    depth: &[D],
    width: usize,
    pinhole: &Pinhole,
    scale: f64,
    mut keep: impl FnMut(&Point3<f64>) -> bool,
) -> Result<BackProjected, CameraError> {
    pinhole.validate()?;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(CameraError::InvalidArgument(format!(
            "depth scale must be finite and > 0, got {scale}"
        )));
    }
    if width == 0 || !depth.len().is_multiple_of(width) {
        return Err(CameraError::Shape(format!(
            "depth image: {} values is not a whole number of rows of {width} pixels",
            depth.len()
        )));
    }
    let mut out = BackProjected::default();
    for (v, row) in depth.chunks_exact(width).enumerate() {
        for (u, &d) in row.iter().enumerate() {
            let d: f64 = d.into();
            if !(d.is_finite() && d > 0.0) {
                continue;
            }
            let p = pinhole.unproject(u as f64, v as f64, d / scale);
            if keep(&p) {
                out.points.push(p);
                out.pixels.push(v * width + u);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formula_skips_and_filter() {
        let k = Pinhole {
            fx: 100.0,
            fy: 200.0,
            cx: 1.0,
            cy: 0.5,
        };
        let depth = [0.0f32, 500.0, f32::INFINITY, 2000.0, -1.0, f32::NAN];
        let b = backproject(&depth, 3, &k, 1000.0, |_| true).unwrap();
        assert_eq!(b.pixels, vec![1, 3]);
        // pixel 3: row 1, column 0, z = 2
        let expect = Point3::new(-1.0 / 100.0 * 2.0, 0.5 / 200.0 * 2.0, 2.0);
        assert!((b.points[1] - expect).norm() < 1e-12);
        let near = backproject(&depth, 3, &k, 1000.0, |p| p.z < 1.0).unwrap();
        assert_eq!(near.pixels, vec![1]);
        assert!(matches!(
            backproject(&depth, 4, &k, 1000.0, |_| true),
            Err(CameraError::Shape(_))
        ));
        assert!(backproject(&depth, 3, &k, 0.0, |_| true).is_err());
    }
}
