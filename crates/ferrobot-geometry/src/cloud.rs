//! Point-cloud obstacles: each point a ball of one radius, in a kd-tree.

use kiddo::{KdTree, SquaredEuclidean};
use nalgebra::{Point3, Vector3};

use crate::error::{GeometryError, Result};

/// A point cloud (e.g. from a depth camera) with a kd-tree.
#[derive(Debug, Clone)]
pub struct PointCloud {
    points: Vec<Point3<f64>>,
    radius: f64,
    tree: KdTree<f64, 3>,
    bounding_radius: f64,
}

impl PointCloud {
    /// A cloud of `points` (object frame), each a ball of `radius` (>= 0).
    pub fn new(points: Vec<Point3<f64>>, radius: f64) -> Result<Self> {
        if points.is_empty() {
            return Err(GeometryError::InvalidShape("point cloud: no points".into()));
        }
        if !(radius.is_finite() && radius >= 0.0) {
            return Err(GeometryError::InvalidShape(format!(
                "point cloud: radius must be finite and >= 0, got {radius}"
            )));
        }
        if let Some(i) = points
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.is_finite()))
        {
            return Err(GeometryError::InvalidShape(format!(
                "point cloud: point {i} is not finite"
            )));
        }
        // kiddo's fixed-size leaf buckets cannot hold more than 32 points
        // at exactly the same position (it panics): insert each distinct
        // position once. Duplicates are the same ball, so every distance
        // answer is unchanged.
        let mut tree: KdTree<f64, 3> = KdTree::with_capacity(points.len());
        let mut seen = std::collections::HashSet::with_capacity(points.len());
        for (i, p) in points.iter().enumerate() {
            // +0.0 for -0.0 so that equal positions have equal bits.
            let key = [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f64::to_bits);
            if seen.insert(key) {
                tree.add(&[p.x, p.y, p.z], i as u64);
            }
        }
        let bounding_radius = points.iter().map(|p| p.coords.norm()).fold(0.0, f64::max) + radius;
        Ok(Self {
            points,
            radius,
            tree,
            bounding_radius,
        })
    }

    /// The points.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// Radius of each point's ball.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Radius of a ball around the origin holding the cloud.
    pub fn bounding_radius(&self) -> f64 {
        self.bounding_radius
    }

    /// Distance to the nearest point's ball and the direction away from it.
    pub fn signed_distance(&self, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        let nn = self.tree.nearest_one::<SquaredEuclidean>(&[p.x, p.y, p.z]);
        let q = self.points[nn.item as usize];
        let d = p - q;
        let n = d.norm();
        let dir = if n > 1e-12 { d / n } else { Vector3::z() };
        (n - self.radius, dir)
    }

    /// Indices of points within `r` of `p`.
    pub fn within(&self, p: &Point3<f64>, r: f64) -> Vec<usize> {
        self.tree
            .within_unsorted::<SquaredEuclidean>(&[p.x, p.y, p.z], r * r)
            .into_iter()
            .map(|n| n.item as usize)
            .collect()
    }
}
