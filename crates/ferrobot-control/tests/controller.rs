//! Behaviour of the controllers against independent references: parry's
//! exact distances, hand geometry, finite differences of forward
//! kinematics, and closed-loop runs on the bundled Panda.

use std::sync::{Arc, OnceLock};

use ferrobot_collision::acm::{AllowedCollisions, AnalyzeCollisions};
use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{CollisionChecker, CollisionWorld, RobotSpheres, Shape};
use ferrobot_control::ControllerCore;
use ferrobot_control::{
    GuidanceStatus, LinkClearance, PotentialFieldConfig, PotentialFieldController, ReactiveConfig,
    ReactiveController,
};
use ferrobot_model::RobotModel;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};

/// The bundled Panda and its 59-sphere model (made once).
fn panda() -> (Arc<RobotModel>, RobotSpheres, AllowedCollisions) {
    static CELL: OnceLock<(Arc<RobotModel>, RobotSpheres, AllowedCollisions)> = OnceLock::new();
    CELL.get_or_init(|| {
        let model = Arc::new(ferrobot_model::robots::panda().unwrap());
        let options = SpherizeOptions {
            total_budget: Some(59),
            ..Default::default()
        };
        let (links, _) = spherize_robot(&model, &options).unwrap();
        let spheres = RobotSpheres::new(&model, links).unwrap();
        // Link pairs never or always touching over sampled configurations
        // are not checked (MoveIt setup-assistant style), as the bindings do.
        let mut acm = AllowedCollisions::from_model(&model);
        acm.analyze(&model, &spheres, 2000, 0).unwrap();
        (model, spheres, acm)
    })
    .clone()
}

fn checker(world: CollisionWorld) -> CollisionChecker {
    let (model, spheres, acm) = panda();
    CollisionChecker::new(model, spheres, acm, world).unwrap()
}

fn ready(model: &RobotModel) -> Vec<f64> {
    model.named_state("ready", None).unwrap()
}

fn at(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::identity())
}

/// Runs the closed loop kinematically (the robot follows the targets
/// exactly) for `steps` steps of `dt`; calls `each` after every step.
fn run(
    ctl: &mut ReactiveController,
    q: &mut Vec<f64>,
    qd: &mut Vec<f64>,
    dt: f64,
    steps: usize,
    mut each: impl FnMut(&mut ReactiveController, usize, &[f64]),
) {
    for i in 0..steps {
        let out = ctl.step(q, qd, dt).unwrap();
        *q = out.q_target;
        *qd = out.qd_target;
        each(ctl, i, q);
    }
}

#[test]
fn sphere_distances_match_parry_and_finite_differences() {
    let mut world = CollisionWorld::new();
    world
        .add_shape("ball", Shape::Sphere { radius: 0.07 }, at(0.45, 0.2, 0.45))
        .unwrap();
    world
        .add_shape(
            "crate",
            Shape::Box {
                half_extents: Vector3::new(0.1, 0.15, 0.05),
            },
            Isometry3::from_parts(
                Translation3::new(0.4, -0.3, 0.3),
                UnitQuaternion::from_euler_angles(0.3, -0.2, 0.7),
            ),
        )
        .unwrap();
    let ck = checker(world.clone());
    let ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let model = ctl.model().clone();
    let q = ready(&model);
    let mut core = ctl.core().clone();
    let (dist, _dirs, grads, centers) = core.sphere_distances(&q, 10.0).unwrap();
    // Reference: parry's ball-ball and ball-cuboid distances (f32) between
    // each robot sphere, placed by the model's own FK, and each obstacle.
    let poses = model.fk_all(&q).unwrap();
    let to_pose = |iso: &Isometry3<f64>| {
        let t = iso.translation.vector;
        let r = iso.rotation.coords;
        parry3d::math::Pose::from_parts(
            parry3d::math::Vector::new(t.x as f32, t.y as f32, t.z as f32),
            parry3d::math::Rot3::from_xyzw(r[0] as f32, r[1] as f32, r[2] as f32, r[3] as f32),
        )
    };
    let ball = parry3d::shape::Ball::new(0.07);
    let cuboid = parry3d::shape::Cuboid::new(parry3d::math::Vector::new(0.1, 0.15, 0.05));
    let mut i = 0;
    let mut checked = 0;
    for (l, spheres) in ck.spheres().links.iter().enumerate() {
        for s in spheres {
            let c = poses[l] * s.center;
            assert!((c - centers[i]).norm() < 1e-9);
            let me = parry3d::shape::Ball::new(s.radius as f32);
            let mp = to_pose(&Isometry3::from_parts(
                c.coords.into(),
                UnitQuaternion::identity(),
            ));
            let d1 = parry3d::query::distance(&mp, &me, &to_pose(&world.objects()[0].pose), &ball)
                .unwrap()
                .distance as f64;
            let d2 = parry3d::query::distance(&mp, &me, &to_pose(&world.objects()[1].pose), &cuboid)
                .unwrap()
                .distance as f64;
            let reference = d1.min(d2);
            if reference > 0.0 {
                assert!(
                    (dist[i] - reference).abs() < 1e-5,
                    "sphere {i}: {} vs parry {reference}",
                    dist[i]
                );
                checked += 1;
            }
            i += 1;
        }
    }
    assert_eq!(i, 59);
    assert!(checked > 50);
    // Gradients in q against central differences of the distance itself.
    let h = 1e-6;
    for (s, g) in grads.iter().enumerate().step_by(5) {
        for dof in 0..7 {
            let mut qp = q.clone();
            let mut qm = q.clone();
            qp[dof] += h;
            qm[dof] -= h;
            let dp = core.sphere_distances(&qp, 10.0).unwrap().0[s];
            let dm = core.sphere_distances(&qm, 10.0).unwrap().0[s];
            let fd = (dp - dm) / (2.0 * h);
            assert!(
                (g[dof] - fd).abs() < 1e-4,
                "sphere {s} dof {dof}: {} vs {fd}",
                g[dof]
            );
        }
    }
}

#[test]
fn converges_to_a_reachable_target_without_obstacles() {
    let ck = checker(CollisionWorld::new());
    let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let model = ctl.model().clone();
    let mut goal = ready(&model);
    for (i, v) in [0.5, 0.3, -0.4, -0.4, 0.3, 0.4, -0.5].iter().enumerate() {
        goal[i] += v;
    }
    let target = model.fk(&goal, None).unwrap();
    ctl.core_mut().set_target(target, true).unwrap();
    let mut q = ready(&model);
    let mut qd = vec![0.0; q.len()];
    run(&mut ctl, &mut q, &mut qd, 0.01, 600, |_, _, _| {});
    let ee = model.fk(&q, None).unwrap();
    let dp = (ee.translation.vector - target.translation.vector).norm();
    let dr = ee.rotation.angle_to(&target.rotation);
    assert!(dp < 2e-3, "position error {dp}");
    assert!(dr < 1e-2, "rotation error {dr}");
    assert!(qd.iter().all(|v| v.abs() < 1e-2), "not at rest: {qd:?}");
}

#[test]
fn joint_limits_and_velocity_limits_are_respected() {
    let ck = checker(CollisionWorld::new());
    let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let model = ctl.model().clone();
    // A target far out of reach pulls the arm into its limits.
    ctl.core_mut()
        .set_target(at(1.6, 0.9, -0.2), false)
        .unwrap();
    let (lo, hi, vmax) = (
        model.lower_limits(),
        model.upper_limits(),
        model.velocity_limits(),
    );
    let mut q = ready(&model);
    let mut qd = vec![0.0; q.len()];
    run(&mut ctl, &mut q, &mut qd, 0.01, 400, |_, _, q| {
        for d in 0..7 {
            assert!(
                q[d] >= lo[d] && q[d] <= hi[d],
                "joint {d} at {} outside [{}, {}]",
                q[d],
                lo[d],
                hi[d]
            );
        }
    });
    for d in 0..7 {
        assert!(qd[d].abs() <= vmax[d] + 1e-9);
    }
}

/// A world with one obstacle, "ball" (a 5 cm sphere), at `start`.
fn ball_world(start: Vector3<f64>) -> CollisionWorld {
    let mut world = CollisionWorld::new();
    world
        .add_shape(
            "ball",
            Shape::Sphere { radius: 0.05 },
            at(start.x, start.y, start.z),
        )
        .unwrap();
    world
}

/// Flies the obstacle "ball" of `world` (and of the controller's world)
/// from `start` along `dir` at `speed` (m/s) through the aim point and on
/// for 1.2 m in total, over 400 closed-loop steps of 5 ms from rest at
/// `q0`; returns the smallest sphere clearance (the controller's spheres)
/// and the smallest exact link clearance (`clear`) seen after each step.
fn fly_ball(
    ctl: &mut ReactiveController,
    world: &mut CollisionWorld,
    clear: &LinkClearance,
    q0: &[f64],
    start: Vector3<f64>,
    dir: Vector3<f64>,
    speed: f64,
) -> (f64, f64) {
    let mut q = q0.to_vec();
    let mut qd = vec![0.0; q.len()];
    let dt = 0.005;
    let mut worst = f64::INFINITY;
    let mut worst_exact = f64::INFINITY;
    for i in 0..400 {
        let t = (i as f64 * dt).min(2.4);
        let c = start + dir * speed * t;
        ctl.set_obstacle_pose(
            "ball",
            at(c.x, c.y, c.z),
            Some([dir.x * speed, dir.y * speed, dir.z * speed, 0.0, 0.0, 0.0]),
        )
        .unwrap();
        world.set_pose("ball", at(c.x, c.y, c.z)).unwrap();
        let out = ctl.step(&q, &qd, dt).unwrap();
        q = out.q_target;
        qd = out.qd_target;
        let (d, ..) = ctl.core().clone().sphere_distances(&q, 10.0).unwrap();
        worst = worst.min(d.iter().cloned().fold(f64::INFINITY, f64::min));
        worst_exact = worst_exact.min(clear.clearance(&q, world).unwrap().distance);
    }
    (worst, worst_exact)
}

/// A ball flying at the arm at 0.5 m/s while it holds its pose: the
/// sphere model never touches it, nor does the exact link geometry.
#[test]
fn never_enters_obstacles_in_scripted_approaches() {
    let (model, ..) = panda();
    let clear = LinkClearance::new(model.clone()).unwrap();
    let q0 = ready(&model);
    let poses = model.fk_all(&q0).unwrap();
    let link = |n: &str| poses[model.link(n).unwrap()].translation.vector;
    // Aim at the hand, the elbow (link 4) and the forearm (link 5), from
    // the side, from the front and from above.
    let cases = [
        (link("panda_hand"), Vector3::new(0.0, -1.0, 0.0)),
        (link("panda_link4"), Vector3::new(0.0, -1.0, 0.0)),
        (link("panda_link5"), Vector3::new(0.0, 0.0, -1.0)),
        (link("panda_hand"), Vector3::new(-0.6, 0.8, 0.0)),
    ];
    for (k, (aim, dir)) in cases.iter().enumerate() {
        let speed = 0.5;
        let start = aim - dir * 0.6;
        let mut world = ball_world(start);
        let ck = checker(world.clone());
        let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
        let target = model.fk(&q0, None).unwrap();
        ctl.core_mut().set_target(target, true).unwrap();
        let (d0, ..) = ctl.core().clone().sphere_distances(&q0, 10.0).unwrap();
        let start_clear = d0.iter().cloned().fold(f64::INFINITY, f64::min);
        assert!(
            start_clear > 0.25,
            "case {k} starts {start_clear} m from the arm"
        );
        let (worst, worst_exact) = fly_ball(&mut ctl, &mut world, &clear, &q0, start, *dir, speed);
        assert!(worst > 0.0, "case {k}: spheres reached {worst}");
        assert!(worst_exact > 0.0, "case {k}: links reached {worst_exact}");
    }
}

#[test]
fn potential_field_converges_without_obstacles() {
    let ck = checker(CollisionWorld::new());
    let mut ctl =
        PotentialFieldController::new(&ck, None, PotentialFieldConfig::default()).unwrap();
    let model = ctl.model().clone();
    let mut goal = ready(&model);
    for (i, v) in [0.4, 0.2, -0.3, -0.4, 0.2, 0.3, -0.3].iter().enumerate() {
        goal[i] += v;
    }
    let target = model.fk(&goal, None).unwrap();
    ctl.core_mut().set_target(target, true).unwrap();
    let mut q = ready(&model);
    let mut qd = vec![0.0; q.len()];
    for _ in 0..2000 {
        let out = ctl.step(&q, &qd, 0.01).unwrap();
        q = out.q_target;
        qd = out.qd_target;
    }
    let ee = model.fk(&q, None).unwrap();
    let dp = (ee.translation.vector - target.translation.vector).norm();
    assert!(dp < 1e-2, "position error {dp}");
}

#[test]
fn potential_field_distances_follow_the_exact_ones() {
    let mut world = CollisionWorld::new();
    world
        .add_shape("ball", Shape::Sphere { radius: 0.08 }, at(0.5, 0.0, 0.5))
        .unwrap();
    let ck = checker(world);
    let ctl = PotentialFieldController::new(&ck, None, PotentialFieldConfig::default()).unwrap();
    let part = &ctl.core().world().parts()[0];
    for p in [
        Point3::new(0.6, 0.05, 0.52),
        Point3::new(0.4, -0.1, 0.62),
        Point3::new(0.5, 0.0, 0.33),
    ] {
        let (d, g) = ferrobot_control::ControlWorld::field_distance(part, &p).unwrap();
        let exact = (p - Point3::new(0.5, 0.0, 0.5)).norm() - 0.08;
        assert!((d - exact).abs() < 2e-3, "{d} vs {exact}");
        assert!(
            g.normalize()
                .dot(&(p - Point3::new(0.5, 0.0, 0.5)).normalize())
                > 0.99
        );
    }
}

#[test]
fn bad_inputs_are_errors() {
    let ck = checker(CollisionWorld::new());
    let mut cfg = ReactiveConfig::default();
    assert!(cfg.set("target_gain", -1.0).is_err());
    assert!(cfg.set("target_gain", f64::NAN).is_err());
    assert!(cfg.set("no_such_gain", 1.0).is_err());
    cfg.collision_distance = 0.0;
    assert!(ReactiveController::new(&ck, None, cfg).is_err());
    let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let q = ready(ctl.model());
    let qd = vec![0.0; q.len()];
    assert!(ctl.step(&q[..7], &qd, 0.01).is_err());
    assert!(ctl.step(&q, &qd[..3], 0.01).is_err());
    assert!(ctl.step(&q, &qd, 0.0).is_err());
    assert!(ctl.step(&q, &qd, f64::NAN).is_err());
    let mut bad = q.clone();
    bad[2] = f64::NAN;
    assert!(ctl.step(&bad, &qd, 0.01).is_err());
    assert!(
        ctl.set_obstacle_pose("nothing", at(0.0, 0.0, 0.0), None)
            .is_err()
    );
    let pf = PotentialFieldConfig {
        field_padding: 0.05,
        ..Default::default()
    };
    assert!(PotentialFieldController::new(&ck, None, pf).is_err());
}

/// A target whose configuration puts joint 4 within 3 cm (rad) of its lower
/// limit: in the limit-aware coordinates nothing pushes away from the
/// limit, so the target is reached (the earlier limit repulsion left a
/// standing offset of centimetres there) and the limit is never crossed.
#[test]
fn reaches_a_target_next_to_a_joint_limit() {
    let ck = checker(CollisionWorld::new());
    let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let model = ctl.model().clone();
    let lo = model.lower_limits();
    let mut goal = ready(&model);
    goal[0] += 0.3;
    goal[3] = lo[3] + 0.03;
    goal[5] += 0.3;
    let target = model.fk(&goal, None).unwrap();
    ctl.core_mut().set_target(target, true).unwrap();
    // Posture at the goal's side of the redundancy (a user's comfortable posture).
    ctl.core_mut().set_posture(&goal).unwrap();
    let mut q = ready(&model);
    let mut qd = vec![0.0; q.len()];
    let mut lowest = f64::INFINITY;
    run(&mut ctl, &mut q, &mut qd, 0.01, 800, |_, _, q| {
        lowest = lowest.min(q[3] - lo[3]);
    });
    let ee = model.fk(&q, None).unwrap();
    let dp = (ee.translation.vector - target.translation.vector).norm();
    let dr = ee.rotation.angle_to(&target.rotation);
    assert!(dp < 3e-3, "position error {dp}");
    assert!(dr < 2e-2, "rotation error {dr}");
    assert!(
        lowest >= ReactiveConfig::default().limit_buffer - 1e-9,
        "limit margin {lowest}"
    );
}

/// Global guidance: waypoints are followed in order (each passed within
/// the tolerance), then the end-effector target takes over; a stall is
/// reported when the arm rests away from an unreachable target.
#[test]
fn waypoints_are_followed_then_the_target_and_stalls_are_reported() {
    let ck = checker(CollisionWorld::new());
    let mut ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let model = ctl.model().clone();
    let start = ready(&model);
    let mut mid = start.clone();
    mid[0] += 0.6;
    mid[1] -= 0.3;
    let mut end = mid.clone();
    end[2] += 0.4;
    end[5] += 0.3;
    let target = model.fk(&end, None).unwrap();
    ctl.core_mut().set_target(target, true).unwrap();
    ctl.set_waypoints(&[mid[..7].to_vec(), end.clone()])
        .unwrap();
    assert!(ctl.set_waypoints(&[vec![0.0; 3]]).is_err());
    assert!(ctl.set_waypoints(&[vec![f64::NAN; 8]]).is_err());
    ctl.set_waypoints(&[mid[..7].to_vec(), end.clone()])
        .unwrap();
    let (mut q, mut qd) = (start.clone(), vec![0.0; start.len()]);
    let mut passed_mid = false;
    let mut remaining = 2;
    run(&mut ctl, &mut q, &mut qd, 0.01, 800, |c, _, q| {
        let gap = (0..7).map(|d| (q[d] - mid[d]).abs()).fold(0.0, f64::max);
        passed_mid |= gap < ReactiveConfig::default().waypoint_tolerance + 1e-9;
        assert!(
            c.waypoints_remaining() <= remaining,
            "waypoints never come back"
        );
        remaining = c.waypoints_remaining();
    });
    assert!(passed_mid, "the first waypoint was not visited");
    assert_eq!(ctl.waypoints_remaining(), 0);
    let ee = model.fk(&q, None).unwrap();
    assert!((ee.translation.vector - target.translation.vector).norm() < 3e-3);
    // Out of reach: the arm comes to rest short of it and the step says so.
    ctl.core_mut()
        .set_target(at(1.6, 0.9, -0.2), false)
        .unwrap();
    let mut stalled = false;
    for _ in 0..800 {
        let out = ctl.step(&q, &qd, 0.01).unwrap();
        stalled |= out.info.stalled;
        q = out.q_target;
        qd = out.qd_target;
    }
    assert!(
        stalled,
        "no stall reported at rest away from an unreachable target"
    );
}

/// Global guidance in the library: a plate between the hand and a target
/// under it is a local minimum. Without guidance the arm stays away from
/// the target; with it the controller detects the stall and plans on its
/// own (blocking, and on a background thread), hands the path over as
/// waypoints, reports its status every step and never touches the plate
/// (exact link geometry, parry).
#[test]
fn guidance_plans_out_of_a_local_minimum() {
    let (model, ..) = panda();
    let clear = LinkClearance::new(model.clone()).unwrap();
    let mut world = CollisionWorld::new();
    world
        .add_shape(
            "plate",
            Shape::Box {
                half_extents: Vector3::new(0.08, 0.12, 0.01),
            },
            at(0.45, 0.0, 0.42),
        )
        .unwrap();
    let ck = checker(world.clone());
    let q0 = ready(&model);
    let target = Isometry3::from_parts(
        Translation3::new(0.45, 0.0, 0.15),
        model.fk(&q0, None).unwrap().rotation,
    );
    let run_with = |plans: f64, blocking: f64| {
        let cfg = ReactiveConfig {
            guidance_plans: plans,
            guidance_blocking: blocking,
            ..Default::default()
        };
        let mut ctl = ReactiveController::new(&ck, None, cfg).unwrap();
        assert!(ctl.guidance_error().is_none());
        let out = ctl.step(&q0, &vec![0.0; q0.len()], 0.01).unwrap();
        assert_eq!(
            out.info.guidance,
            if plans > 0.0 {
                GuidanceStatus::Idle
            } else {
                GuidanceStatus::Off
            }
        );
        ctl.core_mut().set_target(target, true).unwrap();
        let (mut q, mut qd) = (q0.clone(), vec![0.0; q0.len()]);
        let mut seen = Vec::new();
        let mut lowest = f64::INFINITY;
        // 24 s of controller time: enough for the three plans' stalls and the
        // final one that exhausts the budget (with the faster IK of plan23c the
        // last stall came just after 12 s).
        for _ in 0..2400 {
            let out = ctl.step(&q, &qd, 0.01).unwrap();
            if seen.last() != Some(&out.info.guidance) {
                seen.push(out.info.guidance);
            }
            q = out.q_target;
            qd = out.qd_target;
            lowest = lowest.min(clear.clearance(&q, &world).unwrap().distance);
            if !blocking_is_async(blocking) {
                continue;
            }
            // Background planning takes wall time, not controller time:
            // give the thread a moment while the loop keeps running.
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        let ee = model.fk(&q, None).unwrap();
        let dp = (ee.translation.vector - target.translation.vector).norm();
        (dp, seen, lowest, ctl.guidance_last_plan().cloned())
    };
    fn blocking_is_async(b: f64) -> bool {
        b == 0.0
    }
    let (dp, seen, lowest, last) = run_with(0.0, 1.0);
    assert!(dp > 0.05, "the plate is not a local minimum here ({dp} m)");
    assert!(seen.iter().all(|s| *s == GuidanceStatus::Off), "{seen:?}");
    assert!(last.is_none());
    assert!(lowest > 0.0, "touched the plate: {lowest}");
    for blocking in [1.0, 0.0] {
        let (dp, seen, lowest, last) = run_with(3.0, blocking);
        let last = last.expect("a plan was attempted");
        assert_eq!(last.status, "solved", "{last:?}");
        assert!(last.waypoints >= 2, "{last:?}");
        assert!(lowest > 0.0, "touched the plate: {lowest}");
        assert_eq!(seen.first(), Some(&GuidanceStatus::Tracking), "{seen:?}");
        assert!(seen.contains(&GuidanceStatus::Guided), "{seen:?}");
        if blocking == 0.0 {
            assert!(seen.contains(&GuidanceStatus::Planning), "{seen:?}");
        }
        // Known limit (see BENCHMARKS.md): the planner's path hugs the plate
        // (no clearance margin) and the avoidance policies hold the arm off
        // it, so the arm rests short of a waypoint; the controller then
        // drops the path, stalls again and re-plans until the budget is
        // spent. It never hangs in `guided`, and never touches the plate.
        assert!(
            matches!(
                seen.last(),
                Some(GuidanceStatus::Reached | GuidanceStatus::Exhausted)
            ),
            "ends {dp} m from the target in {seen:?}"
        );
    }
}

#[test]
fn guidance_config_counts_are_whole_numbers() {
    let ck = checker(CollisionWorld::new());
    for (name, v) in [("guidance_plans", 2.5), ("guidance_blocking", 0.5)] {
        let mut cfg = ReactiveConfig::default();
        cfg.set(name, v).unwrap();
        let err = ReactiveController::new(&ck, None, cfg).unwrap_err();
        assert!(err.to_string().contains(name), "{err}");
    }
}

/// The exact layer of the velocity filter on a sphere model that does not
/// cover the links (the automatic spheres shrunk to 30% of their radii):
/// balls flying at the arm never reach the links' exact geometry, judged by
/// parry's distance query on the links (not the contact query the filter
/// uses), and the contact query's closest points match the distance query.
#[test]
fn exact_filter_keeps_uncovered_links_off_obstacles() {
    let (model, spheres, acm) = panda();
    let mut small = spheres.clone();
    for link in &mut small.links {
        for s in link.iter_mut() {
            s.radius *= 0.3;
        }
    }
    let clear = LinkClearance::new(model.clone()).unwrap();
    let q0 = ready(&model);
    let poses = model.fk_all(&q0).unwrap();
    let link = |n: &str| poses[model.link(n).unwrap()].translation.vector;
    // link_pair_contact (parry's contact query, GJK/EPA, f32) against
    // parry's distance query on every link pair at `ready`; overlapping
    // pairs (distance 0) have a non-positive contact distance.
    let n_links = model.links().len();
    let mut close = 0;
    for a in 0..n_links {
        for b in a + 1..n_links {
            let (Some(c), Some(d)) = (
                clear.link_pair_contact(&poses, a, b, 10.0),
                clear.link_pair_distance(&poses, a, b),
            ) else {
                continue;
            };
            if d <= 0.0 {
                assert!(c.distance <= 1e-5, "pair {a} {b}: {} vs {d}", c.distance);
                continue;
            }
            // The two queries run GJK with different stopping rules in f32
            // (the contact query stops earlier on far pairs): they agree to
            // 0.5 mm plus 3% of the distance, so within a millimetre in the
            // filter's range (a few centimetres).
            let tol = 5e-4 + 3e-2 * d;
            assert!(
                (c.distance - d).abs() < tol,
                "pair {a} {b}: {} vs {d}",
                c.distance
            );
            assert!(((c.point_b - c.point_a).norm() - d).abs() < tol);
            if d > 1e-3 {
                assert!(((c.point_b - c.point_a).normalize() - c.normal).norm() < 1e-2);
            }
            close += usize::from(d < 0.1);
        }
    }
    assert!(close > 0);
    let cases = [
        (link("panda_hand"), Vector3::new(0.0, -1.0, 0.0)),
        (link("panda_link4"), Vector3::new(0.0, -1.0, 0.0)),
        (link("panda_link5"), Vector3::new(0.0, 0.0, -1.0)),
        (link("panda_link4"), Vector3::new(-0.6, 0.8, 0.0)),
    ];
    let mut worst_off = f64::INFINITY;
    for exact in [1.0, 0.0] {
        for (k, (aim, dir)) in cases.iter().enumerate() {
            let speed = 0.5;
            let start = aim - dir * 0.6;
            let mut world = ball_world(start);
            let ck =
                CollisionChecker::new(model.clone(), small.clone(), acm.clone(), world.clone())
                    .unwrap();
            let config = ReactiveConfig {
                exact_filter: exact,
                ..Default::default()
            };
            let mut ctl = ReactiveController::new(&ck, None, config).unwrap();
            ctl.core_mut()
                .set_target(model.fk(&q0, None).unwrap(), true)
                .unwrap();
            let (_, worst) = fly_ball(&mut ctl, &mut world, &clear, &q0, start, *dir, speed);
            if exact == 1.0 {
                assert!(
                    worst > 0.0,
                    "case {k}: links reached {worst} with the exact filter"
                );
            } else {
                worst_off = worst_off.min(worst);
            }
        }
    }
    // Without the exact layer the sphere policies alone also keep these
    // balls off (their barrier acts from 25 cm): these scripted approaches
    // check that the exact layer does not break avoidance; the cases where
    // it is needed (links touching while the spheres are apart) are in
    // tests/test_reactive.py (the UR5's spherized model, judged with coal).
    assert!(worst_off.is_finite());
}

#[test]
fn exact_layer_watches_every_pair_of_the_unanalysed_matrix() {
    // The judges of benches/reactive.py and the planner check every link
    // pair the model's own matrix (SRDF, adjacent links) checks; the
    // controller's sphere pairs drop those a sampled analysis of the
    // spheres found never or always touching (panda_link5-panda_link7,
    // whose spheres always overlap, among them: an episode of the benchmark
    // pressed the links 1.6 mm into contact). The exact layer must watch
    // every one of them.
    let (model, spheres, acm) = panda();
    let base = AllowedCollisions::from_model(&model);
    let lc = LinkClearance::new(model.clone()).unwrap();
    let ck =
        CollisionChecker::new(model.clone(), spheres, acm.clone(), CollisionWorld::new()).unwrap();
    let ctl = ReactiveController::new(&ck, None, ReactiveConfig::default()).unwrap();
    let watched = ctl.exact_link_pairs();
    let (l5, l7) = (
        model.link("panda_link5").unwrap(),
        model.link("panda_link7").unwrap(),
    );
    let key = (l5.min(l7), l5.max(l7));
    assert!(acm.is_allowed(l5, l7), "the analysis drops link5-link7");
    assert!(!base.is_allowed(l5, l7));
    assert!(watched.contains(&key), "{watched:?}");
    let moved = |l: usize| {
        model
            .path_to(l)
            .into_iter()
            .any(|j| model.joints()[j].kind.is_movable())
    };
    let n = model.links().len();
    let mut expected = 0;
    for a in 0..n {
        for b in a + 1..n {
            if base.is_allowed(a, b)
                || !(lc.has_geometry(a) && lc.has_geometry(b))
                || !(moved(a) || moved(b))
            {
                continue;
            }
            expected += 1;
            assert!(watched.contains(&(a, b)), "pair {a}-{b} not watched");
        }
    }
    assert!(expected >= 20, "{expected}");
}
