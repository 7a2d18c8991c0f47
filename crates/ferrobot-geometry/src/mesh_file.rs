//! Object meshes from files (OBJ, STL, COLLADA): loaded once per file,
//! checked for what makes a mesh unusable as a solid object, and shared per
//! (file, scale, decomposition parameters) so that the convex decomposition
//! of a mesh is computed once per process.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::UNIX_EPOCH;

use nalgebra::{Point3, Vector3};

use crate::decomposition::DecompositionParams;
use crate::error::{GeometryError, Result};
use crate::mesh::{Mesh, MeshSource};
use crate::trimesh::TriMesh;

/// Most triangles an object mesh may have.
pub const MAX_TRIANGLES: usize = 2_000_000;
/// Largest extent (m, after scaling) of an object mesh along any axis.
pub const MAX_EXTENT: f64 = 10.0;
/// Smallest extent (m, after scaling) of an object mesh's largest side.
pub const MIN_EXTENT: f64 = 1e-4;
/// Largest mesh file read (bytes).
pub const MAX_FILE_BYTES: u64 = 512 << 20;
/// Entries kept by each cache before it is emptied.
const CACHE_ENTRIES: usize = 1024;

type FileKey = (PathBuf, u128, u64);
type MeshKey = (FileKey, [u64; 3], (u32, u64, u32));

fn files() -> &'static Mutex<HashMap<FileKey, Arc<TriMesh>>> {
    static C: OnceLock<Mutex<HashMap<FileKey, Arc<TriMesh>>>> = OnceLock::new();
    C.get_or_init(Default::default)
}

fn meshes() -> &'static Mutex<HashMap<MeshKey, Arc<Mesh>>> {
    static C: OnceLock<Mutex<HashMap<MeshKey, Arc<Mesh>>>> = OnceLock::new();
    C.get_or_init(Default::default)
}

fn bad(path: &Path, what: impl std::fmt::Display) -> GeometryError {
    GeometryError::InvalidShape(format!("mesh file '{}': {what}", path.display()))
}

/// Checks a loaded mesh, scaled by `scale`, as a solid object: not empty,
/// not huge (at most [`MAX_TRIANGLES`] triangles, extents at most
/// [`MAX_EXTENT`]), not degenerate (largest extent at least [`MIN_EXTENT`],
/// not flat, triangles with area), and manifold (no edge shared by more
/// than two triangles once coincident vertices are merged). Open meshes
/// are accepted. Errors name `path`.
pub fn check_object_mesh(data: &TriMesh, scale: &Vector3<f64>, path: &Path) -> Result<()> {
    if scale.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err(bad(
            path,
            format!(
                "scale must be positive and finite, got {:?}",
                scale.as_slice()
            ),
        ));
    }
    let n = data.triangles.len();
    if n == 0 {
        return Err(bad(path, "empty: no triangles"));
    }
    if n > MAX_TRIANGLES {
        return Err(bad(
            path,
            format!("huge: {n} triangles, at most {MAX_TRIANGLES} are accepted"),
        ));
    }
    let nv = data.vertices.len();
    if let Some(t) = data
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= nv))
    {
        return Err(bad(
            path,
            format!("triangle {t:?} refers to a vertex beyond the {nv} given"),
        ));
    }
    let v: Vec<Point3<f64>> = data
        .vertices
        .iter()
        .map(|p| Point3::from(p.coords.component_mul(scale)))
        .collect();
    if v.iter().any(|p| !p.coords.iter().all(|c| c.is_finite())) {
        return Err(bad(path, "a vertex is not finite"));
    }
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for t in &data.triangles {
        for &i in t {
            lo = lo.inf(&v[i as usize].coords);
            hi = hi.sup(&v[i as usize].coords);
        }
    }
    let ext = hi - lo;
    let (small, large) = (ext.min(), ext.max());
    if large > MAX_EXTENT {
        return Err(bad(
            path,
            format!(
                "huge: extents {:.3?} m after scaling, at most {MAX_EXTENT} m are accepted",
                ext.as_slice()
            ),
        ));
    }
    if large < MIN_EXTENT {
        return Err(bad(
            path,
            format!(
                "degenerate: largest extent {large:.3e} m after scaling, at least {MIN_EXTENT} m required"
            ),
        ));
    }
    if small <= 1e-6 * large {
        return Err(bad(
            path,
            format!(
                "degenerate: flat (extents {:.3e} x {:.3e} x {:.3e} m), a solid needs a thickness",
                ext.x, ext.y, ext.z
            ),
        ));
    }
    let area: f64 = data
        .triangles
        .iter()
        .map(|t| {
            let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .sum();
    if area.partial_cmp(&(1e-9 * large * large)) != Some(std::cmp::Ordering::Greater) {
        return Err(bad(path, "degenerate: the triangles have no area"));
    }
    // Merge coincident vertices (to 1e-7 of the size), drop collapsed and
    // repeated triangles, count the triangles on each edge.
    let tol = 1e-7 * large;
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    let merged: Vec<u32> = v
        .iter()
        .map(|p| {
            let q = [
                (p.x / tol).round() as i64,
                (p.y / tol).round() as i64,
                (p.z / tol).round() as i64,
            ];
            let next = ids.len() as u32;
            *ids.entry(q).or_insert(next)
        })
        .collect();
    let mut tris: Vec<[u32; 3]> = data
        .triangles
        .iter()
        .map(|t| {
            let mut m = [
                merged[t[0] as usize],
                merged[t[1] as usize],
                merged[t[2] as usize],
            ];
            m.sort_unstable();
            m
        })
        .filter(|m| m[0] != m[1] && m[1] != m[2])
        .collect();
    tris.sort_unstable();
    tris.dedup();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &tris {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[0], t[2])] {
            *edges.entry((a, b)).or_default() += 1;
        }
    }
    let over = edges.values().filter(|&&c| c > 2).count();
    if over > 0 {
        return Err(bad(
            path,
            format!("non-manifold: {over} edges are shared by more than two triangles"),
        ));
    }
    Ok(())
}

/// The mesh with bit-identical vertices merged (parsers repeat a vertex
/// per face), so that its topology (closed or not) is visible.
fn merge_duplicates(mesh: TriMesh) -> TriMesh {
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    let mut vertices = Vec::new();
    let remap: Vec<u32> = mesh
        .vertices
        .iter()
        .map(|p| {
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            *ids.entry(key).or_insert_with(|| {
                vertices.push(*p);
                (vertices.len() - 1) as u32
            })
        })
        .collect();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| remap.get(i as usize).copied().unwrap_or(u32::MAX)))
        .collect();
    TriMesh {
        vertices,
        triangles,
    }
}

fn file_key(path: &Path) -> Result<FileKey> {
    let meta = std::fs::metadata(path).map_err(|e| bad(path, format!("cannot read: {e}")))?;
    if !meta.is_file() {
        return Err(bad(path, "not a file"));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(bad(
            path,
            format!(
                "huge: {} bytes, at most {MAX_FILE_BYTES} are read",
                meta.len()
            ),
        ));
    }
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(UNIX_EPOCH).ok())
        .map_or(0, |d| d.as_nanos());
    let canon = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    Ok((canon, mtime, meta.len()))
}

fn load_file(path: &Path, key: &FileKey) -> Result<Arc<TriMesh>> {
    if let Some(d) = files().lock().ok().and_then(|c| c.get(key).cloned()) {
        return Ok(d);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("obj" | "stl" | "dae")) {
        return Err(bad(
            path,
            "unsupported format: the name must end in .obj, .stl or .dae",
        ));
    }
    // The third-party parsers may panic on content that is not a mesh.
    let loaded = std::panic::catch_unwind(|| TriMesh::load(path))
        .unwrap_or_else(|_| Err("the parser failed: not a valid mesh file".into()));
    let data = Arc::new(merge_duplicates(loaded.map_err(|e| bad(path, e))?));
    if let Ok(mut c) = files().lock() {
        if c.len() >= CACHE_ENTRIES {
            c.clear();
        }
        c.insert(key.clone(), data.clone());
    }
    Ok(data)
}

/// The mesh of an object file (OBJ, STL or DAE) scaled by `scale`, checked
/// by [`check_object_mesh`], with decomposition `params`. Files are read
/// once (re-read when their size or modification time changes) and meshes
/// shared per (file, scale, params), so a mesh used in many scenes is
/// decomposed once. Errors name the file.
pub fn load_object_mesh(
    path: &Path,
    scale: Vector3<f64>,
    params: DecompositionParams,
) -> Result<Arc<Mesh>> {
    params.validate()?;
    let fkey = file_key(path)?;
    let key: MeshKey = (
        fkey.clone(),
        [scale.x.to_bits(), scale.y.to_bits(), scale.z.to_bits()],
        params.key(),
    );
    if let Some(m) = meshes().lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok(m);
    }
    let data = load_file(path, &fkey)?;
    check_object_mesh(&data, &scale, path)?;
    let source = MeshSource {
        filename: path.display().to_string(),
        path: fkey.0.clone(),
    };
    let mesh =
        Arc::new(Mesh::from_shared(data, scale, Some(source)).with_decomposition_params(params));
    if let Ok(mut c) = meshes().lock() {
        if c.len() >= CACHE_ENTRIES {
            c.clear();
        }
        c.insert(key, mesh.clone());
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube about the origin.
    fn cube() -> TriMesh {
        TriMesh::cuboid(Point3::origin(), Vector3::repeat(0.5))
    }

    #[test]
    fn checks_reject_what_they_document() {
        let p = Path::new("cube.obj");
        let s = Vector3::repeat(0.1);
        check_object_mesh(&cube(), &s, p).unwrap();
        let e = check_object_mesh(&cube(), &Vector3::repeat(100.0), p).unwrap_err();
        assert!(e.to_string().contains("huge") && e.to_string().contains("cube.obj"));
        let mut flat = cube();
        for v in &mut flat.vertices {
            v.z = 0.0;
        }
        assert!(
            check_object_mesh(&flat, &s, p)
                .unwrap_err()
                .to_string()
                .contains("degenerate")
        );
        // A fin: a third triangle on the edge (0, 1).
        let mut fin = cube();
        fin.vertices.push(Point3::new(0.0, -2.0, -0.5));
        fin.triangles.push([0, 1, 8]);
        assert!(
            check_object_mesh(&fin, &s, p)
                .unwrap_err()
                .to_string()
                .contains("non-manifold")
        );
        let empty = TriMesh::default();
        assert!(
            check_object_mesh(&empty, &s, p)
                .unwrap_err()
                .to_string()
                .contains("empty")
        );
    }

    #[test]
    fn decomposition_of_a_cube_has_its_volume() {
        let c = cube();
        let m = Mesh::new(c.vertices, c.triangles).unwrap();
        let s = m.convex_decomposition().unwrap();
        let vol = s.mass_properties(1.0).mass() as f64;
        assert!((vol - 1.0).abs() < 1e-3, "{vol}");
        // Computed once: the same Arc on the second call.
        let a = m.convex_decomposition().unwrap() as *const _;
        assert_eq!(a, s as *const _);
    }
}
