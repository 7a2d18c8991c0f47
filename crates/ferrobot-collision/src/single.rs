//! The single-configuration kernel: one configuration, SIMD lanes over
//! spheres and bodies.
//!
//! The batch kernel ([`crate::kernel::check`]) puts eight configurations in
//! the lanes, which leaves seven lanes idle when a planner asks about one
//! configuration. Here the forward kinematics runs on `f32x4` columns
//! ([`crate::kernel::forward_cols`], bit-identical to the batch kernel's
//! frames), the bodies' bounding spheres are looked up in the world grid
//! and tested pair against pair eight at a time
//! ([`crate::body_centres`], [`crate::pair_bounds`]), and each body's
//! spheres are tested eight at a time ([`crate::compiled::SpherePack`]).
//! Every per-sphere test is the same sequence of `f32` operations as in the
//! batch kernel, so the two answer identically.

use wide::{f32x4, f32x8};

use crate::body_centres::BodyCentres;
use crate::compiled::{CompiledRobot, CompiledWorld};
use crate::kernel::{
    Cols, apply_cols, cols_to_frame, complex_hits, forward_cols, sphere_hits_prim,
};
use crate::lanes::Lanes;
use crate::pair_bounds::PairBounds;
use crate::world_grid::{SLACK, WorldGrid};

/// Buffers of [`check_one`] (one per thread), and the robot's self pairs
/// batched for it.
#[derive(Debug, Clone)]
pub struct OneScratch {
    frames: Vec<Cols>,
    bounds: BodyCentres,
    /// Bounding radii, eight bodies per chunk (padding 0).
    bound_r: Vec<f32x8>,
    /// Per chunk of eight bodies: the bodies (bit per lane), and those not
    /// fixed to the base.
    in_chunk: Vec<(u32, u32)>,
    pair_bounds: PairBounds,
    packs: Vec<[f32x8; 3]>,
    done: Vec<bool>,
    /// Self pairs left to the exact stage's GJK, decided after every
    /// cheaper test of the check.
    deferred: Vec<usize>,
}

impl OneScratch {
    /// Buffers sized for `robot`.
    pub fn new(robot: &CompiledRobot) -> Self {
        let n = robot.bodies.len();
        Self {
            frames: vec![[f32x4::splat(0.0); 4]; robot.num_frames()],
            bounds: BodyCentres::new(n),
            bound_r: (0..n.div_ceil(8))
                .map(|c| {
                    f32x8::new(std::array::from_fn(|i| {
                        robot.bodies.get(c * 8 + i).map_or(0.0, |b| b.bound.1)
                    }))
                })
                .collect(),
            in_chunk: robot
                .bodies
                .chunks(8)
                .map(|c| {
                    let bits = |f: &dyn Fn(&crate::compiled::Body) -> bool| {
                        c.iter()
                            .enumerate()
                            .filter(|(_, b)| f(b))
                            .fold(0u32, |m, (i, _)| m | 1 << i)
                    };
                    (bits(&|_| true), bits(&|b| b.frame != 0))
                })
                .collect(),
            pair_bounds: PairBounds::new(&robot.pairs, &robot.pair_reach, n),
            packs: vec![[f32x8::splat(0.0); 3]; robot.packs.len()],
            done: vec![false; n],
            deferred: Vec::with_capacity(robot.pairs.len()),
        }
    }
}

/// Pack centres of body `bi` in the base frame, computed on its first use
/// in a check.
#[inline(always)]
fn ensure_packs(
    robot: &CompiledRobot,
    bi: usize,
    frames: &[Cols],
    done: &mut [bool],
    packs: &mut [[f32x8; 3]],
) {
    if done[bi] {
        return;
    }
    let b = &robot.bodies[bi];
    let range = b.first_pack..b.first_pack + b.pack_count;
    let f = cols_to_frame(&frames[b.frame]).map(f32x8::splat);
    for (out, pack) in packs[range.clone()].iter_mut().zip(&robot.packs[range]) {
        let c = pack.c;
        *out = [
            f[0] * c[0] + f[1] * c[1] + f[2] * c[2] + f[9],
            f[3] * c[0] + f[4] * c[1] + f[5] * c[2] + f[10],
            f[6] * c[0] + f[7] * c[1] + f[8] * c[2] + f[11],
        ];
    }
    done[bi] = true;
}

/// Whether body `bi` (bounding-sphere centre `bc`, bounding radius plus
/// margin `reach_body`) touches obstacle `obs`: the body's bounding sphere
/// against the primitive, then its spheres eight at a time.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn body_hits(
    robot: &CompiledRobot,
    bi: usize,
    obs: &crate::compiled::Obstacle,
    bc: &[f32; 3],
    reach_body: f32,
    m8: f32x8,
    frames: &[Cols],
    done: &mut [bool],
    packs: &mut [[f32x8; 3]],
) -> bool {
    if obs.complex.is_none() && sphere_hits_prim(&obs.prim, bc, reach_body) == 0 {
        return false;
    }
    ensure_packs(robot, bi, frames, done, packs);
    let body = &robot.bodies[bi];
    let range = body.first_pack..body.first_pack + body.pack_count;
    for (c, pack) in packs[range.clone()].iter().zip(&robot.packs[range]) {
        let r = pack.r + m8;
        let hit = match &obs.complex {
            Some((shape, pose)) => complex_hits(shape, pose, c, r, 0xff),
            None => sphere_hits_prim(&obs.prim, c, r),
        };
        if hit != 0 {
            return true;
        }
    }
    false
}

/// Whether configuration `q` (`f32`, model DOF order) touches the world or
/// itself. With `skip_static`, bodies fixed to the base are not tested
/// against the world (the caller knows their answer). `grid`, made for this
/// robot and world, lets bodies far from every obstacle skip the obstacle
/// tests (see [`crate::world_grid`]). Inlined into the
/// [`crate::dispatch`] entry points.
#[inline(always)]
pub fn check_one(
    robot: &CompiledRobot,
    world: &CompiledWorld,
    grid: Option<&WorldGrid>,
    q: &[f32],
    margin: f32,
    skip_static: bool,
    s: &mut OneScratch,
) -> bool {
    let OneScratch {
        frames,
        bounds,
        bound_r,
        in_chunk,
        pair_bounds,
        packs,
        done,
        deferred,
    } = s;
    // Pairs two joints apart (the hand against link 5) that certainly
    // collide here: one lookup per pair of joints, before anything else.
    if robot.collide_maps.iter().any(|m| m.collides(q, margin)) {
        return true;
    }
    forward_cols(robot, q, frames);
    done.fill(false);
    deferred.clear();
    let bodies = &robot.bodies;
    bounds.set_all(bodies.len(), |i| {
        apply_cols(&frames[bodies[i].frame], &bodies[i].bound.0)
    });
    let m8 = f32x8::splat(margin);
    let num_obstacles = world.obstacles.len();
    // Distal bodies first: they collide most often.
    for (chunk, ((centres, r), &(all, moving))) in bounds
        .chunks()
        .iter()
        .zip(bound_r.iter())
        .zip(in_chunk.iter())
        .enumerate()
        .rev()
    {
        // No obstacles: no body has anything to test against.
        let mut todo = match (num_obstacles, skip_static) {
            (0, _) => 0,
            (_, true) => moving,
            (_, false) => all,
        };
        // Most bodies are far from everything: one grid lookup shows it.
        if let Some(g) = grid {
            let reach = (*r + m8) + f32x8::splat(SLACK);
            todo &= !g.clear_lanes(world, centres, reach, todo);
        }
        while todo != 0 {
            let lane = 31 - todo.leading_zeros() as usize;
            todo &= !(1 << lane);
            let bi = chunk * 8 + lane;
            let body = &robot.bodies[bi];
            let bc = bounds.get(bi);
            let (x, y, z) = (
                f32x8::splat(bc[0]),
                f32x8::splat(bc[1]),
                f32x8::splat(bc[2]),
            );
            let rb = f32x8::splat(body.bound.1);
            let reach_body = body.bound.1 + margin;
            // The obstacles near the body's cell, nearest first, when the
            // grid's lists cover this body; else every obstacle.
            let list = grid.filter(|g| reach_body <= g.list_reach()).and_then(|g| {
                g.list_cell_centre(&bc).map(|(c, centre)| {
                    (
                        g.candidates(world, c),
                        WorldGrid::list_limit_at(&centre, &bc, reach_body),
                    )
                })
            });
            if let Some((list, limit)) = list {
                let rb1 = body.bound.1;
                for cand in list {
                    // Nearest first: the rest are out of the body's reach.
                    if cand.distance > limit {
                        break;
                    }
                    let obs = &world.obstacles[cand.obstacle as usize];
                    // The same bound test as the eight-wide one below.
                    let (dx, dy, dz) = (
                        bc[0] - obs.bound_c[0],
                        bc[1] - obs.bound_c[1],
                        bc[2] - obs.bound_c[2],
                    );
                    let reach = (rb1 + obs.bound_r) + margin;
                    if dx * dx + dy * dy + dz * dz >= reach * reach {
                        continue;
                    }
                    if body_hits(robot, bi, obs, &bc, reach_body, m8, frames, done, packs) {
                        return true;
                    }
                }
                continue;
            }
            for (ci, chunk) in world.bound_soa.iter().enumerate() {
                // The body's bounding sphere against eight obstacle bounds.
                let (dx, dy, dz) = (x - chunk[0], y - chunk[1], z - chunk[2]);
                let reach = (rb + chunk[3]) + m8;
                let valid = (num_obstacles - ci * 8).min(8);
                let mut bits =
                    (dx * dx + dy * dy + dz * dz).lt_mask(reach * reach) & ((1u32 << valid) - 1);
                while bits != 0 {
                    let obs = &world.obstacles[ci * 8 + bits.trailing_zeros() as usize];
                    bits &= bits - 1;
                    if body_hits(robot, bi, obs, &bc, reach_body, m8, frames, done, packs) {
                        return true;
                    }
                }
            }
        }
    }
    for pi in pair_bounds.near(bounds, margin) {
        // Bounds overlap: a clearance map may still vouch for the pair.
        if let Some(Some(map)) = robot.pair_maps.get(pi)
            && map.clear(q, margin)
        {
            continue;
        }
        let (a, b) = robot.pairs[pi];
        let pair = pi;
        let cb = bounds.get(b);
        let (ba, bb) = (&robot.bodies[a], &robot.bodies[b]);
        ensure_packs(robot, a, frames, done, packs);
        ensure_packs(robot, b, frames, done, packs);
        let cb8 = cb.map(f32x8::splat);
        let rb = f32x8::splat(bb.bound.1);
        let exact = (&robot.exact[a], &robot.exact[b]);
        'pair: for ka in ba.first_pack..ba.first_pack + ba.pack_count {
            // Eight spheres of `a` against the bounding sphere of `b`.
            let p = &packs[ka];
            let ri = robot.packs[ka].r + m8;
            let d = [p[0] - cb8[0], p[1] - cb8[1], p[2] - cb8[2]];
            let reach = ri + rb;
            let mut near = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(reach * reach);
            while near != 0 {
                let lane = near.trailing_zeros() as usize;
                near &= near - 1;
                // Lanes read from memory, not from a copy of the packs
                // spilled to the stack (see `BodyCentres::get`); the same
                // sum as `ri`'s lane.
                let pi = [
                    p[0].as_array()[lane],
                    p[1].as_array()[lane],
                    p[2].as_array()[lane],
                ]
                .map(f32x8::splat);
                let ri = f32x8::splat(robot.packs[ka].r.as_array()[lane] + margin);
                let range_b = bb.first_pack..bb.first_pack + bb.pack_count;
                for (pb, pack_b) in packs[range_b.clone()].iter().zip(&robot.packs[range_b]) {
                    let d = [pi[0] - pb[0], pi[1] - pb[1], pi[2] - pb[2]];
                    let rr = ri + pack_b.r;
                    if (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).lt_mask(rr * rr) != 0 {
                        // Spheres overlap: the links' exact geometry decides.
                        // Its cheap steps now; GJK waits until every
                        // other pair had its chance to find a collision.
                        match exact {
                            (Some(ea), Some(eb)) => {
                                let (fa, fb) = (
                                    cols_to_frame(&frames[ba.frame]),
                                    cols_to_frame(&frames[bb.frame]),
                                );
                                let (sure, open) =
                                    crate::exact::confirm_cheap(ea, eb, &fa, &fb, 1, margin);
                                if sure != 0 {
                                    return true;
                                }
                                if open != 0 {
                                    deferred.push(pair);
                                }
                                break 'pair;
                            }
                            _ => return true,
                        }
                    }
                }
            }
        }
    }
    deferred.iter().any(|&pi| {
        let (a, b) = robot.pairs[pi];
        let (ba, bb) = (&robot.bodies[a], &robot.bodies[b]);
        match (&robot.exact[a], &robot.exact[b]) {
            (Some(ea), Some(eb)) => {
                let (fa, fb) = (
                    cols_to_frame(&frames[ba.frame]),
                    cols_to_frame(&frames[bb.frame]),
                );
                crate::exact::confirm(ea, eb, &fa, &fb, 1, margin) != 0
            }
            _ => true,
        }
    })
}
