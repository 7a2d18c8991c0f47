//! One reactive-controller step (and one potential-field step) for the
//! bundled Panda: 59 automatic spheres, 10 obstacles (spheres and boxes)
//! around the arm, several within the avoidance distance.
//!
//! `cargo bench -p ferrobot-benches --bench control`

use std::hint::black_box;
use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};
use ferrobot_collision::acm::{AllowedCollisions, AnalyzeCollisions};
use ferrobot_collision::spherize::{SpherizeOptions, spherize_robot};
use ferrobot_collision::{CollisionChecker, CollisionWorld, RobotSpheres, Shape};
use ferrobot_control::{
    ControllerCore, PotentialFieldConfig, PotentialFieldController, ReactiveConfig,
    ReactiveController,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

fn control(c: &mut Criterion) {
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let options = SpherizeOptions {
        total_budget: Some(59),
        ..Default::default()
    };
    let (links, _) = spherize_robot(&model, &options).unwrap();
    let spheres = RobotSpheres::new(&model, links).unwrap();
    let mut acm = AllowedCollisions::from_model(&model);
    acm.analyze(&model, &spheres, 2000, 0).unwrap();
    let mut world = CollisionWorld::new();
    for i in 0..10 {
        let a = i as f64 * 0.63;
        let pose = Isometry3::from_parts(
            Translation3::new(0.45 * a.cos(), 0.45 * a.sin(), 0.2 + 0.06 * i as f64),
            UnitQuaternion::from_euler_angles(0.1 * i as f64, 0.2, 0.0),
        );
        let shape = if i % 2 == 0 {
            Shape::Sphere { radius: 0.06 }
        } else {
            Shape::Box {
                half_extents: Vector3::new(0.05, 0.04, 0.06),
            }
        };
        world.add_shape(&format!("obs{i}"), shape, pose).unwrap();
    }
    let checker = CollisionChecker::new(model.clone(), spheres, acm, world).unwrap();
    let q = model.named_state("ready", None).unwrap();
    let qd = vec![0.05; q.len()];
    let target = Isometry3::from_parts(
        Translation3::new(0.4, 0.2, 0.4),
        UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0),
    );
    // The same state every call is a stalled arm: with guidance on, the
    // controller would start planning after 0.4 s of its clock (400 calls).
    // The step is measured without it (a plan's time is reported by
    // `guidance_last_plan` and counted in benches/reactive.py).
    let cfg = ReactiveConfig {
        guidance_plans: 0.0,
        ..Default::default()
    };
    let mut rmp = ReactiveController::new(&checker, None, cfg).unwrap();
    rmp.core_mut().set_target(target, true).unwrap();
    let out = rmp.step(&q, &qd, 0.001).unwrap();
    println!(
        "reactive: {} spheres, {} self pairs, 10 obstacles, {} active avoidance terms, {} pairs in the self filter",
        rmp.core().num_spheres(),
        rmp.core().num_self_pairs(),
        out.info.active_avoidance,
        out.info.filtered
    );
    // The same controller with the velocity filter on the spheres alone
    // (`exact_filter` 0: the step before the exact layer), measured in the
    // same run for a before/after comparison.
    let mut spheres_only = ReactiveController::new(
        &checker,
        None,
        ReactiveConfig {
            guidance_plans: 0.0,
            exact_filter: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    spheres_only.core_mut().set_target(target, true).unwrap();
    let mut pf =
        PotentialFieldController::new(&checker, None, PotentialFieldConfig::default()).unwrap();
    pf.core_mut().set_target(target, true).unwrap();
    let mut g = c.benchmark_group("control/panda_59_spheres_10_obstacles");
    g.bench_function("reactive_step", |b| {
        b.iter(|| black_box(rmp.step(black_box(&q), black_box(&qd), 0.001).unwrap()))
    });
    g.bench_function("reactive_step_spheres_only_filter", |b| {
        b.iter(|| {
            black_box(
                spheres_only
                    .step(black_box(&q), black_box(&qd), 0.001)
                    .unwrap(),
            )
        })
    });
    g.bench_function("reactive_step_again", |b| {
        b.iter(|| black_box(rmp.step(black_box(&q), black_box(&qd), 0.001).unwrap()))
    });
    g.bench_function("potential_field_step", |b| {
        b.iter(|| black_box(pf.step(black_box(&q), black_box(&qd), 0.001).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, control);
criterion_main!(benches);
