//! Triangle-mesh obstacles: parry's `TriMesh` (with its BVH) for exact
//! point distances, and the sign from its pseudo-normals (closed meshes).

use nalgebra::{Point3, Vector3};
use parry3d::math::Vector as PVec;
use parry3d::query::PointQuery;
use parry3d::shape::{TriMesh, TriMeshFlags};

use crate::error::{CollisionError, Result};

/// A mesh obstacle, with the parry structures built once.
#[derive(Debug, Clone)]
pub struct MeshShape {
    mesh: TriMesh,
    bounding_radius: f64,
    closed: bool,
}

impl MeshShape {
    /// Builds from vertices and triangles (already scaled, in the object frame).
    pub fn new(vertices: &[Point3<f64>], triangles: &[[u32; 3]]) -> Result<Self> {
        if triangles.is_empty() {
            return Err(CollisionError::InvalidShape("mesh: no triangles".into()));
        }
        if let Some(t) = triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= vertices.len()))
        {
            return Err(CollisionError::InvalidShape(format!(
                "mesh: triangle {t:?} refers to a vertex beyond the {} given",
                vertices.len()
            )));
        }
        if vertices
            .iter()
            .any(|v| !v.coords.iter().all(|c| c.is_finite()))
        {
            return Err(CollisionError::InvalidShape(
                "mesh: non-finite vertex".into(),
            ));
        }
        let verts: Vec<PVec> = vertices
            .iter()
            .map(|v| PVec::new(v.x as f32, v.y as f32, v.z as f32))
            .collect();
        let flags = TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES;
        let mesh = TriMesh::with_flags(verts, triangles.to_vec(), flags)
            .map_err(|e| CollisionError::InvalidShape(format!("mesh: {e:?}")))?;
        let bounding_radius = vertices.iter().map(|v| v.coords.norm()).fold(0.0, f64::max);
        let closed = is_closed(triangles);
        Ok(Self {
            mesh,
            bounding_radius,
            closed,
        })
    }

    /// The parry mesh.
    pub fn trimesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// Radius of a ball around the origin holding every vertex.
    pub fn bounding_radius(&self) -> f64 {
        self.bounding_radius
    }

    /// Whether every edge is shared by exactly two triangles (a solid:
    /// points inside get negative distances). Open meshes are surfaces:
    /// distances are unsigned.
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Signed distance (negative inside a closed mesh) and its direction.
    pub fn signed_distance(&self, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        let q = PVec::new(p.x as f32, p.y as f32, p.z as f32);
        let proj = self.mesh.project_local_point(q, false);
        let c = Point3::new(
            proj.point.x as f64,
            proj.point.y as f64,
            proj.point.z as f64,
        );
        let d = p - c;
        let n = d.norm();
        let inside = self.closed && proj.is_inside;
        let dir = if n > 1e-12 { d / n } else { Vector3::z() };
        if inside { (-n, -dir) } else { (n, dir) }
    }
}

fn is_closed(triangles: &[[u32; 3]]) -> bool {
    use std::collections::HashMap;
    let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    edges.values().all(|&c| c == 2)
}
