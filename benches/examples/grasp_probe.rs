//! Profiling probe for grasp detection on a saved frame (for perf/callgrind):
//!
//!     python -c "import numpy as np; ..."   # write depth (f64 LE) and seg (i32 LE), 480 x 640
//!     cargo run --release -p ferrobot-benches --example grasp_probe -- depth.bin seg.bin OBJECT_ID [RUNS] [NUM_SEEDS] [F]
//!
//! Intrinsics of benches/grasp_eval.py (640 x 480, f = 525 or F, centred);
//! OBJECT_ID -1 seeds every labelled object; NUM_SEEDS 0 times everything
//! but the hand search. Prints the median wall time per frame, the number
//! of grasps and a checksum of the grasps (to compare builds exactly).

use std::time::Instant;

use ferrobot_grasp::{DetectOptions, Intrinsics, detect::detect_rgbd};

fn read<T: Copy>(path: &str, conv: fn([u8; 8]) -> T, size: usize) -> Vec<T> {
    let bytes = std::fs::read(path).expect("read input");
    bytes
        .chunks_exact(size)
        .map(|c| {
            let mut b = [0u8; 8];
            b[..size].copy_from_slice(c);
            conv(b)
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        eprintln!("usage: grasp_probe depth.bin seg.bin OBJECT_ID [RUNS]");
        std::process::exit(2);
    }
    let depth = read(&args[1], f64::from_le_bytes, 8);
    let seg = read(
        &args[2],
        |b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        4,
    );
    let id: i32 = args[3].parse().expect("object id");
    let id = (id >= 0).then_some(id);
    let runs: usize = args.get(4).map_or(20, |r| r.parse().expect("runs"));
    let num_seeds: usize = args.get(5).map_or(128, |r| r.parse().expect("num seeds"));
    let f: f64 = args
        .get(6)
        .map_or(525.0, |r| r.parse().expect("focal length"));
    let (h, w) = (480, 640);
    let k = Intrinsics::new(w, h, f, f, 319.5, 239.5).expect("intrinsics");
    let opts = DetectOptions {
        num_seeds,
        ..DetectOptions::default()
    };
    let mut times = Vec::new();
    let mut n = 0;
    let mut sum = 0.0;
    for _ in 0..runs {
        let t = Instant::now();
        let g = detect_rgbd(&depth, &k, Some(&seg), id, None, &opts).expect("detect");
        times.push(t.elapsed().as_secs_f64() * 1e3);
        n = g.grasps.len();
        sum = g
            .grasps
            .iter()
            .enumerate()
            .map(|(i, g)| (i + 1) as f64 * (g.score + g.translation.sum() + g.width))
            .sum();
    }
    times.sort_by(f64::total_cmp);
    println!(
        "median {:.2} ms, min {:.2} ms per frame, {n} grasps, checksum {sum:.12e}",
        times[times.len() / 2],
        times[0]
    );
}
