//! Candidate hands: a search in the local frame of a seed point over
//! approach rotations, with a finger-slot search and deepening (GPD's
//! scheme), each hand checked for collision and scored.
//!
//! At a seed with outward normal n and dominant tangent t, the approach
//! starts as -n; the closing axis is t turned about the approach by
//! k·π/`num_rotations` (k = 0..num_rotations; y and -y give the same hand),
//! and the approach is tilted about the closing axis by each of
//! `approach_tilts`. For each orientation the fingertip depths are tried
//! deepest first: the points in the finger slot form a connected interval
//! along y around the seed (binned at half the width of a finger plus its
//! clearance on both sides: a run of occupied bins is one interval); the
//! fingers are centred on that interval and opened to its extent plus
//! clearance; the first depth whose opening fits and whose hand (grown by a
//! voxel margin) is free of points and above the support plane wins.

use nalgebra::{Matrix3, Point3, Vector3};

use crate::grasp::Grasp;
use crate::gripper::{GripperGeometry, Region};
use crate::normals::SurfaceCloud;
use crate::plane::Plane;
use crate::quality::{contact_from_profile, friction_needed, lever_arm, score, torque_factor};

/// Parameters of the hand search.
#[derive(Debug, Clone)]
pub struct SearchParams {
    /// Gripper geometry.
    pub gripper: GripperGeometry,
    /// Fingertip depths beyond the seed to try, metres.
    pub depths: Vec<f64>,
    /// Number of closing-axis rotations about the approach over a half turn.
    pub num_rotations: usize,
    /// Tilts of the approach about the closing axis, radians.
    pub approach_tilts: Vec<f64>,
    /// Voxel size of the cloud (points are voxel centroids).
    pub voxel_size: f64,
    /// Friction coefficient of the fingers.
    pub friction: f64,
    /// Preferred approach direction (unit).
    pub approach_direction: Vector3<f64>,
    /// A support plane whose far side is solid, if any.
    pub plane: Option<Plane>,
    /// Estimated centre of mass per object label (see [`crate::mass`]).
    pub mass_centres: Vec<(i32, Point3<f64>)>,
    /// Lever arm of the weight about the grasp axis at which the score
    /// halves ([`torque_factor`]); 0 disables the term.
    pub torque_scale: f64,
}

/// How far (m) a hand corner may dip below the support plane.
const PLANE_TOLERANCE: f64 = 0.001;

/// Fewest (x, z) cells of a finger pad the object must reach.
const MIN_CONTACT_CELLS: usize = 4;

/// How much the hand's solid parts are grown for collision: points are
/// voxel centroids, up to about half a voxel and more from the surface.
fn margin(sp: &SearchParams) -> f64 {
    0.75 * sp.voxel_size
}

/// All scored collision-free hands at `seed` (score > 0 only).
pub fn hands_at_seed(cloud: &SurfaceCloud, seed: usize, sp: &SearchParams) -> Vec<Grasp> {
    let p = cloud.points[seed];
    let a0 = -cloud.normal(seed);
    let t0 = cloud.tangent(seed);
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
    let dmin = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
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
    for &i in &nb {
        let d = cloud.points[i] - p;
        let (x, y, z) = (d.dot(&a0), d.dot(&t0), d.dot(&b0));
        if x >= sx_lo && x <= sx_hi && y * y + z * z <= r2_max {
            sx.push(x);
            sy.push(y);
            sz.push(z);
        }
    }
    let n = sx.len();
    let mut out = Vec::new();
    let mut local: Vec<Vector3<f64>> = Vec::with_capacity(n);
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
            let mut kept = 0;
            for i in 0..n {
                let lz = st * sx[i] + ct * kz[i];
                let lx = ct * sx[i] - st * kz[i];
                local[kept] = Vector3::new(lx, ky[i], lz);
                let inside =
                    (lz.abs() <= half_h) & (lx >= x_lo) & (lx <= x_hi) & (ky[i].abs() <= y_max);
                kept += usize::from(inside);
            }
            local.truncate(kept);
            let r = Matrix3::from_columns(&[a, y, z]);
            if let Some(g) = evaluate(cloud, &p, &r, &local, &mut slot, seed, sp) {
                out.push(g);
            }
        }
    }
    out
}

/// The first (deepest) collision-free hand of orientation `r` at `p`;
/// `local` holds the points in the hand frame with |z| <= height / 2.
/// `slot` is scratch space reused across hands.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    local: &[Vector3<f64>],
    slot: &mut Vec<(f64, f64)>,
    seed: usize,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let m = margin(sp);
    let pad = g.clearance + m;
    let gap_max = g.finger_width + 2.0 * pad;
    // Points that can be in a finger slot at some depth.
    let (dmin, dmax) = sp
        .depths
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| {
            (a.min(d), b.max(d))
        });
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
        // Slot points lie within [edges[0], edges[strips]].
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
    for &depth in &sp.depths {
        let base = depth - g.finger_depth;
        lo_y.fill(f64::INFINITY);
        hi_y.fill(f64::NEG_INFINITY);
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
        return score_hand(cloud, p, r, local, seed, depth, width, yc, sp);
    }
    None
}

#[allow(clippy::too_many_arguments)]
fn score_hand(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    local: &[Vector3<f64>],
    seed: usize,
    depth: f64,
    width: f64,
    yc: f64,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let m = margin(sp);
    let mut inside: Vec<Vector3<f64>> = Vec::new();
    for q in local {
        if g.region(q, depth, width, yc, m) == Region::Closing {
            inside.push(*q);
        }
    }
    let left = contact_from_profile(&inside, -1.0, sp.voxel_size)?;
    let right = contact_from_profile(&inside, 1.0, sp.voxel_size)?;
    // Enough of each finger pad must touch the object (not a tip).
    if left.cells.min(right.cells) < MIN_CONTACT_CELLS {
        return None;
    }
    let mu = friction_needed(&left, &right);
    let full = (g.height / sp.voxel_size).max(1.0);
    let support = left.cells.min(right.cells) as f64 / full;
    let approach = r.column(0).into_owned();
    // The weight's torque about the closing axis through the contacts'
    // midpoint (gravity against the support plane's normal when known).
    let label = cloud.labels[seed];
    let torque = match sp.mass_centres.iter().find(|(l, _)| *l == label) {
        Some((_, com)) if sp.torque_scale > 0.0 => {
            let centre = p.coords + r * ((left.point + right.point) / 2.0);
            let up = sp.plane.as_ref().map(|pl| pl.normal);
            let arm = lever_arm(&com.coords, &centre, &r.column(1).into_owned(), up.as_ref());
            torque_factor(arm, sp.torque_scale)
        }
        _ => 1.0,
    };
    let s = torque
        * score(
            mu,
            sp.friction,
            support,
            approach.dot(&sp.approach_direction),
        );
    if s <= 0.0 {
        return None;
    }
    Some(Grasp {
        score: s,
        width,
        height: g.height,
        depth,
        rotation: *r,
        translation: (p + r * Vector3::new(0.0, yc, 0.0)).coords,
        object_id: cloud.labels[seed],
    })
}
