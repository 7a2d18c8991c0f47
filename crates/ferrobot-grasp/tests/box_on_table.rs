//! A box on a table seen from above (the points a camera at z = 0.6 m sees),
//! checked against the box's true geometry.

use ferrobot_grasp::{DetectOptions, GraspError, detect};
use nalgebra::{Point3, Vector3};

/// Table z = 0 around a 4 x 6 x 5 cm box centred at the origin (top at
/// z = 0.05), sampled every 2 mm as seen from straight above: the table where
/// the box does not hide it, and the box's top face.
fn scene() -> Vec<Point3<f64>> {
    let (hx, hy, h) = (0.02, 0.03, 0.05);
    let mut pts = Vec::new();
    let n = 150;
    for i in 0..n {
        for j in 0..n {
            let x = -0.15 + 0.3 * i as f64 / (n - 1) as f64;
            let y = -0.15 + 0.3 * j as f64 / (n - 1) as f64;
            if x.abs() <= hx && y.abs() <= hy {
                pts.push(Point3::new(x, y, h));
            } else {
                pts.push(Point3::new(x, y, 0.0));
            }
        }
    }
    pts
}

fn options() -> DetectOptions {
    DetectOptions {
        viewpoint: Point3::new(0.0, 0.0, 0.6),
        approach_direction: Vector3::new(0.0, 0.0, -1.0),
        ..DetectOptions::default()
    }
}

#[test]
fn top_grasps_close_across_the_box() {
    let group = detect(&scene(), None, None, &options()).unwrap();
    assert!(!group.is_empty());
    let scores: Vec<f64> = group.grasps.iter().map(|g| g.score).collect();
    assert!(scores.windows(2).all(|w| w[0] >= w[1]));
    let best = &group.grasps[0];
    let approach = best.rotation.column(0);
    let closing = best.rotation.column(1);
    assert!(approach.z < -0.95, "approach {approach:?}");
    // Closing along x (4 cm) or y (6 cm), within 10 degrees.
    let (along, extent) = if closing.x.abs() > closing.y.abs() {
        (closing.x.abs(), 0.04)
    } else {
        (closing.y.abs(), 0.06)
    };
    assert!(along > 10f64.to_radians().cos(), "closing {closing:?}");
    assert!(
        best.width >= extent && best.width <= 0.08,
        "width {}",
        best.width
    );
    // Centred on the box's top face, fingertips above the table.
    assert!(best.translation.xy().norm() < 0.03);
    assert!((best.translation.z - 0.05).abs() < 0.01);
    assert!(best.translation.z - best.depth > 0.0);
    for g in &group.grasps {
        assert!(g.width <= 0.08 + 1e-12 && g.score > 0.0 && g.score <= 1.0);
        let det = g.rotation.determinant();
        assert!((det - 1.0).abs() < 1e-9);
    }
}

#[test]
fn degenerate_and_bad_input() {
    let opts = options();
    assert!(detect(&[], None, None, &opts).unwrap().is_empty());
    let same = vec![Point3::new(0.0, 0.0, 0.5); 50];
    assert!(detect(&same, None, None, &opts).unwrap().is_empty());
    let nan = vec![Point3::new(f64::NAN, 0.0, 0.5)];
    assert!(matches!(
        detect(&nan, None, None, &opts),
        Err(GraspError::NonFinite(_))
    ));
    let bad = DetectOptions {
        friction: -1.0,
        ..options()
    };
    assert!(matches!(
        detect(&scene(), None, None, &bad),
        Err(GraspError::InvalidArgument(_))
    ));
    assert!(matches!(
        detect(&scene(), Some(&[1, 2]), None, &opts),
        Err(GraspError::Shape(_))
    ));
}
