//! Simulation speed: Panda steps and 640x480 depth + segmentation renders
//! of a table scene.
//!
//! `cargo bench -p ferrobot-benches --bench sim`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use ferrobot_benches::sim_table_scene;
use ferrobot_camera::look_at;
use ferrobot_sim::camera::{Camera, Intrinsics};
use nalgebra::{Point3, Vector3};

fn sim(c: &mut Criterion) {
    let mut g = c.benchmark_group("sim");
    let mut alone = sim_table_scene(false);
    g.bench_function("panda_step", |b| {
        b.iter(|| alone.step(black_box(1)).unwrap())
    });
    let mut scene = sim_table_scene(true);
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
        depth_scale: 1.0,
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
