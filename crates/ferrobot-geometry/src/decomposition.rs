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

/// Relative difference below which a closed mesh's volume equals its convex
/// hull's: the mesh is convex (f32 vertices carry about 1e-7 relative
/// error, so 1e-5 separates round-off from any real dent).
const CONVEX_VOLUME_TOLERANCE: f64 = 1e-5;

/// The volume enclosed by a closed, consistently wound triangle mesh (the
/// divergence theorem: the sum of the triangles' signed tetrahedra with the
/// origin; its absolute value, whatever the winding).
fn enclosed_volume(vertices: &[PVec], triangles: &[[u32; 3]]) -> f64 {
    let v = |i: u32| {
        let p = vertices[i as usize];
        nalgebra::Vector3::new(f64::from(p.x), f64::from(p.y), f64::from(p.z))
    };
    let sum: f64 = triangles
        .iter()
        .map(|t| v(t[0]).dot(&v(t[1]).cross(&v(t[2]))))
        .sum();
    (sum / 6.0).abs()
}

/// The mesh's convex hull as its one part when the mesh is closed and
/// convex (its enclosed volume equals its hull's): V-HACD's voxels would
/// split even a box into several parts, with internal edges the contacts
/// catch on; a convex mesh is its own decomposition, exactly.
fn convex_mesh_as_hull(vertices: &[PVec], triangles: &[[u32; 3]]) -> Option<SharedShape> {
    if triangles.len() < 4 || !crate::mesh::is_closed(triangles) {
        return None;
    }
    // The hull's volume from its own triangles (parry's mass properties of a
    // convex polyhedron are off by ~0.3 % on a 24 x 48 UV sphere).
    let (hull_vertices, hull_triangles) = parry3d::transformation::convex_hull(vertices);
    let hull_volume = enclosed_volume(&hull_vertices, &hull_triangles);
    let volume = enclosed_volume(vertices, triangles);
    let hull = SharedShape::convex_mesh(hull_vertices, &hull_triangles)?;
    (hull_volume > 0.0 && hull_volume - volume <= CONVEX_VOLUME_TOLERANCE * hull_volume)
        .then(|| SharedShape::compound(vec![(parry3d::math::Pose::IDENTITY, hull)]))
}

/// The convex parts of the mesh `vertices`/`triangles` as a parry compound
/// (each part the exact hull of the mesh triangles in its voxels, so the
/// parts together hold every triangle). A closed convex mesh is one part,
/// its hull. Fails when no part has a volume.
pub fn decompose(
    vertices: &[PVec],
    triangles: &[[u32; 3]],
    params: &DecompositionParams,
) -> Result<SharedShape> {
    params.validate()?;
    if let Some(hull) = convex_mesh_as_hull(vertices, triangles) {
        return Ok(hull);
    }
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
