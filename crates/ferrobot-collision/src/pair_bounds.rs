//! The self pairs' bounding-sphere test of the single-configuration kernel,
//! eight pairs per SIMD instruction.
//!
//! The bodies' bounding-sphere centres are kept eight bodies to a chunk
//! (structure of arrays, [`BodyCentres`]). Pairs are batched eight at a
//! time by the chunks of their two members, so that one lane permute per
//! coordinate picks each member's centres out of its chunk, and one
//! distance test serves the eight pairs. Each lane computes exactly what the
//! scalar test of its pair would (the centres' difference, its squares
//! summed left to right, against `(reach + margin)^2`, a pair going on
//! unless the distance is at least the reach), so the same pairs reach the
//! sphere stage; only their order differs, which cannot change whether any
//! of them collides.

use wide::{f32x8, u32x8};

use crate::body_centres::BodyCentres;

/// Eight self pairs whose first members lie in one chunk of bodies and
/// whose second members lie in one chunk.
#[derive(Debug, Clone)]
struct Batch {
    /// The chunks of the two members.
    chunks: [usize; 2],
    /// The two members' lanes in their chunks, per pair.
    lanes: [u32x8; 2],
    /// Sums of the two bounding radii (0 in padding lanes).
    reach: f32x8,
    /// Lanes that hold a pair.
    valid: u32,
    /// The pairs' indices (see [`PairBounds::new`]), per lane.
    pairs: [usize; 8],
}

/// The self pairs' bounding spheres, batched (see the module docs).
#[derive(Debug, Clone)]
pub struct PairBounds {
    batches: Vec<Batch>,
}

impl PairBounds {
    /// Batches of `pairs` (body indices, for `num_bodies` bodies) with the
    /// sums of their bounding radii `reach` (aligned with `pairs`).
    pub fn new(pairs: &[(usize, usize)], reach: &[f32], num_bodies: usize) -> Self {
        let chunks = num_bodies.div_ceil(8);
        let mut batches = Vec::new();
        for ca in 0..chunks {
            for cb in 0..chunks {
                let group: Vec<usize> = (0..pairs.len())
                    .filter(|&pi| pairs[pi].0 / 8 == ca && pairs[pi].1 / 8 == cb)
                    .collect();
                for group in group.chunks(8) {
                    let lane = |member: fn(&(usize, usize)) -> usize| {
                        u32x8::new(std::array::from_fn(|i| {
                            group
                                .get(i)
                                .map_or(0, |&pi| (member(&pairs[pi]) % 8) as u32)
                        }))
                    };
                    batches.push(Batch {
                        chunks: [ca, cb],
                        lanes: [lane(|p| p.0), lane(|p| p.1)],
                        reach: f32x8::new(std::array::from_fn(|i| {
                            group.get(i).map_or(0.0, |&pi| reach[pi])
                        })),
                        valid: (1u32 << group.len()) - 1,
                        pairs: std::array::from_fn(|i| group.get(i).copied().unwrap_or(0)),
                    });
                }
            }
        }
        Self { batches }
    }

    /// The pairs (indices into the pairs given to [`PairBounds::new`]),
    /// each once, in batch order, whose bounding spheres at `centres` are
    /// not at least their reach plus `margin` apart. Batches are tested as
    /// the iterator reaches them.
    #[inline(always)]
    pub fn near<'a>(&'a self, centres: &'a BodyCentres, margin: f32) -> Near<'a> {
        Near {
            bounds: self,
            centres,
            margin: f32x8::splat(margin),
            next_batch: 0,
            bits: 0,
        }
    }
}

/// Iterator of [`PairBounds::near`].
#[derive(Debug)]
pub struct Near<'a> {
    bounds: &'a PairBounds,
    centres: &'a BodyCentres,
    margin: f32x8,
    next_batch: usize,
    /// Near pairs of the current batch not yet returned.
    bits: u32,
}

impl Iterator for Near<'_> {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        while self.bits == 0 {
            let batch = self.bounds.batches.get(self.next_batch)?;
            self.next_batch += 1;
            let chunks = self.centres.chunks();
            let [ca, cb] =
                [0, 1].map(|s| chunks[batch.chunks[s]].map(|v| v.shuffle(batch.lanes[s])));
            let d = [ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]];
            let reach = batch.reach + self.margin;
            let far = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).simd_ge(reach * reach);
            self.bits = !far.to_bitmask() & batch.valid;
        }
        let i = self.bits.trailing_zeros() as usize;
        self.bits &= self.bits - 1;
        Some(self.bounds.batches[self.next_batch - 1].pairs[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wide::f32x4;

    /// The near pairs are exactly those the scalar test keeps (the
    /// single kernel's former loop), each once, for three chunks of bodies,
    /// every pair, several margins and a NaN centre.
    #[test]
    fn near_pairs_match_the_scalar_test() {
        let n = 19;
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        let pairs: Vec<(usize, usize)> = (0..n)
            .flat_map(|a| (a + 1..n).map(move |b| (a, b)))
            .filter(|&(a, b)| (a * 7 + b) % 5 != 0)
            .collect();
        let reach: Vec<f32> = pairs.iter().map(|_| 0.05 + 0.3 * rnd()).collect();
        let bounds = PairBounds::new(&pairs, &reach, n);
        let mut centres = BodyCentres::new(n);
        let (mut near, mut far) = (0, 0);
        for trial in 0..200 {
            let cs: Vec<[f32; 4]> = (0..n)
                .map(|i| {
                    if trial % 50 == 3 && i == 11 {
                        [f32::NAN; 4]
                    } else {
                        [rnd(), rnd(), rnd(), 0.0]
                    }
                })
                .collect();
            centres.set_all(n, |i| f32x4::from(cs[i]));
            let margin = [0.0, 0.02, -0.01][trial % 3];
            let want: Vec<usize> = pairs
                .iter()
                .enumerate()
                .filter(|&(pi, &(a, b))| {
                    let (ca, cb) = (centres.get(a), centres.get(b));
                    let r = reach[pi] + margin;
                    let d = [ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]];
                    // Near unless at least the reach apart (NaN is near).
                    let far = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) >= r * r;
                    !far
                })
                .map(|(pi, _)| pi)
                .collect();
            let mut got: Vec<usize> = bounds.near(&centres, margin).collect();
            got.sort_unstable();
            assert_eq!(got, want, "trial {trial}");
            near += want.len();
            far += pairs.len() - want.len();
        }
        assert!(near > 1000 && far > 1000, "{near} {far}");
    }
}
