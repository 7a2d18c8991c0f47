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

/// A Panda holding its "ready" pose without a ground (the hand points
/// down, the fingers close horizontally), fingers open.
fn panda_ready(w: &mut World) -> (Arc<ferrobot_model::RobotModel>, usize) {
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let r = w
        .add_robot(model.clone(), &RobotOptions::new("panda"))
        .unwrap();
    let mut q = model.named_state("ready", None).unwrap();
    q[7] = 0.04;
    w.with_robot(r, |rb, s| {
        rb.set_joint_positions(s, &q)?;
        rb.set_position_targets(s, &q, None)
    })
    .unwrap();
    w.step(24).unwrap();
    (model, r)
}

#[test]
fn free_gripper_closes_at_its_velocity_limit() {
    // Hand derivation: the Panda URDF limits the finger joint to 0.2 m/s,
    // so a position servo that honours it closes the free fingers from
    // 0.04 m to 0 in 0.04 / 0.2 = 0.2 s (48 steps at 240 Hz), at 0.2 m/s
    // in between (the PD, tracking a moving setpoint with feed-forward,
    // adds at most a step or two of lag).
    let mut w = world(false);
    let (model, r) = panda_ready(&mut w);
    let limit = model.velocity_limits()[7];
    assert_eq!(limit, 0.2, "the Panda URDF's finger velocity limit");
    w.with_robot(r, |rb, s| rb.close_gripper(s, None)).unwrap();
    let dt = w.config().dt;
    let mut track = Vec::new();
    for _ in 0..96 {
        w.step(1).unwrap();
        track.push(w.robot(r).unwrap().joint_positions(w.state())[7]);
    }
    // Mid-stroke speed over 0.1 s (24 steps) from 0.01 s on.
    let speed = (track[2] - track[26]) / (24.0 * dt);
    assert!(
        (speed - limit).abs() < 0.02 * limit,
        "mid-stroke speed {speed} m/s, limit {limit}"
    );
    let expected = 0.04 / limit;
    let arrive = track
        .iter()
        .position(|&x| x < 5e-4)
        .map(|k| (k + 1) as f64 * dt);
    let arrive = arrive.expect("the fingers close within 0.4 s");
    assert!(
        (arrive - expected).abs() <= 3.0 * dt,
        "closed after {arrive} s, expected {expected} s"
    );
    // And opening again from closed takes as long.
    w.with_robot(r, |rb, s| rb.open_gripper(s, None)).unwrap();
    let mut k = 0;
    while w.robot(r).unwrap().joint_positions(w.state())[7] < 0.04 - 5e-4 {
        w.step(1).unwrap();
        k += 1;
        assert!(k < 96, "the fingers open within 0.4 s");
    }
    assert!(
        (k as f64 * dt - expected).abs() <= 3.0 * dt,
        "opened after {} s, expected {expected} s",
        k as f64 * dt
    );
}

/// Sum of the normal contact forces (N) on collider `c` over the last step.
fn normal_force_on(w: &World, c: rapier3d::prelude::ColliderHandle) -> f64 {
    let dt = w.config().dt;
    w.state()
        .narrow_phase
        .contact_pairs()
        .filter(|p| p.collider1 == c || p.collider2 == c)
        .flat_map(|p| p.manifolds())
        .flat_map(|m| m.points.iter())
        .map(|pt| pt.data.impulse as f64)
        .sum::<f64>()
        / dt
}

#[test]
fn squeeze_at_rest_is_the_effort_cap() {
    // A fixed 30 mm block between the pads; the gripper's driver closes
    // with its force limit `effort` (N). Once at rest the drive must push
    // with exactly that cap, whatever the setpoint did on the way (it
    // stops at the drive's reach, anti-windup). By virtual work the
    // Panda's two fingers, the mimic follower moving with the driver,
    // share it: effort · δq = (f1 + f2) · δq, so the block feels `effort`
    // in all. Measured from the contact impulses, calibrated first on a
    // block resting on the ground (its weight m g).
    let mut g = world(true);
    let mut rest = ObjectDesc::new(
        "weight",
        Shape::Box {
            half_extents: Vector3::new(0.05, 0.05, 0.05),
        },
        Isometry3::translation(0.0, 0.0, 0.05),
    );
    rest.mass = 2.0;
    let i = g.add_object(rest).unwrap();
    g.step(240).unwrap();
    let weight = normal_force_on(&g, g.objects()[i].collider);
    assert!(
        (weight - 2.0 * 9.81).abs() < 0.02 * 2.0 * 9.81,
        "m g read as {weight}"
    );

    let mut w = world(false);
    let (model, r) = panda_ready(&mut w);
    let robot = w.robot(r).unwrap();
    let hand = robot.link_pose(w.state(), model.link("panda_hand").unwrap());
    let l = robot.link_pose(w.state(), model.link("panda_leftfinger").unwrap());
    let rr = robot.link_pose(w.state(), model.link("panda_rightfinger").unwrap());
    // Pads: the fingers' inner faces 36-54 mm beyond the finger frames
    // along the hand's z.
    let centre = (l.translation.vector + rr.translation.vector) / 2.0
        + hand.rotation * Vector3::new(0.0, 0.0, 0.045);
    let mut block = ObjectDesc::new(
        "block",
        Shape::Box {
            half_extents: Vector3::new(0.01, 0.015, 0.006),
        },
        Isometry3::from_parts(centre.into(), hand.rotation),
    );
    block.is_static = true;
    let b = w.add_object(block).unwrap();
    for effort in [10.0, 30.0] {
        w.with_robot(r, |rb, s| rb.set_gripper_driver(s, 0.0, Some(effort)))
            .unwrap();
        assert_eq!(w.robot(r).unwrap().drives()[7].max_force, effort);
        w.step(240).unwrap();
        let q = w.robot(r).unwrap().joint_positions(w.state());
        assert!(
            (q[7] - 0.015).abs() < 1.5e-3,
            "finger held at {} m on the 30 mm block",
            q[7]
        );
        let total = normal_force_on(&w, w.objects()[b].collider);
        assert!(
            (total - effort).abs() < 0.02 * effort,
            "a {effort} N driver effort pressed the block with {total} N in all"
        );
        // Reopening starts at once: the setpoint was not buried in the
        // block, so the fingers leave it within two steps.
        w.with_robot(r, |rb, s| rb.open_gripper(s, None)).unwrap();
        w.step(2).unwrap();
        let q = w.robot(r).unwrap().joint_positions(w.state());
        assert!(
            q[7] > 0.0152,
            "finger at {} m two steps after opening",
            q[7]
        );
        w.step(120).unwrap();
    }
}
