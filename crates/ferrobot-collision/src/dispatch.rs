//! Run-time choice of the instruction set for the collision kernels.
//!
//! For a build of the crate for the architecture's baseline (x86-64: SSE2;
//! aarch64: NEON), e.g. a Rust program using it without
//! `target-cpu=native`. (The Python wheel goes further: it holds the whole
//! extension compiled once per level and loads the best at import,
//! `python/ferrobot/_builds.py`; each of those builds' dispatch then runs
//! its own level, capped through `FERROBOT_SIMD` when a level is forced.)
//! The kernels' entry
//! points (a batch chunk, a motion, one configuration) are compiled once per
//! [`SimdLevel`] by [`dispatched!`](crate::dispatched) with the
//! `multiversion` crate, and the best level the CPU supports is chosen once,
//! at the first query. Everything the entry points call with
//! `#[inline(always)]` (the lanes, forward kinematics, the sphere tests) is
//! compiled into each copy with that level's instructions.
//!
//! Every level gives bit-identical answers: the kernels use IEEE lane-wise
//! operations only and never fuse a multiply with an add (see
//! [`crate::lanes::FUSED`]), so no rounding depends on the instruction set
//! (tested against the scalar path for each level the CPU supports).
//!
//! The environment variable `FERROBOT_SIMD` (read once) caps the level, for
//! benchmarks and diagnosis: one of the [`SimdLevel::name`]s, e.g.
//! `FERROBOT_SIMD=x86-64-v2`. A level above the CPU's, or an unknown name,
//! leaves the detected level (an unknown name is reported once on stderr).

use std::sync::OnceLock;

use wide::f32x8;

use crate::compiled::{CompiledRobot, CompiledWorld};
use crate::kernel::{self, Scratch};
use crate::lanes::Lanes;
use crate::single::{self, OneScratch};
use crate::world_grid::WorldGrid;

/// An instruction-set level a kernel entry point is compiled for, from the
/// baseline up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// The architecture's baseline (x86-64: SSE2; aarch64: NEON; others:
    /// whatever the target guarantees).
    Baseline,
    /// x86-64-v2: SSE4.2, SSSE3, POPCNT.
    X86V2,
    /// x86-64-v3: AVX2, FMA, BMI1/2 (Haswell, Zen 1 and later).
    X86V3,
    /// x86-64-v4: AVX-512 F/BW/CD/DQ/VL (Skylake-X, Zen 4 and later).
    X86V4,
}

impl SimdLevel {
    /// Every level, from the baseline up.
    pub const ALL: [SimdLevel; 4] = [Self::Baseline, Self::X86V2, Self::X86V3, Self::X86V4];

    /// The level's name, as `FERROBOT_SIMD` accepts it: `baseline`,
    /// `x86-64-v2`, `x86-64-v3`, `x86-64-v4`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Baseline => "baseline",
            Self::X86V2 => "x86-64-v2",
            Self::X86V3 => "x86-64-v3",
            Self::X86V4 => "x86-64-v4",
        }
    }

    /// The level named `name` (see [`SimdLevel::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Whether this CPU can run code compiled for the level.
    pub fn supported(self) -> bool {
        self <= detected()
    }
}

/// The best level this CPU supports (detected once).
pub fn detected() -> SimdLevel {
    static DETECTED: OnceLock<SimdLevel> = OnceLock::new();
    *DETECTED.get_or_init(detect)
}

#[cfg(target_arch = "x86_64")]
fn detect() -> SimdLevel {
    use std::arch::is_x86_feature_detected as has;
    let v2 = has!("sse3")
        && has!("ssse3")
        && has!("sse4.1")
        && has!("sse4.2")
        && has!("popcnt")
        && has!("cmpxchg16b");
    let v3 = v2
        && has!("avx")
        && has!("avx2")
        && has!("fma")
        && has!("bmi1")
        && has!("bmi2")
        && has!("lzcnt")
        && has!("movbe")
        && has!("f16c");
    let v4 = v3
        && has!("avx512f")
        && has!("avx512bw")
        && has!("avx512cd")
        && has!("avx512dq")
        && has!("avx512vl");
    if v4 {
        SimdLevel::X86V4
    } else if v3 {
        SimdLevel::X86V3
    } else if v2 {
        SimdLevel::X86V2
    } else {
        SimdLevel::Baseline
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn detect() -> SimdLevel {
    SimdLevel::Baseline
}

/// The level the kernels use: [`detected`], capped by `FERROBOT_SIMD`
/// (chosen once, at the first query).
pub fn level() -> SimdLevel {
    static LEVEL: OnceLock<SimdLevel> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let best = detected();
        match std::env::var("FERROBOT_SIMD") {
            Ok(name) => match SimdLevel::from_name(name.trim()) {
                Some(l) => l.min(best),
                None => {
                    eprintln!(
                        "ferrobot: FERROBOT_SIMD={name:?} is not one of baseline, x86-64-v2, \
                         x86-64-v3, x86-64-v4; using {}",
                        best.name()
                    );
                    best
                }
            },
            Err(_) => best,
        }
    })
}

/// Defines a function compiled once per [`SimdLevel`] whose first argument
/// is the level to run (`level: SimdLevel`); a level the CPU lacks runs the
/// best copy it has. Arguments are plain `name: Type` pairs.
///
/// Each copy is a `multiversion` function with a single target, so its
/// body (and everything it inlines) is compiled with that level's target
/// features, and `multiversion` checks the CPU before running it.
#[macro_export]
#[doc(hidden)]
macro_rules! dispatched {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block
    ) => {
        $(#[$meta])*
        $vis fn $name(level: $crate::dispatch::SimdLevel, $($arg: $ty),*) $(-> $ret)? {
            #[multiversion::multiversion(targets("x86_64+sse3+ssse3+sse4.1+sse4.2+popcnt+cmpxchg16b+avx+avx2+fma+bmi1+bmi2+lzcnt+movbe+f16c+avx512f+avx512bw+avx512cd+avx512dq+avx512vl"))]
            fn v4($($arg: $ty),*) $(-> $ret)? $body
            #[multiversion::multiversion(targets("x86_64+sse3+ssse3+sse4.1+sse4.2+popcnt+cmpxchg16b+avx+avx2+fma+bmi1+bmi2+lzcnt+movbe+f16c"))]
            fn v3($($arg: $ty),*) $(-> $ret)? $body
            #[multiversion::multiversion(targets("x86_64+sse3+ssse3+sse4.1+sse4.2+popcnt+cmpxchg16b"))]
            fn v2($($arg: $ty),*) $(-> $ret)? $body
            #[multiversion::multiversion(targets("x86_64+sse2"))]
            fn base($($arg: $ty),*) $(-> $ret)? $body
            match level {
                $crate::dispatch::SimdLevel::X86V4 => v4($($arg),*),
                $crate::dispatch::SimdLevel::X86V3 => v3($($arg),*),
                $crate::dispatch::SimdLevel::X86V2 => v2($($arg),*),
                $crate::dispatch::SimdLevel::Baseline => base($($arg),*),
            }
        }
    };
}

dispatched! {
    /// The target features the copy for `level` was compiled with (for
    /// tests: the copy that runs has the level's instructions).
    pub fn compiled_features() -> Vec<String> {
        multiversion::target::selected_target!()
            .features()
            .map(|f| f.name().to_string())
            .collect()
    }
}

// The kernels' entry points, one copy per level. Dispatch happens here,
// once per call (a chunk of a batch, a motion, one configuration), never
// per lane operation.

dispatched! {
    /// Collision flags into `out` for the configurations in `qs` (row-major,
    /// `dof` each), eight per SIMD pack (the body of a batch chunk): the
    /// world at `margin`, self pairs at `self_margin`
    /// ([`kernel::check_margins`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn check_packs(
        robot: &CompiledRobot,
        world: &CompiledWorld,
        grid: Option<&WorldGrid>,
        qs: &[f64],
        dof: usize,
        margin: f32,
        self_margin: f32,
        out: &mut [bool],
        scratch: &mut Scratch<f32x8>,
    ) {
        // Up to 32 DOFs packed on the stack (no allocation per pack).
        let mut stack = [f32x8::splat(0.0); 32];
        for (po, pq) in out.chunks_mut(8).zip(qs.chunks(8 * dof)) {
            let n = po.len();
            let heap;
            let lanes: &[f32x8] = if dof <= stack.len() {
                for (d, lane) in stack[..dof].iter_mut().enumerate() {
                    *lane = f32x8::from_fn(|i| pq[i.min(n - 1) * dof + d] as f32);
                }
                &stack[..dof]
            } else {
                heap = crate::checker::pack(pq, dof, n);
                &heap
            };
            let active = (1u32 << n) - 1;
            let hit = kernel::check_margins(
                robot,
                world,
                grid,
                lanes,
                margin,
                self_margin,
                active,
                true,
                scratch,
            );
            for (i, v) in po.iter_mut().enumerate() {
                *v = hit & (1 << i) != 0;
            }
        }
    }
}

dispatched! {
    /// Whether the straight motion from `q0` to `q1` in `steps` equal steps
    /// (endpoints included) is free, eight configurations spread along it
    /// per pack; `lanes` holds one pack (`q0.len()` lanes). `None` when
    /// `deadline` passed first (the clock is read every 64 packs).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn motion_free(
        robot: &CompiledRobot,
        world: &CompiledWorld,
        grid: Option<&WorldGrid>,
        q0: &[f64],
        q1: &[f64],
        steps: usize,
        lanes: &mut [f32x8],
        margin: f32,
        deadline: Option<std::time::Instant>,
        scratch: &mut Scratch<f32x8>,
    ) -> Option<bool> {
        let points = steps.saturating_add(1);
        let packs = points.div_ceil(8);
        for p in 0..packs {
            if p % 64 == 63 && deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                return None;
            }
            let index = |i: usize| (i * packs + p).min(points - 1);
            for (d, lane) in lanes.iter_mut().enumerate() {
                *lane = f32x8::from_fn(|i| {
                    let t = index(i) as f64 / steps as f64;
                    (q0[d] + (q1[d] - q0[d]) * t) as f32
                });
            }
            if kernel::check(robot, world, grid, lanes, margin, 0xff, true, scratch) != 0 {
                return Some(false);
            }
        }
        Some(true)
    }
}

dispatched! {
    /// [`crate::single::check_one`] at the level.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn check_one(
        robot: &CompiledRobot,
        world: &CompiledWorld,
        grid: Option<&WorldGrid>,
        q: &[f32],
        margin: f32,
        skip_static: bool,
        scratch: &mut OneScratch,
    ) -> bool {
        single::check_one(robot, world, grid, q, margin, skip_static, scratch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_levels_are_ordered() {
        for l in SimdLevel::ALL {
            assert_eq!(SimdLevel::from_name(l.name()), Some(l));
        }
        assert!(SimdLevel::ALL.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(SimdLevel::from_name("avx9"), None);
        assert!(level() <= detected());
    }
}
