//! Cameras against analytic depth, conventions, controllers, trajectory
//! execution, determinism and divergence.

use std::sync::Arc;

use ferrobot_camera::{backproject, look_at, opencv_to_opengl, opengl_to_opencv};
use ferrobot_sim::camera::{Camera, Intrinsics};
use ferrobot_sim::{
    JointPid, ObjectDesc, ResolvedRate, RobotOptions, Shape, SimError, World, WorldConfig,
    execute_trajectory,
};
use nalgebra::{Isometry3, Point3, Vector3};

#[test]
fn plane_depth_is_analytic() {
    let w = World::new(WorldConfig::default()).unwrap();
    let pose = look_at(
        &Point3::new(0.0, -1.0, 0.8),
        &Point3::new(0.0, 1.0, 0.0),
        &Vector3::z(),
    )
    .unwrap();
    let intr = Intrinsics::from_fov(80, 60, 1.2).unwrap();
    let frame = w.render(&Camera::new(intr, pose).unwrap(), true).unwrap();
    let mut hits = 0;
    for v in 0..60 {
        for u in 0..80 {
            let d = Vector3::new(
                (u as f64 - intr.cx) / intr.fx,
                (v as f64 - intr.cy) / intr.fy,
                1.0,
            );
            let dw = pose.rotation * d;
            let t = -pose.translation.vector.z / dw.z;
            let got = frame.depth[v * 80 + u] as f64;
            if t > 0.0 && t < 100.0 {
                hits += 1;
                assert!((got - t).abs() < 1e-5 * t, "pixel ({u}, {v}): {got} vs {t}");
                assert_eq!(frame.segmentation[v * 80 + u], 1);
            } else {
                assert!(got.is_infinite());
            }
        }
    }
    assert!(hits > 1000);
    // back-projected points lie on the plane
    let pts = backproject(&frame.depth, &intr, |_| true).unwrap().points;
    for p in pts {
        let wp = pose * p;
        assert!(wp.z.abs() < 1e-5);
    }
}

/// Thin convex hulls (lens-shaped, like flat stones) rendered by the
/// camera: every depth hit lies on the hull's surface (inside every face
/// plane of an independently built hull, on one of them, within 1 mm:
/// parry's polyhedra merge nearly coplanar faces, which moves a face by up
/// to about 0.5 mm), and every pixel without a hit has a ray that meets no
/// hull triangle (Möller-Trumbore). Parry's GJK ray cast on such hulls
/// returned hits centimetres outside.
#[test]
fn convex_hull_depth_lies_on_the_hull() {
    let mut state = 12345u64;
    let mut rnd = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let intr = Intrinsics {
        width: 160,
        height: 120,
        fx: 300.0,
        fy: 300.0,
        cx: 79.5,
        cy: 59.5,
        depth_scale: 1.0,
    };
    let eye = Point3::new(0.3, 0.0, 0.35);
    let pose = look_at(&eye, &Point3::origin(), &Vector3::z()).unwrap();
    let cam = Camera::new(intr, pose).unwrap();
    let mut hits = 0;
    for _ in 0..12 {
        let pts: Vec<Point3<f64>> = (0..60)
            .map(|_| {
                let (a, r) = (rnd() * std::f64::consts::TAU, rnd().sqrt());
                let z = 0.011 * (2.0 * rnd() - 1.0) * (1.0 - r * r).sqrt();
                Point3::new(0.032 * r * a.cos(), 0.05 * r * a.sin(), z)
            })
            .collect();
        let mut w = World::new(WorldConfig {
            ground: false,
            ..WorldConfig::default()
        })
        .unwrap();
        let mut desc = ObjectDesc::new(
            "stone",
            Shape::ConvexHull(std::sync::Arc::new(
                ferrobot_geometry::Hull::new(pts.clone()).unwrap(),
            )),
            Isometry3::identity(),
        );
        desc.is_static = true;
        w.add_object(desc).unwrap();
        let frame = w.render(&cam, false).unwrap();
        // The reference hull: its triangles and outward face planes.
        let f32pts: Vec<_> = pts
            .iter()
            .map(|p| parry3d::math::Vector::new(p.x as f32, p.y as f32, p.z as f32))
            .collect();
        let (verts, tris) = parry3d::transformation::convex_hull(&f32pts);
        let v: Vec<Vector3<f64>> = verts
            .iter()
            .map(|p| Vector3::new(p.x as f64, p.y as f64, p.z as f64))
            .collect();
        let centre = v.iter().sum::<Vector3<f64>>() / v.len() as f64;
        let planes: Vec<(Vector3<f64>, f64)> = tris
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| v[i as usize]);
                let mut n = (b - a).cross(&(c - a)).normalize();
                if n.dot(&(a - centre)) < 0.0 {
                    n = -n;
                }
                (n, n.dot(&a))
            })
            .collect();
        for px in 0..intr.width * intr.height {
            let (u, vv) = ((px % intr.width) as f64, (px / intr.width) as f64);
            let dir = pose.rotation
                * Vector3::new((u - intr.cx) / intr.fx, (vv - intr.cy) / intr.fy, 1.0);
            let depth = frame.depth[px] as f64;
            if depth.is_finite() {
                hits += 1;
                let p = eye.coords + dir * depth;
                let outside = planes
                    .iter()
                    .map(|(n, d)| n.dot(&p) - d)
                    .fold(f64::NEG_INFINITY, f64::max);
                assert!(
                    outside.abs() < 1e-3,
                    "pixel {px}: hit {outside} m off the hull surface"
                );
            } else {
                let meets = tris.iter().any(|t| {
                    let [a, b, c] = t.map(|i| v[i as usize]);
                    let (e1, e2) = (b - a, c - a);
                    let pv = dir.cross(&e2);
                    let det = e1.dot(&pv);
                    if det.abs() < 1e-12 {
                        return false;
                    }
                    let tv = eye.coords - a;
                    let (bu, qv) = (tv.dot(&pv) / det, tv.cross(&e1));
                    let bv = dir.dot(&qv) / det;
                    let inset = 1e-4;
                    bu > inset && bv > inset && bu + bv < 1.0 - inset && e2.dot(&qv) / det > 0.0
                });
                assert!(
                    !meets,
                    "pixel {px}: the ray meets the hull but nothing was rendered"
                );
            }
        }
    }
    assert!(hits > 5000, "{hits} pixels hit");
}

#[test]
fn conventions_round_trip() {
    let pose = look_at(
        &Point3::new(1.0, 2.0, 3.0),
        &Point3::origin(),
        &Vector3::z(),
    )
    .unwrap();
    let gl = opencv_to_opengl(&pose);
    let back = opengl_to_opencv(&gl);
    assert!((back.to_homogeneous() - pose.to_homogeneous()).abs().max() < 1e-12);
    let fwd_cv = pose.rotation * Vector3::z();
    let fwd_gl = gl.rotation * -Vector3::z();
    assert!((fwd_cv - fwd_gl).norm() < 1e-12);
}

#[test]
fn pid_anti_windup() {
    let mut pid = JointPid::new(vec![10.0], vec![5.0], vec![0.0], vec![1.0], vec![2.0]).unwrap();
    for _ in 0..100 {
        let u = pid.update(&[0.0], &[0.0], &[10.0], &[0.0], 0.01).unwrap();
        assert_eq!(u[0], 2.0);
    }
    assert_eq!(pid.integral()[0], 0.0);
    // Small error: the integral grows until the output saturates (0.1 +
    // 5 I = 2 at I = 0.38), then stops: conditional integration.
    for _ in 0..1000 {
        pid.update(&[0.0], &[0.0], &[0.01], &[0.0], 0.1).unwrap();
    }
    assert!(
        (pid.integral()[0] - 0.38).abs() < 1.5e-3,
        "{}",
        pid.integral()[0]
    );
    // Without an output limit the integral stops at its own clamp.
    let mut pid = JointPid::new(
        vec![10.0],
        vec![5.0],
        vec![0.0],
        vec![1.0],
        vec![f64::INFINITY],
    )
    .unwrap();
    for _ in 0..2000 {
        pid.update(&[0.0], &[0.0], &[0.01], &[0.0], 0.1).unwrap();
    }
    assert_eq!(pid.integral()[0], 1.0);
}

#[test]
fn resolved_rate_converges_on_the_model() {
    let model = ferrobot_model::robots::panda().unwrap();
    let ctl = ResolvedRate::new(&model);
    let mut q = vec![0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];
    let target = model
        .fk(&[0.3, -0.1, 0.2, -2.0, 0.1, 2.1, 0.5, 0.04], None)
        .unwrap();
    for _ in 0..2000 {
        let qd = ctl.compute(&model, &q, &target).unwrap();
        for (a, b) in q.iter_mut().zip(&qd) {
            *a += b * 0.005;
        }
    }
    let reached = model.fk(&q, None).unwrap();
    assert!((reached.translation.vector - target.translation.vector).norm() < 1e-4);
    assert!(reached.rotation.angle_to(&target.rotation) < 1e-3);
}

fn scene() -> (World, usize) {
    let mut w = World::new(WorldConfig::default()).unwrap();
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let mut opts = RobotOptions::new("panda");
    opts.q = Some(vec![0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04]);
    let r = w.add_robot(model, &opts).unwrap();
    w.add_object(ObjectDesc::new(
        "box",
        Shape::Box {
            half_extents: Vector3::new(0.03, 0.03, 0.03),
        },
        Isometry3::translation(0.5, 0.0, 0.2),
    ))
    .unwrap();
    (w, r)
}

#[test]
fn trajectory_execution_is_deterministic_and_tracks() {
    let run = || {
        let (mut w, r) = scene();
        let q0 = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785];
        let n = 101;
        let mut pos = Vec::new();
        for i in 0..n {
            let s = i as f64 / (n - 1) as f64;
            let s = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            pos.extend(q0.iter().map(|q| q + 0.4 * s));
        }
        let ix: Vec<usize> = (0..7).collect();
        let rep = execute_trajectory(&mut w, r, &pos, 0.01, None, Some(&ix), 0.2).unwrap();
        (rep, w.object_pose(0))
    };
    let (a, pa) = run();
    let (b, pb) = run();
    assert_eq!(a, b);
    assert_eq!(pa, pb);
    assert!(a.max_error.iter().all(|e| *e < 5e-3), "{:?}", a.max_error);
    assert!(
        a.final_error.iter().all(|e| *e < 1e-3),
        "{:?}",
        a.final_error
    );
}

#[test]
fn diverging_simulation_is_an_error() {
    let (mut w, _) = scene();
    w.set_object_velocity(0, &Vector3::new(1e6, 0.0, 0.0), &Vector3::zeros())
        .unwrap();
    assert!(matches!(w.step(1), Err(SimError::Diverged(_))));
}
