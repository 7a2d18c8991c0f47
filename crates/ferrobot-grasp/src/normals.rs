//! Surface normals from kd-tree neighbourhoods, and the cloud that carries
//! them through detection.

use kiddo::{KdTree, SquaredEuclidean};
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};
use std::sync::OnceLock;

use crate::error::{GraspError, Result, positive};
use crate::plane::Plane;

/// A point cloud with a kd-tree, a label per point, and unit normals
/// oriented towards a viewpoint plus the dominant tangent direction at each
/// point, estimated lazily (on first use, once per point; thread-safe) so
/// that only the points detection touches pay for them.
///
/// The first [`SurfaceCloud::num_observed`] points are observed; the rest
/// are hidden obstacle points added by [`SurfaceCloud::extrude`] (no
/// normals; never seeds or contacts).
#[derive(Debug)]
pub struct SurfaceCloud {
    /// The points: observed ones first, then hidden ones.
    pub points: Vec<Point3<f64>>,
    /// A label per point (segmentation id; -1 when unknown).
    pub labels: Vec<i32>,
    /// The viewpoint the normals face (the camera position in this frame).
    pub viewpoint: Point3<f64>,
    radius: f64,
    num_observed: usize,
    frames: Vec<OnceLock<(Vector3<f64>, Vector3<f64>)>>,
    tree: KdTree<f64, 3>,
    obstacles: Option<KdTree<f64, 3>>,
}

impl SurfaceCloud {
    /// Builds the kd-tree. Normals come from principal component analysis
    /// of the neighbours within `radius` (the 8 nearest points when fewer
    /// than 3 lie within it), flipped to face `viewpoint`.
    pub fn new(
        points: Vec<Point3<f64>>,
        labels: Vec<i32>,
        radius: f64,
        viewpoint: Point3<f64>,
    ) -> Result<Self> {
        positive("normal radius", radius)?;
        if labels.len() != points.len() {
            return Err(GraspError::Shape(format!(
                "labels: {} labels for {} points",
                labels.len(),
                points.len()
            )));
        }
        if let Some(i) = points
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.is_finite()))
        {
            return Err(GraspError::NonFinite(format!(
                "points: point {i} is not finite"
            )));
        }
        let mut tree: KdTree<f64, 3> = KdTree::with_capacity(points.len().max(1));
        for (i, p) in points.iter().enumerate() {
            tree.add(&[p.x, p.y, p.z], i as u64);
        }
        let frames = (0..points.len()).map(|_| OnceLock::new()).collect();
        Ok(Self {
            num_observed: points.len(),
            points,
            labels,
            viewpoint,
            radius,
            frames,
            tree,
            obstacles: None,
        })
    }

    /// Number of observed points (the rest are hidden obstacle points).
    pub fn num_observed(&self) -> usize {
        self.num_observed
    }

    /// Completes the hidden volume under what the camera saw, assuming
    /// objects rest on `plane` without hidden overhangs: the plane is cut
    /// into square cells of side `cell`, and below the highest observed
    /// point of each cell (if more than `threshold` above the plane) hidden
    /// obstacle points are added every `step` down to the plane. Points
    /// within `threshold` of the plane stop being obstacles
    /// ([`Self::within`] no longer returns them): the plane stands for them.
    /// With `clip` (a box `[lo, hi]` in the cloud's frame), only hidden
    /// points inside it are added (detection clips to the seeds' reach).
    pub fn extrude(
        &mut self,
        plane: &Plane,
        threshold: f64,
        cell: f64,
        step: f64,
        clip: Option<(Vector3<f64>, Vector3<f64>)>,
    ) {
        let top =
            plane.highest_per_cell(&self.points[..self.num_observed], threshold, cell, |_| {
                Some(0)
            });
        let mut tops: Vec<(usize, f64)> = top.into_values().collect();
        tops.sort_unstable_by_key(|t| t.0);
        let mut extra = Vec::new();
        let mut extra_labels = Vec::new();
        for (i, h) in tops {
            let p = self.points[i];
            let mut d = step;
            while d < h {
                let q = p - plane.normal * d;
                d += step;
                if let Some((lo, hi)) = &clip
                    && !(0..3).all(|k| q[k] >= lo[k] && q[k] <= hi[k])
                {
                    continue;
                }
                extra.push(q);
                extra_labels.push(self.labels[i]);
            }
        }
        let mut tree: KdTree<f64, 3> = KdTree::with_capacity(self.points.len() + extra.len());
        self.points.truncate(self.num_observed);
        self.labels.truncate(self.num_observed);
        self.points.extend(extra);
        self.labels.extend(extra_labels);
        for (i, p) in self.points.iter().enumerate() {
            if i >= self.num_observed || plane.distance(p) > threshold {
                tree.add(&[p.x, p.y, p.z], i as u64);
            }
        }
        self.obstacles = Some(tree);
    }

    fn frame(&self, i: usize) -> &(Vector3<f64>, Vector3<f64>) {
        self.frames[i].get_or_init(|| {
            let p = &self.points[i];
            let q = [p.x, p.y, p.z];
            let mut nb: Vec<usize> = self
                .tree
                .within_unsorted::<SquaredEuclidean>(&q, self.radius * self.radius)
                .into_iter()
                .map(|n| n.item as usize)
                .collect();
            if nb.len() < 3 {
                nb = self
                    .tree
                    .nearest_n::<SquaredEuclidean>(&q, 8)
                    .into_iter()
                    .map(|n| n.item as usize)
                    .collect();
            }
            local_frame(&self.points, &nb, p, &self.viewpoint)
        })
    }

    /// Unit outward normal of observed point `i` (facing the viewpoint).
    pub fn normal(&self, i: usize) -> Vector3<f64> {
        self.frame(i).0
    }

    /// Unit direction of largest spread of point `i`'s neighbourhood
    /// (perpendicular to its normal).
    pub fn tangent(&self, i: usize) -> Vector3<f64> {
        self.frame(i).1
    }

    /// Number of points (observed and hidden).
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the cloud has no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Indices of the points (observed and hidden) within `r` of `p`.
    pub fn within(&self, p: &Point3<f64>, r: f64) -> Vec<usize> {
        self.obstacles
            .as_ref()
            .unwrap_or(&self.tree)
            .within_unsorted::<SquaredEuclidean>(&[p.x, p.y, p.z], r * r)
            .into_iter()
            .map(|n| n.item as usize)
            .collect()
    }
}

/// Normal (smallest-variance direction, facing `viewpoint`) and tangent
/// (largest-variance direction) of the neighbourhood `nb` of `p`.
fn local_frame(
    points: &[Point3<f64>],
    nb: &[usize],
    p: &Point3<f64>,
    viewpoint: &Point3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let to_view = viewpoint - p;
    let fallback_n = if to_view.norm() > 1e-12 {
        to_view.normalize()
    } else {
        Vector3::z()
    };
    if nb.len() < 3 {
        return (fallback_n, any_perpendicular(&fallback_n));
    }
    let mean = nb.iter().map(|&i| points[i].coords).sum::<Vector3<f64>>() / nb.len() as f64;
    let mut cov = Matrix3::zeros();
    for &i in nb {
        let d = points[i].coords - mean;
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let (mut lo, mut hi) = (0, 0);
    for k in 1..3 {
        if eig.eigenvalues[k] < eig.eigenvalues[lo] {
            lo = k;
        }
        if eig.eigenvalues[k] > eig.eigenvalues[hi] {
            hi = k;
        }
    }
    if lo == hi {
        return (fallback_n, any_perpendicular(&fallback_n));
    }
    let mut n: Vector3<f64> = eig.eigenvectors.column(lo).into_owned();
    if n.dot(&to_view) < 0.0 {
        n = -n;
    }
    let t = eig.eigenvectors.column(hi).into_owned();
    let t = (t - n * n.dot(&t))
        .try_normalize(1e-12)
        .unwrap_or_else(|| any_perpendicular(&n));
    (n, t)
}

/// A unit vector perpendicular to the unit vector `n`.
pub fn any_perpendicular(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    n.cross(&a).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_normals_face_the_viewpoint() {
        let mut pts = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                pts.push(Point3::new(i as f64 * 0.005, j as f64 * 0.005, 1.0));
            }
        }
        let n = pts.len();
        let c = SurfaceCloud::new(pts, vec![-1; n], 0.012, Point3::origin()).unwrap();
        for i in 0..c.len() {
            assert!((c.normal(i) - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-9);
        }
    }
}
