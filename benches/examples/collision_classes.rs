//! Collision-check cost per scene class from Rust (issue 23, deliverable 2):
//! batch throughput on the rayon pool (wall and per CPU-second) and on one
//! thread, and the single check (ns), in an empty world and in the
//! scene classes of [`ferrobot_benches::scenes`], with the exact
//! self-collision stage on (the default) and off (spheres decide), so the
//! stage's share shows.
//!
//! `cargo run --release -p ferrobot-benches --example collision_classes [WORLDS] [N]`
//!
//! `... collision_classes loop CLASS SECONDS [batch|single] [noexact]` checks
//! one class's first world over and over (for `perf record`; `noexact`: with
//! the exact self stage off).
//!
//! `cargo run --release -p ferrobot-benches --features exact-stats --example
//! collision_classes stats [panda|ur5] [N]` counts, per class and per pair of
//! robot parts, what the exact self-collision stage does for N random
//! configurations (box overlaps, inscribed-sphere decisions, GJK calls, mesh
//! refinements, triangle pairs tested, time), per 1,000 configurations.

use std::sync::Arc;
use std::time::Instant;

use ferrobot_benches::{mbm_panda, random_configurations, scenes::CLASSES, shared};
use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use rand::{SeedableRng, rngs::StdRng};

/// CPU time (s) of this process's threads (`/proc/self/task/*/schedstat`).
fn cpu_process() -> f64 {
    std::fs::read_dir("/proc/self/task")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| schedstat(&e.path().join("schedstat")))
                .sum()
        })
        .unwrap_or(f64::NAN)
}

fn schedstat(path: &std::path::Path) -> f64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The checker for world `wi` of class `name` (`empty`: no obstacles).
fn world(name: &str, wi: usize) -> CollisionWorld {
    let mut world = CollisionWorld::new();
    if let Some((_, generate)) = CLASSES.iter().find(|(n, _)| *n == name) {
        let mut rng = StdRng::seed_from_u64(1000 * wi as u64 + name.len() as u64);
        generate(&mut world, &mut rng);
    }
    world
}

struct Figures {
    /// Batch on the pool: M configurations/s wall (fastest run), M per
    /// CPU-s (all runs).
    wall: f64,
    cpu: f64,
    /// Batch on one thread: M per second (fastest run).
    one: f64,
    /// Single check, ns (fastest run).
    single: f64,
    /// Share of the configurations that collide.
    colliding: f64,
}

/// Fastest of `reps` timed runs of `f`, in seconds of wall time (on a
/// shared machine the fastest run is the one least disturbed; the thread's
/// CPU time from `/proc` is counted in scheduler ticks, too coarse here).
fn fastest(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn measure(checker: &CollisionChecker, qs: &[f64], pool1: &rayon::ThreadPool) -> Figures {
    let dof = checker.model().num_dof();
    let n = qs.len() / dof;
    let mut flags = vec![false; n];
    // Warm-up: the grid and the pool.
    checker.in_collision_batch_into(qs, &mut flags);
    let colliding = flags.iter().filter(|&&f| f).count() as f64 / n as f64;
    let reps = 5;
    let c = cpu_process();
    let best = fastest(reps, || checker.in_collision_batch_into(qs, &mut flags));
    let wall = n as f64 / best / 1e6;
    let cpu = (reps * n) as f64 / (cpu_process() - c) / 1e6;
    let one = pool1.install(|| {
        n as f64 / fastest(reps, || checker.in_collision_batch_into(qs, &mut flags)) / 1e6
    });
    let m = n.min(20_000);
    let mut hits = 0;
    let single = fastest(reps, || {
        for q in qs.chunks_exact(dof).take(m) {
            hits += usize::from(checker.in_collision_unchecked(q));
        }
    }) / m as f64
        * 1e9;
    std::hint::black_box(hits);
    Figures {
        wall,
        cpu,
        one,
        single,
        colliding,
    }
}

/// The UR5 of `../shared` with its SRDF and automatic sphere model.
#[cfg(feature = "exact-stats")]
fn ur5() -> (Arc<ferrobot_model::RobotModel>, RobotSpheres) {
    use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
    let model = RobotModel::from_urdf_file(
        shared("robots/ur5/ur5.urdf"),
        &LoadOptions {
            srdf: Some(SrdfSource::File(shared("robots/ur5/ur5.srdf"))),
            ..Default::default()
        },
    )
    .expect("load the shared UR5");
    // Its spherized URDF leaves `ee_link`'s geometry without spheres: the
    // automatic sphere model instead.
    let (links, _) = ferrobot_collision::spherize::spherize_robot(
        &model,
        &ferrobot_collision::spherize::SpherizeOptions::default(),
    )
    .expect("spherize the UR5");
    let spheres = RobotSpheres::new(&model, links).expect("UR5 spheres");
    (Arc::new(model), spheres)
}

/// `stats [panda|ur5] [N]`: the exact stage's counters per class.
#[cfg(feature = "exact-stats")]
fn stats(args: &[String]) {
    use ferrobot_collision::exact::stats;
    let robot = args.get(1).map_or("panda", String::as_str);
    let n: usize = args.get(2).map_or(100_000, |s| s.parse().expect("N"));
    let (model, spheres) = if robot == "ur5" {
        ur5()
    } else {
        let model = Arc::new(mbm_panda());
        let spheres =
            RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
                .expect("spherized Panda");
        (model, spheres)
    };
    let acm = AllowedCollisions::from_model(&model);
    let base =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).expect("checker");
    let (compiled, _) = base.compiled();
    for (b, e) in compiled.bodies.iter().zip(&compiled.exact) {
        if let Some(e) = e {
            println!(
                "{}: {} refined parts, {} inscribed spheres",
                model.links()[b.link].name,
                e.refined_parts(),
                e.inscribed().count()
            );
        }
    }
    let per = 1000.0 / n as f64;
    for name in ["empty", "table", "shelves", "cage", "clutter"] {
        let mut checker = base.clone();
        checker.set_world(world(name, 0));
        let qs = random_configurations(&model, n, 0);
        let mut flags = vec![false; n];
        stats::take();
        checker.in_collision_batch_into(&qs, &mut flags);
        let rows = stats::take();
        let colliding = flags.iter().filter(|&&f| f).count();
        println!(
            "\n{robot} {name}: {n} configurations, {:.1} % colliding; per 1,000 configurations:",
            100.0 * colliding as f64 / n as f64
        );
        println!(
            "{:>24} {:>24} | {:>7} {:>7} {:>6} {:>6} {:>6} {:>6} | {:>22} {:>8} {:>8} {:>8}",
            "part a",
            "part b",
            "boxes",
            "inner",
            "gjk",
            "g-hit",
            "refine",
            "r-hit",
            "hint/vtx/wit/tri/hold/no",
            "tests/r",
            "ns/refine",
            "ns/gjk"
        );
        let mut tot = [0.0f64; 2];
        for (a, b, t) in rows {
            if t.boxes == 0 {
                continue;
            }
            tot[0] += t.refine_ns as f64;
            tot[1] += t.gjk_ns as f64;
            let r = t.refine.max(1) as f64;
            println!(
                "{a:>24} {b:>24} | {:7.2} {:7.2} {:6.2} {:6.2} {:6.3} {:6.3} | {:>22} {:8.0} {:8.0} {:8.0}",
                t.boxes as f64 * per,
                t.inner as f64 * per,
                t.gjk as f64 * per,
                t.gjk_hit as f64 * per,
                t.refine as f64 * per,
                t.refine_hit as f64 * per,
                format!("{:?}", t.by),
                t.touch_tests as f64 / r,
                t.refine_ns as f64 / r,
                t.gjk_ns as f64 / t.gjk.max(1) as f64,
            );
        }
        println!(
            "time per configuration: refinement {:.1} ns, GJK {:.1} ns",
            tot[0] / n as f64,
            tot[1] / n as f64
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    #[cfg(feature = "exact-stats")]
    if args.first().map(String::as_str) == Some("stats") {
        stats(&args);
        return;
    }
    let model = Arc::new(mbm_panda());
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .expect("spherized Panda");
    let acm = AllowedCollisions::from_model(&model);
    let base =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).expect("checker");
    if args.first().map(String::as_str) == Some("loop") {
        let class = args.get(1).map_or("cage", String::as_str);
        let seconds: f64 = args.get(2).map_or(10.0, |s| s.parse().expect("SECONDS"));
        let single = args.get(3).map(String::as_str) == Some("single");
        let mut checker = base.clone();
        checker.set_world(world(class, 0));
        // `noexact` after the mode: the exact self stage off (spheres decide).
        if args.get(4).map(String::as_str) == Some("noexact") {
            checker.set_exact_self_collision(false);
        }
        let qs = random_configurations(&model, 100_000, 0);
        let mut flags = vec![false; 100_000];
        let t = Instant::now();
        let mut checks = 0usize;
        while t.elapsed().as_secs_f64() < seconds {
            if single {
                for q in qs.chunks_exact(model.num_dof()) {
                    flags[0] ^= checker.in_collision_unchecked(q);
                }
            } else {
                checker.in_collision_batch_into(&qs, &mut flags);
            }
            checks += 100_000;
        }
        println!(
            "{class}: {checks} checks, {:.2} M/s wall",
            checks as f64 / t.elapsed().as_secs_f64() / 1e6
        );
        return;
    }
    let worlds: usize = args.first().map_or(3, |s| s.parse().expect("WORLDS"));
    let n: usize = args.get(1).map_or(100_000, |s| s.parse().expect("N"));
    let (robot, _) = base.compiled();
    let refined: Vec<String> = robot
        .bodies
        .iter()
        .zip(&robot.exact)
        .filter_map(|(b, e)| {
            let e = e.as_ref()?;
            let name = &model.links()[b.link].name;
            Some(format!(
                "{name} {} ({} inscribed)",
                e.refined_parts(),
                e.inscribed().count()
            ))
        })
        .collect();
    println!(
        "{} self pairs; exact bodies (refined mesh parts, inscribed spheres): {}",
        robot.pairs.len(),
        refined.join(", ")
    );
    let pool1 = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    println!(
        "{:8} {:>5} {:>9} | {:>8} {:>8} {:>8} {:>8} | exact stage off: {:>6} {:>6} {:>8}",
        "class",
        "obst",
        "colliding",
        "M/s",
        "M/CPU-s",
        "1 thread",
        "single",
        "M/s",
        "1 thr",
        "single"
    );
    for name in ["empty", "table", "shelves", "cage", "clutter"] {
        let ws = if name == "empty" { 1 } else { worlds };
        let mut rows: Vec<(Figures, Figures, usize)> = vec![];
        for wi in 0..ws {
            let mut checker = base.clone();
            checker.set_world(world(name, wi));
            let obstacles = checker.world().len();
            let qs = random_configurations(&model, n, wi as u64);
            let on = measure(&checker, &qs, &pool1);
            checker.set_exact_self_collision(false);
            let off = measure(&checker, &qs, &pool1);
            rows.push((on, off, obstacles));
        }
        let med = |f: &dyn Fn(&(Figures, Figures, usize)) -> f64| {
            median(&mut rows.iter().map(f).collect::<Vec<_>>())
        };
        println!(
            "{name:8} {:5.0} {:8.1}% | {:8.2} {:8.2} {:8.2} {:6.0}ns | {:>16.2} {:6.2} {:6.0}ns",
            med(&|r| r.2 as f64),
            100.0 * med(&|r| r.0.colliding),
            med(&|r| r.0.wall),
            med(&|r| r.0.cpu),
            med(&|r| r.0.one),
            med(&|r| r.0.single),
            med(&|r| r.1.wall),
            med(&|r| r.1.one),
            med(&|r| r.1.single),
        );
    }
}
