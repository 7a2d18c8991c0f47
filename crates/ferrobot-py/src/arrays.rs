//! Reading numpy arrays (or anything numpy converts) with shape checks: the
//! one reader every array argument of every binding goes through.
//!
//! Any layout (C- or Fortran-ordered, transposed or strided views) and any
//! real dtype (float32, integers, bools are converted to float64) gives the
//! values in logical C order: the array is borrowed only when it is already
//! C-contiguous float64, copied otherwise. Complex arrays are refused
//! rather than silently losing their imaginary part.

use numpy::{
    AllowTypeChange, PyArrayDescrMethods, PyArrayLikeDyn, PyUntypedArray, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::{InvalidArgumentError, NonFiniteError, ShapeError};

/// A float64 array read from Python: its shape and its values in C order,
/// borrowed from numpy when the array is already C-contiguous float64.
pub struct Array<'py> {
    /// The shape.
    pub shape: Vec<usize>,
    array: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    owned: Option<Vec<f64>>,
}

impl Array<'_> {
    /// The values in C order.
    pub fn data(&self) -> &[f64] {
        match &self.owned {
            Some(v) => v,
            None => self.array.as_slice().expect("checked contiguous when read"),
        }
    }
}

fn shape_str(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Which non-finite values an array argument may hold.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Finite {
    /// Every value finite (the default for every argument).
    All,
    /// Infinities allowed (e.g. "no reading" in a depth image, unbounded
    /// limits), NaN refused.
    NoNan,
}

/// Reads `obj` as a float64 array of `ndim` dimensions whose trailing
/// dimensions equal `trailing` (None: any), checking all values are finite.
pub fn read_array<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    ndim: usize,
    trailing: &[Option<usize>],
) -> PyResult<Array<'py>> {
    read_array_with(obj, what, ndim, trailing, Finite::All)
}

/// [`read_array`] with a choice of which non-finite values are allowed.
pub fn read_array_with<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    ndim: usize,
    trailing: &[Option<usize>],
    finite: Finite,
) -> PyResult<Array<'py>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        let kind = a.dtype().kind();
        if !matches!(kind, b'f' | b'i' | b'u' | b'b') {
            return Err(InvalidArgumentError::new_err(format!(
                "{what}: expected an array of real numbers, got dtype {}",
                a.dtype()
            )));
        }
    }
    let array: PyArrayLikeDyn<'py, f64, AllowTypeChange> = obj.extract().map_err(|_| {
        InvalidArgumentError::new_err(format!(
            "{what}: expected an array of numbers, got {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })?;
    let shape = array.shape().to_vec();
    let fits = shape.len() == ndim
        && trailing
            .iter()
            .zip(&shape[ndim - trailing.len()..])
            .all(|(want, got)| want.is_none_or(|w| w == *got));
    if !fits {
        let mut dims: Vec<String> = vec!["N".into(); ndim - trailing.len()];
        dims.extend(
            trailing
                .iter()
                .map(|d| d.map_or("N".into(), |d| d.to_string())),
        );
        let expected = if ndim == 1 {
            format!("({},)", dims[0])
        } else {
            format!("({})", dims.join(", "))
        };
        return Err(ShapeError::new_err(format!(
            "{what}: expected shape {expected}, got {}",
            shape_str(&shape)
        )));
    }
    // `as_slice` also accepts Fortran-contiguous arrays (in memory order):
    // borrow only C-contiguous data, copy everything else in logical order.
    let owned = if array.is_c_contiguous() {
        None
    } else {
        Some(array.as_array().iter().copied().collect())
    };
    let out = Array {
        shape,
        array,
        owned,
    };
    let data = out.data();
    let bad = |v: &f64| match finite {
        Finite::All => !v.is_finite(),
        Finite::NoNan => v.is_nan(),
    };
    if let Some(i) = data.iter().position(bad) {
        let mut idx = Vec::with_capacity(out.shape.len());
        let mut rest = i;
        for &d in out.shape.iter().rev() {
            idx.push(rest % d.max(1));
            rest /= d.max(1);
        }
        idx.reverse();
        return Err(NonFiniteError::new_err(format!(
            "{what}: non-finite value {} at index {idx:?}",
            data[i]
        )));
    }
    Ok(out)
}

/// Reads a pose: a 4x4 homogeneous matrix or a 7-vector
/// `[x, y, z, qw, qx, qy, qz]`. The rotation must be a rotation (matrix
/// orthonormal to 1e-6; quaternion norm within 1e-3 of 1, then normalised).
pub fn read_pose(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<nalgebra::Isometry3<f64>> {
    let arr = read_array_any(obj, what)?;
    match arr.shape.as_slice() {
        [7] | [4, 4] => pose_from(arr.data(), what),
        other => Err(ShapeError::new_err(format!(
            "{what}: expected a 4x4 matrix or a 7-vector [x, y, z, qw, qx, qy, qz], got shape {}",
            shape_str(other)
        ))),
    }
}

/// Reads an optional pose (as [`read_pose`]); None is the identity.
pub fn read_pose_or_identity(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<nalgebra::Isometry3<f64>> {
    obj.map(|p| read_pose(p, what))
        .transpose()
        .map(|p| p.unwrap_or_else(nalgebra::Isometry3::identity))
}

/// Reads one pose or a batch of poses: shapes (7,), (4, 4), (N, 7) or
/// (N, 4, 4), each checked as [`read_pose`] does.
pub fn read_poses(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<nalgebra::Isometry3<f64>>> {
    let arr = read_array_any(obj, what)?;
    let data = arr.data();
    match arr.shape.as_slice() {
        [7] | [4, 4] => Ok(vec![pose_from(data, what)?]),
        [_, 7] => data
            .chunks_exact(7)
            .enumerate()
            .map(|(i, c)| pose_from(c, &format!("{what}[{i}]")))
            .collect(),
        [_, 4, 4] => data
            .chunks_exact(16)
            .enumerate()
            .map(|(i, c)| pose_from(c, &format!("{what}[{i}]")))
            .collect(),
        other => Err(ShapeError::new_err(format!(
            "{what}: expected poses of shape (7,), (4, 4), (N, 7) or (N, 4, 4), got {}",
            shape_str(other)
        ))),
    }
}

/// A pose from 7 values `[x, y, z, qw, qx, qy, qz]` or 16 (a row-major
/// 4x4 matrix), validated.
fn pose_from(v: &[f64], what: &str) -> PyResult<nalgebra::Isometry3<f64>> {
    use nalgebra::{Isometry3, Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion};
    if v.len() == 7 {
        let q = Quaternion::new(v[3], v[4], v[5], v[6]);
        if (q.norm() - 1.0).abs() > 1e-3 {
            return Err(InvalidArgumentError::new_err(format!(
                "{what}: quaternion (w, x, y, z) has norm {:.6}, expected 1",
                q.norm()
            )));
        }
        return Ok(Isometry3::from_parts(
            Translation3::new(v[0], v[1], v[2]),
            UnitQuaternion::from_quaternion(q),
        ));
    }
    let m = Matrix3::from_fn(|r, c| v[r * 4 + c]);
    let bottom = [v[12], v[13], v[14], v[15]];
    if bottom != [0.0, 0.0, 0.0, 1.0] {
        return Err(InvalidArgumentError::new_err(format!(
            "{what}: the last row of a 4x4 pose must be [0, 0, 0, 1]"
        )));
    }
    let err = (m.transpose() * m - Matrix3::identity()).abs().max();
    if err > 1e-6 || m.determinant() < 0.0 {
        return Err(InvalidArgumentError::new_err(format!(
            "{what}: the 3x3 block is not a rotation (error {err:.2e})"
        )));
    }
    let rot = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
    Ok(Isometry3::from_parts(
        Translation3::new(v[3], v[7], v[11]),
        rot,
    ))
}

/// Reads a finite float64 array of any shape.
pub fn read_array_any<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Array<'py>> {
    read_array_any_with(obj, what, Finite::All)
}

/// [`read_array_any`] with a choice of which non-finite values are allowed.
pub fn read_array_any_with<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    finite: Finite,
) -> PyResult<Array<'py>> {
    let ndim = match obj.cast::<PyUntypedArray>() {
        Ok(a) => a.ndim(),
        Err(_) => {
            let array: PyArrayLikeDyn<'_, f64, AllowTypeChange> = obj.extract().map_err(|_| {
                InvalidArgumentError::new_err(format!("{what}: expected an array of numbers"))
            })?;
            array.ndim()
        }
    };
    let trailing: Vec<Option<usize>> = vec![None; ndim];
    read_array_with(obj, what, ndim, &trailing, finite)
}
