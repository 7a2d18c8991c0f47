//! A voxelised signed distance field of one obstacle shape, in the shape's
//! frame: distances sampled on a regular grid once, then read back with
//! trilinear interpolation, which also gives the gradient.

use ferrobot_collision::Shape;
use nalgebra::{Point3, Vector3};

use crate::error::{ControlError, Result};

/// Most grid nodes one field may hold (about 64 MB of `f32`).
pub const MAX_NODES: usize = 16_000_000;

/// Signed distances of a shape sampled on a grid in its own frame.
#[derive(Debug, Clone)]
pub struct VoxelField {
    /// Position of node (0, 0, 0) in the shape frame.
    pub origin: Vector3<f64>,
    /// Node spacing (m).
    pub resolution: f64,
    /// Nodes along x, y, z.
    pub dims: [usize; 3],
    /// Distances, x fastest.
    values: Vec<f32>,
}

/// Half extents of an axis-aligned box holding `shape` in its frame.
fn half_box(shape: &Shape) -> Vector3<f64> {
    match shape {
        Shape::Box { half_extents } => *half_extents,
        Shape::Sphere { radius } => Vector3::repeat(*radius),
        Shape::Cylinder {
            radius,
            half_height,
        } => Vector3::new(*radius, *radius, *half_height),
        Shape::Capsule {
            radius,
            half_height,
        } => Vector3::new(*radius, *radius, half_height + radius),
        other => Vector3::repeat(other.bounding_radius()),
    }
}

impl VoxelField {
    /// Samples `shape`'s signed distance on a grid of `resolution` covering
    /// its bounding box grown by `padding` on every side.
    pub fn build(shape: &Shape, resolution: f64, padding: f64) -> Result<Self> {
        if !(resolution.is_finite() && resolution > 0.0 && padding.is_finite() && padding >= 0.0) {
            return Err(ControlError::InvalidArgument(format!(
                "voxel field: resolution ({resolution}) must be positive and padding ({padding}) non-negative"
            )));
        }
        let half = half_box(shape) + Vector3::repeat(padding);
        let mut dims = [0usize; 3];
        for k in 0..3 {
            dims[k] = (2.0 * half[k] / resolution).ceil() as usize + 2;
        }
        let nodes = dims[0].saturating_mul(dims[1]).saturating_mul(dims[2]);
        if nodes > MAX_NODES {
            return Err(ControlError::InvalidArgument(format!(
                "voxel field of a {} would need {nodes} nodes (limit {MAX_NODES}); use a coarser field_resolution",
                shape.kind()
            )));
        }
        let origin = -half;
        let mut values = Vec::with_capacity(nodes);
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = origin + Vector3::new(i as f64, j as f64, k as f64) * resolution;
                    values.push(shape.signed_distance(&Point3::from(p)).0 as f32);
                }
            }
        }
        Ok(Self {
            origin,
            resolution,
            dims,
            values,
        })
    }

    /// Number of grid nodes.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether the grid is empty (never, once built).
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Interpolated distance at `p` (shape frame) and its gradient, or
    /// `None` outside the grid (farther than the padding from the shape).
    pub fn lookup(&self, p: &Point3<f64>) -> Option<(f64, Vector3<f64>)> {
        let g = (p.coords - self.origin) / self.resolution;
        let mut idx = [0usize; 3];
        let mut t = [0.0f64; 3];
        for k in 0..3 {
            let f = g[k].floor();
            if !(f >= 0.0 && (f as usize) + 1 < self.dims[k]) {
                return None;
            }
            idx[k] = f as usize;
            t[k] = g[k] - f;
        }
        let (nx, nxy) = (self.dims[0], self.dims[0] * self.dims[1]);
        let base = idx[0] + idx[1] * nx + idx[2] * nxy;
        let v =
            |dx: usize, dy: usize, dz: usize| self.values[base + dx + dy * nx + dz * nxy] as f64;
        let (c000, c100, c010, c110) = (v(0, 0, 0), v(1, 0, 0), v(0, 1, 0), v(1, 1, 0));
        let (c001, c101, c011, c111) = (v(0, 0, 1), v(1, 0, 1), v(0, 1, 1), v(1, 1, 1));
        let [tx, ty, tz] = t;
        let lerp = |a: f64, b: f64, s: f64| a + (b - a) * s;
        let c00 = lerp(c000, c100, tx);
        let c10 = lerp(c010, c110, tx);
        let c01 = lerp(c001, c101, tx);
        let c11 = lerp(c011, c111, tx);
        let c0 = lerp(c00, c10, ty);
        let c1 = lerp(c01, c11, ty);
        let d = lerp(c0, c1, tz);
        // Partial derivatives of the trilinear interpolant.
        let dx = lerp(
            lerp(c100 - c000, c110 - c010, ty),
            lerp(c101 - c001, c111 - c011, ty),
            tz,
        );
        let dy = lerp(
            lerp(c010 - c000, c110 - c100, tx),
            lerp(c011 - c001, c111 - c101, tx),
            tz,
        );
        let dz = c1 - c0;
        Some((d, Vector3::new(dx, dy, dz) / self.resolution))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_field_matches_the_analytic_distance() {
        let shape = Shape::Sphere { radius: 0.1 };
        let f = VoxelField::build(&shape, 0.005, 0.2).unwrap();
        for p in [
            Point3::new(0.15, 0.02, -0.03),
            Point3::new(-0.05, 0.2, 0.1),
            Point3::new(0.0, 0.0, 0.25),
        ] {
            let (d, g) = f.lookup(&p).unwrap();
            let exact = p.coords.norm() - 0.1;
            // Trilinear error of |p| on a 5 mm grid: at most h²/(8 r)-ish.
            assert!((d - exact).abs() < 1e-3, "{d} vs {exact}");
            let cos = g.normalize().dot(&p.coords.normalize());
            assert!(cos > 0.99, "gradient direction {g:?} at {p:?}");
        }
        assert!(f.lookup(&Point3::new(1.0, 0.0, 0.0)).is_none());
    }

    #[test]
    fn box_field_is_exact_on_flat_faces() {
        let shape = Shape::Box {
            half_extents: Vector3::new(0.2, 0.1, 0.05),
        };
        let f = VoxelField::build(&shape, 0.01, 0.1).unwrap();
        // Off a face (away from edges) the distance is linear: exact.
        let (d, g) = f.lookup(&Point3::new(0.013, -0.027, 0.123)).unwrap();
        assert!((d - 0.073).abs() < 1e-6, "{d}");
        assert!((g - Vector3::z()).norm() < 1e-5, "{g:?}");
    }

    #[test]
    fn too_fine_a_grid_is_refused() {
        let shape = Shape::Box {
            half_extents: Vector3::new(5.0, 5.0, 5.0),
        };
        assert!(VoxelField::build(&shape, 0.001, 0.1).is_err());
    }
}
