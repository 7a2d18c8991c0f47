//! Fuzzing of the URDF and SRDF readers on stable Rust: structured
//! mutations of real files (the bundled Panda, ../shared robots), random
//! bytes, deep nesting, huge numbers and NaN strings. Every input must give
//! `Ok` or `Err`: a panic fails the test, a stack overflow or abort kills it.
//!
//! The default run is short (`FUZZ_DEFAULT` inputs per target); set
//! `FERROBOT_FUZZ_ITERS=N` for a long run (BENCHMARKS.md records one).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use ferrobot_model::{LoadOptions, RobotModel, Srdf, SrdfSource, robots};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const FUZZ_DEFAULT: usize = 300;

fn iterations() -> usize {
    std::env::var("FERROBOT_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(FUZZ_DEFAULT)
}

/// Hostile replacements for numbers and names.
const TOKENS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e400",
    "1e-320",
    "5e-324",
    "99999999999999999999999999",
    "-0",
    "0",
    "",
    " ",
    "1 2",
    "1 2 3 4",
    "0x10",
    "1,5",
    "\u{0}",
    "&amp;",
    "&lt;",
    "&#0;",
    "&#xD800;",
    "\"",
    "'",
    "<",
    ">",
    "]]>",
    "<!--",
    "panda_link0",
    "panda_hand",
    "panda_joint1",
    "world",
    "revolute",
    "fixed",
    "mimic",
    "continuous",
    "prismatic",
    "floating",
    "planar",
];

/// One structured or random mutation of `seed`.
pub fn mutate(rng: &mut StdRng, seed: &str) -> String {
    let b = seed.as_bytes();
    let pos = |rng: &mut StdRng| rng.random_range(0..=b.len());
    let char_pos = |rng: &mut StdRng| {
        let mut p = rng.random_range(0..=seed.len());
        while !seed.is_char_boundary(p) {
            p -= 1;
        }
        p
    };
    match rng.random_range(0..10) {
        // Replace a number (or attribute value) with a hostile token.
        0 | 1 => {
            let quotes: Vec<usize> = seed.match_indices('"').map(|(i, _)| i).collect();
            if quotes.len() < 2 {
                return seed.to_string();
            }
            let k = rng.random_range(0..quotes.len() / 2) * 2;
            let (a, z) = (quotes[k], quotes[k + 1]);
            let tok = TOKENS[rng.random_range(0..TOKENS.len())];
            format!("{}\"{tok}\"{}", &seed[..a], &seed[z + 1..])
        }
        // Delete an element (from one '<' to a later '>').
        2 => {
            let starts: Vec<usize> = seed.match_indices('<').map(|(i, _)| i).collect();
            if starts.is_empty() {
                return seed.to_string();
            }
            let s = starts[rng.random_range(0..starts.len())];
            let end = seed[s..].find('>').map_or(seed.len(), |e| s + e + 1);
            format!("{}{}", &seed[..s], &seed[end..])
        }
        // Duplicate a chunk.
        3 => {
            let a = char_pos(rng);
            let mut z = (a + rng.random_range(0..400usize)).min(seed.len());
            while !seed.is_char_boundary(z) {
                z -= 1;
            }
            format!("{}{}{}", &seed[..z], &seed[a..z], &seed[z..])
        }
        // Truncate.
        4 => seed[..char_pos(rng)].to_string(),
        // Deep nesting inserted after the root's start tag.
        5 => {
            let k = rng.random_range(1..20_000);
            let at = seed
                .find("<robot")
                .and_then(|r| seed[r..].find('>').map(|e| r + e + 1));
            let at = at.unwrap_or(0);
            format!(
                "{}{}{}{}",
                &seed[..at],
                "<link>".repeat(k),
                "</link>".repeat(k),
                &seed[at..]
            )
        }
        // Random bytes spliced in (lossily decoded: the readers take &str).
        6 | 7 => {
            let mut v = b.to_vec();
            for _ in 0..rng.random_range(1..16) {
                let p = pos(rng);
                match rng.random_range(0..3) {
                    0 if p < v.len() => v[p] = rng.random(),
                    1 if p < v.len() => {
                        v.remove(p);
                    }
                    _ => v.insert(p.min(v.len()), rng.random()),
                }
            }
            String::from_utf8_lossy(&v).into_owned()
        }
        // Entirely random text.
        8 => {
            let n = rng.random_range(0..512);
            (0..n)
                .map(|_| {
                    let c: u8 = rng.random_range(0x09..0x7f);
                    c as char
                })
                .collect()
        }
        // Swap two attribute values.
        _ => {
            let quotes: Vec<usize> = seed.match_indices('"').map(|(i, _)| i).collect();
            if quotes.len() < 4 {
                return seed.to_string();
            }
            let k = rng.random_range(0..quotes.len() / 2) * 2;
            let value = &seed[quotes[k] + 1..quotes[k + 1]];
            let j = rng.random_range(0..quotes.len() / 2) * 2;
            format!(
                "{}\"{value}\"{}",
                &seed[..quotes[j]],
                &seed[quotes[j + 1] + 1..]
            )
        }
    }
}

fn seeds(name: &str, bundled: &str) -> Vec<String> {
    let mut out = vec![bundled.to_string()];
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/robots");
    for robot in ["panda", "ur5"] {
        if let Ok(t) = std::fs::read_to_string(shared.join(robot).join(format!("{robot}.{name}"))) {
            out.push(t);
        }
    }
    out
}

fn run(name: &str, seeds: &[String], mut parse: impl FnMut(&str)) {
    let n = iterations();
    let mut rng = StdRng::seed_from_u64(0x15);
    for i in 0..n {
        let seed = &seeds[i % seeds.len()];
        // Mutations stack: one to three rounds.
        let mut text = mutate(&mut rng, seed);
        for _ in 0..rng.random_range(0..3) {
            text = mutate(&mut rng, &text);
        }
        if catch_unwind(AssertUnwindSafe(|| parse(&text))).is_err() {
            let path = std::env::temp_dir().join(format!("ferrobot-fuzz-{name}-{i}.xml"));
            let _ = std::fs::write(&path, &text);
            panic!(
                "{name} reader panicked on input {i} (saved to {})",
                path.display()
            );
        }
    }
    eprintln!("fuzz {name}: {n} inputs, no panic");
}

#[test]
fn fuzz_urdf_reader() {
    let seeds = seeds("urdf", robots::PANDA_URDF);
    run("urdf", &seeds, |text| {
        let _ = RobotModel::from_urdf_str(text, &LoadOptions::default());
    });
}

#[test]
fn fuzz_srdf_reader() {
    let seeds = seeds("srdf", robots::PANDA_SRDF);
    let mut n = 0;
    run("srdf", &seeds, |text| {
        let _ = Srdf::parse(text, "fuzz.srdf");
        // Every few inputs, against the model too (name resolution).
        n += 1;
        if n % 8 == 0 {
            let opts = LoadOptions {
                srdf: Some(SrdfSource::Text(text.to_string())),
                ..LoadOptions::default()
            };
            let _ = RobotModel::from_urdf_str(robots::PANDA_URDF, &opts);
        }
    });
}

#[test]
fn deep_nesting_is_an_error_not_a_crash() {
    for k in [300, 15_000, 200_000] {
        let deep = format!(
            "<robot name=\"r\">{}{}<link name=\"l\"/></robot>",
            "<a>".repeat(k),
            "</a>".repeat(k)
        );
        let e = RobotModel::from_urdf_str(&deep, &LoadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("nested"), "{e}");
        assert!(Srdf::parse(&deep, "deep.srdf").is_err());
    }
}

#[test]
fn joint_names_with_tabs_are_an_error_not_a_panic() {
    // Found by the long fuzz run (input 478,482): roxmltree normalises a tab in an attribute
    // value to a space, urdf-rs keeps it, and the lookup between the two panicked.
    let text = robots::PANDA_URDF.replace(
        "name=\"panda_finger_joint1\"",
        "name=\"panda_finger_joint\t1\"",
    );
    assert!(RobotModel::from_urdf_str(&text, &LoadOptions::default()).is_err());
}
