//! Grasp quality: two-contact force closure at a friction coefficient,
//! contact support and approach direction.
//!
//! A parallel-jaw grasp with contacts c1, c2 and outward surface normals
//! n1, n2 is in force closure at friction coefficient μ when the line
//! between the contacts lies inside both friction cones (Nguyen's condition,
//! the antipodal test of Dex-Net): angle(n1, c1 - c2) ≤ atan μ and
//! angle(n2, c2 - c1) ≤ atan μ. The smallest such μ is
//! tan(max of the two angles).

use nalgebra::Vector3;

/// A contact between a finger and the surface, in the gripper frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The contact point.
    pub point: Vector3<f64>,
    /// Unit outward surface normal at the contact.
    pub normal: Vector3<f64>,
    /// False when the contact face was not seen by the camera and its
    /// normal is the silhouette estimate (see [`estimate_contact`]).
    pub observed: bool,
}

/// The contact of one finger from the band of cloud points nearest it.
///
/// `outward` is the unit direction from the grasp centre towards this
/// finger. When some band point's normal lies within `max_angle` of
/// `outward`, the contact is the best aligned such point (an observed
/// face). Otherwise the face touching the finger was hidden from the camera:
/// at the edge of what is seen the surface is tangent to the viewing ray
/// `view` (the silhouette condition), so the normal is estimated as
/// perpendicular to `view` and to the band's edge direction, facing
/// `outward`. Returns None for an empty band.
pub fn estimate_contact(
    band_points: &[Vector3<f64>],
    band_normals: &[Vector3<f64>],
    outward: &Vector3<f64>,
    view: &Vector3<f64>,
    max_angle: f64,
) -> Option<Contact> {
    let centroid = band_points.iter().sum::<Vector3<f64>>() / band_points.len().max(1) as f64;
    let (best, cos) = band_normals
        .iter()
        .enumerate()
        .map(|(i, n)| (i, n.dot(outward)))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    if cos >= max_angle.cos() {
        return Some(Contact {
            point: band_points[best],
            normal: band_normals[best],
            observed: true,
        });
    }
    // Edge direction: largest spread of the band points, else gripper z.
    let mut edge = Vector3::z();
    if band_points.len() >= 3 {
        let mut cov = nalgebra::Matrix3::zeros();
        for p in band_points {
            let d = p - centroid;
            cov += d * d.transpose();
        }
        let eig = nalgebra::SymmetricEigen::new(cov);
        let k = eig.eigenvalues.imax();
        if eig.eigenvalues[k] > 1e-8 {
            edge = eig.eigenvectors.column(k).into_owned();
        }
    }
    let mut n = view.cross(&edge);
    if n.norm() < 1e-6 {
        n = view.cross(&Vector3::z());
    }
    let mut n = n.try_normalize(1e-9)?;
    if n.dot(outward) < 0.0 {
        n = -n;
    }
    Some(Contact {
        point: centroid,
        normal: n,
        observed: false,
    })
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
    if !(mu_needed <= mu) {
        return 0.0;
    }
    let fc = 1.0 - mu_needed / mu;
    fc * (0.5 + 0.25 * support.clamp(0.0, 1.0) + 0.125 * (1.0 + approach_cos.clamp(-1.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(p: [f64; 3], n: [f64; 3]) -> Contact {
        Contact {
            point: Vector3::from(p),
            normal: Vector3::from(n).normalize(),
            observed: true,
        }
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
    fn hidden_face_is_tangent_to_the_view_ray() {
        // Band of top-face points along z at y = 0.02; normals point up (-x).
        let pts: Vec<_> = (0..5)
            .map(|i| Vector3::new(0.0, 0.02, -0.01 + 0.005 * i as f64))
            .collect();
        let ns = vec![Vector3::new(-1.0, 0.0, 0.0); 5];
        let ct = estimate_contact(&pts, &ns, &Vector3::y(), &Vector3::x(), 0.9).unwrap();
        assert!(!ct.observed);
        assert!((ct.normal - Vector3::y()).norm() < 1e-9);
    }
}
