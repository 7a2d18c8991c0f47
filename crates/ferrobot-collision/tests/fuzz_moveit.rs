//! Fuzzing of the MoveIt planning-scene reader on stable Rust: structured
//! mutations of the MotionBenchMaker scenes in ../shared/bench/mbm (numbers
//! replaced by NaN strings, huge or fractional values, lines deleted,
//! duplicated or re-indented), deep nesting and random bytes. Every input
//! must give `Ok` or `Err`. `FERROBOT_FUZZ_ITERS=N` sets the count (default
//! short; BENCHMARKS.md records a long run).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use ferrobot_collision::CollisionWorld;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const TOKENS: &[&str] = &[
    ".nan",
    "NaN",
    ".inf",
    "-.inf",
    "1e308",
    "1e400",
    "-1e400",
    "5e-324",
    "-1",
    "-0.5",
    "0.5",
    "2.5",
    "4294967296",
    "99999999999999999999",
    "~",
    "null",
    "[]",
    "{}",
    "\"x\"",
    "[1, 2]",
    "box",
    "mesh",
    "sphere",
    "cylinder",
    "cone",
    "&a",
    "*a",
    "!!binary x",
    "<<: *a",
];

fn mutate(rng: &mut StdRng, seed: &str) -> String {
    let lines: Vec<&str> = seed.lines().collect();
    if lines.is_empty() {
        return "world: {collision_objects: [".repeat(rng.random_range(1..50));
    }
    let i = rng.random_range(0..lines.len());
    let mut out: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    match rng.random_range(0..8) {
        // A number (or the value after ':' or '-') replaced by a hostile token.
        0..=2 => {
            let tok = TOKENS[rng.random_range(0..TOKENS.len())];
            let l = &out[i];
            let cut = l.rfind([':', '-', '[', ',']).map_or(0, |c| c + 1);
            out[i] = format!("{} {tok}", &l[..cut]);
        }
        3 => {
            out.remove(i);
        }
        4 => {
            let l = out[i].clone();
            out.insert(i, l);
        }
        5 => {
            let l = out[i].clone();
            out[i] = if rng.random_bool(0.5) {
                format!("  {l}")
            } else {
                l.trim_start().to_string()
            };
        }
        6 => {
            let k = rng.random_range(1..5_000);
            out.insert(i, format!("x: {}{}", "[".repeat(k), "]".repeat(k)));
        }
        _ => {
            let mut v = seed.as_bytes().to_vec();
            for _ in 0..rng.random_range(1..16) {
                let p = rng.random_range(0..v.len().max(1));
                if p < v.len() {
                    v[p] = rng.random();
                }
            }
            return String::from_utf8_lossy(&v).into_owned();
        }
    }
    out.join("\n")
}

#[test]
fn fuzz_moveit_scene_reader() {
    let n: usize = std::env::var("FERROBOT_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/bench/mbm");
    let mut seeds = Vec::new();
    if let Ok(rd) = std::fs::read_dir(&dir) {
        let mut problems: Vec<_> = rd.flatten().map(|e| e.path()).collect();
        problems.sort();
        for p in problems {
            for k in ["scene0001.yaml", "scene0002.yaml"] {
                if let Ok(t) = std::fs::read_to_string(p.join(k)) {
                    seeds.push(t);
                }
            }
        }
    }
    seeds.push(
        "world:\n  collision_objects:\n    - id: m\n      meshes:\n        - vertices: [[0,0,0],[1,0,0],[0,1,0]]\n          triangles: [[0, 1, 2]]\n      mesh_poses:\n        - position: [0, 0, 0]\n          orientation: [0, 0, 0, 1]\n"
            .to_string(),
    );
    let mut rng = StdRng::seed_from_u64(0x15);
    for i in 0..n {
        let mut text = mutate(&mut rng, &seeds[i % seeds.len()]);
        for _ in 0..rng.random_range(0..3) {
            text = mutate(&mut rng, &text);
        }
        if catch_unwind(AssertUnwindSafe(|| {
            let _ = CollisionWorld::from_moveit_scene_str(&text, "fuzz.yaml");
        }))
        .is_err()
        {
            let path = std::env::temp_dir().join(format!("ferrobot-fuzz-moveit-{i}.yaml"));
            let _ = std::fs::write(&path, &text);
            panic!(
                "MoveIt scene reader panicked on input {i} (saved to {})",
                path.display()
            );
        }
    }
    eprintln!(
        "fuzz moveit: {n} inputs over {} seeds, no panic",
        seeds.len()
    );
}

#[test]
fn mesh_indices_must_be_whole_vertex_numbers() {
    for bad in [
        "[0, 1, -1]",
        "[0, 1, 1.5]",
        "[0, 1, 3]",
        "[0, 1, 4294967296]",
    ] {
        let text = format!(
            "world:\n  collision_objects:\n    - id: m\n      meshes:\n        - vertices: [[0,0,0],[1,0,0],[0,1,0]]\n          triangles: [{bad}]\n      mesh_poses:\n        - position: [0, 0, 0]\n          orientation: [0, 0, 0, 1]\n"
        );
        let e = CollisionWorld::from_moveit_scene_str(&text, "t.yaml").unwrap_err();
        assert!(e.to_string().contains("vertex index"), "{bad}: {e}");
    }
}

/// Deep flow nesting is refused by a linear scan before libyaml, whose scan
/// is quadratic in the depth (the fuzzer's 5,000-deep inputs took about
/// 0.1 s each); brackets inside quoted or plain scalars and comments do not
/// count, so real scenes still load.
#[test]
fn deep_flow_collections_are_refused_before_parsing() {
    let scene = |extra: &str| {
        format!(
            "{extra}\nworld:\n  collision_objects:\n    - id: box\n      primitives:\n        - type: box\n          dimensions: [0.1, 0.2, 0.3]\n      primitive_poses:\n        - {{position: [0, 0, 0], orientation: [0, 0, 0, 1]}}\n"
        )
    };
    for k in [65, 5_000, 200_000] {
        let deep = scene(&format!("x: {}{}", "[".repeat(k), "]".repeat(k)));
        let e = CollisionWorld::from_moveit_scene_str(&deep, "deep.yaml").unwrap_err();
        assert!(e.to_string().contains("nested more than 64"), "{k}: {e}");
        assert!(e.to_string().contains("deep.yaml:1"), "{k}: {e}");
        let mixed = scene(&format!("x: {}{}", "[{a: ".repeat(k), "}]".repeat(k)));
        let e = CollisionWorld::from_moveit_scene_str(&mixed, "m.yaml").unwrap_err();
        assert!(e.to_string().contains("nested more than 64"), "{k}: {e}");
    }
    // 64 levels pass the scan (serde_yaml reads them; the scene is unaffected).
    let ok = scene(&format!("x: {}{}", "[".repeat(64), "]".repeat(64)));
    let w = CollisionWorld::from_moveit_scene_str(&ok, "ok.yaml").unwrap();
    assert_eq!(w.objects().len(), 1);
    // Brackets that open no collection: in quoted scalars (with escapes),
    // comments and block plain scalars.
    let b100 = "[".repeat(100);
    for extra in [
        format!("a: \"{b100}\\\"{b100}\""),
        format!("a: '{b100}''{b100}'"),
        format!("# {b100}"),
        format!("a: 1 # {b100}"),
        format!("a: name{b100}"),
        format!("a: [\"{b100}\", '{b100}']"),
    ] {
        let w = CollisionWorld::from_moveit_scene_str(&scene(&extra), "q.yaml")
            .unwrap_or_else(|e| panic!("{extra}: {e}"));
        assert_eq!(w.objects().len(), 1, "{extra}");
    }
}
