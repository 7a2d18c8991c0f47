//! Shared triangle meshes and convex hulls, with their parry structures
//! built once on first use.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use nalgebra::{Point3, Vector3};
use parry3d::math::Vector as PVec;
use parry3d::query::PointQuery;
use parry3d::shape::{SharedShape, TriMeshFlags};

use crate::decomposition::DecompositionParams;
use crate::error::{GeometryError, Result};
use crate::trimesh::TriMesh;

/// Where a mesh came from (a URDF `<mesh filename=...>`).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSource {
    /// The filename as written in the URDF.
    pub filename: String,
    /// The file it resolved to.
    pub path: PathBuf,
}

/// The parry mesh (with its BVH) and what is derived from the topology.
#[derive(Debug, Clone)]
struct MeshQuery {
    mesh: parry3d::shape::TriMesh,
    closed: bool,
}

/// A triangle mesh in its own frame: shared vertex data (loaded once per
/// file), a per-use scale, and the parry BVH built on the first distance
/// query (or by [`Mesh::query_ready`]) and shared by every clone.
#[derive(Debug, Clone)]
pub struct Mesh {
    data: Arc<TriMesh>,
    scale: Vector3<f64>,
    source: Option<MeshSource>,
    bounding_radius: f64,
    query: OnceLock<std::result::Result<MeshQuery, GeometryError>>,
    decomposition_params: DecompositionParams,
    decomposition: OnceLock<std::result::Result<SharedShape, GeometryError>>,
}

fn check_data(vertices: &[Point3<f64>], triangles: &[[u32; 3]]) -> Result<()> {
    if triangles.is_empty() {
        return Err(GeometryError::InvalidShape("mesh: no triangles".into()));
    }
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= vertices.len()))
    {
        return Err(GeometryError::InvalidShape(format!(
            "mesh: triangle {t:?} refers to a vertex beyond the {} given",
            vertices.len()
        )));
    }
    if vertices
        .iter()
        .any(|v| !v.coords.iter().all(|c| c.is_finite()))
    {
        return Err(GeometryError::NonFinite("mesh: non-finite vertex".into()));
    }
    Ok(())
}

impl Mesh {
    /// A mesh of `vertices` (shape frame, metres) and `triangles` (indices
    /// into `vertices`). Fails on no triangles, an index out of range or a
    /// non-finite vertex.
    pub fn new(vertices: Vec<Point3<f64>>, triangles: Vec<[u32; 3]>) -> Result<Self> {
        check_data(&vertices, &triangles)?;
        Ok(Self::from_shared(
            Arc::new(TriMesh {
                vertices,
                triangles,
            }),
            Vector3::repeat(1.0),
            None,
        ))
    }

    /// A mesh over shared data (e.g. one loaded file used by several links)
    /// with a per-axis `scale`. The data is assumed checked by its loader
    /// ([`TriMesh::load`] rejects empty meshes and non-finite vertices).
    pub fn from_shared(
        data: Arc<TriMesh>,
        scale: Vector3<f64>,
        source: Option<MeshSource>,
    ) -> Self {
        let bounding_radius = data
            .vertices
            .iter()
            .map(|v| v.coords.component_mul(&scale).norm())
            .fold(0.0, f64::max);
        Self {
            data,
            scale,
            source,
            bounding_radius,
            query: OnceLock::new(),
            decomposition_params: DecompositionParams::default(),
            decomposition: OnceLock::new(),
        }
    }

    /// The same mesh with other convex decomposition parameters (checked
    /// when the decomposition is computed); to be called before the mesh is
    /// shared, since the decomposition is computed once per mesh.
    pub fn with_decomposition_params(mut self, params: DecompositionParams) -> Self {
        self.decomposition_params = params;
        self.decomposition = OnceLock::new();
        self
    }

    /// The parameters of [`Mesh::convex_decomposition`].
    pub fn decomposition_params(&self) -> &DecompositionParams {
        &self.decomposition_params
    }

    /// The mesh's convex parts (V-HACD, see [`crate::decomposition`]) as a
    /// parry compound, computed on the first call and shared by every clone
    /// of this mesh (and so by the simulator and the planner's world).
    pub fn convex_decomposition(&self) -> Result<&SharedShape> {
        self.decomposition
            .get_or_init(|| {
                crate::decomposition::decompose(
                    &self.parry_vertices(),
                    &self.data.triangles,
                    &self.decomposition_params,
                )
            })
            .as_ref()
            .map_err(Clone::clone)
    }

    /// The shared vertex data, unscaled.
    pub fn data(&self) -> &Arc<TriMesh> {
        &self.data
    }

    /// The per-axis scale applied to [`Mesh::data`].
    pub fn scale(&self) -> &Vector3<f64> {
        &self.scale
    }

    /// The file the mesh came from, if any.
    pub fn source(&self) -> Option<&MeshSource> {
        self.source.as_ref()
    }

    /// The triangles (indices into the vertices).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.data.triangles
    }

    /// The vertices with the scale applied (shape frame, metres).
    pub fn vertices(&self) -> impl ExactSizeIterator<Item = Point3<f64>> + '_ {
        self.data
            .vertices
            .iter()
            .map(|v| Point3::from(v.coords.component_mul(&self.scale)))
    }

    /// The scaled vertices in parry's `f32`.
    pub fn parry_vertices(&self) -> Vec<PVec> {
        self.vertices()
            .map(|v| PVec::new(v.x as f32, v.y as f32, v.z as f32))
            .collect()
    }

    /// Radius of a ball around the origin holding every (scaled) vertex.
    pub fn bounding_radius(&self) -> f64 {
        self.bounding_radius
    }

    fn query(&self) -> std::result::Result<&MeshQuery, &GeometryError> {
        self.query
            .get_or_init(|| {
                check_data(&self.data.vertices, &self.data.triangles)?;
                let flags = TriMeshFlags::ORIENTED | TriMeshFlags::MERGE_DUPLICATE_VERTICES;
                let mesh = parry3d::shape::TriMesh::with_flags(
                    self.parry_vertices(),
                    self.data.triangles.clone(),
                    flags,
                )
                .map_err(|e| GeometryError::InvalidShape(format!("mesh: {e:?}")))?;
                Ok(MeshQuery {
                    mesh,
                    closed: is_closed(&self.data.triangles),
                })
            })
            .as_ref()
    }

    /// Builds the parry mesh and its BVH now (they are otherwise built on
    /// the first query); fails when parry rejects the topology.
    pub fn query_ready(&self) -> Result<()> {
        self.query().map(|_| ()).map_err(Clone::clone)
    }

    /// The parry mesh (with its BVH).
    pub fn parry_trimesh(&self) -> Result<&parry3d::shape::TriMesh> {
        self.query().map(|q| &q.mesh).map_err(Clone::clone)
    }

    /// Whether every edge is shared by exactly two triangles (a solid:
    /// points inside get negative distances). Open meshes are surfaces:
    /// distances are unsigned.
    pub fn is_closed(&self) -> bool {
        self.query().is_ok_and(|q| q.closed)
    }

    /// Signed distance from `p` (negative inside a closed mesh) and the unit
    /// direction in which it grows. A mesh parry rejected (see
    /// [`Mesh::query_ready`]) is infinitely far.
    pub fn signed_distance(&self, p: &Point3<f64>) -> (f64, Vector3<f64>) {
        let Ok(q) = self.query() else {
            return (f64::INFINITY, Vector3::z());
        };
        let proj = q
            .mesh
            .project_local_point(PVec::new(p.x as f32, p.y as f32, p.z as f32), false);
        let c = Point3::new(
            proj.point.x as f64,
            proj.point.y as f64,
            proj.point.z as f64,
        );
        let d = p - c;
        let n = d.norm();
        let inside = q.closed && proj.is_inside;
        let dir = if n > 1e-12 { d / n } else { Vector3::z() };
        if inside { (-n, -dir) } else { (n, dir) }
    }
}

/// Whether every edge of `triangles` is shared by exactly two triangles (a
/// closed surface).
pub(crate) fn is_closed(triangles: &[[u32; 3]]) -> bool {
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

/// The convex hull of a set of points: the points as given, parry's convex
/// polyhedron, and its surface as a closed [`Mesh`] for distance queries.
#[derive(Debug, Clone)]
pub struct Hull {
    points: Vec<Point3<f64>>,
    shape: SharedShape,
    surface: Mesh,
}

impl Hull {
    /// The hull of `points` (shape frame, metres). Fails on a non-finite
    /// point or a degenerate hull (flat, or fewer than 4 points).
    pub fn new(points: Vec<Point3<f64>>) -> Result<Self> {
        if points
            .iter()
            .any(|v| !v.coords.iter().all(|c| c.is_finite()))
        {
            return Err(GeometryError::NonFinite(
                "convex hull: non-finite vertex".into(),
            ));
        }
        let pts: Vec<PVec> = points
            .iter()
            .map(|v| PVec::new(v.x as f32, v.y as f32, v.z as f32))
            .collect();
        let degenerate = || {
            GeometryError::InvalidShape(format!(
                "the convex hull of {} points is degenerate (flat or fewer than 4 points)",
                points.len()
            ))
        };
        let shape = SharedShape::convex_hull(&pts).ok_or_else(degenerate)?;
        let (v, t) = parry3d::transformation::convex_hull(&pts);
        let v: Vec<Point3<f64>> = v
            .iter()
            .map(|p| Point3::new(p.x as f64, p.y as f64, p.z as f64))
            .collect();
        let surface = Mesh::new(v, t).map_err(|_| degenerate())?;
        Ok(Self {
            points,
            shape,
            surface,
        })
    }

    /// The points the hull was built from.
    pub fn points(&self) -> &[Point3<f64>] {
        &self.points
    }

    /// parry's convex polyhedron.
    pub fn parry_shape(&self) -> &SharedShape {
        &self.shape
    }

    /// The hull's surface (closed, outward triangles).
    pub fn surface(&self) -> &Mesh {
        &self.surface
    }
}
