//! Forward kinematics and Jacobian throughput for the Panda.
//!
//! `cargo bench -p ferrobot-benches --bench kinematics`

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use ferrobot_benches::{mbm_panda, random_configurations};

fn kinematics(c: &mut Criterion) {
    let model = mbm_panda();
    let dof = model.num_dof();
    let qs = random_configurations(&model, 100_000, 0);
    let ee = model.ee_link();

    let mut g = c.benchmark_group("panda_fk");
    g.throughput(Throughput::Elements(1));
    g.bench_function("ee_single", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) % 100_000;
            black_box(model.chain(ee).pose(black_box(&qs[i * dof..(i + 1) * dof])))
        })
    });
    g.bench_function("all_links_single", |b| {
        b.iter(|| black_box(model.fk_all(black_box(&qs[..dof])).unwrap()))
    });
    g.bench_function("jacobian_single", |b| {
        b.iter(|| black_box(model.jacobian(black_box(&qs[..dof]), None).unwrap()))
    });
    g.throughput(Throughput::Elements(100_000));
    g.bench_function("ee_batch_100k_rayon", |b| {
        b.iter(|| black_box(model.fk_batch(black_box(&qs), None).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
