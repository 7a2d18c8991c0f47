//! Triangle meshes loaded from STL, OBJ and COLLADA files.

use std::path::Path;

use nalgebra::Point3;

/// An indexed triangle mesh (all sub-meshes of a file merged).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions in the file's frame and units.
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Loads a mesh file (STL, OBJ or DAE by content and extension).
    ///
    /// Fails with a message when the file cannot be read or parsed, or holds
    /// no triangles.
    pub fn load(path: &Path) -> Result<Self, String> {
        let scene = mesh_loader::Loader::default()
            .merge_meshes(false)
            .load(path)
            .map_err(|e| format!("cannot load {}: {e}", path.display()))?;
        let mut out = TriMesh::default();
        for mesh in &scene.meshes {
            let base = out.vertices.len() as u32;
            out.vertices.extend(
                mesh.vertices
                    .iter()
                    .map(|v| Point3::new(v[0] as f64, v[1] as f64, v[2] as f64)),
            );
            for face in &mesh.faces {
                if face.iter().any(|&i| i as usize >= mesh.vertices.len()) {
                    return Err(format!(
                        "{}: a face refers to a vertex that does not exist",
                        path.display()
                    ));
                }
                out.triangles
                    .push([face[0] + base, face[1] + base, face[2] + base]);
            }
        }
        if out.triangles.is_empty() {
            return Err(format!("{} holds no triangles", path.display()));
        }
        if let Some(bad) = out
            .vertices
            .iter()
            .find(|v| !v.coords.iter().all(|c| c.is_finite()))
        {
            return Err(format!(
                "{} has a non-finite vertex {:?}",
                path.display(),
                bad.coords.as_slice()
            ));
        }
        Ok(out)
    }
}
