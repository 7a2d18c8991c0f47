//! Batch IK throughput on the MotionBenchMaker Panda (issue 23): 1,000 poses
//! from FK of random configurations, `solve_batch` over the rayon pool,
//! solves per wall second and per CPU second (all threads), success and
//! seeds per solve; every solution verified by FK and the joint limits.
//!
//! `cargo run --release -p ferrobot-benches --example ik_probe [ROUNDS] [THREADS]`

use std::sync::Arc;
use std::time::Instant;

use ferrobot_benches::{mbm_panda, shared};
use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_planning::{IkOptions, Planner};
use nalgebra::Isometry3;

fn cpu_process() -> f64 {
    std::fs::read_dir("/proc/self/task")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| {
                    std::fs::read_to_string(e.path().join("schedstat"))
                        .ok()
                        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
                        .map_or(0.0, |ns| ns * 1e-9)
                })
                .sum()
        })
        .unwrap_or(f64::NAN)
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("ROUNDS THREADS"))
        .collect();
    let rounds = args.first().copied().unwrap_or(5);
    if let Some(&t) = args.get(1) {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build_global()
            .expect("pool");
    }
    let model = Arc::new(mbm_panda());
    let spheres =
        RobotSpheres::from_spherized_urdf(&model, shared("robots/panda/panda_spherized.urdf"))
            .expect("spherized Panda");
    let acm = AllowedCollisions::from_model(&model);
    let base =
        CollisionChecker::new(model.clone(), spheres, acm, CollisionWorld::new()).expect("checker");
    let ndof = model.num_dof();
    let planner = Planner::new(base, None).expect("planner");
    let dofs = planner.space().dofs.clone();
    let solver = planner.ik_solver(None).unwrap();
    let qs = ferrobot_benches::random_configurations(&model, 1000, 7);
    let goals: Vec<Isometry3<f64>> = qs
        .chunks_exact(ndof)
        .map(|q| solver.pose(&dofs.iter().map(|&d| q[d]).collect::<Vec<_>>()))
        .collect();
    let opts = IkOptions::default();
    let lim: Vec<(f64, f64)> = dofs
        .iter()
        .map(|&d| (model.lower_limits()[d], model.upper_limits()[d]))
        .collect();
    for r in 0..rounds {
        let (t, c) = (Instant::now(), cpu_process());
        let sols = solver.solve_batch(&goals, None, &opts).unwrap();
        let dt = t.elapsed().as_secs_f64();
        let dc = cpu_process() - c;
        let mut ok = 0;
        let mut worst = (0.0f64, 0.0f64);
        for (s, g) in sols.iter().zip(&goals) {
            let p = solver.pose(&s.q);
            let (ep, er) = (
                (p.translation.vector - g.translation.vector).norm(),
                (p.rotation * g.rotation.inverse()).angle(),
            );
            let inside = s.q.iter().zip(&lim).all(|(v, (lo, hi))| v >= lo && v <= hi);
            worst = (worst.0.max(ep), worst.1.max(er));
            if s.success && inside && ep <= opts.position_tolerance && er <= opts.rotation_tolerance
            {
                ok += 1;
            }
        }
        let seeds: usize = sols.iter().map(|s| s.seeds_tried).sum();
        println!(
            "round {r}: {:.0} solves/s wall, {:.0} per CPU-s, {ok}/1000 verified, {:.2} seeds per solve, worst {:.2e} m {:.2e} rad",
            1000.0 / dt,
            1000.0 / dc,
            seeds as f64 / 1000.0,
            worst.0,
            worst.1
        );
    }
}
