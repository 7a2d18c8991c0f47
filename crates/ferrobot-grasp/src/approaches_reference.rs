//! The wall approaches as they were before the test for open seeds was
//! moved ahead of the sort of the neighbours (`main` at bec4c63). Kept
//! (tests only) as the reference the faster version must reproduce.

use nalgebra::{Point3, Vector3};

use super::{Approach, PLANE_TOLERANCE, TILTS, tilted};
use crate::candidates::{Obstacles, SearchParams, is_foreign};
use crate::gripper::body_margin;
use crate::normals::{SurfaceCloud, any_perpendicular};

/// The observed obstacle points within `r` of `p` (from the cloud and the
/// housing's far obstacles) as offsets from `p`, nearest the line through
/// `p` along `u` first (the likeliest to be in a housing: tests stop at
/// the first point inside), and whether each counts as another object for
/// a seed labelled `own` (all do when the seed is unlabelled). The hidden
/// points under observed ones are left out: a housing coming from the
/// camera's side meets the observed surface first (the housing check after
/// the search is against every point).
fn obstacles_near(
    cloud: &SurfaceCloud,
    extra: Option<&Obstacles>,
    p: &Point3<f64>,
    u: &Vector3<f64>,
    r: f64,
    own: i32,
) -> (Vec<Vector3<f64>>, Vec<bool>) {
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
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    found.into_iter().map(|(_, v, o)| (v, o)).unzip()
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
    let (pts, other) = obstacles_near(cloud, extra, &p, &u, r, cloud.labels[seed]);
    if pts.is_empty() {
        return Vec::new();
    }
    // Bit k of the result: the housing at depth sp.depths[k] holds a point
    // or a corner of it dips below the support plane.
    let all = (1u32 << sp.depths.len().min(31)) - 1;
    let blocked = |a: &Vector3<f64>, y: &Vector3<f64>| -> u32 {
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
        for q in &pts {
            if q.dot(y).abs() > hy || q.dot(&z).abs() > hz {
                continue;
            }
            let x = q.dot(a);
            for (k, &d) in sp.depths.iter().enumerate().take(31) {
                if x >= d - back && x <= d - front {
                    hit |= 1 << k;
                }
            }
            if hit == all {
                break;
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
    // Out in the open (no other object's point within reach of a housing
    // along `u` turned any way about it, at any depth: the cylinder of
    // radius half the housing's length about the seed's axis): the
    // seed-normal search is enough.
    let near = pts.iter().zip(&other).any(|(q, &o)| {
        let x = q.dot(&u);
        o && x >= dmin - back && x <= dmax - front && (q - u * x).norm_squared() <= hy * hy
    });
    if !near {
        return Vec::new();
    }
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
