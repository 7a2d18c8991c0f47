//! Steps the Panda (alone, or in the simulation benchmark's table scene,
//! [`ferrobot_benches::sim_table_scene`]) for profiling:
//! `cargo run --release -p ferrobot-benches --example sim_probe -- [alone|table] [steps]`

use std::time::Instant;

use ferrobot_benches::sim_table_scene;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let table = args.get(1).is_some_and(|a| a == "table");
    let n: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(20_000);
    let mut w = sim_table_scene(table);
    let t = Instant::now();
    w.step(n).expect("step");
    let s = t.elapsed().as_secs_f64();
    println!(
        "{} steps: {:.1} us/step ({:.0} steps/s)",
        n,
        1e6 * s / n as f64,
        n as f64 / s
    );
}
