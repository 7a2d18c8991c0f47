//! A coarse grid of lower bounds on the distance to the world, for the
//! single-configuration kernel's first test of each body.
//!
//! In the MotionBenchMaker scenes about 97 % of the Panda's moving bodies are,
//! at a random configuration, clear of every obstacle by their bounding
//! sphere with centimetres to spare; proving it obstacle by obstacle costs
//! more than anything else in a single check. The grid answers it with one
//! lookup: each cell stores a lower bound on the distance from its centre
//! to the nearest obstacle's solid (rounded down to 4 mm, one unit
//! deducted for the rounding); less the distance from the cell's centre to
//! a point of the cell, it bounds that point's distance (the distance to a
//! solid is 1-Lipschitz), so a point near the centre gets a bound up to the
//! cell's half diagonal tighter than a bound for the whole cell. A body
//! whose bounding-sphere centre has a bound exceeding the sphere's radius
//! plus the margin (plus 0.1 mm for the `f32` arithmetic) cannot touch the
//! world, so the obstacle tests, which would
//! find nothing, are skipped: no answer changes. Anything else falls back
//! to those tests.
//!
//! Cells are filled on first use, so a new world costs only the
//! allocation; concurrent fills of one cell write the same value. A cell
//! is filled from the candidate list of the list cell holding it (below):
//! only the listed obstacles are measured, and the bound is capped at the
//! list's radius less the offset of the two centres (any unlisted obstacle
//! is farther), so a fill costs the list's length, not the world's.
//!
//! A second, coarser grid (10 cm cells) holds per cell the list of
//! obstacles a body centred anywhere in the cell could touch, nearest
//! first: every obstacle whose solid lies within the robot's largest
//! bounding radius plus the margin, plus the cell's half diagonal and 1 mm
//! of slack, from the cell centre (the distance to a solid is 1-Lipschitz,
//! so a body centred at `p` in the cell reaching an obstacle means the
//! obstacle is within that distance of the centre). A body not cleared by
//! the first grid tests only these obstacles instead of every obstacle of
//! the world, so the cost of a check follows the obstacles near the robot,
//! not their number. Lists are made on first use of a cell, like the
//! bounds.

use std::sync::OnceLock;
use std::sync::atomic::{AtomicU8, Ordering};

use wide::{f32x8, i32x8};

use crate::compiled::{CompiledRobot, CompiledWorld, Prim};

/// Cell edge (m).
const CELL: f32 = 0.05;
/// Distance units of the stored bounds (m).
const QUANTUM: f32 = 0.004;
/// Marker of a cell not filled yet.
const UNKNOWN: u8 = u8::MAX;
/// Extent the grid may cover from the base along each axis (m).
const MAX_EXTENT: f32 = 3.0;
/// Slack (m) over the bound for the `f32` arithmetic of the kernel.
pub const SLACK: f32 = 1e-4;
/// Edge of a candidate-list cell (m).
const LIST_CELL: f32 = 0.1;
/// Slack (m) of the candidate lists' reach for the `f32` arithmetic.
const LIST_SLACK: f32 = 1e-3;

/// One obstacle of a candidate list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Index into the world's obstacles.
    pub obstacle: u32,
    /// Distance (m) from the list cell's centre to the obstacle's solid
    /// (its bounding sphere for meshes and clouds; 0 where that distance is
    /// not a number), never above the true distance by more than the `f32`
    /// rounding that the lists' 1 mm slack covers. Lists are sorted by it, so a body
    /// centred at `p` with radius plus margin `r` can only touch obstacles
    /// with `distance <= r + |p - centre| + LIST_SLACK` (the distance to a
    /// solid is 1-Lipschitz): the rest of a list can be skipped at the
    /// first entry beyond that.
    pub distance: f32,
}

/// The grid (see the module docs).
#[derive(Debug)]
pub struct WorldGrid {
    origin: [f32; 3],
    n: [usize; 3],
    /// `n` as `f32`.
    n_f32: [f32; 3],
    cells: Box<[AtomicU8]>,
    /// Cells per axis of the candidate-list grid (same origin).
    list_n: [usize; 3],
    /// `list_n` as `f32`.
    list_n_f32: [f32; 3],
    /// Candidate obstacles per list cell, nearest first (made on first use).
    lists: Box<[OnceLock<Box<[Candidate]>>]>,
    /// The bounding radius plus margin the lists cover: a body whose
    /// bounding radius plus margin exceeds it must not use them.
    list_reach: f32,
}

impl WorldGrid {
    /// A grid over the region `robot`'s moving bodies can reach (the union
    /// of their sweep spheres, at most 3 m from the base along each axis),
    /// or `None` when the world is empty or nothing moves.
    /// The candidate lists cover bodies up to the largest moving bounding
    /// radius plus `margin`.
    pub fn for_robot(robot: &CompiledRobot, world: &CompiledWorld, margin: f32) -> Option<Self> {
        if world.obstacles.is_empty() || !margin.is_finite() {
            return None;
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for b in robot.bodies.iter().filter(|b| b.frame != 0) {
            let (c, r) = b.sweep;
            for i in 0..3 {
                lo[i] = lo[i].min(c[i] - r).max(-MAX_EXTENT);
                hi[i] = hi[i].max(c[i] + r).min(MAX_EXTENT);
            }
        }
        if (0..3).any(|i| hi[i] <= lo[i] || hi[i].is_nan() || lo[i].is_nan()) {
            return None;
        }
        let n = [0, 1, 2].map(|i| ((hi[i] - lo[i]) / CELL).ceil() as usize + 1);
        let cells = (0..n[0] * n[1] * n[2])
            .map(|_| AtomicU8::new(UNKNOWN))
            .collect();
        let list_n = [0, 1, 2].map(|i| ((hi[i] - lo[i]) / LIST_CELL).ceil() as usize + 1);
        let lists = (0..list_n[0] * list_n[1] * list_n[2])
            .map(|_| OnceLock::new())
            .collect();
        let list_reach = robot
            .bodies
            .iter()
            .filter(|b| b.frame != 0)
            .map(|b| b.bound.1)
            .fold(0.0f32, f32::max)
            + margin
            // Bounds made from the lists are capped near the lists' reach
            // (see `fill`): three quanta more keep a body far from every
            // obstacle cleared by the bound alone.
            + 3.0 * QUANTUM;
        Some(Self {
            origin: lo,
            n,
            n_f32: n.map(|x| x as f32),
            cells,
            list_n,
            list_n_f32: list_n.map(|x| x as f32),
            lists,
            list_reach,
        })
    }

    /// The bounding radius plus margin the candidate lists cover.
    #[inline(always)]
    pub fn list_reach(&self) -> f32 {
        self.list_reach
    }

    /// The candidate-list cell holding `p`, or `None` outside the grid.
    #[inline(always)]
    pub fn list_cell(&self, p: &[f32; 3]) -> Option<usize> {
        let mut idx = 0usize;
        for (a, &x) in p.iter().enumerate() {
            let f = (x - self.origin[a]) * (1.0 / LIST_CELL);
            // In [0, n) (NaN fails both tests).
            if !(f >= 0.0 && f < self.list_n_f32[a]) {
                return None;
            }
            idx = idx * self.list_n[a] + f as usize;
        }
        Some(idx)
    }

    /// The candidate-list cell holding `p` and its centre (the same `f32`
    /// value as [`WorldGrid::list_centre`]'s, without its divisions), or
    /// `None` outside the grid.
    #[inline(always)]
    pub fn list_cell_centre(&self, p: &[f32; 3]) -> Option<(usize, [f32; 3])> {
        let mut idx = 0usize;
        let mut centre = [0.0; 3];
        for (a, &x) in p.iter().enumerate() {
            let f = (x - self.origin[a]) * (1.0 / LIST_CELL);
            // In [0, n) (NaN fails both tests).
            if !(f >= 0.0 && f < self.list_n_f32[a]) {
                return None;
            }
            let i = f as usize;
            idx = idx * self.list_n[a] + i;
            centre[a] = self.origin[a] + (i as f32 + 0.5) * LIST_CELL;
        }
        Some((idx, centre))
    }

    /// [`WorldGrid::list_limit`] for the list cell centred at `centre`
    /// (from [`WorldGrid::list_cell_centre`]).
    #[inline(always)]
    pub fn list_limit_at(centre: &[f32; 3], p: &[f32; 3], reach: f32) -> f32 {
        let d = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
        reach + (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() + LIST_SLACK
    }

    /// Centre of list cell `idx`.
    #[inline(always)]
    pub fn list_centre(&self, idx: usize) -> [f32; 3] {
        let k = idx % self.list_n[2];
        let j = (idx / self.list_n[2]) % self.list_n[1];
        let i = idx / (self.list_n[2] * self.list_n[1]);
        let c = [i, j, k];
        [0, 1, 2].map(|a| self.origin[a] + (c[a] as f32 + 0.5) * LIST_CELL)
    }

    /// The farthest distance from the centre of list cell `idx` a
    /// [`Candidate`] of that cell can have and still be touched by a body
    /// centred at `p` with bounding radius plus margin `reach`.
    #[inline(always)]
    pub fn list_limit(&self, idx: usize, p: &[f32; 3], reach: f32) -> f32 {
        Self::list_limit_at(&self.list_centre(idx), p, reach)
    }

    /// The obstacles (indices into `world.obstacles`, nearest first) a body
    /// centred anywhere in list cell `idx` (from [`WorldGrid::list_cell`])
    /// with bounding radius plus margin at most
    /// [`WorldGrid::list_reach`] can touch; every other obstacle is
    /// farther from it than that.
    #[inline(always)]
    pub fn candidates(&self, world: &CompiledWorld, idx: usize) -> &[Candidate] {
        self.lists[idx].get_or_init(|| self.fill_list(world, idx))
    }

    /// Distance from a list cell's centre within which every obstacle is
    /// on its list.
    fn list_radius(&self) -> f32 {
        self.list_reach + 0.5 * LIST_CELL * 3f32.sqrt() + LIST_SLACK
    }

    #[cold]
    #[inline(never)]
    fn fill_list(&self, world: &CompiledWorld, idx: usize) -> Box<[Candidate]> {
        let c = self.list_centre(idx);
        let reach = self.list_radius();
        let mut near: Vec<(f32, u32)> = world
            .obstacles
            .iter()
            .enumerate()
            .filter_map(|(oi, o)| {
                let d = obstacle_distance(o, &c);
                // NaN (degenerate data) keeps the obstacle.
                (d.is_nan() || d <= reach).then_some((if d.is_nan() { 0.0 } else { d }, oi as u32))
            })
            .collect();
        near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        near.into_iter()
            .map(|(distance, obstacle)| Candidate { obstacle, distance })
            .collect()
    }

    /// A lower bound on the distance from `p` to every obstacle of `world`
    /// (the world the grid was made for); 0 outside the grid.
    pub fn clearance(&self, world: &CompiledWorld, p: &[f32; 3]) -> f32 {
        let mut bound = 0.0;
        self.cells(world, &p.map(f32x8::splat), 1, |_, v, off| {
            bound = (v as f32 * QUANTUM - off).max(0.0)
        });
        bound
    }

    /// The lanes set in `lanes` whose point (x, y, z lanes of `p`) has a
    /// [`WorldGrid::clearance`] greater than that lane of `reach`.
    #[inline(always)]
    pub fn clear_lanes(
        &self,
        world: &CompiledWorld,
        p: &[f32x8; 3],
        reach: f32x8,
        lanes: u32,
    ) -> u32 {
        let reach = reach.to_array();
        let mut clear = 0;
        // Lane by lane in registers: a vector assembled from eight scalar
        // stores would stall on store forwarding.
        self.cells(world, p, lanes, |l, v, off| {
            if v as f32 * QUANTUM - off > reach[l] {
                clear |= 1 << l;
            }
        });
        clear
    }

    /// Calls `f(lane, stored bound, distance from the cell's centre)` for
    /// each lane set in `lanes` whose point lies in the grid. The stored
    /// bound (in quanta) holds at the cell's centre; less the distance
    /// from it, it holds at the point (1-Lipschitz).
    #[inline(always)]
    fn cells(
        &self,
        world: &CompiledWorld,
        p: &[f32x8; 3],
        lanes: u32,
        mut f: impl FnMut(usize, u8, f32),
    ) {
        let zero = f32x8::splat(0.0);
        let mut inside = lanes;
        let mut ijk = [i32x8::splat(0); 3];
        let mut off2 = zero;
        for a in 0..3 {
            let f = (p[a] - f32x8::splat(self.origin[a])) * f32x8::splat(1.0 / CELL);
            // In [0, n) (NaN fails both tests).
            inside &= (f.simd_ge(zero) & f.simd_lt(f32x8::splat(self.n_f32[a]))).to_bitmask();
            // In range where it counts, so the plain truncating conversion is exact.
            ijk[a] = f.fast_trunc_int();
            // The offset from the cell's centre, in cells (the fractional
            // part less one half); its rounding is far below `SLACK`.
            let d = (f - ijk[a].round_float()) - f32x8::splat(0.5);
            off2 += d * d;
        }
        let off = (off2.sqrt() * f32x8::splat(CELL)).to_array();
        // At most 6 m / 5 cm + 1 = 121 cells per axis: inside lanes' indices
        // stay far below 2^31.
        let idx = ((ijk[0] * i32x8::splat(self.n[1] as i32) + ijk[1])
            * i32x8::splat(self.n[2] as i32)
            + ijk[2])
            .to_array();
        while inside != 0 {
            let l = inside.trailing_zeros() as usize;
            inside &= inside - 1;
            let v = self.cell(world, idx[l] as usize, || {
                ijk.map(|c| c.to_array()[l] as usize)
            });
            f(l, v, off[l]);
        }
    }

    /// The stored bound of cell `idx` (cell `ijk()` of the grid), filled on
    /// first use.
    #[inline(always)]
    fn cell(&self, world: &CompiledWorld, idx: usize, ijk: impl FnOnce() -> [usize; 3]) -> u8 {
        let Some(cell) = self.cells.get(idx) else {
            return 0;
        };
        let mut v = cell.load(Ordering::Relaxed);
        if v == UNKNOWN {
            v = self.fill(world, ijk());
            cell.store(v, Ordering::Relaxed);
        }
        v
    }

    /// The stored bound of cell (`i`, `j`, `k`).
    #[cold]
    #[inline(never)]
    fn fill(&self, world: &CompiledWorld, ijk: [usize; 3]) -> u8 {
        let c = [0, 1, 2].map(|a| self.origin[a] + (ijk[a] as f32 + 0.5) * CELL);
        // The cell lies in the list cell of half its indices (list cells
        // are two cells wide, same origin): only that list's obstacles can
        // be nearer than the list's radius minus the offset of the centres;
        // every other obstacle is farther (the distance to a solid is
        // 1-Lipschitz), so the bound is capped there. The stored bound's
        // one-unit deduction covers the `f32` rounding of both distances.
        let l = ijk.map(|i| i / 2);
        let nearest = if l.iter().zip(&self.list_n).all(|(i, n)| i < n) {
            let idx = (l[0] * self.list_n[1] + l[1]) * self.list_n[2] + l[2];
            let lc = self.list_centre(idx);
            let offset = norm([c[0] - lc[0], c[1] - lc[1], c[2] - lc[2]]);
            self.candidates(world, idx)
                .iter()
                .map(|cand| obstacle_distance(&world.obstacles[cand.obstacle as usize], &c))
                .fold(self.list_radius() - offset, f32::min)
        } else {
            world
                .obstacles
                .iter()
                .map(|o| obstacle_distance(o, &c))
                .fold(f32::INFINITY, f32::min)
        };
        // The bound at the centre; the lookups deduct the point's offset.
        let bound = nearest / QUANTUM;
        if bound.is_nan() || bound < 1.0 {
            0
        } else {
            // One unit less than the floor: immune to the rounding above.
            (bound.floor() - 1.0).min((UNKNOWN - 1) as f32) as u8
        }
    }
}

/// Distance from `p` to obstacle `o`'s solid (to its bounding sphere for
/// meshes and clouds): a lower bound on the distance to its geometry.
fn obstacle_distance(o: &crate::compiled::Obstacle, p: &[f32; 3]) -> f32 {
    match o.prim {
        Prim::Complex => {
            let d = [
                p[0] - o.bound_c[0],
                p[1] - o.bound_c[1],
                p[2] - o.bound_c[2],
            ];
            norm(d) - o.bound_r
        }
        ref prim => prim_distance(prim, p),
    }
}

fn norm(d: [f32; 3]) -> f32 {
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Distance from `p` to the solid `prim` (0 inside).
pub fn prim_distance(prim: &Prim, p: &[f32; 3]) -> f32 {
    match *prim {
        Prim::Sphere { c, r } => (norm([p[0] - c[0], p[1] - c[1], p[2] - c[2]]) - r).max(0.0),
        Prim::Box { c, rt, h } => {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let q: [f32; 3] = std::array::from_fn(|i| {
                let l = d[0] * rt[i * 3] + d[1] * rt[i * 3 + 1] + d[2] * rt[i * 3 + 2];
                (l.abs() - h[i]).max(0.0)
            });
            norm(q)
        }
        Prim::Cylinder { c, a, r, h } => {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let z = d[0] * a[0] + d[1] * a[1] + d[2] * a[2];
            let rho = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - z * z)
                .max(0.0)
                .sqrt();
            let (dr, dz) = ((rho - r).max(0.0), (z.abs() - h).max(0.0));
            (dr * dr + dz * dz).sqrt()
        }
        Prim::Capsule { c, a, r, h } => {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let z = (d[0] * a[0] + d[1] * a[1] + d[2] * a[2]).clamp(-h, h);
            (norm([d[0] - z * a[0], d[1] - z * a[1], d[2] - z * a[2]]) - r).max(0.0)
        }
        Prim::Complex => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitive_distances_match_analytic_values() {
        let rt = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let boxp = Prim::Box {
            c: [1.0, 0.0, 0.0],
            rt,
            h: [0.5, 0.5, 0.5],
        };
        assert!((prim_distance(&boxp, &[3.0, 0.0, 0.0]) - 1.5).abs() < 1e-6);
        assert!((prim_distance(&boxp, &[2.5, 2.5, 0.0]) - 5f32.sqrt()).abs() < 1e-6);
        assert_eq!(prim_distance(&boxp, &[1.2, 0.1, 0.0]), 0.0);
        let cyl = Prim::Cylinder {
            c: [0.0; 3],
            a: [0.0, 0.0, 1.0],
            r: 0.1,
            h: 0.2,
        };
        assert!((prim_distance(&cyl, &[0.5, 0.0, 0.0]) - 0.4).abs() < 1e-6);
        assert!((prim_distance(&cyl, &[0.0, 0.0, 0.5]) - 0.3).abs() < 1e-6);
        assert!((prim_distance(&cyl, &[0.4, 0.0, 0.6]) - 0.5).abs() < 1e-6);
        let cap = Prim::Capsule {
            c: [0.0; 3],
            a: [1.0, 0.0, 0.0],
            r: 0.1,
            h: 0.5,
        };
        assert!((prim_distance(&cap, &[1.0, 0.0, 0.0]) - 0.4).abs() < 1e-6);
        assert!((prim_distance(&cap, &[0.2, 0.6, 0.0]) - 0.5).abs() < 1e-6);
        let sph = Prim::Sphere {
            c: [0.0, 0.0, 1.0],
            r: 0.25,
        };
        assert!((prim_distance(&sph, &[0.0, 0.0, 0.0]) - 0.75).abs() < 1e-6);
    }
}
