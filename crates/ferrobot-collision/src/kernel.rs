//! The collision kernel, generic over [`Lanes`]: forward kinematics of the
//! lane frames, then spheres against the world and against each other, with
//! bounding spheres first and an early exit once every lane has collided.

use nalgebra::Point3;

use crate::compiled::{CompiledRobot, CompiledWorld, Prim, Step};
use wide::{f32x4, f32x8};

use crate::lanes::{Lanes, sin_cos};
use crate::world_grid::WorldGrid;

/// A lane frame: row-major rotation (9) then translation (3).
pub type LaneFrame<L> = [L; 12];

/// Reusable buffers of the kernel (one per thread).
#[derive(Debug, Clone)]
pub struct Scratch<L: Lanes> {
    frames: Vec<LaneFrame<L>>,
    centers: Vec<[L; 3]>,
    done: Vec<bool>,
    bounds: Vec<[L; 3]>,
    /// Self pairs left to the exact stage's GJK (pair, lanes), decided
    /// after every cheaper test of the check.
    deferred: Vec<(usize, u32)>,
}

impl<L: Lanes> Scratch<L> {
    /// Buffers sized for `robot`.
    pub fn new(robot: &CompiledRobot) -> Self {
        let zero = L::splat(0.0);
        Self {
            frames: vec![[zero; 12]; robot.num_frames()],
            centers: vec![[zero; 3]; robot.centers.len()],
            done: vec![false; robot.bodies.len()],
            bounds: vec![[zero; 3]; robot.bodies.len()],
            deferred: Vec::with_capacity(robot.pairs.len()),
        }
    }

    /// The lane frames computed by the last [`forward`].
    pub fn frames(&self) -> &[LaneFrame<L>] {
        &self.frames
    }
}

/// `p` times the step's constant transform. A rotation that is a signed
/// permutation is applied by picking columns; the translation adds all three
/// terms, in increasing order. [`forward_cols`] performs the same operations
/// (up to multiplications by 1 and sign changes, which are exact), so the
/// one-configuration and eight-lane kinematics agree bit for bit.
#[inline(always)]
fn compose<L: Lanes>(p: &LaneFrame<L>, step: &Step) -> LaneFrame<L> {
    let s = L::splat;
    let k = &step.k;
    let mut o = [s(0.0); 12];
    match step.perm {
        Some((src, sign)) => {
            for i in 0..3 {
                for j in 0..3 {
                    o[i * 3 + j] = p[i * 3 + src[j]] * s(sign[j]);
                }
            }
        }
        None => {
            for i in 0..3 {
                let (a, b, c) = (p[i * 3], p[i * 3 + 1], p[i * 3 + 2]);
                for j in 0..3 {
                    o[i * 3 + j] = a * s(k.r[j]) + b * s(k.r[3 + j]) + c * s(k.r[6 + j]);
                }
            }
        }
    }
    for i in 0..3 {
        let mut t = p[9 + i];
        for l in 0..3 {
            t = p[i * 3 + l] * s(k.t[l]) + t;
        }
        o[9 + i] = t;
    }
    o
}

/// Applies joint `step` at coordinate `qj` (with `sc` = (sin, cos) of `qj`
/// for a revolute joint) to its parent's frame.
#[inline(always)]
fn joint_frame<L: Lanes>(parent: &LaneFrame<L>, step: &Step, qj: L, sc: (L, L)) -> LaneFrame<L> {
    let mut m = compose(parent, step);
    if step.prismatic {
        for r in 0..3 {
            m[9 + r] = m[9 + r] + m[r * 3 + 2] * qj;
        }
    } else {
        let (s, c) = sc;
        for r in 0..3 {
            let (x, y) = (m[r * 3], m[r * 3 + 1]);
            m[r * 3] = x * c + y * s;
            m[r * 3 + 1] = y * c - x * s;
        }
    }
    m
}

/// Forward kinematics of every lane frame for the DOF lanes `q`.
///
/// With one lane (a single configuration), the sines and cosines of up to
/// eight joints are evaluated at once in SIMD lanes; [`sin_cos`] is
/// lane-exact, so the frames equal the eight-lane kernel's bit for bit.
#[inline(always)]
pub fn forward<L: Lanes>(robot: &CompiledRobot, q: &[L], scratch: &mut Scratch<L>) {
    let (one, zero) = (L::splat(1.0), L::splat(0.0));
    scratch.frames[0] = [
        one, zero, zero, zero, one, zero, zero, zero, one, zero, zero, zero,
    ];
    if L::WIDTH == 1 {
        for (block, steps) in robot.steps.chunks(8).enumerate() {
            let qj: [L; 8] = std::array::from_fn(|i| match steps.get(i) {
                Some(st) => q[st.dof] * L::splat(st.gain) + L::splat(st.offset),
                None => zero,
            });
            let (s8, c8) = sin_cos(f32x8::from(qj.map(|v| v.lane(0))));
            let (s8, c8) = (s8.to_array(), c8.to_array());
            for (i, step) in steps.iter().enumerate() {
                let f = block * 8 + i;
                let sc = (L::splat(s8[i]), L::splat(c8[i]));
                scratch.frames[f + 1] = joint_frame(&scratch.frames[step.parent], step, qj[i], sc);
            }
        }
        return;
    }
    for (i, step) in robot.steps.iter().enumerate() {
        let qj = q[step.dof] * L::splat(step.gain) + L::splat(step.offset);
        let sc = if step.prismatic {
            (zero, zero)
        } else {
            sin_cos(qj)
        };
        scratch.frames[i + 1] = joint_frame(&scratch.frames[step.parent], step, qj, sc);
    }
}

/// A frame of one configuration as four `f32x4` columns: the rotation's
/// three columns, then the translation (fourth lanes 0).
pub type Cols = [f32x4; 4];

/// Forward kinematics of one configuration with each frame held as
/// [`Cols`]: `cols[f]` is frame `f` (`cols` holds
/// [`CompiledRobot::num_frames`] frames). Every entry goes through the same
/// operations, in the same order, as in [`forward`], so the frames are
/// bit-identical to `forward::<f32>`'s (tested); the columns just let one
/// instruction serve three rows.
///
/// The kinematics is a chain of dependent steps, so its cost is latency:
/// the joint coordinates are gathered into one vector in registers, a step
/// whose parent is the frame just made takes it from registers (columns
/// permuted by a branch on the constant permutation, not by an index,
/// which would go through memory), and any other step reads its parent's
/// columns one at a time (a 32-byte load of two columns just stored
/// separately would stall on store forwarding).
#[inline(always)]
pub fn forward_cols(robot: &CompiledRobot, q: &[f32], cols: &mut [Cols]) {
    let zero4 = f32x4::splat(0.0);
    cols[0] = [
        f32x4::from([1.0, 0.0, 0.0, 0.0]),
        f32x4::from([0.0, 1.0, 0.0, 0.0]),
        f32x4::from([0.0, 0.0, 1.0, 0.0]),
        zero4,
    ];
    let mut prev = cols[0];
    for (block, (steps, sb)) in robot.steps.chunks(8).zip(&robot.step_blocks).enumerate() {
        // The same products and sums as the eight-lane kernel's, lane-wise.
        let qv = f32x8::new(sb.dofs.map(|d| q[d])) * sb.gain + sb.offset;
        let (s8, c8) = sin_cos(qv);
        let [sign0, sign1] = sb.signs;
        let qj = qv.to_array();
        // A permutation's signs of columns 0 and 1 folded into the rotation
        // terms: (x s0) c = x (c s0) exactly, so the columns equal
        // `compose` then `joint_frame`'s.
        let rot = [c8 * sign0, s8 * sign1, c8 * sign1, s8 * sign0].map(|v| v.to_array());
        let (sign0, sign1) = (sign0.to_array(), sign1.to_array());
        for (i, step) in steps.iter().enumerate() {
            let f = block * 8 + i + 1;
            // The previous frame from registers when it is the parent (a
            // chain); else by reference (see the function's docs).
            let p = if step.parent + 1 == f {
                prev
            } else {
                let c = &cols[step.parent];
                [c[0], c[1], c[2], c[3]]
            };
            let k = &step.k;
            let (x, y, z) = match step.perm {
                Some((src, sign)) => {
                    // Columns picked by a branch, not an index, so they stay in registers.
                    let (a, b, c) = match src {
                        [0, 1, 2] => (p[0], p[1], p[2]),
                        [0, 2, 1] => (p[0], p[2], p[1]),
                        [1, 0, 2] => (p[1], p[0], p[2]),
                        [1, 2, 0] => (p[1], p[2], p[0]),
                        [2, 0, 1] => (p[2], p[0], p[1]),
                        _ => (p[2], p[1], p[0]),
                    };
                    (a, b, c * f32x4::splat(sign[2]))
                }
                None => {
                    let col = |j: usize| {
                        p[0] * f32x4::splat(k.r[j])
                            + p[1] * f32x4::splat(k.r[3 + j])
                            + p[2] * f32x4::splat(k.r[6 + j])
                    };
                    (col(0), col(1), col(2))
                }
            };
            let mut t = p[3];
            for (l, &tl) in k.t.iter().enumerate() {
                t = p[l] * f32x4::splat(tl) + t;
            }
            prev = if step.prismatic {
                [
                    x * f32x4::splat(sign0[i]),
                    y * f32x4::splat(sign1[i]),
                    z,
                    t + z * f32x4::splat(qj[i]),
                ]
            } else {
                let r = |v: usize| f32x4::splat(rot[v][i]);
                [x * r(0) + y * r(1), y * r(2) - x * r(3), z, t]
            };
            cols[f] = prev;
        }
    }
}

/// The row-major [`LaneFrame`] of a frame held as [`Cols`].
#[inline(always)]
pub fn cols_to_frame(m: &Cols) -> LaneFrame<f32> {
    let [c0, c1, c2, t] = m.map(|c| c.to_array());
    [
        c0[0], c1[0], c2[0], c0[1], c1[1], c2[1], c0[2], c1[2], c2[2], t[0], t[1], t[2],
    ]
}

/// `m` applied to point `p`: the same operations per row as `apply`, so
/// the result equals `apply(&cols_to_frame(m), p)` bit for bit (fourth
/// lane 0).
#[inline(always)]
pub fn apply_cols(m: &Cols, p: &[f32; 3]) -> f32x4 {
    m[0] * f32x4::splat(p[0]) + m[1] * f32x4::splat(p[1]) + m[2] * f32x4::splat(p[2]) + m[3]
}

/// [`forward_cols`] written out as row-major frames into `scratch` (see
/// [`Scratch::frames`]).
pub fn forward_one(robot: &CompiledRobot, q: &[f32], scratch: &mut Scratch<f32>) {
    let mut cols = vec![[f32x4::splat(0.0); 4]; scratch.frames.len()];
    forward_cols(robot, q, &mut cols);
    for (f, m) in scratch.frames.iter_mut().zip(&cols) {
        *f = cols_to_frame(m);
    }
}

#[inline(always)]
pub(crate) fn apply<L: Lanes>(f: &LaneFrame<L>, p: &[f32; 3]) -> [L; 3] {
    let s = L::splat;
    [
        f[0] * s(p[0]) + f[1] * s(p[1]) + f[2] * s(p[2]) + f[9],
        f[3] * s(p[0]) + f[4] * s(p[1]) + f[5] * s(p[2]) + f[10],
        f[6] * s(p[0]) + f[7] * s(p[1]) + f[8] * s(p[2]) + f[11],
    ]
}

#[inline(always)]
fn dist2<L: Lanes>(a: &[L; 3], b: &[f32; 3]) -> L {
    let (x, y, z) = (
        a[0] - L::splat(b[0]),
        a[1] - L::splat(b[1]),
        a[2] - L::splat(b[2]),
    );
    x * x + y * y + z * z
}

/// Lanes where a sphere at `c` of radius `r` (margin included) touches `prim`.
#[inline(always)]
pub(crate) fn sphere_hits_prim<L: Lanes>(prim: &Prim, c: &[L; 3], r: L) -> u32 {
    let s = L::splat;
    let zero = s(0.0);
    match *prim {
        Prim::Sphere { c: o, r: ro } => {
            let rr = r + s(ro);
            dist2(c, &o).lt_mask(rr * rr)
        }
        Prim::Box { c: o, rt, h } => {
            let d = [c[0] - s(o[0]), c[1] - s(o[1]), c[2] - s(o[2])];
            let mut out2 = zero;
            for i in 0..3 {
                let p = d[0] * s(rt[i * 3]) + d[1] * s(rt[i * 3 + 1]) + d[2] * s(rt[i * 3 + 2]);
                let q = (p.abs() - s(h[i])).max(zero);
                out2 = out2 + q * q;
            }
            out2.lt_mask(r * r)
        }
        Prim::Cylinder { c: o, a, r: ro, h } => {
            let d = [c[0] - s(o[0]), c[1] - s(o[1]), c[2] - s(o[2])];
            let z = d[0] * s(a[0]) + d[1] * s(a[1]) + d[2] * s(a[2]);
            let rho2 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] - z * z).max(zero);
            let dr = (rho2.sqrt() - s(ro)).max(zero);
            let dz = (z.abs() - s(h)).max(zero);
            (dr * dr + dz * dz).lt_mask(r * r)
        }
        Prim::Capsule { c: o, a, r: ro, h } => {
            let d = [c[0] - s(o[0]), c[1] - s(o[1]), c[2] - s(o[2])];
            let z = (d[0] * s(a[0]) + d[1] * s(a[1]) + d[2] * s(a[2]))
                .max(-s(h))
                .min(s(h));
            let e = [d[0] - z * s(a[0]), d[1] - z * s(a[1]), d[2] - z * s(a[2])];
            let rr = r + s(ro);
            (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).lt_mask(rr * rr)
        }
        Prim::Complex => 0,
    }
}

/// Obstacles from which the eight-lane kernel uses the world grid (below,
/// testing every obstacle's bound against the body's sweep costs less than
/// the grid lookups; both give the same answers).
const GRID_MIN_OBSTACLES: usize = 16;

/// Checks the lanes of `q` (DOF-major: `q[dof]` holds that DOF for every
/// lane) against the world and for self-collision. Lanes outside `active`
/// are ignored. With `skip_static`, bodies fixed to the base (frame 0) are
/// not tested against the world: their answer does not depend on `q` and
/// the caller has it already. Returns the bitmask of colliding lanes.
///
/// Inlined into its callers, so that a [`crate::dispatch`] entry point
/// compiles it with its level's instructions.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn check<L: Lanes>(
    robot: &CompiledRobot,
    world: &CompiledWorld,
    grid: Option<&WorldGrid>,
    q: &[L],
    margin: f32,
    active: u32,
    skip_static: bool,
    scratch: &mut Scratch<L>,
) -> u32 {
    check_margins(
        robot,
        world,
        grid,
        q,
        margin,
        margin,
        active,
        skip_static,
        scratch,
    )
}

/// [`check`] with the world tested at `margin` and the self pairs at
/// `self_margin`, on one forward kinematics: the lanes that touch the world
/// at `margin` or collide with themselves at `self_margin` (the union of
/// the two checks, so a lane in it may be colliding in either way). The
/// continuous certification uses it to test world contacts at a grown
/// margin and self pairs at the base margin in one pass
/// ([`crate::CollisionChecker::curve_certified_until`]).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn check_margins<L: Lanes>(
    robot: &CompiledRobot,
    world: &CompiledWorld,
    grid: Option<&WorldGrid>,
    q: &[L],
    margin: f32,
    self_margin: f32,
    active: u32,
    skip_static: bool,
    scratch: &mut Scratch<L>,
) -> u32 {
    forward(robot, q, scratch);
    scratch.done.iter_mut().for_each(|d| *d = false);
    scratch.deferred.clear();
    let m = L::splat(margin);
    let mut hit = 0u32;
    // Distal bodies first: they collide most often.
    for (bi, body) in robot.bodies.iter().enumerate() {
        scratch.bounds[bi] = apply(&scratch.frames[body.frame], &body.bound.0);
    }
    for bi in (0..robot.bodies.len()).rev() {
        let body = &robot.bodies[bi];
        let bc = scratch.bounds[bi];
        if body.frame == 0 && skip_static {
            continue;
        }
        // Lanes tested against every obstacle (all of them without a grid).
        let mut full = active & !hit;
        if let Some(g) = grid
            && L::WIDTH == 8
            && world.obstacles.len() >= GRID_MIN_OBSTACLES
            && body.bound.1 + margin <= g.list_reach()
        {
            // Lanes the grid clears skip the world; the others test only
            // their cell's candidate obstacles, lanes sharing a cell
            // together.
            let p8 = [0, 1, 2].map(|a| f32x8::from_fn(|i| bc[a].lane(i)));
            let reach = f32x8::splat(body.bound.1 + margin + crate::world_grid::SLACK);
            let mut todo = full & !g.clear_lanes(world, &p8, reach, full);
            // (cell, its lanes, the farthest candidate distance they reach)
            let mut cells = [(usize::MAX, 0u32, 0.0f32); 8];
            let mut ncells = 0;
            full = 0;
            let reach_body = body.bound.1 + margin;
            while todo != 0 {
                let l = todo.trailing_zeros() as usize;
                todo &= todo - 1;
                let p = [bc[0].lane(l), bc[1].lane(l), bc[2].lane(l)];
                match g.list_cell_centre(&p) {
                    None => full |= 1 << l,
                    Some((c, centre)) => {
                        let limit = WorldGrid::list_limit_at(&centre, &p, reach_body);
                        match cells[..ncells].iter_mut().find(|x| x.0 == c) {
                            Some(x) => {
                                x.1 |= 1 << l;
                                x.2 = x.2.max(limit);
                            }
                            None => {
                                cells[ncells] = (c, 1 << l, limit);
                                ncells += 1;
                            }
                        }
                    }
                }
            }
            for &(c, lanes, limit) in &cells[..ncells] {
                for cand in g.candidates(world, c) {
                    // Nearest first: the rest are out of these lanes' reach.
                    // (NaN limits were kept out by `list_cell`.)
                    if cand.distance > limit {
                        break;
                    }
                    let obs = &world.obstacles[cand.obstacle as usize];
                    self::world_pair(robot, body, bi, &bc, obs, m, lanes, &mut hit, scratch);
                    if hit & active == active {
                        return hit & active;
                    }
                    if hit & lanes == lanes {
                        break;
                    }
                }
            }
        }
        if full == 0 {
            continue;
        }
        for (ci, chunk) in world.bound_soa.iter().enumerate() {
            // One configuration: its bounding sphere against eight obstacle
            // bounds at once (the same arithmetic as the lane test below).
            let candidates = if L::WIDTH == 1 {
                let (x, y, z) = (bc[0].lane(0), bc[1].lane(0), bc[2].lane(0));
                let (dx, dy, dz) = (
                    f32x8::splat(x) - chunk[0],
                    f32x8::splat(y) - chunk[1],
                    f32x8::splat(z) - chunk[2],
                );
                let reach = (f32x8::splat(body.bound.1) + chunk[3]) + f32x8::splat(margin);
                (dx * dx + dy * dy + dz * dz).lt_mask(reach * reach)
            } else {
                // Eight lanes: the sphere the body sweeps over all
                // configurations against eight obstacle bounds (obstacles
                // out of the arm's reach from this body never get tested).
                let (c, r) = body.sweep;
                let (dx, dy, dz) = (
                    f32x8::splat(c[0]) - chunk[0],
                    f32x8::splat(c[1]) - chunk[1],
                    f32x8::splat(c[2]) - chunk[2],
                );
                let reach = (f32x8::splat(r) + chunk[3]) + f32x8::splat(margin);
                (dx * dx + dy * dy + dz * dz).lt_mask(reach * reach)
            };
            let valid = (world.obstacles.len() - ci * 8).min(8);
            let mut bits = candidates & ((1u32 << valid) - 1);
            while bits != 0 {
                let oi = ci * 8 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let obs = &world.obstacles[oi];
                self::world_pair(robot, body, bi, &bc, obs, m, full, &mut hit, scratch);
                if hit & active == active {
                    return hit & active;
                }
            }
        }
    }
    // Self pairs at their own margin.
    let (m, margin) = (L::splat(self_margin), self_margin);
    for (pi, &(a, b)) in robot.pairs.iter().enumerate() {
        let (ba, bb) = (&robot.bodies[a], &robot.bodies[b]);
        let (ca, cb) = (scratch.bounds[a], scratch.bounds[b]);
        let reach = L::splat(ba.bound.1 + bb.bound.1) + m;
        let d = [ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]];
        let mut near =
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(reach * reach) & active & !hit;
        // Lanes a joint-space clearance map vouches for need no spheres.
        if near != 0
            && let Some(Some(map)) = robot.pair_maps.get(pi)
        {
            near &= !map.clear_lanes(q, margin, near);
        }
        if near == 0 {
            continue;
        }
        ensure_centers(robot, a, scratch);
        ensure_centers(robot, b, scratch);
        let mut spheres_hit = 0u32;
        for i in ba.first..ba.first + ba.count {
            // Each sphere of `a` against the bounding sphere of `b` first.
            let p = scratch.centers[i];
            let ri = L::splat(robot.radii[i]) + m;
            let d = [p[0] - cb[0], p[1] - cb[1], p[2] - cb[2]];
            let rb = ri + L::splat(bb.bound.1);
            let near_i =
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(rb * rb) & near & !spheres_hit;
            if near_i == 0 {
                continue;
            }
            for j in bb.first..bb.first + bb.count {
                let q = scratch.centers[j];
                let d = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
                let rr = ri + L::splat(robot.radii[j]);
                spheres_hit |= (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(rr * rr) & near_i;
            }
        }
        // Spheres overlap: the links' exact geometry decides. Its cheap
        // steps now; lanes that need GJK wait until every other pair had
        // its chance to find them colliding.
        hit |= match (&robot.exact[a], &robot.exact[b]) {
            (Some(ea), Some(eb)) if spheres_hit != 0 => {
                let (fa, fb) = (&scratch.frames[ba.frame], &scratch.frames[bb.frame]);
                let (sure, open) = crate::exact::confirm_cheap(ea, eb, fa, fb, spheres_hit, margin);
                if open != 0 {
                    scratch.deferred.push((pi, open));
                }
                sure
            }
            _ => spheres_hit,
        };
        if hit & active == active {
            scratch.deferred.clear();
            return hit & active;
        }
    }
    for k in 0..scratch.deferred.len() {
        let (pi, open) = scratch.deferred[k];
        let lanes = open & active & !hit;
        if lanes == 0 {
            continue;
        }
        let (a, b) = robot.pairs[pi];
        let (Some(ea), Some(eb)) = (&robot.exact[a], &robot.exact[b]) else {
            continue;
        };
        let (fa, fb) = (
            &scratch.frames[robot.bodies[a].frame],
            &scratch.frames[robot.bodies[b].frame],
        );
        hit |= crate::exact::confirm(ea, eb, fa, fb, lanes, margin);
        if hit & active == active {
            break;
        }
    }
    scratch.deferred.clear();
    hit & active
}

/// One body against one obstacle: bounding sphere against the exact
/// primitive (its own bounding sphere for meshes and clouds; large flat
/// obstacles such as tables have bounding spheres that cover the workspace),
/// then the body's spheres. Sets the colliding lanes in `hit`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn world_pair<L: Lanes>(
    robot: &CompiledRobot,
    body: &crate::compiled::Body,
    bi: usize,
    bc: &[L; 3],
    obs: &crate::compiled::Obstacle,
    m: L,
    active: u32,
    hit: &mut u32,
    scratch: &mut Scratch<L>,
) {
    let mut near = if L::WIDTH == 1 {
        // Already established by the eight-wide bound test.
        active & !*hit
    } else {
        let reach = L::splat(body.bound.1 + obs.bound_r) + m;
        dist2(bc, &obs.bound_c).lt_mask(reach * reach) & active & !*hit
    };
    if near != 0 && obs.complex.is_none() {
        near &= sphere_hits_prim(&obs.prim, bc, L::splat(body.bound.1) + m);
    }
    if near == 0 {
        return;
    }
    ensure_centers(robot, bi, scratch);
    for k in body.first..body.first + body.count {
        let c = scratch.centers[k];
        let r = L::splat(robot.radii[k]) + m;
        let h = if let Some((shape, pose)) = &obs.complex {
            complex_hits(shape, pose, &c, r, near & !*hit)
        } else {
            sphere_hits_prim(&obs.prim, &c, r) & near
        };
        *hit |= h;
        if *hit & active == active {
            return;
        }
        // Lanes that hit need no more of this body's spheres.
        near &= !h;
        if near == 0 {
            return;
        }
    }
}

#[inline(always)]
fn ensure_centers<L: Lanes>(robot: &CompiledRobot, body: usize, scratch: &mut Scratch<L>) {
    if scratch.done[body] {
        return;
    }
    let b = &robot.bodies[body];
    let frame = &scratch.frames[b.frame];
    for k in b.first..b.first + b.count {
        scratch.centers[k] = apply(frame, &robot.centers[k]);
    }
    scratch.done[body] = true;
}

pub(crate) fn complex_hits<L: Lanes>(
    shape: &ferrobot_geometry::Shape,
    pose: &nalgebra::Isometry3<f64>,
    c: &[L; 3],
    r: L,
    lanes: u32,
) -> u32 {
    let mut out = 0;
    for i in 0..L::WIDTH {
        if lanes & (1 << i) == 0 {
            continue;
        }
        let p = Point3::new(
            c[0].lane(i) as f64,
            c[1].lane(i) as f64,
            c[2].lane(i) as f64,
        );
        let (d, _) = shape.signed_distance(&pose.inverse_transform_point(&p));
        if d < r.lane(i) as f64 {
            out |= 1 << i;
        }
    }
    out
}
