//! Back-projection of a depth image to camera-frame points: the one formula
//! and the one policy for missing depth.
//!
//! Missing depth: a pixel whose depth is **0 or +inf** has no reading (0 is
//! what sensors write, +inf what a ray that hits nothing gives, as in REP 117)
//! and is skipped. NaN, -inf and negative depths are errors naming the pixel
//! by (row, column). Returned pixels are (row, column) pairs.

use nalgebra::Point3;

use crate::error::CameraError;
use crate::intrinsics::Intrinsics;

/// The points back-projected from a depth image.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BackProjected {
    /// Points in the camera frame (OpenCV convention), metres.
    pub points: Vec<Point3<f64>>,
    /// For each point, the pixel `(row, column)` it came from.
    pub pixels: Vec<(usize, usize)>,
}

impl BackProjected {
    /// The pixels as flat row-major indices `row * width + column`.
    pub fn flat_pixels(&self, width: usize) -> Vec<usize> {
        self.pixels.iter().map(|&(r, c)| r * width + c).collect()
    }
}

/// Whether a depth value is a missing reading (0 or +inf).
#[inline]
pub fn is_missing(d: f64) -> bool {
    d == 0.0 || d == f64::INFINITY
}

/// Back-projects a row-major `intrinsics.height` x `intrinsics.width` depth
/// image: z = depth / depth_scale, x = (u - cx) / fx · z,
/// y = (v - cy) / fy · z, for pixel column u and row v.
///
/// Missing depths (0, +inf) are skipped; NaN or -inf is
/// [`CameraError::NonFinite`], a negative depth
/// [`CameraError::InvalidArgument`], a size mismatch [`CameraError::Shape`].
/// Points for which `keep` is false are dropped (e.g. outside a workspace).
/// `depth` may be `f32` (rendered images) or `f64`.
pub fn backproject<D: Copy + Into<f64>>(
    depth: &[D],
    intrinsics: &Intrinsics,
    mut keep: impl FnMut(&Point3<f64>) -> bool,
) -> Result<BackProjected, CameraError> {
    let mut out = BackProjected::default();
    for_each_point(depth, intrinsics, |v, u, p| {
        if keep(&p) {
            out.points.push(p);
            out.pixels.push((v, u));
        }
    })?;
    Ok(out)
}

/// Calls `f(row, column, point)` for every pixel of a depth image with a
/// reading, in row-major order, with the point [`backproject`] gives for it
/// (the same formula and policy; bit for bit the same point): for consumers
/// that reduce the cloud as it is made (a voxel grid) instead of storing
/// every point. Returns the first bad depth's error (row-major), after
/// `f` has seen the pixels before it; the checks of the intrinsics and the
/// image size come before any call.
pub fn for_each_point<D: Copy + Into<f64>>(
    depth: &[D],
    intrinsics: &Intrinsics,
    mut f: impl FnMut(usize, usize, Point3<f64>),
) -> Result<(), CameraError> {
    intrinsics.validate()?;
    let (w, h) = (intrinsics.width, intrinsics.height);
    if depth.len() != w * h {
        return Err(CameraError::Shape(format!(
            "depth image: {} values for a {h}x{w} image",
            depth.len()
        )));
    }
    let scale = intrinsics.depth_scale;
    // (u - cx) / fx per column and (v - cy) / fy per row, computed once:
    // the same operations in the same order as `Intrinsics::unproject`.
    let cols: Vec<f64> = (0..w)
        .map(|u| (u as f64 - intrinsics.cx) / intrinsics.fx)
        .collect();
    for (v, row) in depth.chunks_exact(w).enumerate() {
        let b = (v as f64 - intrinsics.cy) / intrinsics.fy;
        for (u, (&d, &a)) in row.iter().zip(&cols).enumerate() {
            let d: f64 = d.into();
            if d > 0.0 && d < f64::INFINITY {
                let z = d / scale;
                f(v, u, Point3::new(a * z, b * z, z));
            } else if !is_missing(d) {
                return Err(bad_depth(d, v, u));
            }
        }
    }
    Ok(())
}

fn bad_depth(d: f64, row: usize, col: usize) -> CameraError {
    if d.is_nan() || d.is_infinite() {
        CameraError::NonFinite(format!(
            "depth image: non-finite value {d} at pixel (row {row}, column {col}) (missing depth is 0 or +inf)"
        ))
    } else {
        CameraError::InvalidArgument(format!(
            "depth image: negative depth {d} at pixel (row {row}, column {col}) (missing depth is 0 or +inf)"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formula_skips_errors_and_filter() {
        let k = Intrinsics::new(3, 2, 100.0, 200.0, 1.0, 0.5)
            .unwrap()
            .with_depth_scale(1000.0)
            .unwrap();
        let depth = [0.0f32, 500.0, f32::INFINITY, 2000.0, 0.0, 0.0];
        let b = backproject(&depth, &k, |_| true).unwrap();
        assert_eq!(b.pixels, vec![(0, 1), (1, 0)]);
        assert_eq!(b.flat_pixels(3), vec![1, 3]);
        // pixel (1, 0): row 1, column 0, z = 2
        let expect = Point3::new(-1.0 / 100.0 * 2.0, 0.5 / 200.0 * 2.0, 2.0);
        assert!((b.points[1] - expect).norm() < 1e-12);
        let near = backproject(&depth, &k, |p| p.z < 1.0).unwrap();
        assert_eq!(near.pixels, vec![(0, 1)]);
        assert!(matches!(
            backproject(&depth[..5], &k, |_| true),
            Err(CameraError::Shape(_))
        ));
        let mut bad = depth;
        bad[4] = f32::NAN;
        assert!(matches!(
            backproject(&bad, &k, |_| true),
            Err(CameraError::NonFinite(m)) if m.contains("row 1, column 1")
        ));
        bad[4] = -1.0;
        assert!(matches!(
            backproject(&bad, &k, |_| true),
            Err(CameraError::InvalidArgument(_))
        ));
        bad[4] = f32::NEG_INFINITY;
        assert!(matches!(
            backproject(&bad, &k, |_| true),
            Err(CameraError::NonFinite(_))
        ));
    }
}
