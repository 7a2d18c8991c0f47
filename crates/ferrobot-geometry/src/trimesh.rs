//! Triangle meshes loaded from STL, OBJ and COLLADA files.

use std::path::Path;

use nalgebra::{Point3, Vector3};

/// An indexed triangle mesh (all sub-meshes of a file merged).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions in the file's frame and units.
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as indices into `vertices`.
    pub triangles: Vec<[u32; 3]>,
}

/// The 12 outward-facing triangles of a box whose corner `c` lies at
/// (x, y, z) = (`c & 1`, `c >> 1 & 1`, `c >> 2 & 1`) (0 = low side, 1 = high side).
pub const BOX_TRIANGLES: [[u32; 3]; 12] = [
    [0, 2, 1],
    [1, 2, 3],
    [4, 5, 6],
    [5, 7, 6],
    [0, 1, 4],
    [1, 5, 4],
    [2, 6, 3],
    [3, 6, 7],
    [0, 4, 2],
    [2, 4, 6],
    [1, 3, 5],
    [3, 7, 5],
];

impl TriMesh {
    /// A closed box of 8 vertices and 12 outward-facing triangles ([`BOX_TRIANGLES`]),
    /// centred at `center` with the given half extents along x, y and z (metres, each ≥ 0).
    pub fn cuboid(center: Point3<f64>, half_extents: Vector3<f64>) -> Self {
        let vertices = (0..8)
            .map(|c| {
                let side = |bit: usize| if (c >> bit) & 1 == 1 { 1.0 } else { -1.0 };
                center
                    + Vector3::new(
                        side(0) * half_extents.x,
                        side(1) * half_extents.y,
                        side(2) * half_extents.z,
                    )
            })
            .collect();
        TriMesh {
            vertices,
            triangles: BOX_TRIANGLES.to_vec(),
        }
    }

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

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem: positive only if every triangle faces outward.
    #[test]
    fn cuboid_is_closed_and_outward() {
        let m = TriMesh::cuboid(Point3::new(1.0, -2.0, 0.5), Vector3::new(0.1, 0.2, 0.3));
        let volume: f64 = m
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.vertices[i as usize].coords);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum();
        assert!((volume - 0.2 * 0.4 * 0.6).abs() < 1e-12, "{volume}");
        // Each of the 18 undirected edges is shared by exactly two triangles in opposite directions.
        let mut edges = std::collections::HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                *edges.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        assert_eq!(edges.len(), 36);
        assert!(edges.keys().all(|&(a, b)| edges.get(&(b, a)) == Some(&1)));
    }
}
