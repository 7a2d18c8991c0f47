//! Collision-check throughput for the Panda (MotionBenchMaker spherized
//! model, 59 spheres) in MotionBenchMaker scenes.
//!
//! `cargo bench -p ferrobot-benches --bench collision`

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use ferrobot_benches::{mbm_checker, random_configurations};
use rand::{Rng, SeedableRng, rngs::StdRng};

fn collision(c: &mut Criterion) {
    let n = 100_000;
    let qs = random_configurations(mbm_checker("table_pick_panda/scene0001.yaml").model(), n, 0);
    for scene in [
        "table_pick_panda/scene0001.yaml",
        "bookshelf_small_panda/scene0001.yaml",
    ] {
        let checker = mbm_checker(scene);
        let frac = checker
            .in_collision_batch(&qs)
            .unwrap()
            .iter()
            .filter(|&&b| b)
            .count() as f64
            / n as f64;
        println!(
            "{scene}: {:.1}% of random configurations collide",
            100.0 * frac
        );
        let name = scene.split('/').next().unwrap();
        let mut g = c.benchmark_group(format!("collision/{name}"));
        g.throughput(Throughput::Elements(1));
        g.bench_function("single_check", |b| {
            let mut i = 0;
            b.iter(|| {
                i = (i + 1) % n;
                black_box(checker.in_collision_unchecked(black_box(&qs[i * 7..i * 7 + 7])))
            })
        });
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function("batch_100k_2cores", |b| {
            b.iter(|| black_box(checker.in_collision_batch(black_box(&qs)).unwrap()))
        });
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        g.bench_function("batch_100k_1core", |b| {
            b.iter(|| {
                pool.install(|| black_box(checker.in_collision_batch(black_box(&qs)).unwrap()))
            })
        });
        // Motions: pairs of random configurations 0.3 rad apart per joint at most, 5 mrad resolution.
        let mut rng = StdRng::seed_from_u64(1);
        let motions: Vec<(Vec<f64>, Vec<f64>)> = (0..1000)
            .map(|i| {
                let a = qs[i * 7..i * 7 + 7].to_vec();
                let b = a.iter().map(|x| x + rng.random_range(-0.3..0.3)).collect();
                (a, b)
            })
            .collect();
        g.throughput(Throughput::Elements(1));
        g.bench_function("motion_5mrad", |b| {
            let mut i = 0;
            b.iter(|| {
                i = (i + 1) % motions.len();
                black_box(checker.motion_valid_unchecked(&motions[i].0, &motions[i].1, 0.005))
            })
        });
        g.finish();
    }
}

criterion_group!(benches, collision);
criterion_main!(benches);
