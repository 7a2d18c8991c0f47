//! A fixed workload for instruction counting (`valgrind --tool=callgrind`):
//! `cargo build --release -p ferrobot-benches --example collision_probe`
//! then `valgrind --tool=callgrind target/release/examples/collision_probe MODE [SCENE]` with MODE one of
//! `none` (setup only), `single`, `single-twice` (every check twice), `batch`, `motion`, `fk`,
//! `classes` (wall time per check of free, world-colliding and self-colliding configurations),
//! `self-only` (the self-colliding configurations, empty world, checked 5 times); `single-spheres` and `batch-spheres`
//! decide self-collision by spheres alone (no exact stage), for reference; a `-noworld`
//! suffix (e.g. `single-noworld`, `single-spheres-noworld`) empties the world (self-collision only).

use ferrobot_benches::{mbm_checker, random_configurations};

fn main() {
    let arg = std::env::args().nth(1).unwrap_or_else(|| "single".into());
    // Optional second argument: the scene below `bench/mbm` (default table_pick scene0001).
    let scene = std::env::args()
        .nth(2)
        .unwrap_or_else(|| "table_pick_panda/scene0001.yaml".into());
    let mut checker = mbm_checker(&scene);
    let mut mode = arg.clone();
    if let Some(m) = mode.strip_suffix("-noworld") {
        checker.set_world(ferrobot_collision::CollisionWorld::new());
        mode = m.to_string();
    }
    if let Some(m) = mode.strip_suffix("-spheres") {
        checker.set_exact_self_collision(false);
        mode = m.to_string();
    }
    let n = 20_000;
    let qs = random_configurations(checker.model(), n, 0);
    let hits = match mode.as_str() {
        "batch" => checker
            .in_collision_batch(&qs)
            .unwrap()
            .iter()
            .filter(|&&b| b)
            .count(),
        "motion" => (0..2000)
            .filter(|&i| {
                !checker.motion_valid_unchecked(
                    &qs[i * 7..i * 7 + 7],
                    &qs[(i + 1) * 7..(i + 1) * 7 + 7],
                    0.005,
                )
            })
            .count(),
        "single" => qs
            .chunks(7)
            .filter(|q| checker.in_collision_unchecked(q))
            .count(),
        // The same checks twice (caches such as the world grid warm for the
        // second pass); the second pass's cost is this mode's minus `single`'s.
        "single-twice" => (0..2)
            .map(|_| {
                qs.chunks(7)
                    .filter(|q| checker.in_collision_unchecked(q))
                    .count()
            })
            .last()
            .unwrap_or(0),
        // Self-colliding configurations only (found in a first pass).
        "self-only" => {
            let mut own = checker.clone();
            own.set_world(ferrobot_collision::CollisionWorld::new());
            let sel: Vec<&[f64]> = qs
                .chunks(7)
                .filter(|q| own.in_collision_unchecked(q))
                .collect();
            (0..5)
                .map(|_| sel.iter().filter(|q| own.in_collision_unchecked(q)).count())
                .sum()
        }
        "fk" => {
            let (r, _) = checker.compiled();
            let mut sc = ferrobot_collision::kernel::Scratch::<f32>::new(r);
            let mut acc = 0.0f32;
            for q in qs.chunks(7) {
                let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
                ferrobot_collision::kernel::forward(r, &q32, &mut sc);
                acc += sc.frames()[7][11];
            }
            acc as usize
        }
        // Wall time of the warm single check per class of configuration:
        // free, colliding with the world only, colliding with the robot
        // itself (median of 5 passes per class).
        "classes" => {
            let mut own = checker.clone();
            own.set_world(ferrobot_collision::CollisionWorld::new());
            for q in qs.chunks(7) {
                checker.in_collision_unchecked(q);
            }
            let mut classes: [(&str, Vec<&[f64]>); 4] = [
                ("all", qs.chunks(7).collect()),
                ("free", vec![]),
                ("world only", vec![]),
                ("self", vec![]),
            ];
            for q in qs.chunks(7) {
                let k = match (
                    checker.in_collision_unchecked(q),
                    own.in_collision_unchecked(q),
                ) {
                    (false, _) => 1,
                    (true, false) => 2,
                    (true, true) => 3,
                };
                classes[k].1.push(q);
            }
            for (name, set) in &classes {
                let mut ns: Vec<f64> = (0..5)
                    .map(|_| {
                        let t = std::time::Instant::now();
                        let hits = set
                            .iter()
                            .filter(|q| checker.in_collision_unchecked(q))
                            .count();
                        std::hint::black_box(hits);
                        t.elapsed().as_nanos() as f64 / set.len() as f64
                    })
                    .collect();
                ns.sort_by(f64::total_cmp);
                println!(
                    "{name:>10}: {:6} configurations, {:7.1} ns per check",
                    set.len(),
                    ns[2]
                );
            }
            classes[2].1.len() + classes[3].1.len()
        }
        _ => 0,
    };
    let (r, w) = checker.compiled();
    println!(
        "{arg}: {hits} of {n} collide; {} bodies, {} spheres, {} self pairs, {} obstacles",
        r.bodies.len(),
        r.centers.len(),
        r.pairs.len(),
        w.obstacles.len()
    );
}
