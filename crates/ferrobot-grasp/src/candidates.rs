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
use crate::gripper::{GripperGeometry, Region, body_margin};
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
    /// Reject hands whose closing region holds [`MAX_FOREIGN_POINTS`] or
    /// more points labelled as another object than the seed's (labelled
    /// seeds only): such a grasp would lift two objects, or none cleanly.
    pub single_object: bool,
}

/// Fewest points of another labelled object between the fingers that make
/// a hand grasp more than its seed's object ([`SearchParams::single_object`]):
/// a 1 cm² patch at the default 5 mm voxels; single stray points (depth
/// edges, segmentation bleeding) are tolerated.
pub const MAX_FOREIGN_POINTS: usize = 4;

/// Whether a point labelled `other` belongs to another object than a seed
/// labelled `own`: both labels known (>= 0) and different. Label 0 (no
/// object in a segmentation) counts as another object for a seed with a
/// positive label: unsegmented clutter is not the target either.
pub fn is_foreign(own: i32, other: i32) -> bool {
    own > 0 && other >= 0 && other != own
}

/// How far (m) a hand corner may dip below the support plane.
const PLANE_TOLERANCE: f64 = 0.001;

/// Fewest (x, z) cells of a finger pad the object must reach.
const MIN_CONTACT_CELLS: usize = 4;

/// Shallowest plane-limited depth tried (see [`plane_limited_depth`]):
/// fingertips must reach at least this far past the seed.
pub const MIN_PLANE_DEPTH: f64 = 0.005;

/// The shallowest depth a hand of `sp` may take: the smallest fixed depth,
/// or [`MIN_PLANE_DEPTH`] with a support plane.
pub fn shallowest_depth(sp: &SearchParams) -> f64 {
    let d = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
    if sp.plane.is_some() {
        d.min(MIN_PLANE_DEPTH)
    } else {
        d
    }
}

/// The deepest fingertip depth at which no finger corner of a hand at `p`
/// with orientation `r` (fingers anywhere within `reach_y` of the approach
/// axis) goes more than [`PLANE_TOLERANCE`] below `plane`; None when the
/// approach does not head towards the plane.
fn plane_limited_depth(
    plane: &Plane,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    g: &GripperGeometry,
    reach_y: f64,
) -> Option<f64> {
    let a = r.column(0).dot(&plane.normal);
    if a >= -1e-6 {
        return None;
    }
    let (y, z) = (
        r.column(1).dot(&plane.normal),
        r.column(2).dot(&plane.normal),
    );
    // Lowest corner of the fingertips at depth 0: distance + depth·a.
    let lowest = plane.distance(p) - (y * reach_y).abs() - (z * g.height / 2.0).abs();
    Some((lowest + 0.5 * PLANE_TOLERANCE) / -a)
}

/// How much the hand's solid parts are grown for collision: points are
/// voxel centroids, up to about half a voxel and more from the surface.
fn margin(sp: &SearchParams) -> f64 {
    body_margin(sp.voxel_size)
}

/// All scored collision-free hands at `seed` (score > 0 only).
pub fn hands_at_seed(cloud: &SurfaceCloud, seed: usize, sp: &SearchParams) -> Vec<Grasp> {
    hands_in_frame(cloud, seed, -cloud.normal(seed), cloud.tangent(seed), sp)
}

/// [`hands_at_seed`] in a given seed frame: approach `a0` and closing axis
/// `t0` (unit, perpendicular) instead of the seed's inward normal and
/// tangent, turned by `sp.num_rotations` about `a0` and tilted by
/// `sp.approach_tilts` about the closing axis as there.
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
    let plane_depth = sp
        .plane
        .as_ref()
        .and_then(|pl| plane_limited_depth(pl, p, r, g, reach_y))
        .filter(|&d| d >= MIN_PLANE_DEPTH && d < shallowest);
    for (k, depth) in sp.depths.iter().copied().chain(plane_depth).enumerate() {
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
        return score_hand(cloud, p, r, local, seed, depth, width, yc, sp);
    }
    None
}

/// The hand body's box in the grasp frame of `g` (see
/// [`GripperGeometry::body_box`]) swept back by the approach distance (the
/// hand comes from there) and grown by `margin`, as (min, max) corners.
pub fn body_sweep_box(
    gripper: &GripperGeometry,
    depth: f64,
    margin: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let (mut lo, hi) = gripper.body_box(depth, 0.0);
    lo.x -= gripper.approach_distance;
    (lo.add_scalar(-margin), hi.add_scalar(margin))
}

/// Whether any obstacle point of `cloud` (observed above the support plane
/// or hidden, see [`SurfaceCloud::within`]) lies inside the hand body of
/// grasp `g` swept back along the approach ([`body_sweep_box`]). The
/// fingers, palm and approach corridor are checked during the search; this
/// is the housing behind them, against the whole cloud (neighbouring
/// objects and bin walls included).
pub fn body_collides(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    g: &Grasp,
    gripper: &GripperGeometry,
    margin: f64,
) -> bool {
    let (lo, hi) = body_sweep_box(gripper, g.depth, margin);
    let centre = (lo + hi) / 2.0;
    let radius = ((hi - lo) / 2.0).norm();
    let c = Point3::from(g.translation + g.rotation * centre);
    let rt = g.rotation.transpose();
    let inside = |p: &Point3<f64>| {
        let q = rt * (p.coords - g.translation);
        (0..3).all(|k| q[k] >= lo[k] && q[k] <= hi[k])
    };
    cloud
        .within(&c, radius)
        .into_iter()
        .any(|i| inside(&cloud.points[i]))
        || extra.is_some_and(|o| o.within(&c, radius).any(inside))
}

/// Obstacle points beyond the hand search's crop that only the housing
/// can reach (observed points above the support plane), with a kd-tree.
#[derive(Debug)]
pub struct Obstacles {
    points: Vec<Point3<f64>>,
    tree: kiddo::KdTree<f64, 3>,
}

impl Obstacles {
    /// Indexes `points`.
    pub fn new(points: Vec<Point3<f64>>) -> Self {
        let mut tree: kiddo::KdTree<f64, 3> = kiddo::KdTree::with_capacity(points.len().max(1));
        for (i, p) in points.iter().enumerate() {
            tree.add(&[p.x, p.y, p.z], i as u64);
        }
        Self { points, tree }
    }

    /// The points within `r` of `p`.
    pub fn within(&self, p: &Point3<f64>, r: f64) -> impl Iterator<Item = &Point3<f64>> {
        self.tree
            .within_unsorted::<kiddo::SquaredEuclidean>(&[p.x, p.y, p.z], r * r)
            .into_iter()
            .map(|n| &self.points[n.item as usize])
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Plane {
        Plane {
            normal: Vector3::z(),
            offset: 0.0,
        }
    }

    #[test]
    fn plane_limited_depth_straight_down() {
        // Seed on top of a 1 cm tall piece, hand pointing straight down
        // (x = -z, y = +x, z = x × y = -y): the corners are as low as the
        // fingertips, so the depth is the seed's height plus half the
        // tolerance.
        let r = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), -Vector3::y()]);
        let g = GripperGeometry::default();
        let d = plane_limited_depth(&table(), &Point3::new(0.0, 0.0, 0.01), &r, &g, 0.09).unwrap();
        assert!((d - (0.01 + 0.5 * PLANE_TOLERANCE)).abs() < 1e-12, "{d}");
        // Pointing up or sideways: no limit.
        let up = Matrix3::from_columns(&[Vector3::z(), Vector3::x(), Vector3::y()]);
        assert!(
            plane_limited_depth(&table(), &Point3::new(0.0, 0.0, 0.01), &up, &g, 0.09).is_none()
        );
    }

    #[test]
    fn plane_limited_depth_tilted() {
        // Approach tilted by t from straight down about the world y axis:
        // the closing axis y stays horizontal, the fingers' z half-height
        // h/2 drops by sin t; the fingertips descend cos t per unit depth.
        let t: f64 = 0.4;
        let a = Vector3::new(t.sin(), 0.0, -t.cos());
        let y = Vector3::y();
        let r = Matrix3::from_columns(&[a, y, a.cross(&y)]);
        let g = GripperGeometry::default();
        let h = 0.012;
        let d = plane_limited_depth(&table(), &Point3::new(0.0, 0.0, h), &r, &g, 0.09).unwrap();
        let expect = (h - g.height / 2.0 * t.sin() + 0.5 * PLANE_TOLERANCE) / t.cos();
        assert!((d - expect).abs() < 1e-12, "{d} vs {expect}");
        // Every finger corner at that depth is within the tolerance.
        for sy in [-0.09, 0.09] {
            for sz in [-g.height / 2.0, g.height / 2.0] {
                let c = Point3::new(0.0, 0.0, h) + r * Vector3::new(d, sy, sz);
                assert!(c.z >= -PLANE_TOLERANCE, "{c:?}");
            }
        }
    }

    #[test]
    fn body_collision_against_points_in_and_out_of_the_housing() {
        // A grasp at the origin pointing down (-z), closing along x: the
        // housing spans x in ±palm_width/2, y in ±palm_height/2 and z from
        // the fingers' base (depth - finger_depth above the origin, as
        // approach is -z) up by palm_depth + approach_distance.
        let g = GripperGeometry::default();
        let r = Matrix3::from_columns(&[-Vector3::z(), Vector3::x(), -Vector3::y()]);
        let grasp = Grasp {
            score: 1.0,
            width: 0.05,
            height: g.height,
            depth: 0.03,
            rotation: r,
            translation: Vector3::zeros(),
            object_id: -1,
        };
        let base_z = g.finger_depth - 0.03; // 2 cm above the origin
        let top_z = base_z + g.palm_depth + g.approach_distance;
        let m = 0.001;
        let cases = [
            (Point3::new(0.1, 0.03, base_z + 0.05), true),
            (Point3::new(0.0, 0.0, top_z - 0.002), true),
            (Point3::new(0.0, 0.0, top_z + 0.002), false),
            (Point3::new(0.106, 0.0, base_z + 0.01), false),
            (Point3::new(0.0, 0.0333, base_z + 0.01), false),
            (Point3::new(0.0, 0.0, base_z - 0.002), false),
        ];
        for (pt, expect) in cases {
            let cloud = SurfaceCloud::new(
                vec![pt, Point3::new(1.0, 1.0, 1.0)],
                vec![-1, -1],
                0.01,
                Point3::new(0.0, 0.0, 1.0),
            )
            .unwrap();
            assert_eq!(body_collides(&cloud, None, &grasp, &g, m), expect, "{pt:?}");
            let far = SurfaceCloud::new(
                vec![Point3::new(1.0, 1.0, 1.0)],
                vec![-1],
                0.01,
                Point3::new(0.0, 0.0, 1.0),
            )
            .unwrap();
            let extra = Obstacles::new(vec![pt]);
            assert_eq!(
                body_collides(&far, Some(&extra), &grasp, &g, m),
                expect,
                "{pt:?} (extra)"
            );
        }
    }

    #[test]
    fn foreign_labels() {
        assert!(is_foreign(1, 2));
        assert!(is_foreign(1, 0));
        assert!(!is_foreign(1, 1));
        assert!(!is_foreign(1, -1));
        assert!(!is_foreign(-1, 2));
        assert!(!is_foreign(0, 2));
    }
}
