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
}

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
}

/// `(sin x, cos x)` to about 1e-7, lane-wise, from the half angle: `x` is
/// reduced to `[-pi, pi]`, the half angle's sine and cosine come from
/// Taylor polynomials on `[-pi/2, pi/2]`, then `sin x = 2 s c`,
/// `cos x = 1 - 2 s^2`.
#[inline(always)]
pub fn sin_cos<L: Lanes>(x: L) -> (L, L) {
    // 2 pi split in two parts so that k * 2pi is exact in the first part.
    const TWO_PI_HI: f32 = 6.28125;
    const TWO_PI_LO: f32 = 0.001_935_307_2;
    const INV_TWO_PI: f32 = 0.159_154_94;
    let k = (x * L::splat(INV_TWO_PI)).round();
    let r = x - k * L::splat(TWO_PI_HI) - k * L::splat(TWO_PI_LO);
    let h = r * L::splat(0.5);
    let h2 = h * h;
    // sin h = h (1 - h2/3! (1 - h2/(4*5) (1 - h2/(6*7) (1 - h2/(8*9) (1 - h2/(10*11))))))
    let one = L::splat(1.0);
    let s = h
        * (one
            - h2 * L::splat(1.0 / 6.0)
                * (one
                    - h2 * L::splat(1.0 / 20.0)
                        * (one
                            - h2 * L::splat(1.0 / 42.0)
                                * (one
                                    - h2 * L::splat(1.0 / 72.0)
                                        * (one - h2 * L::splat(1.0 / 110.0))))));
    let c = one
        - h2 * L::splat(0.5)
            * (one
                - h2 * L::splat(1.0 / 12.0)
                    * (one
                        - h2 * L::splat(1.0 / 30.0)
                            * (one
                                - h2 * L::splat(1.0 / 56.0)
                                    * (one
                                        - h2 * L::splat(1.0 / 90.0)
                                            * (one - h2 * L::splat(1.0 / 132.0))))));
    let two = L::splat(2.0);
    (two * s * c, one - two * s * s)
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
