//! Approaches chosen for the walls and neighbours around a seed.
//!
//! The hand search ([`crate::candidates::hands_at_seed`]) turns the hand
//! about the seed's inward normal and tilts it a little about the closing
//! axis. Next to a bin wall, in a corner or between tall neighbours none of
//! those hands may leave room for the hand's housing (the body the fingers
//! slide in, [`GripperGeometry::body_box`](crate::gripper::GripperGeometry::body_box), much longer along the closing
//! axis than the fingers), and the object gets no grasp at all although a
//! person would reach it: from above, the housing turned along the wall and
//! leaning away from it.
//!
//! [`clear_approaches`] adds those hands. For each closing axis (the
//! search's `num_rotations` directions over a half turn, perpendicular to
//! the preferred approach direction) it tries the approach along the
//! preferred direction, then tilted about the closing axis (the housing
//! leans across its short side) and about the housing's short axis (it
//! leans along its long side), in the order of [`TILTS`]; the first
//! orientation whose housing, swept back along the approach, holds no
//! observed point of the cloud (nor of the far obstacles) and stays above
//! the support plane at some fingertip depth is returned, with those
//! depths. The hand search then runs on exactly that orientation and
//! those depths ([`crate::candidates::hands_in_frame`]): the fingers are
//! fitted to the object and every check of the search applies, and the
//! housing is checked again, at the depth the search chose, after
//! non-maximum suppression as for every grasp.
//!
//! Only seeds where the housing of some hand along the preferred direction
//! would meet another object's points (or any point, without labels) get
//! these hands: out in the open the seed-normal search already reaches
//! everything, and its results stay as they were. Nothing here depends on a
//! particular gripper: the housing is the gripper description's.

use nalgebra::{Point3, Vector3};

use crate::candidates::{Obstacles, SearchParams, hands_in_frame, is_foreign};
use crate::grasp::Grasp;
use crate::gripper::body_margin;
use crate::normals::{SurfaceCloud, any_perpendicular};

/// How far (m) a corner of the housing may dip below the support plane
/// (the hand search's tolerance for its hands).
const PLANE_TOLERANCE: f64 = 0.001;

/// Tilts (radians) of the approach away from the preferred direction tried
/// by [`clear_approaches`]: (about the closing axis, about the housing's
/// short axis), each with both signs. The first twelve go smallest total
/// tilt first, up to (0.9, 0.6): 62° from the preferred direction. A lean
/// about the short axis raises one end of the housing (20.8 cm long on the
/// Panda) and lowers the other by half its length times the sine of the
/// lean: a low object lying along a bin wall, closed across, needs its
/// wall-side end over the wall while the other end stays above the floor,
/// a band of leans a few tenths of a radian wide (a 3 cm tube 7 cm from a
/// 10 cm wall: about 0.45 rad) that steps of 0.3 skip. The leans between
/// (0.15, 0.45) come last, so that a closing axis where one of the first
/// twelve clears keeps that orientation: they only add hands where none
/// of those fit (a lean in the first place also changed grasps elsewhere,
/// among them one closing on a neighbour's unobserved corner in
/// `tests/test_grasp_clutter.py`).
pub const TILTS: [(f64, f64); 20] = [
    (0.0, 0.0),
    (0.3, 0.0),
    (0.0, 0.3),
    (0.3, 0.3),
    (0.6, 0.0),
    (0.0, 0.6),
    (0.6, 0.3),
    (0.3, 0.6),
    (0.6, 0.6),
    (0.9, 0.0),
    (0.9, 0.3),
    (0.9, 0.6),
    (0.0, 0.15),
    (0.3, 0.15),
    (0.0, 0.45),
    (0.3, 0.45),
    (0.6, 0.15),
    (0.6, 0.45),
    (0.9, 0.15),
    (0.9, 0.45),
];

/// Points per block of the housing test in [`clear_approaches`].
const BLOCK: usize = 64;

/// One hand orientation for the search: approach `approach`, closing axis
/// `closing` (unit, perpendicular), and the fingertip depths (a subset of
/// the search's, deepest first) at which its housing is clear.
#[derive(Debug, Clone)]
pub struct Approach {
    /// Approach direction (gripper x), unit.
    pub approach: Vector3<f64>,
    /// Closing direction (gripper y), unit, perpendicular to `approach`.
    pub closing: Vector3<f64>,
    /// Depths of `SearchParams::depths` at which the housing is clear.
    pub depths: Vec<f64>,
}

/// The orientation of a hand whose approach is `u` tilted by `alpha` about
/// the closing axis `y0` (perpendicular to `u`) and then by `beta` about
/// the resulting z axis: (approach, closing), unit and perpendicular. The
/// first tilt follows [`crate::candidates::hands_at_seed`]'s convention.
pub fn tilted(
    u: &Vector3<f64>,
    y0: &Vector3<f64>,
    alpha: f64,
    beta: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let z0 = u.cross(y0);
    let (sa, ca) = alpha.sin_cos();
    let a1 = u * ca - z0 * sa;
    let (sb, cb) = beta.sin_cos();
    let a = a1 * cb + y0 * sb;
    let y = y0 * cb - a1 * sb;
    (a, y)
}

/// The observed obstacle points within `r` of `p` (from the cloud and the
/// housing's far obstacles) as offsets from `p`, each with its squared
/// distance from the line through `p` along `u` and whether it counts as
/// another object for a seed labelled `own` (all do when the seed is
/// unlabelled), unordered. The hidden points under observed ones are left
/// out: a housing coming from the camera's side meets the observed surface
/// first (the housing check after the search is against every point).
fn obstacles_near(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    p: &Point3<f64>,
    u: &Vector3<f64>,
    r: f64,
    own: i32,
) -> Vec<(f64, Vector3<f64>, bool)> {
    let mut found: Vec<(f64, Vector3<f64>, bool)> = Vec::new();
    let off_axis = |v: &Vector3<f64>| (v - u * v.dot(u)).norm_squared();
    for i in cloud.within(p, r) {
        if i < cloud.num_observed() {
            let v = cloud.points[i] - p;
            found.push((
                off_axis(&v),
                v,
                own <= 0 || is_foreign(own, cloud.labels[i]),
            ));
        }
    }
    if let Some(o) = extra {
        for q in o.within(p, r) {
            let v = q - p;
            found.push((off_axis(&v), v, true));
        }
    }
    found
}

/// Hand orientations at `seed` whose housing clears the walls and
/// neighbours, for the hand search (see the module documentation); empty
/// when every hand along the preferred direction `sp.approach_direction`
/// already clears every other object, or when nothing fits. `extra` holds
/// obstacle points beyond the cloud's crop that only the housing reaches.
pub fn clear_approaches(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    seed: usize,
    sp: &SearchParams,
) -> Vec<Approach> {
    let g = &sp.gripper;
    let m = body_margin(sp.voxel_size);
    let p = cloud.points[seed];
    let u = sp.approach_direction;
    // The housing swept back along the approach (as in
    // `candidates::body_sweep_box`) at fingertip depth d spans
    // x in [d - back, d - front] of a hand at the seed (yc = 0).
    let front = g.finger_depth - m;
    let back = g.finger_depth + g.palm_depth + g.approach_distance + m;
    let (hy, hz) = (g.palm_width / 2.0 + m, g.palm_height / 2.0 + m);
    let dmin = sp.depths.iter().copied().fold(f64::INFINITY, f64::min);
    let dmax = sp.depths.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let xfar = (dmin - back).abs().max((dmax - front).abs());
    let r = (xfar * xfar + hy * hy + hz * hz).sqrt();
    let mut found = obstacles_near(cloud, extra, &p, &u, r, cloud.labels[seed]);
    // Out in the open (no other object's point within reach of a housing
    // along `u` turned any way about it, at any depth: the cylinder of
    // radius half the housing's length about the seed's axis): the
    // seed-normal search is enough.
    let near = found.iter().any(|(_, q, o)| {
        let x = q.dot(&u);
        *o && x >= dmin - back && x <= dmax - front && (q - u * x).norm_squared() <= hy * hy
    });
    if !near {
        return Vec::new();
    }
    // Nearest the seed's axis first: the likeliest to be in a housing, so
    // that `blocked` stops early (its result does not depend on the order).
    found.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    // One array per axis, and each depth's window of x for the housing.
    let (qx, qy, qz): (Vec<f64>, Vec<f64>, Vec<f64>) = (
        found.iter().map(|f| f.1.x).collect(),
        found.iter().map(|f| f.1.y).collect(),
        found.iter().map(|f| f.1.z).collect(),
    );
    let windows: Vec<(f64, f64)> = sp
        .depths
        .iter()
        .take(31)
        .map(|&d| (d - back, d - front))
        .collect();
    // Bit k of the result: the housing at depth sp.depths[k] holds a point
    // or a corner of it dips below the support plane. The points are
    // tested in blocks (loops the compiler vectorises; nalgebra's dot
    // product order), stopping once every depth is blocked.
    let all = (1u32 << sp.depths.len().min(31)) - 1;
    let (mut xs, mut across) = ([0.0; BLOCK], [false; BLOCK]);
    let mut blocked = |a: &Vector3<f64>, y: &Vector3<f64>| -> u32 {
        let z = a.cross(y);
        let mut hit = 0u32;
        if let Some(pl) = &sp.plane {
            for (k, &d) in sp.depths.iter().enumerate().take(31) {
                let below = (0..8).any(|c| {
                    let x = if c & 1 == 0 { d - back } else { d - front };
                    let cy = if c & 2 == 0 { -hy } else { hy };
                    let cz = if c & 4 == 0 { -hz } else { hz };
                    pl.distance(&(p + a * x + y * cy + z * cz)) < -PLANE_TOLERANCE
                });
                if below {
                    hit |= 1 << k;
                }
            }
        }
        for ((bx, by), bz) in qx.chunks(BLOCK).zip(qy.chunks(BLOCK)).zip(qz.chunks(BLOCK)) {
            if hit == all {
                break;
            }
            for ((((x_out, inside), &qx), &qy), &qz) in
                xs.iter_mut().zip(across.iter_mut()).zip(bx).zip(by).zip(bz)
            {
                let dy = qx * y.x + qy * y.y + qz * y.z;
                let dz = qx * z.x + qy * z.y + qz * z.z;
                *x_out = qx * a.x + qy * a.y + qz * a.z;
                *inside = (dy.abs() <= hy) & (dz.abs() <= hz);
            }
            let len = bx.len();
            for (k, &(lo, hi)) in windows.iter().enumerate() {
                if hit & (1 << k) == 0
                    && xs[..len]
                        .iter()
                        .zip(&across[..len])
                        .fold(false, |any, (&x, &o)| any | (o & (x >= lo) & (x <= hi)))
                {
                    hit |= 1 << k;
                }
            }
        }
        hit
    };
    let e1 = any_perpendicular(&u);
    let e2 = u.cross(&e1);
    let n = sp.num_rotations;
    let axes: Vec<Vector3<f64>> = (0..n)
        .map(|k| {
            let phi = k as f64 * std::f64::consts::PI / n as f64;
            e1 * phi.cos() + e2 * phi.sin()
        })
        .collect();
    let mut out = Vec::new();
    for y0 in &axes {
        'tilts: for &(ta, tb) in &TILTS {
            for sa in [1.0, -1.0] {
                for sb in [1.0, -1.0] {
                    if (ta == 0.0 && sa < 0.0) || (tb == 0.0 && sb < 0.0) {
                        continue;
                    }
                    let (a, y) = tilted(&u, y0, sa * ta, sb * tb);
                    let hit = blocked(&a, &y);
                    if hit != all {
                        let depths = sp
                            .depths
                            .iter()
                            .enumerate()
                            .filter(|&(k, _)| k < 31 && hit & (1 << k) == 0)
                            .map(|(_, &d)| d)
                            .collect();
                        out.push(Approach {
                            approach: a,
                            closing: y,
                            depths,
                        });
                        break 'tilts;
                    }
                }
            }
        }
    }
    out
}

/// The hands of [`crate::candidates::hands_at_seed`] at `seed` and, in
/// clutter, those of the orientations [`clear_approaches`] finds there
/// (each searched at its clear depths only).
pub fn hands_with_clear_approaches(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    seed: usize,
    sp: &SearchParams,
) -> Vec<Grasp> {
    let mut out = crate::candidates::hands_at_seed(cloud, seed, sp);
    for ap in clear_approaches(cloud, extra, seed, sp) {
        let one = SearchParams {
            depths: ap.depths,
            num_rotations: 1,
            approach_tilts: vec![0.0],
            ..sp.clone()
        };
        out.extend(hands_in_frame(cloud, seed, ap.approach, ap.closing, &one));
    }
    out
}

#[cfg(test)]
#[path = "approaches_reference.rs"]
pub(crate) mod reference;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gripper::GripperGeometry;

    fn params() -> SearchParams {
        SearchParams {
            gripper: GripperGeometry::default(),
            depths: vec![0.04, 0.03, 0.02, 0.015],
            num_rotations: 8,
            approach_tilts: vec![0.0],
            voxel_size: 0.005,
            friction: 1.0,
            approach_direction: -Vector3::z(),
            plane: None,
            mass_centres: Vec::new(),
            torque_scale: 0.0,
            single_object: true,
        }
    }

    #[test]
    fn tilted_frames_are_orthonormal_and_tilted_by_the_angles() {
        let u = -Vector3::z();
        let y0 = Vector3::x();
        for (a, b) in [(0.0, 0.0), (0.3, 0.0), (0.0, 0.6), (0.9, -0.6)] {
            let (ap, y) = tilted(&u, &y0, a, b);
            assert!((ap.norm() - 1.0).abs() < 1e-12 && (y.norm() - 1.0).abs() < 1e-12);
            assert!(ap.dot(&y).abs() < 1e-12);
            // cos of the angle from u is cos a · cos b.
            let c: f64 = ap.dot(&u);
            assert!((c - a.cos() * b.cos()).abs() < 1e-12, "{a} {b}");
        }
    }

    /// A wall: a vertical sheet of points at x = `wall_x`, from z = 0 to
    /// 0.1, y in ±0.15, labelled 0 (not an object).
    fn wall(wall_x: f64) -> Vec<Point3<f64>> {
        let mut w = Vec::new();
        for i in 0..=20 {
            for j in -30..=30 {
                w.push(Point3::new(wall_x, 0.005 * j as f64, 0.005 * i as f64));
            }
        }
        w
    }

    #[test]
    fn open_seed_gets_no_extra_approaches_and_a_wall_seed_leans_away() {
        let sp = params();
        // A seed 3 cm up, in the open: nothing within the housing's reach.
        let seed = Point3::new(0.0, 0.0, 0.03);
        let cloud =
            SurfaceCloud::new(vec![seed], vec![1], 0.015, Point3::new(0.0, 0.0, 1.0)).unwrap();
        assert!(clear_approaches(&cloud, None, 0, &sp).is_empty());
        // The same seed 2.5 cm from a 10 cm wall (x = 0.025).
        let mut pts = vec![seed];
        pts.extend(wall(0.025));
        let labels = std::iter::once(1)
            .chain(std::iter::repeat_n(0, pts.len() - 1))
            .collect();
        let cloud =
            SurfaceCloud::new(pts.clone(), labels, 0.015, Point3::new(0.0, 0.0, 1.0)).unwrap();
        let out = clear_approaches(&cloud, None, 0, &sp);
        assert!(!out.is_empty());
        let g = GripperGeometry::default();
        let m = body_margin(sp.voxel_size);
        for ap in &out {
            // Every returned orientation leans away from the wall (its
            // palm, behind the fingertips, is on the -x side) or is straight
            // down, and at each returned depth no wall point is in the
            // housing (checked here with the housing box of
            // `candidates::body_sweep_box`).
            assert!(ap.approach.x >= -1e-9, "{:?}", ap.approach);
            assert!(!ap.depths.is_empty());
            let z = ap.approach.cross(&ap.closing);
            for &d in &ap.depths {
                let (lo, hi) = crate::candidates::body_sweep_box(&g, d, m);
                for q in &pts[1..] {
                    let v = q - seed;
                    let l = Vector3::new(v.dot(&ap.approach), v.dot(&ap.closing), v.dot(&z));
                    let inside = (0..3).all(|k| l[k] >= lo[k] && l[k] <= hi[k]);
                    assert!(!inside, "{ap:?} depth {d}: {q:?}");
                }
            }
        }
        // The closing axis along the wall (y) fits with the smallest tilt.
        let along = out
            .iter()
            .find(|a| a.closing.y.abs() > 0.99)
            .expect("an approach closing along the wall");
        assert!(along.approach.dot(&sp.approach_direction) > 0.9f64.cos() - 1e-9);
    }
}
