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
//! along y around the seed (gaps narrower than a finger plus clearance join
//! it); the fingers are centred on that interval and opened to its extent
//! plus clearance; the first depth whose opening fits and whose hand is free
//! of points wins.

use nalgebra::{Matrix3, Point3, Rotation3, Unit, Vector3};

use crate::grasp::Grasp;
use crate::gripper::{GripperGeometry, Region};
use crate::normals::SurfaceCloud;
use crate::quality::{estimate_contact, friction_needed, score};

/// Contact normals further than this from the finger's direction belong to
/// faces that do not face the finger (the touched face was not seen).
const HIDDEN_FACE_ANGLE: f64 = 75.0 * std::f64::consts::PI / 180.0;

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
}

/// All scored collision-free hands at `seed` (score > 0 only).
pub fn hands_at_seed(cloud: &SurfaceCloud, seed: usize, sp: &SearchParams) -> Vec<Grasp> {
    let p = cloud.points[seed];
    let a0 = -cloud.normals[seed];
    let t0 = cloud.tangents[seed];
    let max_depth = sp.depths.iter().copied().fold(0.0, f64::max);
    let nb = cloud.within(&p, sp.gripper.reach(max_depth));
    let a0u = Unit::new_unchecked(a0);
    let mut out = Vec::new();
    let mut local: Vec<(Vector3<f64>, usize)> = Vec::with_capacity(nb.len());
    for k in 0..sp.num_rotations {
        let phi = k as f64 * std::f64::consts::PI / sp.num_rotations as f64;
        let y = Rotation3::from_axis_angle(&a0u, phi) * t0;
        for &tilt in &sp.approach_tilts {
            let a = Rotation3::from_axis_angle(&Unit::new_unchecked(y), tilt) * a0;
            let z = a.cross(&y);
            let r = Matrix3::from_columns(&[a, y, z]);
            let rt = r.transpose();
            local.clear();
            for &i in &nb {
                let q = rt * (cloud.points[i] - p);
                if q.z.abs() <= sp.gripper.height / 2.0 {
                    local.push((q, i));
                }
            }
            if let Some(g) = evaluate(cloud, &p, &r, &local, seed, sp) {
                out.push(g);
            }
        }
    }
    out
}

/// The first (deepest) collision-free hand of orientation `r` at `p`.
fn evaluate(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    local: &[(Vector3<f64>, usize)],
    seed: usize,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let pad = g.clearance + sp.voxel_size / 2.0;
    let gap_max = g.finger_width + 2.0 * g.clearance;
    let mut ys: Vec<f64> = Vec::new();
    for &depth in &sp.depths {
        let base = depth - g.finger_depth;
        ys.clear();
        ys.extend(
            local
                .iter()
                .filter(|(q, _)| q.x >= base && q.x <= depth && q.y.abs() <= g.max_width + g.finger_width)
                .map(|(q, _)| q.y),
        );
        if ys.is_empty() {
            continue;
        }
        ys.sort_by(f64::total_cmp);
        let mut lo = ys
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .map(|(i, _)| i)?;
        let mut hi = lo;
        while lo > 0 && ys[lo] - ys[lo - 1] < gap_max {
            lo -= 1;
        }
        while hi + 1 < ys.len() && ys[hi + 1] - ys[hi] < gap_max {
            hi += 1;
        }
        let (ymin, ymax) = (ys[lo], ys[hi]);
        let width = ymax - ymin + 2.0 * pad;
        if width > g.max_width {
            continue;
        }
        let yc = (ymin + ymax) / 2.0;
        let mut collision = false;
        let mut closing = 0usize;
        for (q, _) in local {
            match g.region(q, depth, width, yc) {
                Region::Collision => {
                    collision = true;
                    break;
                }
                Region::Closing => closing += 1,
                Region::Free => {}
            }
        }
        if collision || closing == 0 {
            continue;
        }
        return score_hand(cloud, p, r, local, seed, depth, width, yc, ymin, ymax, sp);
    }
    None
}

#[allow(clippy::too_many_arguments)]
fn score_hand(
    cloud: &SurfaceCloud,
    p: &Point3<f64>,
    r: &Matrix3<f64>,
    local: &[(Vector3<f64>, usize)],
    seed: usize,
    depth: f64,
    width: f64,
    yc: f64,
    ymin: f64,
    ymax: f64,
    sp: &SearchParams,
) -> Option<Grasp> {
    let g = &sp.gripper;
    let band = sp.voxel_size.max(0.003);
    let rt = r.transpose();
    let mut sides = [(Vec::new(), Vec::new()), (Vec::new(), Vec::new())];
    for (q, i) in local {
        if g.region(q, depth, width, yc) != Region::Closing {
            continue;
        }
        if q.y <= ymin + band {
            sides[0].0.push(*q);
            sides[0].1.push(rt * cloud.normals[*i]);
        }
        if q.y >= ymax - band {
            sides[1].0.push(*q);
            sides[1].1.push(rt * cloud.normals[*i]);
        }
    }
    let mut contacts = Vec::with_capacity(2);
    for (k, (pts, ns)) in sides.iter().enumerate() {
        let outward = if k == 0 { -Vector3::y() } else { Vector3::y() };
        let centroid = pts.iter().sum::<Vector3<f64>>() / pts.len().max(1) as f64;
        let world = p + r * centroid;
        let view = rt * (world - cloud.viewpoint).try_normalize(1e-12).unwrap_or(Vector3::z());
        contacts.push(estimate_contact(pts, ns, &outward, &view, HIDDEN_FACE_ANGLE)?);
    }
    let mu = friction_needed(&contacts[0], &contacts[1]);
    let support = sides[0].0.len().min(sides[1].0.len()) as f64 / (g.height / sp.voxel_size).max(1.0);
    let approach = r.column(0).into_owned();
    let s = score(mu, sp.friction, support, approach.dot(&sp.approach_direction));
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
