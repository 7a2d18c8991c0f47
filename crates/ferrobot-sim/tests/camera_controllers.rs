//! Cameras against analytic depth, conventions, controllers, trajectory
//! execution, determinism and divergence.

use std::sync::Arc;

use ferrobot_sim::camera::{Camera, Intrinsics};
use ferrobot_sim::conventions::{depth_to_points, look_at, opencv_to_opengl, opengl_to_opencv};
use ferrobot_sim::{
    JointPid, ObjectDesc, ObjectShape, ResolvedRate, RobotOptions, SimError, World, WorldConfig,
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
    let (pts, _) = depth_to_points(&frame.depth, &intr).unwrap();
    for p in pts {
        let wp = pose * Point3::new(p[0], p[1], p[2]);
        assert!(wp.z.abs() < 1e-5);
    }
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
        ObjectShape::Box {
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
