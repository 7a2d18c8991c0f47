//! Estimated centres of mass of the labelled objects in a cloud, for
//! preferring grasps whose axis passes near them (a grasp far from the
//! centre of mass must resist the object's weight as a torque about the
//! closing axis, which two small finger contacts hold poorly).
//!
//! With a support plane, each object is taken as the solid under what the
//! camera saw (the same assumption as [`crate::SurfaceCloud::extrude`]): the
//! plane is cut into square cells, and the column from the highest observed
//! point of each cell down to the plane is one uniform-density prism whose
//! mass centre is half way down. Without a plane the centroid of the
//! object's points stands in.

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};

use crate::plane::Plane;

/// The estimated centre of mass of every label other than -1 (unknown) in
/// `points`, as (label, centre) sorted by label. Points within `threshold`
/// of `plane` are ignored; `cell` is the side of the plane's cells.
pub fn mass_centres(
    points: &[Point3<f64>],
    labels: &[i32],
    plane: Option<&Plane>,
    threshold: f64,
    cell: f64,
) -> Vec<(i32, Point3<f64>)> {
    let mut sums: HashMap<i32, (Vector3<f64>, f64)> = HashMap::new();
    match plane {
        None => {
            for (p, &l) in points.iter().zip(labels) {
                if l != -1 {
                    let e = sums.entry(l).or_insert((Vector3::zeros(), 0.0));
                    e.0 += p.coords;
                    e.1 += 1.0;
                }
            }
        }
        Some(pl) => {
            // Highest point of each (label, cell).
            let top = pl.highest_per_cell(points, threshold, cell, |i| {
                (labels[i] != -1).then_some(labels[i])
            });
            for ((l, _, _), (i, h)) in top {
                let c = points[i].coords - pl.normal * (h / 2.0);
                let e = sums.entry(l).or_insert((Vector3::zeros(), 0.0));
                e.0 += c * h;
                e.1 += h;
            }
        }
    }
    let mut out: Vec<(i32, Point3<f64>)> = sums
        .into_iter()
        .filter(|(_, (_, w))| *w > 0.0)
        .map(|(l, (s, w))| (l, Point3::from(s / w)))
        .collect();
    out.sort_by_key(|(l, _)| *l);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_boxs_top_face_gives_its_volume_centre() {
        // Table z = 0 (normal +z); a box 4 x 2 cm, 6 cm tall, whose top face
        // is all the camera saw, centred at (0.1, -0.05): its mass centre
        // is at half its height.
        let plane = Plane {
            normal: Vector3::z(),
            offset: 0.0,
        };
        let mut pts = Vec::new();
        let mut labels = Vec::new();
        for i in 0..8 {
            for j in 0..4 {
                let x = 0.1 - 0.02 + 0.0025 + 0.005 * i as f64;
                let y = -0.05 - 0.01 + 0.0025 + 0.005 * j as f64;
                pts.push(Point3::new(x, y, 0.06));
                labels.push(3);
                pts.push(Point3::new(x + 0.3, y, 0.0)); // table
                labels.push(0);
            }
        }
        let c = mass_centres(&pts, &labels, Some(&plane), 0.002, 0.005);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].0, 3);
        assert!((c[0].1 - Point3::new(0.1, -0.05, 0.03)).norm() < 1e-9);
        // Without the plane: the centroid of the points, per label.
        let c = mass_centres(&pts, &labels, None, 0.002, 0.005);
        assert_eq!(c.len(), 2);
        assert!((c[1].1 - Point3::new(0.1, -0.05, 0.06)).norm() < 1e-9);
    }

    #[test]
    fn a_wedge_leans_towards_its_tall_side() {
        // Top surface z = x over x in [0, 0.04] (a wedge on the table): the
        // mass centre of the triangle's area is at x = 2/3 of 0.04, height
        // 1/3 of 0.04 (in the limit of fine cells).
        let plane = Plane {
            normal: Vector3::z(),
            offset: 0.0,
        };
        let n = 400;
        let cell = 0.04 / n as f64;
        let pts: Vec<_> = (0..n)
            .map(|i| {
                let x = (i as f64 + 0.5) * cell;
                Point3::new(x, 0.0, x)
            })
            .collect();
        let labels = vec![1; n];
        let c = mass_centres(&pts, &labels, Some(&plane), 0.0, cell)[0].1;
        assert!((c.x - 0.04 * 2.0 / 3.0).abs() < 1e-4, "{c}");
        assert!((c.z - 0.04 / 3.0).abs() < 1e-4, "{c}");
    }
}
