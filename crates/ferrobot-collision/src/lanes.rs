//! SIMD lanes: the collision kernel is written once, generic over a lane
//! type that is either one `f32` (the scalar path) or `wide::f32x8` (eight
//! configurations at once). Every operation is an IEEE lane-wise operation
//! and `sin_cos` is our own polynomial, so a configuration gets bit-identical
//! results whichever lane (or the scalar path) carries it.

use std::ops::{Add, Mul, Neg, Sub};

use wide::f32x8;

/// A vector of `WIDTH` independent `f32` lanes.
pub trait Lanes:
    Copy
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
{
    /// Number of lanes.
    const WIDTH: usize;
    /// Bitmask with every lane set.
    const FULL: u32;
    /// All lanes equal to `v`.
    fn splat(v: f32) -> Self;
    /// Lane `i` set to `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;
    /// Lane `i`.
    fn lane(self, i: usize) -> f32;
    /// Lane-wise minimum.
    fn min(self, o: Self) -> Self;
    /// Lane-wise maximum.
    fn max(self, o: Self) -> Self;
    /// Lane-wise absolute value.
    fn abs(self) -> Self;
    /// Lane-wise square root.
    fn sqrt(self) -> Self;
    /// Lane-wise rounding to nearest, ties to even.
    fn round(self) -> Self;
    /// Bitmask of the lanes where `self < o`.
    fn lt_mask(self, o: Self) -> u32;
    /// `self * a + b`, rounded once where the target has FMA ([`FUSED`])
    /// and twice elsewhere, identically for every lane type.
    fn mul_add(self, a: Self, b: Self) -> Self;
}

/// Whether [`Lanes::mul_add`] is one fused operation on this target.
pub const FUSED: bool = cfg!(target_feature = "fma");

impl Lanes for f32 {
    const WIDTH: usize = 1;
    const FULL: u32 = 1;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> f32 {
        self
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        if o < self { o } else { self }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        if o > self { o } else { self }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn round(self) -> Self {
        self.round_ties_even()
    }
    #[inline(always)]
    fn lt_mask(self, o: Self) -> u32 {
        (self < o) as u32
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        if FUSED {
            f32::mul_add(self, a, b)
        } else {
            self * a + b
        }
    }
}

impl Lanes for f32x8 {
    const WIDTH: usize = 8;
    const FULL: u32 = 0xff;
    #[inline(always)]
    fn splat(v: f32) -> Self {
        f32x8::splat(v)
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f32) -> Self {
        f32x8::new([f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)])
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f32 {
        self.to_array()[i]
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // Same selection rule as the scalar path: `o` where `o < self`.
        let m = o.simd_lt(self);
        m.select(o, self)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        let m = self.simd_lt(o);
        m.select(o, self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32x8::abs(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32x8::sqrt(self)
    }
    #[inline(always)]
    fn round(self) -> Self {
        f32x8::round_ties_even(self)
    }
    #[inline(always)]
    fn lt_mask(self, o: Self) -> u32 {
        self.simd_lt(o).to_bitmask()
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        if FUSED {
            f32x8::mul_add(self, a, b)
        } else {
            self * a + b
        }
    }
}

/// `(sin x, cos x)` to about 1e-7, lane-wise, from the half angle: `x` is
/// reduced to `[-pi, pi]`, the half angle's sine and cosine come from
/// Taylor polynomials on `[-pi/2, pi/2]`, then `sin x = 2 s c`,
/// `cos x = 1 - 2 s^2`. The polynomials are evaluated in Estrin's scheme
/// with [`Lanes::mul_add`]: the forward kinematics waits on this, so its
/// latency counts more than its operation count.
#[inline(always)]
pub fn sin_cos<L: Lanes>(x: L) -> (L, L) {
    // pi split in two parts so that k * pi is exact in the first part.
    const PI_HI: f32 = 3.140_625;
    const PI_LO: f32 = 0.000_967_653_6;
    const INV_TWO_PI: f32 = 0.159_154_94;
    let s = L::splat;
    let k = (x * s(INV_TWO_PI)).round();
    // Half of x - 2 pi k.
    let h = (x * s(0.5) - k * s(PI_HI)) - k * s(PI_LO);
    let u = h * h;
    let (u2, u4) = (u * u, (u * u) * (u * u));
    // sin h / h = 1 - u/3! + u^2/5! - u^3/7! + u^4/9! - u^5/11!
    let p01 = u.mul_add(s(-1.0 / 6.0), s(1.0));
    let p23 = u.mul_add(s(-1.0 / 5040.0), s(1.0 / 120.0));
    let p45 = u.mul_add(s(-1.0 / 39_916_800.0), s(1.0 / 362_880.0));
    let sh = h * u4.mul_add(p45, u2.mul_add(p23, p01));
    // cos h = 1 - u/2! + u^2/4! - u^3/6! + u^4/8! - u^5/10! + u^6/12!
    let q01 = u.mul_add(s(-0.5), s(1.0));
    let q23 = u.mul_add(s(-1.0 / 720.0), s(1.0 / 24.0));
    let q45 = u.mul_add(s(-1.0 / 3_628_800.0), s(1.0 / 40_320.0));
    let q6 = s(1.0 / 479_001_600.0);
    let ch = u4.mul_add(u2.mul_add(q6, q45), u2.mul_add(q23, q01));
    let two_s = sh + sh;
    (two_s * ch, (-two_s).mul_add(sh, s(1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_accurate_and_lane_exact() {
        let xs: Vec<f32> = (-2000..=2000).map(|i| i as f32 * 0.0131).collect();
        for chunk in xs.chunks(8) {
            if chunk.len() < 8 {
                continue;
            }
            let v = f32x8::from_fn(|i| chunk[i]);
            let (s8, c8) = sin_cos(v);
            for (i, &x) in chunk.iter().enumerate() {
                let (s, c) = sin_cos(x);
                assert_eq!(s.to_bits(), s8.lane(i).to_bits());
                assert_eq!(c.to_bits(), c8.lane(i).to_bits());
                assert!((s as f64 - (x as f64).sin()).abs() < 2e-6, "{x}");
                assert!((c as f64 - (x as f64).cos()).abs() < 2e-6, "{x}");
            }
        }
    }

    #[test]
    fn min_max_lt_agree() {
        let a = f32x8::from_fn(|i| i as f32 - 3.5);
        let b = f32x8::splat(0.0);
        assert_eq!(a.lt_mask(b), 0b0000_1111);
        for i in 0..8 {
            assert_eq!(a.min(b).lane(i), (i as f32 - 3.5).min(0.0));
            assert_eq!(a.max(b).lane(i), (i as f32 - 3.5).max(0.0));
        }
    }
}
