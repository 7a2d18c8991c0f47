//! Voxel-grid downsampling.

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};

use crate::error::{Result, positive};

/// Downsamples `points` on a grid of cubes of side `size`: each occupied
/// voxel gives the centroid of its points. Returns the centroids and, for
/// each, the index of the first input point that fell in the voxel (so
/// per-point attributes such as labels can follow). Output order is the
/// order in which voxels are first met, so the result is deterministic.
pub fn voxel_downsample(
    points: &[Point3<f64>],
    size: f64,
) -> Result<(Vec<Point3<f64>>, Vec<usize>)> {
    positive("voxel size", size)?;
    let inv = 1.0 / size;
    let mut index: HashMap<(i64, i64, i64), usize> = HashMap::with_capacity(points.len() / 4 + 1);
    let mut sums: Vec<(Vector3<f64>, u32)> = Vec::new();
    let mut first = Vec::new();
    for (i, p) in points.iter().enumerate() {
        let key = (
            (p.x * inv).floor() as i64,
            (p.y * inv).floor() as i64,
            (p.z * inv).floor() as i64,
        );
        let slot = *index.entry(key).or_insert_with(|| {
            sums.push((Vector3::zeros(), 0));
            first.push(i);
            sums.len() - 1
        });
        sums[slot].0 += p.coords;
        sums[slot].1 += 1;
    }
    let centroids = sums
        .into_iter()
        .map(|(s, n)| Point3::from(s / f64::from(n)))
        .collect();
    Ok((centroids, first))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centroids_per_voxel() {
        let pts = [
            Point3::new(0.001, 0.001, 0.001),
            Point3::new(0.003, 0.003, 0.003),
            Point3::new(0.011, 0.0, 0.0),
        ];
        let (c, first) = voxel_downsample(&pts, 0.01).unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(first, vec![0, 2]);
        assert!((c[0] - Point3::new(0.002, 0.002, 0.002)).norm() < 1e-12);
        assert!(voxel_downsample(&pts, 0.0).is_err());
    }
}
