//! Profiling probe for grasp detection on a saved frame (for perf/callgrind):
//!
//!     python -c "import numpy as np; ..."   # write depth (f64 LE) and seg (i32 LE), 480 x 640
//!     cargo run --release -p ferrobot-benches --example grasp_probe -- depth.bin seg.bin OBJECT_ID [RUNS]
//!
//! Intrinsics of benches/grasp_eval.py (640 x 480, f = 525, centred); prints
//! the median wall time per frame and the number of grasps.

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
    let runs: usize = args.get(4).map_or(20, |r| r.parse().expect("runs"));
    let (h, w) = (480, 640);
    let k = Intrinsics::new(w, h, 525.0, 525.0, 319.5, 239.5).expect("intrinsics");
    let opts = DetectOptions::default();
    let mut times = Vec::new();
    let mut n = 0;
    for _ in 0..runs {
        let t = Instant::now();
        let g = detect_rgbd(&depth, &k, Some(&seg), Some(id), None, &opts).expect("detect");
        times.push(t.elapsed().as_secs_f64() * 1e3);
        n = g.grasps.len();
    }
    times.sort_by(f64::total_cmp);
    println!(
        "median {:.1} ms, min {:.1} ms per frame, {n} grasps",
        times[times.len() / 2],
        times[0]
    );
}
