//! Plans every MotionBenchMaker problem once with the Rust API and prints
//! median stage times (a quick probe; the benchmark proper is `benches/mbm.py`).
//! `cargo run --release -p ferrobot-benches --example plan_probe [--no-exact] [FOLDER...]`
//!
//! `--no-exact`: self-collision decided by the spheres alone (the exact
//! self-collision stage off), to see what that stage costs the planner.

use ferrobot_benches::{mbm_checker, mbm_problems};
use ferrobot_planning::{PlanOptions, Planner};

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        f64::NAN
    } else {
        v[v.len() / 2]
    }
}

fn main() {
    let mut folders: Vec<String> = std::env::args().skip(1).collect();
    let no_exact = folders.iter().any(|f| f == "--no-exact");
    folders.retain(|f| f != "--no-exact");
    if folders.is_empty() {
        folders = vec!["table_pick_panda".into(), "bookshelf_small_panda".into()];
    }
    for folder in folders {
        let (mut plan, mut simp, mut traj, mut total) = (vec![], vec![], vec![], vec![]);
        let (mut solved, mut valid, mut stops) = (0, 0, 0);
        let problems = mbm_problems(&folder);
        for p in &problems {
            let mut checker = mbm_checker(&p.scene);
            if no_exact {
                checker.set_exact_self_collision(false);
            }
            let mut planner = Planner::new(checker, None).expect("planner");
            let mut full = planner.model().neutral_configuration();
            full[..7].copy_from_slice(&p.start);
            // Fingers as in the request (opened).
            for v in full.iter_mut().skip(7) {
                *v = 0.035;
            }
            planner.set_locked(&full).unwrap();
            let r = planner
                .plan(&p.start, &p.goal, &PlanOptions::default())
                .unwrap();
            if r.status.name().contains("collision") {
                continue;
            }
            valid += 1;
            if r.success() {
                solved += 1;
                stops += usize::from(r.stops_at_waypoints);
                plan.push(r.times.planning * 1e6);
                simp.push((r.times.planning + r.times.simplify) * 1e6);
                traj.push(r.times.trajectory * 1e6);
                total.push(r.times.total * 1e6);
            } else {
                println!("{}: {} {}", p.scene, r.status.name(), r.message);
            }
        }
        println!(
            "{folder}: {solved}/{valid} solved ({stops} stop at waypoints); median plan {:.0} us, plan+simplify {:.0} us, trajectory {:.0} us, total {:.0} us",
            median(&mut plan),
            median(&mut simp),
            median(&mut traj),
            median(&mut total)
        );
    }
}
