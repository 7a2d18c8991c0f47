//! Reading numpy arrays (or anything numpy converts) with shape checks.

use numpy::{AllowTypeChange, PyArrayLikeDyn, PyUntypedArrayMethods};
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

/// Reads `obj` as a float64 array of `ndim` dimensions whose trailing
/// dimensions equal `trailing` (None: any), checking all values are finite.
pub fn read_array<'py>(
    obj: &Bound<'py, PyAny>,
    what: &str,
    ndim: usize,
    trailing: &[Option<usize>],
) -> PyResult<Array<'py>> {
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
    let owned = match array.as_slice() {
        Ok(_) => None,
        Err(_) => Some(array.as_array().iter().copied().collect()),
    };
    let out = Array {
        shape,
        array,
        owned,
    };
    let data = out.data();
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
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
