//! The bodies' bounding-sphere centres of one configuration, eight bodies
//! to a chunk (structure of arrays), for the single-configuration kernel's
//! eight-wide tests over bodies: world grid lookups and self pair bounds.

use wide::{f32x4, f32x8};

/// Bounding-sphere centres of a robot's bodies, eight bodies per chunk
/// (x, y, z lanes). Padding lanes are NaN.
#[derive(Debug, Clone)]
pub struct BodyCentres(Vec<[f32x8; 3]>);

impl BodyCentres {
    /// Room for `num_bodies` centres (NaN until set).
    pub fn new(num_bodies: usize) -> Self {
        Self(vec![[f32x8::splat(f32::NAN); 3]; num_bodies.div_ceil(8)])
    }

    /// Sets the centres of bodies `0, 1, ...` from the first three lanes
    /// of each item of `centres`.
    #[inline(always)]
    pub fn set_all(&mut self, mut centres: impl Iterator<Item = f32x4>) {
        for chunk in &mut self.0 {
            for lane in 0..8 {
                let Some(c) = centres.next() else {
                    return;
                };
                for (lanes, v) in chunk.iter_mut().zip(c.to_array()) {
                    lanes.as_mut_array()[lane] = v;
                }
            }
        }
    }

    /// The centre of `body`.
    #[inline(always)]
    pub fn get(&self, body: usize) -> [f32; 3] {
        let chunk = &self.0[body / 8];
        chunk.map(|v| v.as_array()[body % 8])
    }

    /// The chunks: bodies `8 c .. 8 c + 8` in chunk `c`.
    #[inline(always)]
    pub fn chunks(&self) -> &[[f32x8; 3]] {
        &self.0
    }
}
