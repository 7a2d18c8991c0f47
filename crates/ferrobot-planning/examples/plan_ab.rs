//! In-process A/B of planner variants on a list of problems (issue 23): the
//! variants alternate problem by problem (and repeat by repeat), so a busy
//! machine's drift hits every variant alike; the figure per plan is the
//! least wall time of the repeats (a plan runs on the calling thread; the
//! least of a few repeats drops the times another process took the core).
//!
//! `cargo run --release -p ferrobot-planning --example plan_ab -- PROBLEMS URDF SRDF SPHERIZED [REPEATS]`
//!
//! `PROBLEMS` holds one problem a line: a MoveIt scene file, then the 7 start
//! and 7 goal joint values of the Panda arm (`benches/plan_tails.py --dump`
//! writes it for MotionBenchMaker folders).

use std::sync::Arc;
use std::time::Duration;

use ferrobot_collision::{AllowedCollisions, CollisionChecker, CollisionWorld, RobotSpheres};
use ferrobot_model::{LoadOptions, RobotModel, SrdfSource};
use ferrobot_planning::{PlanCounts, PlanOptions, PlanResult, Planner};

fn now_ns() -> u64 {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_nanos() as u64
}

fn variants() -> Vec<(&'static str, PlanOptions)> {
    let new = PlanOptions::default();
    let mut old = PlanOptions::default();
    old.rrt.balance = false;
    old.rrt.dynamic_domain = false;
    old.simplify.min_gain = 0.0;
    // (certification is the same code in both: the old whole-edge scheme
    // is not kept)
    old.simplify.recheck_parts = true;
    let mut v = vec![("old", old), ("new", new.clone())];
    if let Ok(extra) = std::env::var("PLAN_AB_VARIANTS") {
        for name in extra.split(',') {
            let mut o = new.clone();
            match name {
                "nodd" => o.rrt.dynamic_domain = false,
                "nobal" => o.rrt.balance = false,
                "gain0" => o.simplify.min_gain = 0.0,
                "parts" => o.simplify.recheck_parts = true,
                "gain1" => o.simplify.min_gain = 0.01,
                "gain2" => o.simplify.min_gain = 0.02,
                "gain5" => o.simplify.min_gain = 0.05,
                "fail5" => o.simplify.max_failures = 5,
                "cf8" => o.coarse_factor = 8.0,
                "cf6" => o.coarse_factor = 6.0,
                "range2" => o.rrt.range = 2.0,
                _ => panic!("unknown variant {name}"),
            }
            v.push((Box::leak(name.to_string().into_boxed_str()), o));
        }
    }
    v
}

/// Configurations tested certifying `path`'s edges whole at intervals of
/// the resolution (the scheme of plan23d: tube first, the whole edge again
/// without it where the tube fails): (with the tube, without it, edges
/// whose tube failed, edges, sampled check at the resolution).
/// `PLAN_AB_CERT=1` prints them per problem for the second variant.
fn certify_counts(planner: &Planner, path: &[Vec<f64>]) -> [usize; 5] {
    let checker = planner.checker();
    let space = planner.space();
    let res = 0.005;
    let mut delta = vec![0.0; planner.model().num_dof()];
    for &d in &space.dofs {
        delta[d] = ferrobot_planning::recheck::SKIP_DEVIATION * res;
    }
    let tube = checker.motion_margin(&delta);
    let mut out = [0; 5];
    for w in path.windows(2) {
        let (a, b) = (space.expand(&w[0]), space.expand(&w[1]));
        let rate: Vec<f64> = a.iter().zip(&b).map(|(x, y)| (y - x).abs()).collect();
        let span = rate.iter().copied().fold(0.0, f64::max);
        let steps = ((span / res).ceil() as usize).max(1);
        let mut point = |u: f64, q: &mut [f64]| {
            for ((o, x), y) in q.iter_mut().zip(&a).zip(&b) {
                *o = x + (y - x) * u;
            }
        };
        let ok = checker.curve_certified_until(&mut point, &rate, steps, tube, None, &mut out[0]);
        if ok != Some(true) {
            out[2] += 1;
            checker.curve_certified_until(&mut point, &rate, steps, 0.0, None, &mut out[1]);
        }
        out[3] += 1;
        out[4] += steps + 1;
    }
    out
}

/// Stage times (us) and work counts of one plan.
#[derive(Default, Clone)]
struct Profile {
    planning: f64,
    simplify: f64,
    certify: f64,
    counts: PlanCounts,
    path: usize,
}

impl Profile {
    fn of(r: &PlanResult) -> Self {
        Self {
            planning: r.times.planning * 1e6,
            simplify: r.times.simplify * 1e6,
            certify: r.times.certify * 1e6,
            counts: r.counts,
            path: r.path.len(),
        }
    }

    fn mean<'a>(it: impl Iterator<Item = &'a Profile>) -> String {
        let v: Vec<&Profile> = it.collect();
        let n = v.len().max(1) as f64;
        let m = |f: &dyn Fn(&Profile) -> f64| v.iter().map(|p| f(p)).sum::<f64>() / n;
        format!(
            "rrt {:.0} us ({:.1} checks, {:.1} vertices), simplify {:.0} us of which certify {:.0} us; \
             reduce checks {:.1}; shortcuts drawn {:.1} small {:.1} checked {:.1} kept {:.1}; final vertices {:.1}; \
             certify edges {:.1} tested {:.0} tube failures {:.2} not free {:.2} repairs {:.2}",
            m(&|p| p.planning),
            m(&|p| p.counts.rrt_checks as f64),
            m(&|p| p.counts.rrt_vertices as f64),
            m(&|p| p.simplify),
            m(&|p| p.certify),
            m(&|p| p.counts.reduce_checks as f64),
            m(&|p| p.counts.shortcuts_drawn as f64),
            m(&|p| p.counts.shortcuts_small as f64),
            m(&|p| p.counts.shortcuts_checked as f64),
            m(&|p| p.counts.shortcuts_kept as f64),
            m(&|p| p.path as f64),
            m(&|p| p.counts.certify_edges as f64),
            m(&|p| p.counts.certify_tested as f64),
            m(&|p| p.counts.tube_failures as f64),
            m(&|p| p.counts.not_free as f64),
            m(&|p| p.counts.repairs as f64),
        )
    }
}

fn stats(v: &mut [f64]) -> String {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return "-".into();
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    let p95 = v[((n as f64 * 0.95).ceil() as usize).clamp(1, n) - 1];
    format!("{:7.0} / {:7.0} / {:7.0}", v[n / 2], mean, p95)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [problems, urdf, srdf, spherized] = &args[..4] else {
        panic!("usage: plan_ab PROBLEMS URDF SRDF SPHERIZED [REPEATS]");
    };
    let repeats: usize = args.get(4).map_or(3, |r| r.parse().expect("repeats"));
    let model = RobotModel::from_urdf_file(
        urdf,
        &LoadOptions {
            srdf: Some(SrdfSource::File(srdf.into())),
            ee_link: Some("panda_hand".into()),
            ..Default::default()
        },
    )
    .expect("robot");
    let spheres = RobotSpheres::from_spherized_urdf(&model, spherized).expect("spheres");
    let acm = AllowedCollisions::from_model(&model);
    let checker = CollisionChecker::new(Arc::new(model), spheres, acm, CollisionWorld::new())
        .expect("checker");
    let mut planner = Planner::new(checker, None).expect("planner");
    let variants = variants();
    // Per variant: (plan+simplify us (min of repeats), trajectory us (min of repeats), samples, length, certify us, failed ids)
    type Row = (
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
        Vec<f64>,
        Vec<String>,
    );
    let mut rows: Vec<Row> = variants.iter().map(|_| Default::default()).collect();
    let mut slow: Vec<Vec<(f64, String, usize)>> = variants.iter().map(|_| Vec::new()).collect();
    // Per variant and solved problem: (plan+simplify us, the plan's stage times and counts).
    let mut profiles: Vec<Vec<(f64, Profile)>> = variants.iter().map(|_| Vec::new()).collect();
    let text = std::fs::read_to_string(problems).expect("problems file");
    let mut scene: Option<String> = None;
    for (k, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split_whitespace().collect();
        // The world (and the grid built with it) changes with the scene
        // only, as in a bench setting the world once for many problems.
        if scene.as_deref() != Some(f[0]) {
            let world = CollisionWorld::from_moveit_scene(f[0]).expect("scene");
            planner.update_world(world);
            scene = Some(f[0].to_string());
        }
        let q: Vec<f64> = f[1..15].iter().map(|x| x.parse().unwrap()).collect();
        let (start, goal) = (&q[..7], &q[7..]);
        let mut best = vec![(f64::INFINITY, f64::INFINITY); variants.len()];
        let mut last = vec![None; variants.len()];
        for rep in 0..repeats {
            for j in 0..variants.len() {
                let v = (j + rep + k) % variants.len();
                let mut o = variants[v].1.clone();
                o.rrt.seed = k as u64;
                o.rrt.time_limit = Duration::from_secs(5);
                o.trajectory = false;
                let c0 = now_ns();
                let r = planner.plan(start, goal, &o).expect("plan");
                let ps = (now_ns() - c0) as f64 * 1e-3;
                o.trajectory = true;
                let c0 = now_ns();
                let rt = planner.plan(start, goal, &o).expect("plan");
                let tr = (now_ns() - c0) as f64 * 1e-3;
                // The plans of the repeat with the least plan + simplify
                // time are kept (their stage times and counts).
                if ps < best[v].0 {
                    last[v] = Some((r, rt));
                }
                best[v] = (best[v].0.min(ps), best[v].1.min(tr));
            }
        }
        for (v, row) in rows.iter_mut().enumerate() {
            let (r, rt) = last[v].take().expect("planned");
            if r.status.name().contains("collision") {
                continue;
            }
            let id: Vec<&str> = f[0].rsplit('/').take(2).collect();
            let id = format!(
                "{}/{}:{k}",
                &id[1][..id[1].len().min(5)],
                id[0].trim_end_matches(".yaml")
            );
            if !(r.success() && rt.success()) {
                row.5.push(format!(
                    "{id}:{}:{}:{}",
                    r.status.name(),
                    rt.status.name(),
                    if r.success() {
                        rt.message.clone()
                    } else {
                        r.message.clone()
                    }
                ));
                continue;
            }
            row.0.push(best[v].0);
            row.1.push(best[v].1);
            row.2.push(r.samples as f64);
            row.3.push(r.path_length());
            row.4.push(r.times.certify * 1e6);
            slow[v].push((best[v].0, id.clone(), r.samples));
            profiles[v].push((best[v].0, Profile::of(&r)));
            if std::env::var("PLAN_AB_CERT").is_ok() && v == 1 {
                let c = certify_counts(&planner, &r.path);
                println!(
                    "{id}: certify tested {} with tube + {} without ({} of {} edges failed the tube); sampled check {}",
                    c[0], c[1], c[2], c[3], c[4]
                );
            }
        }
    }
    for (((name, _), (row, sl)), prof) in variants
        .iter()
        .zip(rows.iter_mut().zip(slow.iter_mut()))
        .zip(profiles.iter_mut())
    {
        let n = row.0.len();
        println!(
            "{name:6} solved {n} failed {:?}\n    plan+simplify us (min of repeats) median/mean/p95 {}\n    trajectory us (min of repeats)    median/mean/p95 {}\n    certify wall us median/mean/p95 {}\n    samples mean {:.1}, path length mean {:.3}",
            row.5,
            stats(&mut row.0),
            stats(&mut row.1),
            stats(&mut row.4),
            row.2.iter().sum::<f64>() / n.max(1) as f64,
            row.3.iter().sum::<f64>() / n.max(1) as f64,
        );
        sl.sort_by(|a, b| b.0.total_cmp(&a.0));
        let top: Vec<String> = sl
            .iter()
            .take(6)
            .map(|(c, id, s)| format!("{id} {c:.0}us {s}smp"))
            .collect();
        println!("    slowest: {}", top.join(", "));
        prof.sort_by(|a, b| a.0.total_cmp(&b.0));
        let n = prof.len();
        if n > 0 {
            let tail = (n / 20).max(1);
            let mid = n / 2;
            println!(
                "    all (mean):        {}",
                Profile::mean(prof.iter().map(|p| &p.1))
            );
            println!(
                "    median 10 (mean):  {}",
                Profile::mean(
                    prof[mid.saturating_sub(5)..(mid + 5).min(n)]
                        .iter()
                        .map(|p| &p.1)
                )
            );
            println!(
                "    slowest 5% (mean): {}",
                Profile::mean(prof[n - tail..].iter().map(|p| &p.1))
            );
        }
    }
}
