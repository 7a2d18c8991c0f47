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

    /// Sets the centres of bodies `0..n` to the first three lanes of
    /// `centre(body)` (`n` at most the number of bodies). Each chunk is
    /// assembled in registers: writing lanes one by one and then loading
    /// the chunk would stall on store forwarding.
    #[inline(always)]
    pub fn set_all(&mut self, n: usize, centre: impl Fn(usize) -> f32x4) {
        for (c, chunk) in self.0.iter_mut().enumerate() {
            let v: [f32x4; 8] = std::array::from_fn(|i| {
                if c * 8 + i < n {
                    centre(c * 8 + i)
                } else {
                    f32x4::splat(f32::NAN)
                }
            });
            let lo = f32x4::transpose([v[0], v[1], v[2], v[3]]);
            let hi = f32x4::transpose([v[4], v[5], v[6], v[7]]);
            *chunk = std::array::from_fn(|k| {
                let (l, h) = (lo[k].to_array(), hi[k].to_array());
                f32x8::new([l[0], l[1], l[2], l[3], h[0], h[1], h[2], h[3]])
            });
        }
    }

    /// The centre of `body`, read lane by lane from the stored chunk (a
    /// copy of the chunk in registers would be spilled to the stack to
    /// pick a lane by index, and the lane's load would wait on that store).
    #[inline(always)]
    pub fn get(&self, body: usize) -> [f32; 3] {
        let chunk = &self.0[body / 8];
        let lane = body % 8;
        [
            chunk[0].as_array()[lane],
            chunk[1].as_array()[lane],
            chunk[2].as_array()[lane],
        ]
    }

    /// The chunks: bodies `8 c .. 8 c + 8` in chunk `c`.
    #[inline(always)]
    pub fn chunks(&self) -> &[[f32x8; 3]] {
        &self.0
    }
}
