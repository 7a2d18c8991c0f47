//! Per-scene-class profile of the planner from Rust (issue 23): the scene
//! classes of `benches/scene_classes.py` (open table, shelves with dividers,
//! a cage of thin bars, clutter), regenerated here with Rust's RNG (same
//! shapes and ranges, different draws). Per class it prints the batch and
//! single check cost, and per plan (random free start and goal, joint goals)
//! the stage times, with the trajectory stage split into spline fit + time
//! scaling and the dense re-check, the configurations that re-check tested
//! and the refinements; then batch IK throughput.
//!
//! `cargo run --release -p ferrobot-benches --example scene_probe [WORLDS] [PROBLEMS]`

use std::sync::Arc;
use std::time::Instant;

use ferrobot_benches::{mbm_panda, shared};
use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_planning::{IkOptions, PlanOptions, Planner};
use nalgebra::Isometry3;
use rand::{SeedableRng, rngs::StdRng};

/// CPU time (s) of this process's threads (`/proc/self/task/*/schedstat`,
/// nanoseconds on the CPU): robust to the machine's load, unlike wall time.
fn cpu_process() -> f64 {
    std::fs::read_dir("/proc/self/task")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| schedstat(&e.path().join("schedstat")))
                .sum()
        })
        .unwrap_or(f64::NAN)
}

/// CPU time (s) of the calling thread.
fn cpu_thread() -> f64 {
    schedstat(std::path::Path::new("/proc/thread-self/schedstat"))
}

fn schedstat(path: &std::path::Path) -> f64 {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(0.0, |ns| ns * 1e-9)
}

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("WORLDS PROBLEMS"))
        .collect();
    let worlds = args.first().copied().unwrap_or(3);
    let problems = args.get(1).copied().unwrap_or(10);
    let model = Arc::new(mbm_panda());
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .expect("spherized Panda");
    let acm = AllowedCollisions::from_model(&model);
    let classes = ferrobot_benches::scenes::CLASSES;
    let base =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).expect("checker");
    let ndof = model.num_dof();
    let mut planner = Planner::new(base, None).expect("planner");
    let dofs = planner.space().dofs.clone();
    for (name, generate) in classes {
        let (mut batch, mut batch_cpu, mut single) = (vec![], vec![], vec![]);
        let (mut ps, mut tr, mut fit, mut chk) = (vec![], vec![], vec![], vec![]);
        let mut tails = vec![];
        let (mut samples, mut refinements, mut waypoints) = (vec![], vec![], vec![]);
        let (mut solved, mut total, mut obstacles) = (0, 0, 0);
        for wi in 0..worlds {
            let mut rng = StdRng::seed_from_u64(1000 * wi as u64 + name.len() as u64);
            let mut world = CollisionWorld::new();
            generate(&mut world, &mut rng);
            obstacles = world.len();
            planner.update_world(world);
            let checker = planner.checker().clone();
            let n = 100_000;
            let qs = ferrobot_benches::random_configurations(&model, n, wi as u64);
            let mut flags = vec![false; n];
            checker.in_collision_batch_into(&qs[..1000 * ndof], &mut flags[..1000]);
            let (t, c) = (Instant::now(), cpu_process());
            for _ in 0..3 {
                checker.in_collision_batch_into(&qs, &mut flags);
            }
            batch.push(3.0 * n as f64 / t.elapsed().as_secs_f64());
            batch_cpu.push(3.0 * n as f64 / (cpu_process() - c));
            let c = cpu_thread();
            let mut hits = 0;
            for q in qs.chunks_exact(ndof).take(20_000) {
                hits += usize::from(checker.in_collision_unchecked(q));
            }
            single.push((cpu_thread() - c) / 20_000.0 * 1e9);
            std::hint::black_box(hits);
            let free: Vec<Vec<f64>> = qs
                .chunks_exact(ndof)
                .zip(&flags)
                .filter(|(_, f)| !**f)
                .map(|(q, _)| dofs.iter().map(|&d| q[d]).collect())
                .take(2 * problems)
                .collect();
            let mut locked = model.neutral_configuration();
            for v in locked.iter_mut().skip(7) {
                *v = 0.035;
            }
            planner.set_locked(&locked).unwrap();
            for p in 0..problems {
                let (s, g) = (&free[2 * p], &free[2 * p + 1]);
                let mut opts = PlanOptions::default();
                opts.rrt.seed = p as u64;
                opts.trajectory = false;
                total += 1;
                let t = Instant::now();
                let r = planner.plan(s, g, &opts).unwrap();
                let e_ps = t.elapsed().as_secs_f64();
                opts.trajectory = true;
                let t = Instant::now();
                let rt = planner.plan(s, g, &opts).unwrap();
                let e_tr = t.elapsed().as_secs_f64();
                if r.success() && rt.success() {
                    solved += 1;
                    ps.push(e_ps * 1e6);
                    tails.push((
                        e_ps * 1e6,
                        r.times.planning * 1e6,
                        r.times.simplify * 1e6,
                        r.path.len(),
                    ));
                    tr.push(e_tr * 1e6);
                    fit.push(rt.times.fit * 1e6);
                    chk.push(rt.times.recheck * 1e6);
                    samples.push(rt.recheck_samples as f64);
                    refinements.push(rt.refinements as f64);
                    waypoints.push(rt.path.len() as f64);
                }
            }
        }
        println!(
            "{name:8} obstacles {obstacles:4} batch {:.2} M/s wall, {:.2} M per CPU-s; single {:.0} CPU-ns; solved {solved}/{total}",
            pct(&mut batch, 0.5) / 1e6,
            pct(&mut batch_cpu, 0.5) / 1e6,
            pct(&mut single, 0.5)
        );
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        tails.sort_by(|a, b| b.0.total_cmp(&a.0));
        // The tail: which stage the slowest plans spent their time in.
        println!(
            "         slowest 3 plans (plan+simplify, of which search, shortcutting, µs wall; waypoints): {:?}",
            tails
                .iter()
                .take(3)
                .map(|t| (t.0 as i64, t.1 as i64, t.2 as i64, t.3))
                .collect::<Vec<_>>()
        );
        println!(
            "         plan+simplify {:.0} (p95 {:.0}) us, trajectory {:.0} (p95 {:.0}) us; last stage: fit+timing {:.0} us, re-check {:.0} us (median), {:.0} samples, {:.2} refinements, {:.1} waypoints (mean)",
            pct(&mut ps, 0.5),
            pct(&mut ps, 0.95),
            pct(&mut tr, 0.5),
            pct(&mut tr, 0.95),
            pct(&mut fit, 0.5),
            pct(&mut chk, 0.5),
            mean(&samples),
            mean(&refinements),
            mean(&waypoints),
        );
    }
    // IK: 1,000 poses from FK of random configurations, batch over cores.
    let solver = planner.ik_solver(None).unwrap();
    let qs = ferrobot_benches::random_configurations(&model, 1000, 7);
    let goals: Vec<Isometry3<f64>> = qs
        .chunks_exact(ndof)
        .map(|q| solver.pose(&dofs.iter().map(|&d| q[d]).collect::<Vec<_>>()))
        .collect();
    // The default options, then fewer iterations per seed (more seeds).
    for (k, iters) in [60, 60, 30, 20, 15].into_iter().enumerate() {
        let opts = IkOptions {
            max_iterations: iters,
            ..IkOptions::default()
        };
        let (t, c) = (Instant::now(), cpu_process());
        let sols = solver.solve_batch(&goals, None, &opts).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let dc = cpu_process() - c;
        let ok = sols.iter().filter(|s| s.success).count();
        let seeds: usize = sols.iter().map(|s| s.seeds_tried).sum();
        println!(
            "IK batch (max_iterations {iters}{}): {:.0} solves/s wall, {:.0} per CPU-s, {ok}/1000 solved, {:.2} seeds per solve",
            if k == 0 { ", warm-up" } else { "" },
            1000.0 / dt,
            1000.0 / dc,
            seeds as f64 / 1000.0
        );
    }
}
