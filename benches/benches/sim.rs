//! Simulation speed: Panda steps and 640x480 depth + segmentation renders
//! of a table scene.
//!
//! `cargo bench -p ferrobot-benches --bench sim`

use std::hint::black_box;
use std::sync::Arc;

use criterion::{Criterion, criterion_group, criterion_main};
use ferrobot_sim::camera::{Camera, Intrinsics};
use ferrobot_sim::conventions::look_at;
use ferrobot_sim::{ObjectDesc, ObjectShape, RobotOptions, World, WorldConfig};
use nalgebra::{Isometry3, Point3, Vector3};

const Q0: [f64; 8] = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];

fn table_scene(objects: bool) -> World {
    let mut w = World::new(WorldConfig::default()).unwrap();
    let model = Arc::new(ferrobot_model::robots::panda().unwrap());
    let mut opts = RobotOptions::new("panda");
    opts.q = Some(Q0.to_vec());
    let r = w.add_robot(model, &opts).unwrap();
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q0, None))
        .unwrap();
    if objects {
        let mut add = |name: &str, shape, pose, is_static| {
            let mut d = ObjectDesc::new(name, shape, pose);
            d.is_static = is_static;
            w.add_object(d).unwrap();
        };
        add(
            "table",
            ObjectShape::Box {
                half_extents: Vector3::new(0.4, 0.6, 0.2),
            },
            Isometry3::translation(0.6, 0.0, 0.2),
            true,
        );
        add(
            "box",
            ObjectShape::Box {
                half_extents: Vector3::new(0.025, 0.025, 0.025),
            },
            Isometry3::translation(0.5, 0.0, 0.425),
            false,
        );
        add(
            "can",
            ObjectShape::Cylinder {
                radius: 0.03,
                length: 0.12,
            },
            Isometry3::translation(0.6, 0.25, 0.46),
            false,
        );
        add(
            "ball",
            ObjectShape::Sphere { radius: 0.04 },
            Isometry3::translation(0.7, -0.25, 0.44),
            false,
        );
    }
    w.step(240).unwrap();
    w
}

fn sim(c: &mut Criterion) {
    let mut g = c.benchmark_group("sim");
    let mut alone = table_scene(false);
    g.bench_function("panda_step", |b| {
        b.iter(|| alone.step(black_box(1)).unwrap())
    });
    let mut scene = table_scene(true);
    g.bench_function("table_scene_step", |b| {
        b.iter(|| scene.step(black_box(1)).unwrap())
    });
    let pose = look_at(
        &Point3::new(1.4, 0.0, 1.2),
        &Point3::new(0.55, 0.0, 0.4),
        &Vector3::z(),
    )
    .unwrap();
    let intr = Intrinsics {
        width: 640,
        height: 480,
        fx: 525.0,
        fy: 525.0,
        cx: 319.5,
        cy: 239.5,
    };
    let cam = Camera::new(intr, pose).unwrap();
    g.bench_function("render_640x480_depth_seg", |b| {
        b.iter(|| black_box(scene.render(&cam, false).unwrap()))
    });
    g.bench_function("render_640x480_depth_seg_rgb", |b| {
        b.iter(|| black_box(scene.render(&cam, true).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, sim);
criterion_main!(benches);
