//! Plan requests carry their locked joints (issue 16): one shared planner
//! answers queries with different finger openings exactly as a planner
//! copied and re-locked for each query did, and leaves its own locked values
//! untouched.

use std::sync::Arc;

use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{
    AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres, Shape,
};
use ferrobot_planning::{Goal, PlanOptions, PlanRequest, PlanStatus, Planner};
use nalgebra::Isometry3;

/// The bundled Panda with a small ball held between its fingertips at the
/// `ready` pose: closed fingers (0 m) go through it, open ones (4 cm each)
/// clear it.
fn planner_and_ready() -> (Planner, Vec<f64>) {
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let options = SpherizeOptions {
        total_budget: Some(59),
        ..Default::default()
    };
    let (links, _) = spherize_robot(&model, &options).unwrap();
    let spheres = RobotSpheres::new(&model, links).unwrap();
    let acm = AllowedCollisions::from_model(&model);
    let ready = model.named_state("ready", None).unwrap();
    // Between the finger pads: 10.2 cm along the hand's z.
    let hand = model
        .fk(&ready, Some(model.link("panda_hand").unwrap()))
        .unwrap();
    let centre = hand * Isometry3::translation(0.0, 0.0, 0.102);
    let mut world = CollisionWorld::new();
    world
        .add_shape("ball", Shape::Sphere { radius: 0.005 }, centre)
        .unwrap();
    let checker = CollisionChecker::new(model, spheres, acm, world).unwrap();
    (Planner::new(checker, None).unwrap(), ready)
}

#[test]
fn a_request_locks_joints_for_itself_only() {
    let (planner, ready) = planner_and_ready();
    let finger = planner
        .model()
        .dof_names()
        .iter()
        .position(|n| n == "panda_finger_joint1")
        .unwrap();
    let (mut open, mut closed) = (ready.clone(), ready.clone());
    open[finger] = 0.04;
    closed[finger] = 0.0;
    // The premise, from the geometry: only closed fingers touch the ball.
    let checker = planner.checker();
    assert!(
        !checker.in_collision(&open).unwrap(),
        "{:?}",
        checker.contacts(&open)
    );
    assert!(checker.in_collision(&closed).unwrap());

    let space = planner.space();
    let start = space.restrict(&ready);
    let mut goal = start.clone();
    goal[0] += 0.3; // turn the base joint: the ball stays put, the hand leaves it
    let mut options = PlanOptions::default();
    options.rrt.seed = 3;
    let before = space.locked.clone();
    for (full, expected) in [
        (&open, PlanStatus::Solved),
        (&closed, PlanStatus::StartInCollision),
    ] {
        let request = PlanRequest {
            start: start.clone(),
            goal: Goal::Configuration(goal.clone()),
            locked: Some(full.clone()),
            options: options.clone(),
        };
        let shared = planner.solve(&request).unwrap();
        assert_eq!(shared.status, expected, "{}", shared.message);
        // The reference: a copy of the planner locked for this query.
        let mut copy = planner.clone();
        copy.set_locked(full).unwrap();
        let copied = copy.plan(&start, &goal, &options).unwrap();
        assert_eq!(copied.status, shared.status);
        assert_eq!(copied.path, shared.path);
        assert_eq!(copied.message, shared.message);
    }
    // The shared planner's own locked values did not change.
    assert_eq!(planner.space().locked, before);
    // A locked configuration of the wrong length is refused.
    let bad = PlanRequest {
        start,
        goal: Goal::Configuration(goal),
        locked: Some(vec![0.0; 3]),
        options,
    };
    assert!(planner.solve(&bad).is_err());
}
