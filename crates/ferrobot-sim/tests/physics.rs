//! Behaviour against analytic physics and the model's kinematics.

use std::sync::Arc;

use ferrobot_sim::{ObjectDesc, RobotOptions, Shape, SimError, World, WorldConfig};
use nalgebra::{Isometry3, Vector3};

fn world(ground: bool) -> World {
    World::new(WorldConfig {
        ground,
        ..Default::default()
    })
    .unwrap()
}

#[test]
fn free_fall_matches_analytic() {
    let mut w = world(false);
    let i = w
        .add_object(ObjectDesc::new(
            "ball",
            Shape::Sphere { radius: 0.05 },
            Isometry3::translation(0.0, 0.0, 10.0),
        ))
        .unwrap();
    w.step(240).unwrap();
    let t = w.time();
    let z = w.object_pose(i).translation.z;
    // Exact z0 - g t^2 / 2 up to the integrator's O(g t dt) error.
    let exact = 10.0 - 0.5 * 9.81 * t * t;
    assert!(
        (z - exact).abs() < 9.81 * t / 240.0,
        "z {z} vs exact {exact}"
    );
    let (v, _) = w.object_velocity(i);
    assert!((v.z + 9.81 * t).abs() < 1e-3);
}

#[test]
fn box_rests_on_ground_at_half_height() {
    let mut w = world(true);
    let i = w
        .add_object(ObjectDesc::new(
            "box",
            Shape::Box {
                half_extents: Vector3::new(0.1, 0.1, 0.05),
            },
            Isometry3::translation(0.0, 0.0, 0.2),
        ))
        .unwrap();
    w.step(480).unwrap();
    let z = w.object_pose(i).translation.z;
    assert!((z - 0.05).abs() < 2e-3, "resting height {z}");
}

#[test]
fn panda_teleport_matches_fk_and_mimic_follows() {
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let mut w = world(true);
    let base = Isometry3::translation(0.3, -0.2, 0.1);
    let mut opts = RobotOptions::new("panda");
    opts.pose = base;
    let r = w.add_robot(model.clone(), &opts).unwrap();
    let q = vec![0.3, -0.5, 0.2, -2.0, 0.1, 1.6, 0.7, 0.03];
    w.with_robot(r, |rb, s| rb.set_joint_positions(s, &q))
        .unwrap();
    let got = w.robot(r).unwrap().joint_positions(w.state());
    for (a, b) in got.iter().zip(&q) {
        assert!((a - b).abs() < 1e-5, "{got:?} vs {q:?}");
    }
    let fk = model.fk_all(&q).unwrap();
    for (l, pose) in fk.iter().enumerate() {
        let sim = w.robot(r).unwrap().link_pose(w.state(), l);
        let expect = base * pose;
        let d = (sim.translation.vector - expect.translation.vector).norm();
        let a = sim.rotation.angle_to(&expect.rotation);
        assert!(d < 1e-5 && a < 1e-5, "link {l}: {d} m, {a} rad");
    }
    // Hold the pose: drives target q, gravity compensated.
    w.with_robot(r, |rb, s| rb.set_position_targets(s, &q, None))
        .unwrap();
    w.step(240).unwrap();
    let held = w.robot(r).unwrap().joint_positions(w.state());
    for (a, b) in held.iter().zip(&q) {
        assert!((a - b).abs() < 1e-3, "held {held:?} vs {q:?}");
    }
    // The mimic finger follows the driver through the coupling.
    w.with_robot(r, |rb, s| rb.open_gripper(s, None)).unwrap();
    w.step(240).unwrap();
    let robot = w.robot(r).unwrap();
    let f1 = model.link("panda_leftfinger").unwrap();
    let f2 = model.link("panda_rightfinger").unwrap();
    let hand = model.link("panda_hand").unwrap();
    let p1 = robot.link_pose(w.state(), hand).inverse() * robot.link_pose(w.state(), f1);
    let p2 = robot.link_pose(w.state(), hand).inverse() * robot.link_pose(w.state(), f2);
    let q = robot.joint_positions(w.state());
    assert!((q[7] - 0.04).abs() < 1e-3, "finger {}", q[7]);
    assert!(((p1.translation.y - p2.translation.y).abs() - 0.08).abs() < 2e-3);
}

#[test]
fn bad_inputs_are_errors() {
    let mut w = world(true);
    let mut d = ObjectDesc::new("b", Shape::Sphere { radius: 0.1 }, Isometry3::identity());
    d.mass = -1.0;
    assert!(matches!(w.add_object(d), Err(SimError::InvalidArgument(_))));
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let r = w.add_robot(model, &RobotOptions::new("p")).unwrap();
    let e = w.with_robot(r, |rb, s| rb.set_position_targets(s, &[0.0], Some(&[12])));
    assert!(matches!(e, Err(SimError::UnknownName(_))));
    let e = w.with_robot(r, |rb, s| rb.set_joint_positions(s, &[0.0; 3]));
    assert!(matches!(e, Err(SimError::Shape { .. })));
    let e = w.with_robot(r, |rb, s| rb.set_joint_positions(s, &[f64::NAN; 8]));
    assert!(matches!(e, Err(SimError::NonFinite(_))));
}

/// The robot's extra substeps are used only while it touches something other
/// than itself or a joint nears a limit its drive pushes towards.
#[test]
fn extra_substeps_only_while_touching_or_near_a_limit() {
    const Q: [f64; 8] = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let mut opts = RobotOptions::new("panda");
    opts.q = Some(Q.to_vec());
    // Free in the air (the open fingers rest at their upper limit, held there).
    let mut w = world(false);
    let r = w.add_robot(model.clone(), &opts).unwrap();
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q, None))
        .unwrap();
    w.step(20).unwrap();
    assert_eq!(w.robot(r).unwrap().active_solver_iterations(), 0);
    // Holding still and touching nothing: one substep.
    assert_eq!(w.robot(r).unwrap().active_substeps(), 1);
    // Moving towards a new target (away from the limits): the world's 4.
    let mut moved = Q;
    moved[0] = 0.3;
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &moved, None))
        .unwrap();
    w.step(2).unwrap();
    assert_eq!(w.robot(r).unwrap().active_substeps(), 4);
    assert_eq!(w.robot(r).unwrap().active_solver_iterations(), 0);
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q, None))
        .unwrap();
    w.step(480).unwrap();
    assert_eq!(w.robot(r).unwrap().active_substeps(), 1);
    // Driven beyond joint 4's upper limit (-0.0698 rad): on once it gets near.
    let mut beyond = Q;
    beyond[3] = 0.3;
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &beyond, None))
        .unwrap();
    w.step(240).unwrap();
    assert_eq!(w.robot(r).unwrap().active_solver_iterations(), 4);
    // The world's 4 substeps plus the robot's 4 extra.
    assert_eq!(w.robot(r).unwrap().active_substeps(), 8);
    // Back to the free pose: off again.
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q, None))
        .unwrap();
    w.step(240).unwrap();
    assert_eq!(w.robot(r).unwrap().active_solver_iterations(), 0);
    // A box between the fingers (hand at about (0.48, 0, 0.41)): on.
    let mut w = world(false);
    let r = w.add_robot(model, &opts).unwrap();
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q, None))
        .unwrap();
    let mut d = ObjectDesc::new(
        "box",
        Shape::Box {
            half_extents: Vector3::new(0.02, 0.02, 0.02),
        },
        Isometry3::translation(0.484, 0.0, 0.42),
    );
    d.is_static = true;
    w.add_object(d).unwrap();
    w.step(5).unwrap();
    assert_eq!(w.robot(r).unwrap().active_solver_iterations(), 4);
}
