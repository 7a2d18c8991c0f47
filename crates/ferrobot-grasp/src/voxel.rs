//! Voxel-grid downsampling.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use nalgebra::{Point3, Vector3};

use crate::error::{GraspError, Result, positive};

/// A fast multiply-rotate hasher for integer grid keys (the std SipHash
/// cost a quarter of detection time on a 640 x 480 frame); not
/// DoS-resistant, which grid keys from a depth image do not need.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct GridHasher(u64);

const GRID_HASH_K: u64 = 0x517c_c1b7_2722_0a95;

impl Hasher for GridHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(GRID_HASH_K);
    }
    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
}

/// A `HashMap` keyed by grid cells, hashed with [`GridHasher`].
pub(crate) type GridMap<K, V> = HashMap<K, V, BuildHasherDefault<GridHasher>>;

/// Packs integer cell coordinates within ±2^20 into one key (21 bits each).
fn pack_cell(x: f64, y: f64, z: f64) -> Option<u64> {
    const HALF: f64 = (1u64 << 20) as f64;
    let mut key = 0u64;
    for (k, c) in [x, y, z].into_iter().enumerate() {
        if !(-HALF..HALF).contains(&c) {
            return None;
        }
        key |= ((c + HALF) as u64) << (21 * k);
    }
    Some(key)
}

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
    let mut index: GridMap<u64, usize> =
        GridMap::with_capacity_and_hasher(points.len() / 4 + 1, Default::default());
    let mut sums: Vec<(Vector3<f64>, u32)> = Vec::new();
    let mut first = Vec::new();
    for (i, p) in points.iter().enumerate() {
        let key = pack_cell(
            (p.x * inv).floor(),
            (p.y * inv).floor(),
            (p.z * inv).floor(),
        )
        .ok_or_else(|| {
            GraspError::InvalidArgument(format!(
                "voxel grid: point {i} ({}, {}, {}) is more than 2^20 voxels of {size} m from the origin",
                p.x, p.y, p.z
            ))
        })?;
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
