//! The support plane (a table top): found by RANSAC, then treated as the
//! top of a solid half-space. Its underside is hidden from the camera, so
//! without it fingers could pass through a table where the table lies in an
//! object's shadow.

use nalgebra::{Point3, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// A plane `normal · p = offset` whose `normal` points to the free side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal towards the free side (the viewpoint's side).
    pub normal: Vector3<f64>,
    /// Offset along the normal.
    pub offset: f64,
}

impl Plane {
    /// Signed distance of `p` (positive on the free side).
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        self.normal.dot(&p.coords) - self.offset
    }

    /// The highest point of each group and square cell of the plane (side
    /// `cell`): for every `(group, column, row)`, the index and height of
    /// the point highest above the plane, over the `points` more than
    /// `threshold` above it. `group` gives each point's group (e.g. its
    /// object label), or `None` to skip the point.
    pub(crate) fn highest_per_cell(
        &self,
        points: &[Point3<f64>],
        threshold: f64,
        cell: f64,
        group: impl Fn(usize) -> Option<i32>,
    ) -> crate::voxel::GridMap<(i32, i64, i64), (usize, f64)> {
        let e1 = crate::normals::any_perpendicular(&self.normal);
        let e2 = self.normal.cross(&e1);
        let mut top: crate::voxel::GridMap<(i32, i64, i64), (usize, f64)> = Default::default();
        for (i, p) in points.iter().enumerate() {
            let h = self.distance(p);
            let Some(g) = group(i) else { continue };
            if h <= threshold {
                continue;
            }
            let key = (
                g,
                (e1.dot(&p.coords) / cell).floor() as i64,
                (e2.dot(&p.coords) / cell).floor() as i64,
            );
            let e = top.entry(key).or_insert((i, h));
            if h > e.1 {
                *e = (i, h);
            }
        }
        top
    }
}

/// The plane with the most points within `threshold`, by RANSAC over
/// `iterations` random triples (deterministic for a given `seed`), if it
/// holds at least `min_fraction` of the points. The normal faces
/// `viewpoint`.
pub fn find_support_plane(
    points: &[Point3<f64>],
    threshold: f64,
    min_fraction: f64,
    iterations: usize,
    viewpoint: &Point3<f64>,
    seed: u64,
) -> Option<Plane> {
    let n = points.len();
    if n < 3 {
        return None;
    }
    let mut rng = StdRng::seed_from_u64(seed);
    // Score on a subsample for speed, refit on all inliers.
    let step = (n / 4000).max(1);
    let sample: Vec<&Point3<f64>> = points.iter().step_by(step).collect();
    // The sample's coordinates one array per axis, so that counting a
    // plane's inliers is a loop the compiler vectorises; the distance is
    // computed as `Plane::distance` does (nalgebra's 3-vector dot product
    // is (x·x' + y·y') + z·z'), so the counts are the same.
    let xs: Vec<f64> = sample.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = sample.iter().map(|p| p.y).collect();
    let zs: Vec<f64> = sample.iter().map(|p| p.z).collect();
    let mut best: Option<(usize, Plane)> = None;
    for _ in 0..iterations {
        let a = points[rng.random_range(0..n)];
        let b = points[rng.random_range(0..n)];
        let c = points[rng.random_range(0..n)];
        let Some(normal) = (b - a).cross(&(c - a)).try_normalize(1e-12) else {
            continue;
        };
        let plane = Plane {
            normal,
            offset: normal.dot(&a.coords),
        };
        let (nx, ny, nz, off) = (normal.x, normal.y, normal.z, plane.offset);
        let count: usize = xs
            .iter()
            .zip(&ys)
            .zip(&zs)
            .map(|((&x, &y), &z)| {
                usize::from(((nx * x + ny * y) + nz * z - off).abs() <= threshold)
            })
            .sum();
        if best.is_none_or(|(k, _)| count > k) {
            best = Some((count, plane));
        }
    }
    let (count, plane) = best?;
    if (count as f64) < min_fraction * sample.len() as f64 {
        return None;
    }
    // Least-squares refit on the inliers.
    let inliers: Vec<&Point3<f64>> = points
        .iter()
        .filter(|p| plane.distance(p).abs() <= threshold)
        .collect();
    let mean = inliers.iter().map(|p| p.coords).sum::<Vector3<f64>>() / inliers.len() as f64;
    let mut cov = nalgebra::Matrix3::zeros();
    for p in &inliers {
        let d = p.coords - mean;
        cov += d * d.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(cov);
    let mut normal: Vector3<f64> = eig.eigenvectors.column(eig.eigenvalues.imin()).into_owned();
    if normal.dot(&(viewpoint.coords - mean)) < 0.0 {
        normal = -normal;
    }
    Some(Plane {
        normal,
        offset: normal.dot(&mean),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_table() {
        let mut pts = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                pts.push(Point3::new(i as f64 * 0.01, j as f64 * 0.01, 0.2));
            }
        }
        for k in 0..100 {
            pts.push(Point3::new(0.1, 0.1, 0.2 - 0.001 * k as f64));
        }
        let p = find_support_plane(&pts, 0.003, 0.2, 100, &Point3::origin(), 0).unwrap();
        assert!((p.normal - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-3);
        assert!((p.offset + 0.2).abs() < 1e-3);
        assert!(p.distance(&Point3::new(0.0, 0.0, 0.3)) < 0.0);
    }

    #[test]
    fn vectorised_count_is_the_distance_test() {
        // The inlier count's arithmetic is Plane::distance's, bit for bit.
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..1000 {
            let normal = Vector3::new(next(), next(), next()).normalize();
            let plane = Plane {
                normal,
                offset: next(),
            };
            let p = Point3::new(next(), next(), next());
            let (nx, ny, nz) = (normal.x, normal.y, normal.z);
            assert_eq!(
                ((nx * p.x + ny * p.y) + nz * p.z - plane.offset).to_bits(),
                plane.distance(&p).to_bits()
            );
        }
    }
}
