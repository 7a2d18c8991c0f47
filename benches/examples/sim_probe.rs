//! Steps the Panda (alone, or beside a table with two resting objects it does
//! not touch) for profiling:
//! `cargo run --release -p ferrobot-benches --example sim_probe -- [alone|table] [steps]`

use std::sync::Arc;
use std::time::Instant;

use ferrobot_sim::{ObjectDesc, ObjectShape, RobotOptions, World, WorldConfig};
use nalgebra::{Isometry3, Vector3};

const Q0: [f64; 8] = [0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.785, 0.04];

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let table = args.get(1).is_some_and(|a| a == "table");
    let n: usize = args.get(2).and_then(|a| a.parse().ok()).unwrap_or(20_000);
    let mut w = World::new(WorldConfig::default()).expect("world");
    let model = Arc::new(ferrobot_model::robots::panda().expect("panda"));
    let mut opts = RobotOptions::new("panda");
    opts.q = Some(Q0.to_vec());
    let r = w.add_robot(model, &opts).expect("robot");
    w.with_robot(r, |robot, s| robot.set_position_targets(s, &Q0, None))
        .expect("targets");
    if table {
        let mut add = |name: &str, shape, pose, is_static| {
            let mut d = ObjectDesc::new(name, shape, pose);
            d.is_static = is_static;
            w.add_object(d).expect("object");
        };
        add(
            "table",
            ObjectShape::Box {
                half_extents: Vector3::new(0.4, 0.6, 0.2),
            },
            Isometry3::translation(0.6, 0.0, 0.2),
            true,
        );
        add(
            "box",
            ObjectShape::Box {
                half_extents: Vector3::new(0.025, 0.025, 0.025),
            },
            Isometry3::translation(0.55, 0.2, 0.425),
            false,
        );
        add(
            "ball",
            ObjectShape::Sphere { radius: 0.04 },
            Isometry3::translation(0.7, -0.25, 0.44),
            false,
        );
    }
    w.step(240).expect("step");
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
