//! Run-time instruction-set dispatch: the detected level matches the CPU's
//! flags as the kernel reports them (`/proc/cpuinfo`), the copy that runs
//! was compiled with the level's instructions, and every level the CPU
//! supports gives exactly the answers of the scalar lane (`check::<f32>`,
//! one configuration at a time, compiled for the baseline).

mod common;

use common::{mbm_panda, random_q, shared};

use ferrobot_collision::compiled::CompiledRobot;
use ferrobot_collision::dispatch::{self, SimdLevel, compiled_features};
use ferrobot_collision::kernel::{self, Scratch};
use ferrobot_collision::lanes::Lanes;
use ferrobot_collision::{CollisionChecker, CollisionWorld};
use rand::{Rng, SeedableRng, rngs::StdRng};
use wide::f32x8;

/// The level `/proc/cpuinfo`'s flags allow (Linux x86-64), an independent
/// reading of the CPU's features.
#[cfg(all(target_os = "linux", target_arch = "x86_64"))]
fn level_from_cpuinfo() -> SimdLevel {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap();
    let flags: Vec<&str> = info
        .lines()
        .find(|l| l.starts_with("flags"))
        .unwrap()
        .split_whitespace()
        .collect();
    let has = |f: &str| flags.contains(&f);
    let v2 = ["pni", "ssse3", "sse4_1", "sse4_2", "popcnt", "cx16"]
        .iter()
        .all(|f| has(f));
    let v3 = v2
        && ["avx", "avx2", "fma", "bmi1", "bmi2", "abm", "movbe", "f16c"]
            .iter()
            .all(|f| has(f));
    let v4 = v3
        && ["avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"]
            .iter()
            .all(|f| has(f));
    match (v2, v3, v4) {
        (_, _, true) => SimdLevel::X86V4,
        (_, true, _) => SimdLevel::X86V3,
        (true, _, _) => SimdLevel::X86V2,
        _ => SimdLevel::Baseline,
    }
}

#[test]
fn dispatch_picks_the_best_level_the_cpu_has() {
    #[cfg(all(target_os = "linux", target_arch = "x86_64"))]
    assert_eq!(dispatch::detected(), level_from_cpuinfo());
    let (model, spheres, acm) = mbm_panda();
    let checker = CollisionChecker::new(model, spheres, acm, CollisionWorld::new()).unwrap();
    match std::env::var("FERROBOT_SIMD") {
        Err(_) => assert_eq!(checker.simd_level(), dispatch::detected()),
        Ok(_) => assert!(checker.simd_level() <= dispatch::detected()),
    }
    // The copy that runs for a level has that level's instructions.
    for level in SimdLevel::ALL.into_iter().filter(|l| l.supported()) {
        let f = compiled_features(level);
        let want: &[&str] = match level {
            SimdLevel::X86V4 => &["avx512f", "avx512vl", "avx2", "fma"],
            SimdLevel::X86V3 => &["avx2", "fma"],
            SimdLevel::X86V2 => &["sse4.2", "ssse3"],
            SimdLevel::Baseline => &[],
        };
        for w in want {
            assert!(
                f.iter().any(|x| x == w),
                "{}: {f:?} lacks {w}",
                level.name()
            );
        }
        // A build whose baseline already has AVX2 (target-cpu=native on this machine) gives
        // every copy AVX2; only a portable build can show the lower copies without it.
        if level < SimdLevel::X86V3 && !cfg!(target_feature = "avx2") {
            assert!(!f.iter().any(|x| x == "avx2"), "{}: {f:?}", level.name());
        }
    }
    // A level the CPU lacks is refused by name.
    if let Some(&above) = SimdLevel::ALL.iter().find(|l| !l.supported()) {
        let (model, spheres, acm) = mbm_panda();
        let mut c = CollisionChecker::new(model, spheres, acm, CollisionWorld::new()).unwrap();
        let e = c.set_simd_level(above).unwrap_err().to_string();
        assert!(e.contains(above.name()), "{e}");
    }
}

/// Frames of eight configurations from the eight-lane kinematics, as bits.
fn frames_bits(robot: &CompiledRobot, q: &[f32x8]) -> Vec<u32> {
    let mut s = Scratch::<f32x8>::new(robot);
    kernel::forward(robot, q, &mut s);
    s.frames()
        .iter()
        .flat_map(|f| f.iter().flat_map(|v| v.to_array().map(f32::to_bits)))
        .collect()
}

ferrobot_collision::dispatched! {
    fn frames_at(robot: &CompiledRobot, q: &[f32x8]) -> Vec<u32> {
        let mut s = Scratch::<f32x8>::new(robot);
        kernel::forward(robot, q, &mut s);
        s.frames()
            .iter()
            .flat_map(|f| f.iter().flat_map(|v| v.to_array().map(f32::to_bits)))
            .collect()
    }
}

#[test]
fn every_level_gives_the_scalar_answers() {
    let (model, spheres, acm) = mbm_panda();
    let mut rng = StdRng::seed_from_u64(22);
    let levels: Vec<SimdLevel> = SimdLevel::ALL
        .into_iter()
        .filter(|l| l.supported())
        .collect();
    for scene in [
        "table_pick_panda/scene0002.yaml",
        "bookshelf_small_panda/scene0004.yaml",
    ] {
        let world =
            CollisionWorld::from_moveit_scene(shared(&format!("bench/mbm/{scene}"))).unwrap();
        let mut checker =
            CollisionChecker::new(model.clone(), spheres.clone(), acm.clone(), world).unwrap();
        checker.set_margin(0.01).unwrap();
        let n = 803; // not a multiple of 8
        let qs: Vec<Vec<f64>> = (0..n).map(|_| random_q(&model, &mut rng)).collect();
        // The reference: the scalar lane, one configuration at a time.
        let (robot, world) = checker.compiled();
        let mut scratch = Scratch::<f32>::new(robot);
        let scalar: Vec<bool> = qs
            .iter()
            .map(|q| {
                let q32: Vec<f32> = q.iter().map(|&v| v as f32).collect();
                kernel::check(robot, world, None, &q32, 0.01, 1, false, &mut scratch) != 0
            })
            .collect();
        assert!(scalar.iter().any(|&b| b) && scalar.iter().any(|&b| !b));
        // Kinematics of eight configurations, bit for bit.
        let q8: Vec<f32x8> = (0..model.num_dof())
            .map(|d| f32x8::from_fn(|i| qs[i][d] as f32))
            .collect();
        let frames = frames_bits(robot, &q8);
        let flat: Vec<f64> = qs.concat();
        let motions: Vec<(Vec<f64>, Vec<f64>)> = (0..60)
            .map(|i| {
                let a = qs[i].clone();
                let b = a.iter().map(|x| x + rng.random_range(-0.3..0.3)).collect();
                (a, b)
            })
            .collect();
        let mut motion_answers: Vec<Vec<bool>> = Vec::new();
        for &level in &levels {
            checker.set_simd_level(level).unwrap();
            let (robot, _) = checker.compiled();
            assert_eq!(frames_at(level, robot, &q8), frames, "{}", level.name());
            let batch = checker.in_collision_batch(&flat).unwrap();
            assert_eq!(batch, scalar, "{scene}: batch at {}", level.name());
            let single: Vec<bool> = qs
                .iter()
                .map(|q| checker.in_collision(q).unwrap())
                .collect();
            assert_eq!(single, scalar, "{scene}: single at {}", level.name());
            motion_answers.push(
                motions
                    .iter()
                    .map(|(a, b)| checker.motion_valid(a, b, 0.005).unwrap())
                    .collect(),
            );
        }
        // Motions: every level the same, and each free motion's endpoints
        // free for the scalar lane.
        assert!(motion_answers.windows(2).all(|w| w[0] == w[1]));
        for ((a, _), &ok) in motions.iter().zip(&motion_answers[0]) {
            if ok {
                let q32: Vec<f32> = a.iter().map(|&v| v as f32).collect();
                let (robot, world) = checker.compiled();
                assert_eq!(
                    kernel::check(robot, world, None, &q32, 0.01, 1, false, &mut scratch),
                    0
                );
            }
        }
    }
}
