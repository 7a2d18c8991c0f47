//! Object meshes from files: `ferrobot.load_mesh` and the helpers of
//! `World.add_mesh_file` (in `sim.rs`). Loading, checks, caching and the
//! convex decomposition are `ferrobot_geometry::mesh_file`'s.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use ferrobot_geometry::{DecompositionParams, GeometryError, Mesh, load_object_mesh};
use nalgebra::Vector3;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2};
use pyo3::prelude::*;

use crate::arrays::read_array;
use crate::errors::{InvalidArgumentError, MeshError, guard};

/// Decomposition parameters, checked (`InvalidArgumentError` naming the field).
pub fn decomposition_params(
    resolution: u32,
    concavity: f64,
    max_convex_hulls: u32,
) -> PyResult<DecompositionParams> {
    let p = DecompositionParams {
        resolution,
        concavity,
        max_convex_hulls,
    };
    p.validate()
        .map_err(|e| InvalidArgumentError::new_err(e.to_string()))?;
    Ok(p)
}

/// A scale given as one positive number or three.
pub fn scale_arg(scale: Option<&Bound<'_, PyAny>>) -> PyResult<Vector3<f64>> {
    let Some(s) = scale else {
        return Ok(Vector3::repeat(1.0));
    };
    let v = if let Ok(x) = s.extract::<f64>() {
        Vector3::repeat(x)
    } else {
        let a = read_array(s, "scale", 1, &[Some(3)])?;
        let d = a.data();
        Vector3::new(d[0], d[1], d[2])
    };
    if v.iter().any(|x| !(x.is_finite() && *x > 0.0 && *x <= 1e3)) {
        return Err(InvalidArgumentError::new_err(format!(
            "scale: each factor must be in (0, 1000], got {:?}",
            v.as_slice()
        )));
    }
    Ok(v)
}

fn mesh_error(path: &Path, e: GeometryError) -> PyErr {
    let m = e.to_string();
    if m.starts_with("mesh file '") {
        MeshError::new_err(m)
    } else {
        MeshError::new_err(format!("mesh file '{}': {m}", path.display()))
    }
}

/// The checked, cached mesh of `path` (GIL released); with `decompose`, its
/// convex decomposition is computed now so that its failure names the file.
pub fn object_mesh(
    py: Python<'_>,
    path: &Path,
    scale: Vector3<f64>,
    params: DecompositionParams,
    decompose: bool,
) -> PyResult<Arc<Mesh>> {
    py.detach(|| {
        let m = load_object_mesh(path, scale, params)?;
        if decompose {
            m.convex_decomposition()?;
        }
        Ok(m)
    })
    .map_err(|e| mesh_error(path, e))
}

fn points_array<'py>(
    py: Python<'py>,
    pts: impl ExactSizeIterator<Item = [f64; 3]>,
) -> Bound<'py, PyArray2<f64>> {
    let n = pts.len();
    let flat: Vec<f64> = pts.flatten().collect();
    Array2::from_shape_vec((n, 3), flat)
        .expect("n x 3")
        .into_pyarray(py)
}

fn faces_array<'py>(py: Python<'py>, tris: &[[u32; 3]]) -> Bound<'py, PyArray2<i64>> {
    let flat: Vec<i64> = tris.iter().flatten().map(|&i| i as i64).collect();
    Array2::from_shape_vec((tris.len(), 3), flat)
        .expect("n x 3")
        .into_pyarray(py)
}

/// Loads an object mesh (OBJ, STL, DAE) scaled by `scale`, checks it and
/// computes its convex decomposition (both cached per file, scale and
/// parameters). Returns a `LoadedMesh`: `vertices` (N, 3) and `faces` (M, 3) of
/// the scaled mesh, `parts` (list of (vertices, faces) of the convex
/// parts), `volume` (m³, of the decomposition), `closed` (every edge
/// shared by two triangles). Bad files raise `ferrobot.errors.MeshError`
/// naming the file.
#[pyfunction]
#[pyo3(signature = (path, scale=None, *, resolution=64, concavity=0.01, max_convex_hulls=32))]
pub fn load_mesh<'py>(
    py: Python<'py>,
    path: PathBuf,
    scale: Option<&Bound<'py, PyAny>>,
    resolution: u32,
    concavity: f64,
    max_convex_hulls: u32,
) -> PyResult<crate::results::PyLoadedMesh> {
    guard(|| {
        let scale = scale_arg(scale)?;
        let params = decomposition_params(resolution, concavity, max_convex_hulls)?;
        let mesh = object_mesh(py, &path, scale, params, true)?;
        let shape = mesh
            .convex_decomposition()
            .map_err(|e| mesh_error(&path, e))?;
        let mut parts = Vec::new();
        if let Some(c) = shape.as_compound() {
            for (_, s) in c.shapes() {
                if let Some(poly) = s.as_convex_polyhedron() {
                    let (v, t) = poly.to_trimesh();
                    let v =
                        points_array(py, v.iter().map(|p| [p.x as f64, p.y as f64, p.z as f64]));
                    parts.push((v.unbind(), faces_array(py, &t).unbind()));
                }
            }
        }
        Ok(crate::results::PyLoadedMesh {
            vertices: points_array(py, mesh.vertices().map(|p| [p.x, p.y, p.z])).unbind(),
            faces: faces_array(py, mesh.triangles()).unbind(),
            parts,
            volume: shape.mass_properties(1.0).mass() as f64,
            closed: mesh.is_closed(),
        })
    })
}
