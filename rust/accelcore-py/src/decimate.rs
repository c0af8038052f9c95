//! `Decimator` and its result, `DecimatedBlocks`.

use accelcore_core::{DecimatedBlocks, Decimator, DecimatorConfig};
use ndarray::Array2;
use numpy::{
    IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::gateway::{count, push_stream, run_detached};

/// Time-aligned block-mean decimator (see `accelcore.core.Decimator` in the stubs).
#[pyclass(name = "Decimator", module = "accelcore.core")]
pub(crate) struct PyDecimator {
    pub(crate) inner: Decimator,
}

/// Decimated blocks: arrays with one row per kept block.
#[pyclass(name = "DecimatedBlocks", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyDecimatedBlocks {
    block_index: Py<PyArray1<i64>>,
    count: Py<PyArray1<i64>>,
    time_s: Py<PyArray1<f64>>,
    temperature_c: Py<PyArray1<f64>>,
    channels: Py<PyArray2<f64>>,
}

pub(crate) fn blocks_to_py(py: Python<'_>, blocks: DecimatedBlocks) -> PyResult<PyDecimatedBlocks> {
    let n = blocks.block_index.len();
    let channels = Array2::from_shape_vec((n, blocks.n_channels), blocks.channels)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    // In place: the collected `Vec` reuses the buffer of `blocks.count`.
    let count: Vec<i64> = blocks.count.into_iter().map(|c| c as i64).collect();
    Ok(PyDecimatedBlocks {
        block_index: blocks.block_index.into_pyarray(py).unbind(),
        count: count.into_pyarray(py).unbind(),
        time_s: blocks.time_s.into_pyarray(py).unbind(),
        temperature_c: blocks.temperature_c.into_pyarray(py).unbind(),
        channels: channels.into_pyarray(py).unbind(),
    })
}

impl PyDecimatedBlocks {
    /// The core value behind these arrays.
    pub(crate) fn to_core(&self, py: Python<'_>) -> PyResult<DecimatedBlocks> {
        let channels = self.channels.bind(py).readonly();
        let n_channels = channels.as_array().ncols();
        let count: Vec<u64> = self
            .count
            .bind(py)
            .readonly()
            .as_array()
            .iter()
            .map(|&c| c.max(0) as u64)
            .collect();
        Ok(DecimatedBlocks {
            n_channels,
            block_index: self.block_index.bind(py).readonly().as_array().to_vec(),
            count,
            time_s: self.time_s.bind(py).readonly().as_array().to_vec(),
            temperature_c: self.temperature_c.bind(py).readonly().as_array().to_vec(),
            channels: channels.as_array().iter().copied().collect(),
        })
    }
}

/// Rebuild `DecimatedBlocks` from its arrays (pickling).
#[pyfunction(name = "_blocks_from_arrays")]
pub(crate) fn py_blocks_from_arrays(
    py: Python<'_>,
    block_index: Vec<i64>,
    count: Vec<i64>,
    time_s: Vec<f64>,
    temperature_c: Vec<f64>,
    channels: PyReadonlyArray2<'_, f64>,
) -> PyResult<PyDecimatedBlocks> {
    let n = block_index.len();
    let channels = channels.as_array();
    for (what, len) in [
        ("count", count.len()),
        ("time_s", time_s.len()),
        ("temperature_c", temperature_c.len()),
        ("channels rows", channels.nrows()),
    ] {
        if len != n {
            return Err(crate::errors::CoreError(accelcore_core::Error::Shape {
                what,
                expected: n,
                got: len,
            })
            .into());
        }
    }
    let blocks = DecimatedBlocks {
        n_channels: channels.ncols(),
        block_index,
        count: count.iter().map(|&c| c.max(0) as u64).collect(),
        time_s,
        temperature_c,
        channels: channels.iter().copied().collect(),
    };
    blocks_to_py(py, blocks)
}

#[pymethods]
impl PyDecimatedBlocks {
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let rebuild = py
            .import("accelcore._accelcore")?
            .getattr("_blocks_from_arrays")?;
        let args = (
            self.block_index.clone_ref(py),
            self.count.clone_ref(py),
            self.time_s.clone_ref(py),
            self.temperature_c.clone_ref(py),
            self.channels.clone_ref(py),
        )
            .into_pyobject(py)?
            .into_any();
        Ok((rebuild, args))
    }

    fn __len__(&self, py: Python<'_>) -> usize {
        self.block_index.bind(py).len()
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "DecimatedBlocks(n_blocks={})",
            self.block_index.bind(py).len()
        )
    }
}

#[pymethods]
impl PyDecimator {
    #[new]
    #[pyo3(signature = (*, factor = 10, rate_hz = 20.0, n_channels = 3, min_count = 1, t0_s = None))]
    fn new(
        factor: i64,
        rate_hz: f64,
        n_channels: i64,
        min_count: i64,
        t0_s: Option<f64>,
    ) -> PyResult<Self> {
        let config = DecimatorConfig {
            factor: count("factor", factor)?,
            rate_hz,
            n_channels: count("n_channels", n_channels)?,
            min_count: count("min_count", min_count)?,
            t0_s,
        };
        let inner = Decimator::new(config).map_err(crate::errors::CoreError)?;
        Ok(Self { inner })
    }

    /// Push a chunk of samples.
    fn push(
        &mut self,
        py: Python<'_>,
        time_s: &Bound<'_, PyAny>,
        temperature_c: &Bound<'_, PyAny>,
        channels: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let inner = &mut self.inner;
        push_stream(py, time_s, temperature_c, channels, |t, temp, ch| {
            inner.push(t, temp, ch)
        })
    }

    /// Merge another decimator's state into this one.
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyDecimator>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// Blocks with at least `min_count` valid samples.
    fn finish(&self, py: Python<'_>) -> PyResult<PyDecimatedBlocks> {
        let inner = &self.inner;
        let blocks = run_detached(py, || inner.finish())?;
        blocks_to_py(py, blocks)
    }

    /// Remove and return the blocks that can no longer change.
    fn drain_completed(&mut self, py: Python<'_>) -> PyResult<PyDecimatedBlocks> {
        let inner = &mut self.inner;
        let blocks = run_detached(py, || Ok(inner.drain_completed()))?;
        blocks_to_py(py, blocks)
    }

    #[getter]
    fn n_samples(&self) -> u64 {
        self.inner.n_samples()
    }

    #[getter]
    fn n_skipped_nonfinite(&self) -> u64 {
        self.inner.n_skipped_nonfinite()
    }

    #[getter]
    fn factor(&self) -> usize {
        self.inner.config().factor
    }

    #[getter]
    fn rate_hz(&self) -> f64 {
        self.inner.config().rate_hz
    }

    #[getter]
    fn n_channels(&self) -> usize {
        self.inner.config().n_channels
    }

    #[getter]
    fn min_count(&self) -> usize {
        self.inner.config().min_count
    }

    #[getter]
    fn t0_s(&self) -> Option<f64> {
        self.inner.config().t0_s
    }

    fn __repr__(&self) -> String {
        let c = self.inner.config();
        format!(
            "Decimator(factor={}, rate_hz={}, n_channels={}, min_count={}, t0_s={:?}, n_samples={})",
            c.factor,
            c.rate_hz,
            c.n_channels,
            c.min_count,
            c.t0_s,
            self.inner.n_samples()
        )
    }
}
