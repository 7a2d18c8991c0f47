//! The hand search as it was before the per-seed scratch buffers and the
//! fused slot compaction: every hand's points compacted from the whole
//! neighbourhood, scratch allocated per hand. Kept (tests only) as the
//! exhaustive reference the optimised search must reproduce bit for bit.

use nalgebra::{Matrix3, Point3, Vector3};

use super::{
    MAX_FOREIGN_POINTS, PLANE_TOLERANCE, SearchParams, engagement_factor, engages_fully,
    is_foreign, margin, pad_engagement, plane_depths, score_hand, shallowest_depth,
    tips_below_mid_height,
};
use crate::grasp::Grasp;
use crate::gripper::Region;
use crate::normals::SurfaceCloud;

/// All scored collision-free hands at `seed` (score > 0 only).
pub fn hands_at_seed(cloud: &SurfaceCloud, seed: usize, sp: &SearchParams) -> Vec<Grasp> {
    hands_in_frame(cloud, seed, -cloud.normal(seed), cloud.tangent(seed), sp)
}

/// [`hands_at_seed`] with approach `a0` and closing axis `t0` in place of
/// the seed's inward normal and tangent.
pub fn hands_in_frame(
    cloud: &SurfaceCloud,
    seed: usize,
    a0: Vector3<f64>,
    t0: Vector3<f64>,
    sp: &SearchParams,
) -> Vec<Grasp> {
    let p = cloud.points[seed];
    let b0 = a0.cross(&t0);
    let max_depth = sp.depths.iter().copied().fold(0.0, f64::max);
    let nb = cloud.within(&p, sp.gripper.reach(max_depth));
    let g = &sp.gripper;
    let m = margin(sp);
    let half_h = g.height / 2.0 + m;
    // Points outside this slab of the hand frame are Free for every hand
    // evaluated here (behind the approach corridor, beyond the deepest
    // fingertips, or further along y than any opening and centring reach):
    // dropping them changes nothing but the work.
    let dmin = shallowest_depth(sp);
    let x_lo = dmin - g.finger_depth - g.finger_width - g.approach_distance - m;
    let x_hi = max_depth + m;
    let y_max = g.max_width + g.finger_width + m;
    // The same slab in the seed frame, over every tilt t (the hand frame is
    // the seed frame turned by t about y): a = cos t·x' + sin t·z' and
    // |z'| <= half_h bound the seed-frame x; y and the rotated z bound the
    // distance from the seed's approach axis.
    let (mut cmin, mut smax) = (1.0f64, 0.0f64);
    for &t in &sp.approach_tilts {
        cmin = cmin.min(t.cos());
        smax = smax.max(t.sin().abs());
    }
    let sx_lo = x_lo.min(cmin * x_lo) - smax * half_h;
    let sx_hi = x_hi.max(cmin * x_hi) + smax * half_h;
    let kz_max = (half_h + smax * sx_lo.abs().max(sx_hi.abs())) / cmin;
    let r2_max = y_max * y_max + kz_max * kz_max;
    // Neighbours in the seed frame (a0, t0, b0), one array per axis.
    let n = nb.len();
    let (mut sx, mut sy, mut sz) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let own = cloud.labels[seed];
    let mut sf: Vec<bool> = Vec::with_capacity(n);
    for &i in &nb {
        let d = cloud.points[i] - p;
        let (x, y, z) = (d.dot(&a0), d.dot(&t0), d.dot(&b0));
        if x >= sx_lo && x <= sx_hi && y * y + z * z <= r2_max {
            sx.push(x);
            sy.push(y);
            sz.push(z);
            sf.push(is_foreign(own, cloud.labels[i]));
        }
    }
    let n = sx.len();
    let mut out = Vec::new();
    let mut local: Vec<Vector3<f64>> = Vec::with_capacity(n);
    let mut foreign: Vec<bool> = Vec::with_capacity(n);
    let mut slot: Vec<(f64, f64)> = Vec::with_capacity(n);
    let (mut ky, mut kz) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..sp.num_rotations {
        // Closing axis y = t0 turned by phi about a0; z = a0 × y.
        let phi = k as f64 * std::f64::consts::PI / sp.num_rotations as f64;
        let (s, c) = phi.sin_cos();
        let y = t0 * c + b0 * s;
        let z0 = b0 * c - t0 * s;
        for i in 0..n {
            ky[i] = c * sy[i] + s * sz[i];
            kz[i] = -s * sy[i] + c * sz[i];
        }
        for &tilt in &sp.approach_tilts {
            // Approach a0 turned by tilt about y: a = cos·a0 - sin·z0, z = sin·a0 + cos·z0.
            let (st, ct) = tilt.sin_cos();
            let a = a0 * ct - z0 * st;
            let z = a0 * st + z0 * ct;
            // Branch-free compaction: every point is written, and the
            // count only advances past the ones inside the slab.
            local.resize(n, Vector3::zeros());
            foreign.resize(n, false);
            let mut kept = 0;
            for i in 0..n {
                let lz = st * sx[i] + ct * kz[i];
                let lx = ct * sx[i] - st * kz[i];
                local[kept] = Vector3::new(lx, ky[i], lz);
                foreign[kept] = sf[i];
                let inside =
                    (lz.abs() <= half_h) & (lx >= x_lo) & (lx <= x_hi) & (ky[i].abs() <= y_max);
                kept += usize::from(inside);
            }
            local.truncate(kept);
            foreign.truncate(kept);
            let r = Matrix3::from_columns(&[a, y, z]);
            if let Some(g) = evaluate(cloud, &p, &r, &local, &foreign, &mut slot, seed, sp) {
                out.push(g);
            }
        }
    }
    out
}

/// The first (deepest) collision-free hand of orientation `r` at `p`;
/// `local` holds the points in the hand frame with |z| <= height / 2, and
/// `foreign` whether each belongs to another object than the seed's.
/// `slot` is scratch space reused across hands.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    local: &[Vector3<f64>],
    foreign: &[bool],
    slot: &mut Vec<(f64, f64)>,
    seed: usize,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let m = margin(sp);
    let pad = g.clearance + m;
    let gap_max = g.finger_width + 2.0 * pad;
    // Points that can be in a finger slot at some depth.
    let dmin = shallowest_depth(sp);
    let dmax = sp.depths.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let reach_y = g.max_width + g.finger_width;
    // Branch-free compaction, as for `local`.
    slot.resize(local.len(), (0.0, 0.0));
    let mut kept = 0;
    for q in local {
        slot[kept] = (q.x, q.y);
        let inside = (q.x >= dmin - g.finger_depth)
            & (q.x <= dmax)
            & (q.z.abs() <= g.height / 2.0)
            & (q.y.abs() <= reach_y);
        kept += usize::from(inside);
    }
    slot.truncate(kept);
    // The object's interval along y around the seed (y = 0): bins of half
    // the largest gap a finger cannot use; a run of occupied bins is one
    // object (an empty bin is a gap a finger may use: collision decides).
    let bin = gap_max / 2.0;
    let nbins = (2.0 * reach_y / bin).ceil() as usize + 1;
    let index = |y: f64| (((y + reach_y) / bin).floor() as usize).min(nbins - 1);
    let centre = index(0.0);
    // Each depth's finger slot is x in [depth - finger_depth, depth]. The
    // slot's points are binned once into strips along x between the
    // windows' ends (`edges`), and each depth merges the strips inside its
    // window; a point exactly on an edge is kept apart and tested per depth.
    let mut edges: Vec<f64> = sp
        .depths
        .iter()
        .flat_map(|&d| [d - g.finger_depth, d])
        .collect();
    edges.sort_by(f64::total_cmp);
    edges.dedup();
    let strips = edges.len() - 1;
    let mut strip_lo = vec![f64::INFINITY; strips * nbins];
    let mut strip_hi = vec![f64::NEG_INFINITY; strips * nbins];
    let mut on_edge: Vec<(f64, f64)> = Vec::new();
    for &(x, y) in slot.iter() {
        // Slot points lie within [edges[0], edges[strips]], or in front of
        // edges[0] for the plane-limited depth only (scanned directly).
        if x < edges[0] {
            continue;
        }
        let Some(j) = (0..strips).find(|&j| x < edges[j + 1]) else {
            on_edge.push((x, y));
            continue;
        };
        if x == edges[j] {
            on_edge.push((x, y));
            continue;
        }
        let k = j * nbins + index(y);
        strip_lo[k] = strip_lo[k].min(y);
        strip_hi[k] = strip_hi[k].max(y);
    }
    let mut lo_y = vec![f64::INFINITY; nbins];
    let mut hi_y = vec![f64::NEG_INFINITY; nbins];
    // The fixed depths, deepest first; then, when the support plane stopped
    // them all, the deepest depth it allows (objects lower than the
    // shallowest fixed depth: thin pieces lying flat, small objects).
    let shallowest = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
    let plane_stage = match &sp.plane {
        Some(pl) => plane_depths(pl, p, r, g, reach_y, shallowest, pad, |depth| {
            let base = depth - g.finger_depth;
            let mut lo_y = vec![f64::INFINITY; nbins];
            let mut hi_y = vec![f64::NEG_INFINITY; nbins];
            for &(x, y) in slot.iter() {
                if x >= base && x <= depth {
                    let k = index(y);
                    lo_y[k] = lo_y[k].min(y);
                    hi_y[k] = hi_y[k].max(y);
                }
            }
            if lo_y[centre] > hi_y[centre] {
                return None;
            }
            let (mut lo, mut hi) = (centre, centre);
            while lo > 0 && lo_y[lo - 1] <= hi_y[lo - 1] {
                lo -= 1;
            }
            while hi + 1 < nbins && lo_y[hi + 1] <= hi_y[hi + 1] {
                hi += 1;
            }
            Some((lo_y[lo], hi_y[hi]))
        }),
        None => [None, None],
    };
    for (k, depth) in sp
        .depths
        .iter()
        .copied()
        .chain(plane_stage.into_iter().flatten())
        .enumerate()
    {
        let base = depth - g.finger_depth;
        lo_y.fill(f64::INFINITY);
        hi_y.fill(f64::NEG_INFINITY);
        if k < sp.depths.len() {
            for j in 0..strips {
                if edges[j] >= base && edges[j + 1] <= depth {
                    let (sl, sh) = (
                        &strip_lo[j * nbins..(j + 1) * nbins],
                        &strip_hi[j * nbins..(j + 1) * nbins],
                    );
                    for k in 0..nbins {
                        lo_y[k] = lo_y[k].min(sl[k]);
                        hi_y[k] = hi_y[k].max(sh[k]);
                    }
                }
            }
            for &(x, y) in &on_edge {
                if x >= base && x <= depth {
                    let k = index(y);
                    lo_y[k] = lo_y[k].min(y);
                    hi_y[k] = hi_y[k].max(y);
                }
            }
        } else {
            for &(x, y) in slot.iter() {
                if x >= base && x <= depth {
                    let k = index(y);
                    lo_y[k] = lo_y[k].min(y);
                    hi_y[k] = hi_y[k].max(y);
                }
            }
        }
        if lo_y[centre] > hi_y[centre] {
            continue;
        }
        let (mut lo, mut hi) = (centre, centre);
        while lo > 0 && lo_y[lo - 1] <= hi_y[lo - 1] {
            lo -= 1;
        }
        while hi + 1 < nbins && lo_y[hi + 1] <= hi_y[hi + 1] {
            hi += 1;
        }
        let (ymin, ymax) = (lo_y[lo], hi_y[hi]);
        let width = ymax - ymin + 2.0 * pad;
        if width > g.max_width {
            continue;
        }
        let yc = (ymin + ymax) / 2.0;
        let (collision, closing) = g.collision_and_closing(local, depth, width, yc, m);
        if collision || closing == 0 {
            continue;
        }
        if let Some(plane) = &sp.plane {
            let [f1, f2, palm] = g.boxes(depth, width, yc);
            let below = [f1, f2, palm, g.body_box(depth, yc)]
                .iter()
                .any(|(lo, hi)| {
                    (0..8).any(|k| {
                        let c = Vector3::new(
                            if k & 1 == 0 { lo.x } else { hi.x },
                            if k & 2 == 0 { lo.y } else { hi.y },
                            if k & 4 == 0 { lo.z } else { hi.z },
                        );
                        plane.distance(&(p + r * c)) < -PLANE_TOLERANCE
                    })
                });
            if below {
                continue;
            }
        }
        if sp.single_object
            && local
                .iter()
                .zip(foreign)
                .filter(|(q, f)| **f && g.region(q, depth, width, yc, m) == Region::Closing)
                .count()
                >= MAX_FOREIGN_POINTS
        {
            continue;
        }
        let inside: Vec<Vector3<f64>> = local
            .iter()
            .filter(|q| g.region(q, depth, width, yc, m) == Region::Closing)
            .copied()
            .collect();
        if k >= sp.depths.len()
            && let Some(plane) = &sp.plane
            && !tips_below_mid_height(plane, p, r, depth, width, yc, &inside)
        {
            continue;
        }
        let engaged = pad_engagement(&inside, depth);
        if k < sp.depths.len() && !engages_fully(g, engaged) {
            continue;
        }
        let factor = engagement_factor(g, engaged);
        return score_hand(cloud, p, r, &inside, seed, depth, width, yc, factor, sp);
    }
    None
}
