//! Bindings of the fault-injection models of `ferrobot_control::faults`
//! (encoder noise, depth noise, command arbitration); `ferrobot.scenarios`
//! wraps them.

use ferrobot_control::{Arbiter, ControlError, DepthNoise, DepthNoiseParams, EncoderNoise};
use numpy::ndarray::{Array1, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArray1, PyArrayDyn};
use pyo3::prelude::*;

use crate::arrays::{Finite, read_array, read_array_any, read_array_with};
use crate::errors::{InvalidArgumentError, NonFiniteError, ShapeError, UnknownNameError, guard};

fn fault_err(e: ControlError) -> PyErr {
    match e {
        ControlError::NonFinite(m) => NonFiniteError::new_err(m),
        ControlError::UnknownName(m) => UnknownNameError::new_err(m),
        ControlError::InvalidArgument(m) => InvalidArgumentError::new_err(m),
        other => InvalidArgumentError::new_err(other.to_string()),
    }
}

/// Joint encoder noise (`ferrobot_control::EncoderNoise`).
#[pyclass(name = "EncoderNoise", module = "ferrobot._core")]
pub struct PyEncoderNoise {
    inner: EncoderNoise,
}

#[pymethods]
impl PyEncoderNoise {
    /// `sigma`: one value or one per joint (>= 0); `resolution` >= 0; `seed`.
    #[new]
    #[pyo3(signature = (sigma, resolution=0.0, seed=0))]
    fn new(sigma: &Bound<'_, PyAny>, resolution: f64, seed: u64) -> PyResult<Self> {
        let s = read_array_any(sigma, "sigma")?;
        if s.shape.len() > 1 {
            return Err(ShapeError::new_err(format!(
                "sigma: expected a number or a 1-D array, got {} dimensions",
                s.shape.len()
            )));
        }
        Ok(Self {
            inner: EncoderNoise::new(s.data(), resolution, seed).map_err(fault_err)?,
        })
    }

    /// A noisy reading of `q` (a number, (n,) or (batch, n)).
    fn apply<'py>(
        &mut self,
        py: Python<'py>,
        q: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        guard(|| {
            let a = read_array_any(q, "q")?;
            let shape = a.shape.clone();
            let rows = if shape.len() >= 2 {
                shape[..shape.len() - 1].iter().product()
            } else {
                1
            };
            let rows = if a.data().is_empty() { 0 } else { rows };
            if a.data().is_empty() {
                return Ok(ArrayD::<f64>::zeros(IxDyn(&shape)).into_pyarray(py));
            }
            let data = a.data().to_vec();
            let out = self.inner.apply(&data, rows).map_err(fault_err)?;
            let arr = ArrayD::from_shape_vec(IxDyn(&shape), out)
                .map_err(|e| ShapeError::new_err(format!("q: {e}")))?;
            Ok(arr.into_pyarray(py))
        })
    }
}

/// Depth camera noise (`ferrobot_control::DepthNoise`).
#[pyclass(name = "DepthNoise", module = "ferrobot._core")]
pub struct PyDepthNoise {
    inner: DepthNoise,
}

fn depth_arg<'py>(depth: &Bound<'py, PyAny>) -> PyResult<(Vec<f64>, usize, usize)> {
    let a = read_array_with(depth, "depth", 2, &[None, None], Finite::NoNan)?;
    Ok((a.data().to_vec(), a.shape[0], a.shape[1]))
}

#[pymethods]
impl PyDepthNoise {
    /// The model's parameters (see `ferrobot.scenarios.DepthNoise`); each
    /// one left out (None) takes its default from the Rust
    /// `DepthNoiseParams::default()`.
    #[new]
    #[pyo3(signature = (*, sigma0=None, sigma2=None, z0=None, dropout=None, edge_threshold=None,
        edge_dropout=None, missing_value=None, seed=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        sigma0: Option<f64>,
        sigma2: Option<f64>,
        z0: Option<f64>,
        dropout: Option<f64>,
        edge_threshold: Option<f64>,
        edge_dropout: Option<f64>,
        missing_value: Option<f64>,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        guard(|| {
            let d = DepthNoiseParams::default();
            let p = DepthNoiseParams {
                sigma0: sigma0.unwrap_or(d.sigma0),
                sigma2: sigma2.unwrap_or(d.sigma2),
                z0: z0.unwrap_or(d.z0),
                dropout: dropout.unwrap_or(d.dropout),
                edge_threshold: edge_threshold.unwrap_or(d.edge_threshold),
                edge_dropout: edge_dropout.unwrap_or(d.edge_dropout),
                missing_value: missing_value.unwrap_or(d.missing_value),
                seed: seed.unwrap_or(d.seed),
            };
            Ok(Self {
                inner: DepthNoise::new(p).map_err(fault_err)?,
            })
        })
    }

    /// The parameters: a `DepthNoiseParams` (sigma0, sigma2, z0, dropout,
    /// edge_threshold, edge_dropout, missing_value).
    fn params(&self) -> crate::results::PyDepthNoiseParams {
        let n = &self.inner;
        crate::results::PyDepthNoiseParams {
            sigma0: n.sigma0,
            sigma2: n.sigma2,
            z0: n.z0,
            dropout: n.dropout,
            edge_threshold: n.edge_threshold,
            edge_dropout: n.edge_dropout,
            missing_value: n.missing_value,
        }
    }

    /// Axial standard deviation (m) per depth in `z` (m), any shape.
    fn sigma<'py>(
        &self,
        py: Python<'py>,
        z: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        guard(|| {
            let a = read_array_any(z, "z")?;
            let out: Vec<f64> = a.data().iter().map(|&z| self.inner.sigma(z)).collect();
            let arr = ArrayD::from_shape_vec(IxDyn(&a.shape), out)
                .map_err(|e| ShapeError::new_err(format!("z: {e}")))?;
            Ok(arr.into_pyarray(py))
        })
    }

    /// Discontinuity mask (H, W) of a depth image (inf or <= 0: no reading).
    fn edges<'py>(
        &self,
        py: Python<'py>,
        depth: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<bool>>> {
        guard(|| {
            let (d, h, w) = depth_arg(depth)?;
            let e = py
                .detach(|| self.inner.edges(&d, h, w))
                .map_err(fault_err)?;
            let arr = ArrayD::from_shape_vec(IxDyn(&[h, w]), e)
                .map_err(|e| ShapeError::new_err(format!("depth: {e}")))?;
            Ok(arr.into_pyarray(py))
        })
    }

    /// (noisy depth, missing mask), both (H, W).
    #[allow(clippy::type_complexity)]
    fn apply<'py>(
        &mut self,
        py: Python<'py>,
        depth: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArrayDyn<f64>>, Bound<'py, PyArrayDyn<bool>>)> {
        guard(|| {
            let (d, h, w) = depth_arg(depth)?;
            let inner = &mut self.inner;
            let (out, miss) = py.detach(|| inner.apply(&d, h, w)).map_err(fault_err)?;
            let out = ArrayD::from_shape_vec(IxDyn(&[h, w]), out)
                .map_err(|e| ShapeError::new_err(format!("depth: {e}")))?;
            let miss = ArrayD::from_shape_vec(IxDyn(&[h, w]), miss)
                .map_err(|e| ShapeError::new_err(format!("depth: {e}")))?;
            Ok((out.into_pyarray(py), miss.into_pyarray(py)))
        })
    }
}

/// Command arbitration (`ferrobot_control::Arbiter`).
#[pyclass(name = "Arbiter", module = "ferrobot._core")]
pub struct PyArbiter {
    inner: Arbiter,
}

#[pymethods]
impl PyArbiter {
    /// `num_joints` >= 1, `timeout` > 0 s, `tolerance` >= 0.
    #[new]
    fn new(num_joints: i64, timeout: f64, tolerance: f64) -> PyResult<Self> {
        if num_joints < 1 {
            return Err(InvalidArgumentError::new_err(format!(
                "num_joints must be >= 1, got {num_joints}"
            )));
        }
        Ok(Self {
            inner: Arbiter::new(num_joints as usize, timeout, tolerance).map_err(fault_err)?,
        })
    }

    /// Registers a source (higher priority wins).
    fn add_source(&mut self, name: &str, priority: i64) -> PyResult<()> {
        self.inner.add_source(name, priority).map_err(fault_err)
    }

    /// Source names in registration order.
    #[getter]
    fn sources(&self) -> Vec<String> {
        self.inner.sources().into_iter().map(String::from).collect()
    }

    /// `source` commands `values` for joint indices `joints` at time `t`.
    fn command(
        &mut self,
        source: &str,
        t: f64,
        joints: Vec<i64>,
        values: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        guard(|| {
            let n = self.inner.num_joints();
            if let Some(j) = joints.iter().find(|&&j| j < 0 || j as usize >= n) {
                return Err(UnknownNameError::new_err(format!(
                    "joints: index {j} is not in [0, {n})"
                )));
            }
            let v = read_array(values, "values", 1, &[Some(joints.len())])?;
            let j: Vec<usize> = joints.iter().map(|&j| j as usize).collect();
            self.inner
                .command(source, t, &j, v.data())
                .map_err(fault_err)
        })
    }

    /// Per joint, (values with NaN where no command is fresh, winning
    /// source names with None there).
    #[allow(clippy::type_complexity)]
    fn resolve<'py>(
        &mut self,
        py: Python<'py>,
        t: f64,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Vec<Option<String>>)> {
        guard(|| {
            let r = self.inner.resolve(t).map_err(fault_err)?;
            let names = self.inner.sources();
            let values: Vec<f64> = r.iter().map(|w| w.map_or(f64::NAN, |w| w.0)).collect();
            let winners = r
                .iter()
                .map(|w| w.map(|w| names[w.1].to_string()))
                .collect();
            Ok((Array1::from_vec(values).into_pyarray(py), winners))
        })
    }

    /// Every conflict so far: `ArbiterConflict`s (t, joint, winner, losers).
    #[getter]
    fn conflicts(&self) -> Vec<crate::results::PyArbiterConflict> {
        self.inner
            .conflicts()
            .iter()
            .map(|c| crate::results::PyArbiterConflict {
                t: c.t,
                joint: c.joint,
                winner: c.winner.clone(),
                losers: c.losers.clone(),
            })
            .collect()
    }
}

/// Registers the fault-injection classes.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyEncoderNoise>()?;
    m.add_class::<PyDepthNoise>()?;
    m.add_class::<PyArbiter>()?;
    Ok(())
}
