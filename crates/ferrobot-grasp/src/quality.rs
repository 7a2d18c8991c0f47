//! Grasp quality: two-contact force closure at a friction coefficient,
//! contact support and approach direction.
//!
//! A parallel-jaw grasp with contacts c1, c2 and outward surface normals
//! n1, n2 is in force closure at friction coefficient μ when the line
//! between the contacts lies inside both friction cones (Nguyen's condition,
//! the antipodal test of Dex-Net): angle(n1, c1 - c2) ≤ atan μ and
//! angle(n2, c2 - c1) ≤ atan μ. The smallest such μ is
//! tan(max of the two angles). Contact normals come from the profile of
//! the object between the fingers ([`contact_from_profile`]), which covers
//! faces the camera did not see once the hidden volume is completed.

use nalgebra::Vector3;

/// A contact between a finger and the surface, in the gripper frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The contact point.
    pub point: Vector3<f64>,
    /// Unit outward surface normal at the contact.
    pub normal: Vector3<f64>,
    /// Number of (x, z) cells of the finger face the surface reaches: the
    /// contact's support.
    pub cells: usize,
    /// Root-mean-square distance of the profile from the fitted face: large
    /// for an edge, a corner or a strongly curved contact.
    pub residual: f64,
}

/// The contact of one finger from the profile of the object between the
/// fingers (gripper frame; observed and hidden points alike).
///
/// `side` is -1 for the finger at -y, +1 for the one at +y. The points are
/// binned into `cell`-sized (x, z) cells; in each cell the point nearest the
/// finger (smallest y for side -1, largest for +1) is on the surface the
/// finger meets (cells are laid from the points' smallest x and z). A plane y = a + b·x + c·z fitted to those points by least
/// squares is the contact face: its normal, facing the finger, is the
/// contact normal (b = c = 0: a face square to the closing axis). Directions
/// without spread (fewer than two distinct cells) are not fitted. Returns
/// None for no points.
pub fn contact_from_profile(points: &[Vector3<f64>], side: f64, cell: f64) -> Option<Contact> {
    if points.is_empty() {
        return None;
    }
    let cells = ProfileCells::new(points, cell);
    let mut grid: Vec<Option<Vector3<f64>>> = vec![None; cells.len()];
    for p in points {
        keep_nearest(&mut grid[cells.index(p)], p, side);
    }
    let ext: Vec<Vector3<f64>> = grid.into_iter().flatten().collect();
    Some(fit_contact(&ext, side, cell))
}

/// The contacts of both fingers, (side -1, side +1): the same as two calls
/// of [`contact_from_profile`], bit for bit, with one pass over the points.
/// None for no points.
pub fn contacts_from_profile(points: &[Vector3<f64>], cell: f64) -> Option<(Contact, Contact)> {
    if points.is_empty() {
        return None;
    }
    let cells = ProfileCells::new(points, cell);
    // The cells first (a loop without branches the compiler vectorises),
    // then per cell the y of the points kept so far for each side.
    let at: Vec<usize> = points.iter().map(|p| cells.index(p)).collect();
    let mut grid: Vec<[Option<Vector3<f64>>; 2]> = vec![[None; 2]; cells.len()];
    for (p, &k) in points.iter().zip(&at) {
        let [left, right] = &mut grid[k];
        keep_nearest(left, p, -1.0);
        keep_nearest(right, p, 1.0);
    }
    let mut ext: Vec<Vector3<f64>> = Vec::with_capacity(grid.len());
    ext.extend(grid.iter().filter_map(|c| c[0]));
    let left = fit_contact(&ext, -1.0, cell);
    ext.clear();
    ext.extend(grid.iter().filter_map(|c| c[1]));
    Some((left, fit_contact(&ext, 1.0, cell)))
}

/// A dense grid of `cell`-sized (x, z) cells over the points' bounds, laid
/// from their smallest x and z (see [`contact_from_profile`]).
struct ProfileCells {
    x0: f64,
    z0: f64,
    nx: usize,
    nz: usize,
    cell: f64,
}

impl ProfileCells {
    fn new(points: &[Vector3<f64>], cell: f64) -> Self {
        let (mut x0, mut z0, mut x1, mut z1) = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for p in points {
            x0 = x0.min(p.x);
            x1 = x1.max(p.x);
            z0 = z0.min(p.z);
            z1 = z1.max(p.z);
        }
        let nx = ((x1 - x0) / cell).floor() as usize + 1;
        let nz = ((z1 - z0) / cell).floor() as usize + 1;
        Self {
            x0,
            z0,
            nx,
            nz,
            cell,
        }
    }

    fn len(&self) -> usize {
        self.nx * self.nz
    }

    /// The cell of `p`.
    fn index(&self, p: &Vector3<f64>) -> usize {
        let ix = (((p.x - self.x0) / self.cell).floor() as usize).min(self.nx - 1);
        let iz = (((p.z - self.z0) / self.cell).floor() as usize).min(self.nz - 1);
        ix * self.nz + iz
    }
}

/// Keeps in `slot` the point nearest the finger on `side` (the first of
/// equals).
fn keep_nearest(slot: &mut Option<Vector3<f64>>, p: &Vector3<f64>, side: f64) {
    match slot {
        Some(e) if side * p.y <= side * e.y => {}
        _ => *slot = Some(*p),
    }
}

/// The contact face fitted to the profile points `ext` (one per cell, the
/// grid's order) of the finger on `side`.
fn fit_contact(ext: &[Vector3<f64>], side: f64, cell: f64) -> Contact {
    let n = ext.len();
    let mean = ext.iter().sum::<Vector3<f64>>() / n as f64;
    let (mut sxx, mut szz, mut sxz, mut sxy, mut szy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in ext {
        let d = p - mean;
        sxx += d.x * d.x;
        szz += d.z * d.z;
        sxz += d.x * d.z;
        sxy += d.x * d.y;
        szy += d.z * d.y;
    }
    let spread = (cell * cell) / 4.0 * n as f64;
    let fit_x = sxx > spread;
    let fit_z = szz > spread;
    let (b, c) = match (fit_x, fit_z) {
        (true, true) => {
            let det = sxx * szz - sxz * sxz;
            if det.abs() > 1e-18 {
                ((sxy * szz - szy * sxz) / det, (szy * sxx - sxy * sxz) / det)
            } else {
                (sxy / sxx, 0.0)
            }
        }
        (true, false) => (sxy / sxx, 0.0),
        (false, true) => (0.0, szy / szz),
        (false, false) => (0.0, 0.0),
    };
    // Surface y - b·x - c·z = a; gradient (-b, 1, -c) points to +y.
    let normal = Vector3::new(-b, 1.0, -c).normalize() * side;
    let residual = (ext
        .iter()
        .map(|p| {
            let d = p - mean;
            (d.y - b * d.x - c * d.z).powi(2)
        })
        .sum::<f64>()
        / n as f64)
        .sqrt()
        / (1.0 + b * b + c * c).sqrt();
    Contact {
        point: mean,
        normal,
        cells: n,
        residual,
    }
}

/// The smallest friction coefficient at which the two contacts are in force
/// closure (infinite when a normal faces away from the contact line).
pub fn friction_needed(a: &Contact, b: &Contact) -> f64 {
    let line = b.point - a.point;
    let Some(l) = line.try_normalize(1e-9) else {
        return f64::INFINITY;
    };
    let ca = a.normal.dot(&-l).clamp(-1.0, 1.0);
    let cb = b.normal.dot(&l).clamp(-1.0, 1.0);
    let c = ca.min(cb);
    if c <= 1e-9 {
        return f64::INFINITY;
    }
    (1.0 - c * c).sqrt() / c
}

/// Score in (0, 1] of a grasp needing friction `mu_needed` with a gripper of
/// friction `mu`, `support` in [0, 1] (how well the contacts are backed by
/// points) and `approach_cos` the cosine between the approach and the
/// preferred approach direction; 0 when not in force closure at `mu`.
///
/// score = (1 - mu_needed / mu) · (0.5 + 0.25 · support + 0.25 · (1 + approach_cos) / 2).
pub fn score(mu_needed: f64, mu: f64, support: f64, approach_cos: f64) -> f64 {
    if mu_needed.is_nan() || mu_needed > mu {
        return 0.0;
    }
    let fc = 1.0 - mu_needed / mu;
    fc * (0.5 + 0.25 * support.clamp(0.0, 1.0) + 0.125 * (1.0 + approach_cos.clamp(-1.0, 1.0)))
}

/// Lever arm (m) of the weight at `com` about the closing axis through
/// `centre` along the unit `axis`: with `up` (unit, against gravity) the
/// horizontal distance of `com` from the axis measured perpendicular to it,
/// |((com - centre) × up) · axis|, so the weight's torque about the axis is
/// m·g times it; without `up` (gravity unknown) the distance from `com` to
/// the axis line, the largest lever arm over all directions of gravity.
pub fn lever_arm(
    com: &Vector3<f64>,
    centre: &Vector3<f64>,
    axis: &Vector3<f64>,
    up: Option<&Vector3<f64>>,
) -> f64 {
    let d = com - centre;
    match up {
        Some(u) => d.cross(u).dot(axis).abs(),
        None => (d - axis * d.dot(axis)).norm(),
    }
}

/// Score factor in (0, 1] for a lever arm `arm` of the object's weight about
/// the grasp axis: 1 / (1 + (arm / scale)²), which halves at `arm` = `scale`
/// (1 when `scale` is 0: no preference).
pub fn torque_factor(arm: f64, scale: f64) -> f64 {
    if scale <= 0.0 {
        return 1.0;
    }
    let r = arm / scale;
    1.0 / (1.0 + r * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(p: [f64; 3], n: [f64; 3]) -> Contact {
        Contact {
            point: Vector3::from(p),
            normal: Vector3::from(n).normalize(),
            cells: 1,
            residual: 0.0,
        }
    }

    #[test]
    fn both_contacts_at_once_equal_one_side_at_a_time() {
        // Bit for bit, on profiles with ties in y within a cell (the first
        // point of equals is kept), signed zeros, one point, one row of
        // cells and a scattered cloud.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rand = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut sets: Vec<Vec<Vector3<f64>>> = vec![
            vec![Vector3::new(0.01, 0.0, 0.0)],
            vec![Vector3::new(0.0, -0.0, 0.0), Vector3::new(0.0, 0.0, 0.001)],
            (0..12)
                .map(|i| Vector3::new(0.004 * i as f64, 0.02, 0.0))
                .collect(),
        ];
        for _ in 0..40 {
            let n = 1 + (rand() * 300.0) as usize;
            sets.push(
                (0..n)
                    .map(|_| {
                        // y on a coarse grid so that cells hold equal y.
                        let y = (rand() * 8.0).floor() * 0.005 - 0.02;
                        Vector3::new(rand() * 0.05 - 0.01, y, rand() * 0.02 - 0.01)
                    })
                    .collect(),
            );
        }
        for (k, pts) in sets.iter().enumerate() {
            for cell in [0.005, 0.003] {
                let (l, r) = contacts_from_profile(pts, cell).unwrap();
                let l1 = contact_from_profile(pts, -1.0, cell).unwrap();
                let r1 = contact_from_profile(pts, 1.0, cell).unwrap();
                for (a, b) in [(l, l1), (r, r1)] {
                    assert_eq!(a.cells, b.cells, "set {k}");
                    for (x, y) in a
                        .point
                        .iter()
                        .chain(a.normal.iter())
                        .chain([&a.residual])
                        .zip(b.point.iter().chain(b.normal.iter()).chain([&b.residual]))
                    {
                        assert_eq!(x.to_bits(), y.to_bits(), "set {k}");
                    }
                }
            }
        }
        assert!(contacts_from_profile(&[], 0.005).is_none());
    }

    #[test]
    fn antipodal_needs_no_friction_and_tilted_needs_tan() {
        let a = c([0.0, -0.02, 0.0], [0.0, -1.0, 0.0]);
        let b = c([0.0, 0.02, 0.0], [0.0, 1.0, 0.0]);
        assert!(friction_needed(&a, &b) < 1e-9);
        let b2 = c([0.0, 0.02, 0.0], [0.0, 1.0, 0.5]);
        assert!((friction_needed(&a, &b2) - 0.5).abs() < 1e-9);
        let b3 = c([0.0, 0.02, 0.0], [0.0, -1.0, 0.0]);
        assert!(friction_needed(&a, &b3).is_infinite());
        assert_eq!(score(0.6, 0.5, 1.0, 1.0), 0.0);
        assert!((score(0.0, 1.0, 1.0, 1.0) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn lever_arm_of_an_offset_weight() {
        let y = Vector3::y();
        let up = Vector3::z();
        let c = Vector3::zeros();
        // Straight below or above the axis: no torque; 3 cm to the side
        // (along x) and 2 cm down: 3 cm arm; an offset along the axis
        // itself never makes a torque about it.
        assert!(lever_arm(&Vector3::new(0.0, 0.0, -0.05), &c, &y, Some(&up)) < 1e-12);
        let arm = lever_arm(&Vector3::new(0.03, 0.5, -0.02), &c, &y, Some(&up));
        assert!((arm - 0.03).abs() < 1e-12);
        // Tilted axis (45 degrees up in the x-z plane): the horizontal arm
        // perpendicular to it is the y offset.
        let ax = Vector3::new(1.0, 0.0, 1.0).normalize();
        let arm = lever_arm(&Vector3::new(0.1, 0.02, 0.1), &c, &ax, Some(&up));
        assert!((arm - 0.02 / 2f64.sqrt()).abs() < 1e-12);
        // Gravity unknown: the distance to the axis line.
        let arm = lever_arm(&Vector3::new(0.03, 0.5, -0.04), &c, &y, None);
        assert!((arm - 0.05).abs() < 1e-12);
        assert_eq!(torque_factor(0.02, 0.02), 0.5);
        assert_eq!(torque_factor(0.05, 0.0), 1.0);
        assert!((torque_factor(0.0, 0.02) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn profile_of_a_tilted_face() {
        // Face at y = 0.02 + 0.5 x on the +y side, sampled on a grid, with
        // interior points that must be ignored.
        let mut pts = Vec::new();
        for i in 0..8 {
            for k in 0..4 {
                let (x, z) = (0.005 * i as f64, -0.0075 + 0.005 * k as f64);
                pts.push(Vector3::new(x, 0.02 + 0.5 * x, z));
                pts.push(Vector3::new(x, 0.0, z));
            }
        }
        let ct = contact_from_profile(&pts, 1.0, 0.005).unwrap();
        let want = Vector3::new(-0.5, 1.0, 0.0).normalize();
        assert!((ct.normal - want).norm() < 1e-9);
        assert_eq!(ct.cells, 32);
        assert!(ct.residual < 1e-12);
        let left = contact_from_profile(&pts, -1.0, 0.005).unwrap();
        assert!((left.normal - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-9);
    }
}
