//! Voxel-grid downsampling.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::backproject::{Intrinsics, Workspace};
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
///
/// Runs on the rayon pool: the voxel keys are computed in parallel, then
/// the voxels are split among the threads by key, each thread summing its
/// voxels' points in input order (so every centroid is the same sum as a
/// serial pass gives), and the voxels are put back in first-met order.
pub fn voxel_downsample(
    points: &[Point3<f64>],
    size: f64,
) -> Result<(Vec<Point3<f64>>, Vec<usize>)> {
    positive("voxel size", size)?;
    let inv = 1.0 / size;
    let keys: Vec<u64> = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            pack_cell(
                (p.x * inv).floor(),
                (p.y * inv).floor(),
                (p.z * inv).floor(),
            )
            .ok_or_else(|| {
                GraspError::InvalidArgument(format!(
                    "voxel grid: point {i} ({}, {}, {}) is more than 2^20 voxels of {size} m from the origin",
                    p.x, p.y, p.z
                ))
            })
        })
        .collect::<Result<_>>()?;
    let parts = rayon::current_num_threads().clamp(1, 16) as u64;
    // (first index, centroid) of every voxel, one list per part.
    let lists: Vec<Vec<(usize, Point3<f64>)>> = (0..parts)
        .into_par_iter()
        .map(|part| {
            let mut index: GridMap<u64, usize> = GridMap::with_capacity_and_hasher(
                points.len() / (4 * parts as usize) + 1,
                Default::default(),
            );
            let mut sums: Vec<(Vector3<f64>, u32, usize)> = Vec::new();
            // Neighbouring pixels mostly share a voxel: the last voxel's
            // slot is reused without hashing (keys use 63 bits, so MAX is
            // never a key).
            let (mut last_key, mut last_slot) = (u64::MAX, 0usize);
            for (i, (&key, p)) in keys.iter().zip(points).enumerate() {
                if part_of(key, parts) != part {
                    continue;
                }
                let slot = if key == last_key {
                    last_slot
                } else {
                    let slot = *index.entry(key).or_insert_with(|| {
                        sums.push((Vector3::zeros(), 0, i));
                        sums.len() - 1
                    });
                    (last_key, last_slot) = (key, slot);
                    slot
                };
                sums[slot].0 += p.coords;
                sums[slot].1 += 1;
            }
            sums.into_iter()
                .map(|(s, n, first)| (first, Point3::from(s / f64::from(n))))
                .collect()
        })
        .collect();
    let mut all: Vec<(usize, Point3<f64>)> = lists.into_iter().flatten().collect();
    all.sort_unstable_by_key(|(first, _)| *first);
    Ok(all.into_iter().map(|(f, c)| (c, f)).unzip())
}

/// The voxel grid of a depth image, built straight from its pixels (the
/// cloud is never stored): what [`voxel_downsample`] gives for the points
/// of [`crate::backproject()`] with the same `workspace`, bit for bit (each
/// centroid is the same sum in the same order), with, for each voxel, the
/// row-major index `row * width + column` of the first pixel that fell in
/// it instead of the point's index. Errors as those two calls in turn: the
/// workspace, intrinsics, image size and depth values first (the first bad
/// depth in row-major order), then a point too far from the origin for the
/// grid, named by its pixel.
///
/// One serial pass over the image: the work per pixel is small and the
/// pixels of a voxel are mostly neighbours, so the slots of the pixel to
/// the left and of the one above are reused without hashing; splitting the
/// keys over threads (as [`voxel_downsample`] does) would make every
/// thread walk the whole image for half the hashing.
pub fn voxel_downsample_depth(
    depth: &[f64],
    intrinsics: &Intrinsics,
    workspace: Option<&Workspace>,
    size: f64,
) -> Result<(Vec<Point3<f64>>, Vec<usize>)> {
    if let Some(w) = workspace {
        w.validate()?;
    }
    positive("voxel size", size)?;
    let inv = 1.0 / size;
    let width = intrinsics.width;
    let mut index: GridMap<u64, usize> =
        GridMap::with_capacity_and_hasher(depth.len() / 16 + 1, Default::default());
    // (sum, count, first pixel) per voxel, in first-met order.
    let mut sums: Vec<(Vector3<f64>, u32, usize)> = Vec::new();
    // Neighbouring pixels mostly share a voxel: the slot of the pixel before
    // in the row and of the last pixel seen in each column are reused
    // without hashing (a key's slot never changes; keys use 63 bits, so MAX
    // is never a key).
    let (mut last_key, mut last_slot) = (u64::MAX, 0usize);
    let mut above: Vec<(u64, usize)> = vec![(u64::MAX, 0); width];
    // The first point that is not finite and the first one off the grid
    // (the former wins, as the point-cloud path checks it first).
    let (mut non_finite, mut off) = (None, None);
    ferrobot_camera::for_each_point(depth, intrinsics, |v, u, p| {
        if workspace.is_some_and(|w| !w.contains(&p)) {
            return;
        }
        let Some(key) = pack_cell(
            (p.x * inv).floor(),
            (p.y * inv).floor(),
            (p.z * inv).floor(),
        ) else {
            if !p.coords.iter().all(|c| c.is_finite()) {
                non_finite.get_or_insert((p, v, u));
            } else {
                off.get_or_insert((p, v, u));
            }
            return;
        };
        if off.is_some() || non_finite.is_some() {
            return;
        }
        let slot = if key == last_key {
            last_slot
        } else {
            let slot = if above[u].0 == key {
                above[u].1
            } else {
                *index.entry(key).or_insert_with(|| {
                    sums.push((Vector3::zeros(), 0, v * width + u));
                    sums.len() - 1
                })
            };
            (last_key, last_slot) = (key, slot);
            slot
        };
        above[u] = (key, slot);
        sums[slot].0 += p.coords;
        sums[slot].1 += 1;
    })?;
    if let Some((p, v, u)) = non_finite.or(off) {
        return Err(off_grid(&p, v, u, size));
    }
    Ok(sums
        .into_iter()
        .map(|(s, n, first)| (Point3::from(s / f64::from(n)), first))
        .unzip())
}

/// The error for a point of pixel (`row`, `col`) the grid cannot hold.
fn off_grid(p: &Point3<f64>, row: usize, col: usize, size: f64) -> GraspError {
    if p.coords.iter().all(|c| c.is_finite()) {
        GraspError::InvalidArgument(format!(
            "voxel grid: the point ({}, {}, {}) of depth pixel (row {row}, column {col}) is more than 2^20 voxels of {size} m from the origin",
            p.x, p.y, p.z
        ))
    } else {
        GraspError::NonFinite(format!(
            "depth pixel (row {row}, column {col}) back-projects to a non-finite point ({}, {}, {})",
            p.x, p.y, p.z
        ))
    }
}

/// Which of `parts` parts a voxel key belongs to (a multiplicative hash, so
/// neighbouring voxels spread over the parts).
fn part_of(key: u64, parts: u64) -> u64 {
    // A multiply-shift range reduction: no division per point.
    ((key.wrapping_mul(GRID_HASH_K) >> 32) * parts) >> 32
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

    #[test]
    fn parallel_split_gives_the_serial_result() {
        // Many points over many voxels, in a scrambled order: centroids
        // (bit for bit) and first indices must be what one serial pass in
        // input order gives, on any number of threads.
        let mut pts = Vec::new();
        let mut state = 12345u64;
        for _ in 0..20000 {
            let mut next = || {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            pts.push(Point3::new(
                next() * 0.3,
                next() * 0.2 - 0.1,
                0.5 + next() * 0.1,
            ));
        }
        let size = 0.01;
        let mut order: Vec<u64> = Vec::new();
        let mut serial: HashMap<u64, (Vector3<f64>, u32, usize)> = HashMap::new();
        for (i, p) in pts.iter().enumerate() {
            let key = pack_cell(
                (p.x / size).floor(),
                (p.y / size).floor(),
                (p.z / size).floor(),
            )
            .unwrap();
            let e = serial.entry(key).or_insert_with(|| {
                order.push(key);
                (Vector3::zeros(), 0, i)
            });
            e.0 += p.coords;
            e.1 += 1;
        }
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (c, first) = pool.install(|| voxel_downsample(&pts, size)).unwrap();
            assert_eq!(c.len(), order.len());
            for (k, key) in order.iter().enumerate() {
                let (s, n, f) = serial[key];
                assert_eq!(first[k], f);
                assert_eq!(c[k], Point3::from(s / f64::from(n)));
            }
        }
    }

    #[test]
    fn depth_grid_equals_the_back_projected_cloud() {
        // A rough surface with missing pixels: the grid built from the
        // pixels gives the centroids (bit for bit) and first points of
        // back-projecting then downsampling, on any number of threads.
        let k = Intrinsics::new(97, 61, 80.0, 75.0, 48.0, 30.5).unwrap();
        let mut state = 99u64;
        let depth: Vec<f64> = (0..97 * 61)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let r = (state >> 11) as f64 / (1u64 << 53) as f64;
                match i % 37 {
                    0 => 0.0,
                    5 => f64::INFINITY,
                    _ => 0.4 + 0.002 * (i % 97) as f64 + 0.03 * r,
                }
            })
            .collect();
        let ws = Workspace([-0.1, 0.3, -0.2, 0.2, 0.0, 1.0]);
        for w in [None, Some(&ws)] {
            let bp = crate::backproject::backproject(&depth, &k, w).unwrap();
            let (want, first) = voxel_downsample(&bp.points, 0.01).unwrap();
            let want_px: Vec<usize> = first
                .iter()
                .map(|&i| bp.pixels[i].0 * k.width + bp.pixels[i].1)
                .collect();
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (c, px) = pool
                    .install(|| voxel_downsample_depth(&depth, &k, w, 0.01))
                    .unwrap();
                assert_eq!(c, want);
                assert_eq!(px, want_px);
            }
        }
    }
}
