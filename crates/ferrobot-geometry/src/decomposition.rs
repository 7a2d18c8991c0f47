//! Convex decomposition of triangle meshes (parry's V-HACD), computed once
//! per [`crate::Mesh`] and shared by every clone of it.

use parry3d::math::Vector as PVec;
use parry3d::shape::SharedShape;
use parry3d::transformation::vhacd::{VHACD, VHACDParameters};

use crate::error::{GeometryError, Result};

/// The parameters of a convex decomposition (a subset of V-HACD's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecompositionParams {
    /// Voxels along the mesh's longest side (8..=256; default 64). Finer
    /// voxels follow concavities more closely and cost more time.
    pub resolution: u32,
    /// Largest concavity a part may keep, relative to the mesh's size
    /// (0..=1; default 0.01).
    pub concavity: f64,
    /// Most convex parts kept (1..=1024; default 32).
    pub max_convex_hulls: u32,
}

impl Default for DecompositionParams {
    fn default() -> Self {
        Self {
            resolution: 64,
            concavity: 0.01,
            max_convex_hulls: 32,
        }
    }
}

impl DecompositionParams {
    /// Checks the documented ranges; the message names the field.
    pub fn validate(&self) -> Result<()> {
        if !(8..=256).contains(&self.resolution) {
            return Err(GeometryError::InvalidShape(format!(
                "convex decomposition: resolution must be in [8, 256], got {}",
                self.resolution
            )));
        }
        if !(self.concavity.is_finite() && (0.0..=1.0).contains(&self.concavity)) {
            return Err(GeometryError::InvalidShape(format!(
                "convex decomposition: concavity must be in [0, 1], got {}",
                self.concavity
            )));
        }
        if !(1..=1024).contains(&self.max_convex_hulls) {
            return Err(GeometryError::InvalidShape(format!(
                "convex decomposition: max_convex_hulls must be in [1, 1024], got {}",
                self.max_convex_hulls
            )));
        }
        Ok(())
    }

    /// A hashable key (for caches).
    pub fn key(&self) -> (u32, u64, u32) {
        (
            self.resolution,
            self.concavity.to_bits(),
            self.max_convex_hulls,
        )
    }
}

/// The convex parts of the mesh `vertices`/`triangles` as a parry compound
/// (each part the exact hull of the mesh triangles in its voxels, so the
/// parts together hold every triangle). Fails when no part has a volume.
pub fn decompose(
    vertices: &[PVec],
    triangles: &[[u32; 3]],
    params: &DecompositionParams,
) -> Result<SharedShape> {
    params.validate()?;
    let p = VHACDParameters {
        resolution: params.resolution,
        concavity: params.concavity as f32,
        max_convex_hulls: params.max_convex_hulls,
        ..VHACDParameters::default()
    };
    let decomp = VHACD::decompose(&p, vertices, triangles, true);
    let parts: Vec<_> = decomp
        .compute_exact_convex_hulls(vertices, triangles)
        .into_iter()
        .filter_map(|(v, i)| SharedShape::convex_mesh(v, &i))
        .map(|s| (parry3d::math::Pose::IDENTITY, s))
        .collect();
    if parts.is_empty() {
        return Err(GeometryError::InvalidShape(
            "the convex decomposition has no part with a volume (a flat or degenerate mesh)".into(),
        ));
    }
    Ok(SharedShape::compound(parts))
}
