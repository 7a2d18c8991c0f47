//! Joint-space clearance maps for self-collision pairs that only two joints
//! move relative to each other.
//!
//! Some self pairs are close in almost every configuration: on the Panda,
//! the hand and the fingers against link 5, whose bounding spheres always
//! overlap, so the sphere stage runs for them at every check. Their relative
//! pose depends on two joints only (joints 6 and 7), so a bitmap over those
//! two coordinates can say in one lookup that a configuration is clear.
//!
//! A cell's bit is set only if every configuration in the cell is clear: at
//! the cell centre, every sphere of one body is farther from every sphere of
//! the other than the sum of their radii plus the margin, plus the farthest
//! any sphere centre can move within the cell (angle half-widths times the
//! sphere's distance from each joint axis), plus a slack for `f32`
//! rounding. A set bit therefore means the sphere stage would find no
//! overlapping spheres: skipping it changes no answer. Cells that are not
//! certain fall back to the sphere stage. Both kernels use the maps: the
//! single-configuration one per pair, the lane kernel per lane.
//!
//! A second bitmap marks the cells where the pair certainly collides: at the
//! cell centre some sphere pair overlaps (with the margin) by more than the
//! motion bound plus the slack, so the sphere stage reaches the exact stage
//! everywhere in the cell, and, when both bodies have exact geometry, some
//! pair of their inscribed spheres overlaps by as much, so the exact stage
//! ([`crate::exact::confirm`]) confirms the contact everywhere in the cell.
//! About half of the Panda's self-collisions are the hand or a finger
//! against link 5; the single-configuration kernel answers those with one
//! lookup per pair of joints ([`collide_maps`]) before any other test.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;
use wide::{f32x4, f32x8, i32x4};

use crate::compiled::CompiledRobot;
use crate::kernel::{LaneFrame, Scratch, apply, forward};
use crate::lanes::Lanes;

/// Cells along each of the two joint coordinates.
const CELLS: usize = 128;
/// Slack (m) over the exact clearance for the `f32` arithmetic of the
/// kernel (frames computed through the whole chain differ from the map's by
/// about `1e-6` m).
const SLACK: f32 = 1e-4;

/// A bitmap over two joint coordinates of a self pair (see the module docs).
#[derive(Debug, Clone)]
pub struct PairMap {
    /// The two DOFs whose coordinates index the map.
    dofs: [usize; 2],
    /// Lower joint limits of the two DOFs (lanes 0 and 1; lanes 2 and 3
    /// are 0).
    lo: f32x4,
    /// Upper joint limits of the two DOFs (lanes as in `lo`).
    hi: f32x4,
    /// Cells per unit of each coordinate (lanes as in `lo`).
    inv_h: f32x4,
    /// Margin the map was built for: its clear cells are valid for margins
    /// up to this, its colliding cells for margins from this.
    margin: f32,
    /// One bit per cell, row-major over (first DOF, second DOF): clear.
    bits: Vec<u64>,
    /// One bit per cell (as `bits`): certainly colliding.
    collide_bits: Vec<u64>,
    /// Fraction of cells that are clear.
    clear_fraction: f64,
    /// Fraction of cells that certainly collide.
    collide_fraction: f64,
}

impl PairMap {
    /// Whether the sphere stage is certain to find the pair clear at `q`
    /// (model DOF order) with `margin`. Coordinates outside the joint
    /// limits or a larger margin than the map's give `false`.
    #[inline(always)]
    pub fn clear(&self, q: &[f32], margin: f32) -> bool {
        self.clear_at(q[self.dofs[0]], q[self.dofs[1]], margin)
    }

    /// [`PairMap::clear`] for the lanes of `q` (DOF-major lane vectors)
    /// set in `lanes`: the bitmask of those the map vouches for.
    #[inline(always)]
    pub fn clear_lanes<L: Lanes>(&self, q: &[L], margin: f32, lanes: u32) -> u32 {
        let (x, y) = (q[self.dofs[0]], q[self.dofs[1]]);
        let mut out = 0;
        let mut rest = lanes;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            if self.clear_at(x.lane(i), y.lane(i), margin) {
                out |= 1 << i;
            }
        }
        out
    }

    /// Whether the cell at coordinates (`x`, `y`) of the two DOFs is clear.
    #[inline(always)]
    fn clear_at(&self, x: f32, y: f32, margin: f32) -> bool {
        margin <= self.margin && self.cell(x, y).is_some_and(|k| bit(&self.bits, k))
    }

    /// Whether the pair certainly collides at `q` (model DOF order) with
    /// `margin`: the exact stage would confirm a contact. Coordinates
    /// outside the joint limits or a smaller margin than the map's give
    /// `false`.
    #[inline(always)]
    pub fn collides(&self, q: &[f32], margin: f32) -> bool {
        margin >= self.margin
            && self
                .cell(q[self.dofs[0]], q[self.dofs[1]])
                .is_some_and(|k| bit(&self.collide_bits, k))
    }

    /// The cell (row-major index) of coordinates (`x`, `y`) of the two
    /// DOFs, or `None` outside the limits (or NaN).
    #[inline(always)]
    fn cell(&self, x: f32, y: f32) -> Option<usize> {
        let v = f32x4::from([x, y, 0.0, 0.0]);
        // Both coordinates within the limits (NaN fails).
        if (v.simd_ge(self.lo) & v.simd_le(self.hi)).to_bitmask() != 0b1111 {
            return None;
        }
        // In [0, CELLS] after the test above, so the plain truncating
        // conversion is exact.
        let ij = ((v - self.lo) * self.inv_h)
            .fast_trunc_int()
            .min(i32x4::splat(CELLS as i32 - 1))
            .to_array();
        Some(ij[0] as usize * CELLS + ij[1] as usize)
    }

    /// The two DOFs that index the map.
    pub fn dofs(&self) -> [usize; 2] {
        self.dofs
    }

    /// Fraction of the map's cells that are certainly clear.
    pub fn clear_fraction(&self) -> f64 {
        self.clear_fraction
    }

    /// Fraction of the map's cells where the pair certainly collides.
    pub fn collide_fraction(&self) -> f64 {
        self.collide_fraction
    }

    /// Builds the map of body pair (`a`, `b`) of `robot` for `margin`, or
    /// `None` if the pair does not qualify: a body is an attached object,
    /// neither body's frame is an ancestor of the other's, the joints
    /// between them are not exactly two distinct revolute DOFs used once
    /// each, or a limit is not finite. `limits` are the model's DOF limits.
    pub fn build(
        robot: &CompiledRobot,
        a: usize,
        b: usize,
        margin: f32,
        limits: &[(f64, f64)],
    ) -> Option<Self> {
        let plan = Plan::new(robot, a, b, limits)?;
        Some(plan.build(robot, margin))
    }
}

/// Spheres as (centre, radius) in a body's lane frame.
type Spheres = Vec<([f32; 3], f32)>;

/// What a map of one pair is computed from.
struct Plan {
    /// The proximal and distal body.
    prox: usize,
    dist: usize,
    /// Steps of the two joints, proximal first.
    steps: [usize; 2],
    dofs: [usize; 2],
    lo: [f32; 2],
    hi: [f32; 2],
}

impl Plan {
    fn new(robot: &CompiledRobot, a: usize, b: usize, limits: &[(f64, f64)]) -> Option<Self> {
        let (ba, bb) = (&robot.bodies[a], &robot.bodies[b]);
        if ba.attached.is_some() || bb.attached.is_some() {
            return None;
        }
        // Steps from a frame up to the base (frame f is made by step f - 1).
        let chain = |mut f: usize| {
            let mut out = Vec::new();
            while f > 0 {
                out.push(f - 1);
                f = robot.steps[f - 1].parent;
            }
            out
        };
        let (ca, cb) = (chain(ba.frame), chain(bb.frame));
        let (prox, dist, between) = if cb.len() > ca.len() && cb.ends_with(&ca) {
            (a, b, cb[..cb.len() - ca.len()].to_vec())
        } else if ca.len() > cb.len() && ca.ends_with(&cb) {
            (b, a, ca[..ca.len() - cb.len()].to_vec())
        } else {
            return None;
        };
        // `between` runs distal to proximal.
        if between.len() != 2 {
            return None;
        }
        let steps = [between[1], between[0]];
        let dofs = steps.map(|s| robot.steps[s].dof);
        if dofs[0] == dofs[1] || steps.iter().any(|&s| robot.steps[s].prismatic) {
            return None;
        }
        // Each DOF must drive no other step on either chain.
        for s in ca.iter().chain(cb.iter()) {
            if !steps.contains(s) && dofs.contains(&robot.steps[*s].dof) {
                return None;
            }
        }
        let lim = dofs.map(|d| limits.get(d).copied());
        let mut lo = [0.0f32; 2];
        let mut hi = [0.0f32; 2];
        for i in 0..2 {
            let (l, h) = lim[i]?;
            if !(l.is_finite() && h.is_finite() && h > l) {
                return None;
            }
            (lo[i], hi[i]) = (l as f32, h as f32);
        }
        Some(Self {
            prox,
            dist,
            steps,
            dofs,
            lo,
            hi,
        })
    }

    fn build(&self, robot: &CompiledRobot, margin: f32) -> PairMap {
        let h = [0, 1].map(|i| (self.hi[i] - self.lo[i]) / CELLS as f32);
        let centre = |i: usize, k: usize| self.lo[i] + (k as f32 + 0.5) * h[i];
        // Distances from the two joint origins to the distal body's sphere
        // centres (rigid in the frames that turn about those axes, so any
        // configuration will do), for the bound on motion within a cell.
        let mut q = vec![0.0f32; robot.num_dof];
        q[self.dofs[0]] = centre(0, 0);
        q[self.dofs[1]] = centre(1, 0);
        let mut scratch = Scratch::<f32>::new(robot);
        forward(robot, &q, &mut scratch);
        let frames = scratch.frames();
        let body = &robot.bodies[self.dist];
        let origin = |s: usize| {
            let f = &frames[s + 1];
            [f[9], f[10], f[11]]
        };
        let (o1, o2) = (origin(self.steps[0]), origin(self.steps[1]));
        let inscribed = self.inscribed(robot);
        let mut r2 = 0.0f32;
        for c in (body.first..body.first + body.count)
            .map(|k| &robot.centers[k])
            .chain(inscribed.iter().flat_map(|i| i[1].iter().map(|(c, _)| c)))
        {
            let c: [f32; 3] = apply(&frames[body.frame], c);
            r2 = r2.max(norm(sub(c, o2)));
        }
        let r1 = norm(sub(o2, o1)) + r2;
        let gains = self.steps.map(|s| robot.steps[s].gain.abs());
        let motion = 0.5 * (gains[0] * h[0] * r1 * 1.001 + gains[1] * h[1] * r2 * 1.001);
        let threshold = margin + motion + SLACK;
        // One row of cells (fixed first coordinate) per task.
        let rows: Vec<Vec<(bool, bool)>> = (0..CELLS)
            .into_par_iter()
            .map_init(
                || (Scratch::<f32>::new(robot), vec![0.0f32; robot.num_dof]),
                |(scratch, q), i| {
                    q[self.dofs[0]] = centre(0, i);
                    (0..CELLS)
                        .map(|j| {
                            q[self.dofs[1]] = centre(1, j);
                            forward(robot, q, scratch);
                            let frames = scratch.frames();
                            (
                                self.cell_clear(robot, frames, threshold),
                                self.cell_collides(
                                    robot,
                                    frames,
                                    margin,
                                    motion + SLACK,
                                    inscribed.as_ref(),
                                ),
                            )
                        })
                        .collect()
                },
            )
            .collect();
        let mut bits = vec![0u64; (CELLS * CELLS).div_ceil(64)];
        let mut collide_bits = bits.clone();
        let (mut clear, mut collide) = (0usize, 0usize);
        for (i, row) in rows.iter().enumerate() {
            for (j, &(c, x)) in row.iter().enumerate() {
                let k = i * CELLS + j;
                if c {
                    bits[k >> 6] |= 1 << (k & 63);
                    clear += 1;
                }
                if x {
                    collide_bits[k >> 6] |= 1 << (k & 63);
                    collide += 1;
                }
            }
        }
        PairMap {
            dofs: self.dofs,
            lo: lanes2(self.lo),
            hi: lanes2(self.hi),
            inv_h: lanes2(h.map(|x| 1.0 / x)),
            margin,
            bits,
            collide_bits,
            clear_fraction: clear as f64 / (CELLS * CELLS) as f64,
            collide_fraction: collide as f64 / (CELLS * CELLS) as f64,
        }
    }

    /// The inscribed spheres of the proximal and distal body, if both have
    /// exact geometry (else the sphere stage alone decides the pair).
    fn inscribed(&self, robot: &CompiledRobot) -> Option<[Spheres; 2]> {
        let exact = |b: usize| robot.exact.get(b).and_then(|e| e.as_ref());
        match (exact(self.prox), exact(self.dist)) {
            (Some(p), Some(d)) => Some([p, d].map(|e| e.inscribed().copied().collect())),
            _ => None,
        }
    }

    /// Whether the pair certainly collides everywhere within `motion` of
    /// these frames (see the module docs): some sphere pair overlaps, with
    /// `margin`, by more than `motion`, and so does some pair of
    /// `inscribed` spheres (proximal, distal; `None`: spheres decide).
    fn cell_collides(
        &self,
        robot: &CompiledRobot,
        frames: &[LaneFrame<f32>],
        margin: f32,
        motion: f32,
        inscribed: Option<&[Spheres; 2]>,
    ) -> bool {
        let (bp, bd) = (&robot.bodies[self.prox], &robot.bodies[self.dist]);
        // Largest overlap of a sphere of `a` (frame fa) with one of `b`.
        let overlap = |a: &[([f32; 3], f32)], fa: usize, b: &[([f32; 3], f32)], fb: usize| {
            let b: Spheres = b
                .iter()
                .map(|(c, r)| (apply::<f32>(&frames[fb], c), *r))
                .collect();
            let mut best = f32::NEG_INFINITY;
            for (c, r) in a {
                let c = apply::<f32>(&frames[fa], c);
                for (cb, rb) in &b {
                    best = best.max(r + rb - norm(sub(c, *cb)));
                }
            }
            best
        };
        let spheres = |b: &crate::compiled::Body| -> Spheres {
            (b.first..b.first + b.count)
                .map(|k| (robot.centers[k], robot.radii[k]))
                .collect()
        };
        // NaN compares false: not certain.
        let sure = |depth: f32| depth > motion;
        if !sure(overlap(&spheres(bp), bp.frame, &spheres(bd), bd.frame) + margin) {
            return false;
        }
        match inscribed {
            Some([p, d]) => sure(overlap(p, bp.frame, d, bd.frame)),
            None => true,
        }
    }

    /// Whether every sphere pair of the two bodies is more than
    /// `threshold` apart (surface to surface) at these frames.
    fn cell_clear(&self, robot: &CompiledRobot, frames: &[LaneFrame<f32>], threshold: f32) -> bool {
        let (bp, bd) = (&robot.bodies[self.prox], &robot.bodies[self.dist]);
        let fd = frames[bd.frame].map(f32x8::splat);
        let t = f32x8::splat(threshold);
        let packs: Vec<([f32x8; 3], f32x8)> = (bd.first_pack..bd.first_pack + bd.pack_count)
            .map(|k| {
                let p = &robot.packs[k];
                let c = p.c;
                (
                    [
                        fd[0] * c[0] + fd[1] * c[1] + fd[2] * c[2] + fd[9],
                        fd[3] * c[0] + fd[4] * c[1] + fd[5] * c[2] + fd[10],
                        fd[6] * c[0] + fd[7] * c[1] + fd[8] * c[2] + fd[11],
                    ],
                    p.r + t,
                )
            })
            .collect();
        for k in bp.first..bp.first + bp.count {
            let c = apply::<f32>(&frames[bp.frame], &robot.centers[k]).map(f32x8::splat);
            let r = f32x8::splat(robot.radii[k]);
            for (pc, pr) in &packs {
                let d = [c[0] - pc[0], c[1] - pc[1], c[2] - pc[2]];
                let rr = r + *pr;
                // Not clear where the distance is at most the sum (also NaN).
                if (rr * rr).lt_mask(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) != 0xff {
                    return false;
                }
            }
        }
        true
    }
}

/// Bit `k` of `bits`.
#[inline(always)]
fn bit(bits: &[u64], k: usize) -> bool {
    bits[k >> 6] >> (k & 63) & 1 == 1
}

/// One map per pair of DOFs among `maps` whose colliding cells are those
/// of any of its maps (and which has no clear cells): one lookup tells
/// whether some pair of bodies those two joints separate certainly
/// collides. Maps over the same DOFs share their limits and so their cells.
pub fn collide_maps(maps: &[Option<Arc<PairMap>>]) -> Vec<PairMap> {
    let mut out: Vec<PairMap> = Vec::new();
    for m in maps.iter().flatten() {
        let same = |o: &PairMap| {
            o.dofs == m.dofs
                && o.margin == m.margin
                && [o.lo, o.hi, o.inv_h].map(|v| v.to_array())
                    == [m.lo, m.hi, m.inv_h].map(|v| v.to_array())
        };
        match out.iter_mut().find(|o| same(o)) {
            Some(o) => {
                for (a, b) in o.collide_bits.iter_mut().zip(&m.collide_bits) {
                    *a |= b;
                }
            }
            None => out.push(PairMap {
                bits: vec![0; m.bits.len()],
                clear_fraction: 0.0,
                ..(**m).clone()
            }),
        }
    }
    for o in &mut out {
        let n: u32 = o.collide_bits.iter().map(|b| b.count_ones()).sum();
        o.collide_fraction = n as f64 / (CELLS * CELLS) as f64;
    }
    out.retain(|o| o.collide_fraction > 0.0);
    out
}

/// `v` in lanes 0 and 1, lanes 2 and 3 zero.
fn lanes2(v: [f32; 2]) -> f32x4 {
    f32x4::from([v[0], v[1], 0.0, 0.0])
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f32; 3]) -> f32 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Maps of `robot`'s self pairs (aligned with [`CompiledRobot::pairs`]),
/// `None` for pairs that do not qualify. Maps are cached for the process,
/// keyed by everything they are computed from (the steps, the two bodies'
/// spheres, the limits and the margin), so rebuilding a checker or attaching
/// an object reuses them.
pub fn maps_for(
    robot: &CompiledRobot,
    margin: f32,
    limits: &[(f64, f64)],
) -> Vec<Option<Arc<PairMap>>> {
    static CACHE: OnceLock<Mutex<HashMap<u64, Arc<PairMap>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    robot
        .pairs
        .iter()
        .map(|&(a, b)| {
            let plan = Plan::new(robot, a, b, limits)?;
            let key = key(robot, &plan, margin);
            if let Some(m) = cache.lock().ok()?.get(&key) {
                return Some(m.clone());
            }
            let map = Arc::new(plan.build(robot, margin));
            if let Ok(mut c) = cache.lock() {
                if c.len() > 4096 {
                    c.clear();
                }
                c.insert(key, map.clone());
            }
            Some(map)
        })
        .collect()
}

/// Hash of everything a pair's map depends on.
fn key(robot: &CompiledRobot, plan: &Plan, margin: f32) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let bits = |h: &mut std::collections::hash_map::DefaultHasher, v: &[f32]| {
        for x in v {
            x.to_bits().hash(h);
        }
    };
    for s in &robot.steps {
        (s.parent, s.dof, s.prismatic).hash(&mut h);
        bits(&mut h, &s.k.r);
        bits(&mut h, &s.k.t);
        bits(&mut h, &[s.gain, s.offset]);
    }
    for bi in [plan.prox, plan.dist] {
        let b = &robot.bodies[bi];
        (b.frame, b.first_pack, b.pack_count).hash(&mut h);
        for k in b.first..b.first + b.count {
            bits(&mut h, &robot.centers[k]);
            bits(&mut h, &[robot.radii[k]]);
        }
    }
    match plan.inscribed(robot) {
        Some(sets) => {
            for set in sets {
                set.len().hash(&mut h);
                for (c, r) in set {
                    bits(&mut h, &c);
                    bits(&mut h, &[r]);
                }
            }
        }
        None => u8::MAX.hash(&mut h),
    }
    (plan.steps, plan.dofs).hash(&mut h);
    bits(
        &mut h,
        &[plan.lo[0], plan.lo[1], plan.hi[0], plan.hi[1], margin],
    );
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_index_handles_bounds_and_nan() {
        let map = PairMap {
            dofs: [0, 1],
            lo: lanes2([-1.0, 0.0]),
            hi: lanes2([1.0, 2.0]),
            inv_h: lanes2([CELLS as f32 / 2.0, CELLS as f32 / 2.0]),
            margin: 0.01,
            bits: vec![u64::MAX; (CELLS * CELLS).div_ceil(64)],
            collide_bits: vec![0; (CELLS * CELLS).div_ceil(64)],
            clear_fraction: 1.0,
            collide_fraction: 0.0,
        };
        assert!(map.clear(&[0.0, 1.0], 0.0));
        assert!(map.clear(&[1.0, 2.0], 0.01));
        assert!(
            !map.clear(&[0.0, 1.0], 0.02),
            "larger margin than built for"
        );
        assert!(!map.clear(&[1.1, 1.0], 0.0), "outside the limits");
        assert!(!map.clear(&[f32::NAN, 1.0], 0.0));
    }

    /// The cell looked up is the one of the scalar formula the maps were
    /// built for (`(x - lo) * inv_h` truncated, at most `CELLS - 1`), at
    /// random points, cell edges and the limits.
    #[test]
    fn cell_lookup_matches_scalar_index() {
        let (lo, hi) = ([-2.8973f32, -0.0175], [2.8973f32, 3.7525]);
        let inv_h = [0, 1].map(|i| CELLS as f32 / (hi[i] - lo[i]));
        let mut seed = 3u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            seed >> 11
        };
        let bits: Vec<u64> = (0..(CELLS * CELLS).div_ceil(64)).map(|_| next()).collect();
        let map = PairMap {
            dofs: [0, 1],
            lo: lanes2(lo),
            hi: lanes2(hi),
            inv_h: lanes2(inv_h),
            margin: 0.0,
            bits: bits.clone(),
            collide_bits: bits.iter().map(|b| !b).collect(),
            clear_fraction: 0.5,
            collide_fraction: 0.5,
        };
        let mut points: Vec<[f32; 2]> = (0..20_000)
            .map(|_| [0, 1].map(|i| lo[i] + (hi[i] - lo[i]) * (next() % 1_000_001) as f32 / 1e6))
            .collect();
        for k in 0..=CELLS {
            let edge = [0, 1].map(|i| lo[i] + k as f32 / inv_h[i]);
            points.push(edge.map(|e| e.clamp(lo[0].min(lo[1]), hi[0].max(hi[1]))));
        }
        points.extend([lo, hi, [lo[0], hi[1]], [hi[0], lo[1]]]);
        for p in points {
            let inside = (0..2).all(|i| p[i] >= lo[i] && p[i] <= hi[i]);
            let want = inside && {
                let c =
                    [0, 1].map(|i| (((p[i] - lo[i]) * inv_h[i]) as i32 as usize).min(CELLS - 1));
                let k = c[0] * CELLS + c[1];
                bits[k >> 6] >> (k & 63) & 1 == 1
            };
            assert_eq!(map.clear(&p, 0.0), want, "{p:?}");
            assert_eq!(map.collides(&p, 0.0), inside && !want, "{p:?}");
        }
    }
}
