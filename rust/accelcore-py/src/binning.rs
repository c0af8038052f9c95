//! `TemperatureBinner` and its result, `BinnedStats`.

use accelcore_core::{BinnedStats, BinnerConfig, TemperatureBinner};
use ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

use crate::gateway::{count, push_stream, run_detached};

/// Fixed-width temperature binner (see `accelcore.core.TemperatureBinner` in the stubs).
#[pyclass(name = "TemperatureBinner", module = "accelcore.core")]
pub(crate) struct PyTemperatureBinner {
    pub(crate) inner: TemperatureBinner,
}

/// Per-bin statistics.
#[pyclass(name = "BinnedStats", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyBinnedStats {
    edges_c: Py<PyArray1<f64>>,
    count: Py<PyArray1<i64>>,
    temperature_c: Py<PyArray1<f64>>,
    time_s: Py<PyArray1<f64>>,
    mean: Py<PyArray2<f64>>,
    variance: Py<PyArray2<f64>>,
    n_below: u64,
    n_above: u64,
    n_nonfinite: u64,
}

fn to_2d(values: Vec<f64>, rows: usize, cols: usize) -> PyResult<Array2<f64>> {
    Array2::from_shape_vec((rows, cols), values)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
}

pub(crate) fn stats_to_py(py: Python<'_>, stats: BinnedStats) -> PyResult<PyBinnedStats> {
    let n_bins = stats.count.len();
    let count: Vec<i64> = stats.count.iter().map(|&c| c as i64).collect();
    Ok(PyBinnedStats {
        edges_c: stats.edges_c.into_pyarray(py).unbind(),
        count: count.into_pyarray(py).unbind(),
        temperature_c: stats.temperature_c.into_pyarray(py).unbind(),
        time_s: stats.time_s.into_pyarray(py).unbind(),
        mean: to_2d(stats.mean, n_bins, stats.n_channels)?
            .into_pyarray(py)
            .unbind(),
        variance: to_2d(stats.variance, n_bins, stats.n_channels)?
            .into_pyarray(py)
            .unbind(),
        n_below: stats.n_below,
        n_above: stats.n_above,
        n_nonfinite: stats.n_nonfinite,
    })
}

#[pymethods]
impl PyBinnedStats {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "BinnedStats(n_bins={}, n_below={}, n_above={}, n_nonfinite={})",
            self.count.bind(py).len(),
            self.n_below,
            self.n_above,
            self.n_nonfinite
        )
    }
}

#[pymethods]
impl PyTemperatureBinner {
    #[new]
    #[pyo3(signature = (*, lo_c = 0.0, hi_c = 60.0, width_c = 0.5, n_channels = 3))]
    fn new(lo_c: f64, hi_c: f64, width_c: f64, n_channels: i64) -> PyResult<Self> {
        let n_channels = count("n_channels", n_channels)?;
        let config = BinnerConfig {
            lo_c,
            hi_c,
            width_c,
            n_channels,
        };
        let inner = TemperatureBinner::new(config).map_err(crate::errors::CoreError)?;
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

    /// Merge another binner of the same configuration.
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyTemperatureBinner>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// Per-bin statistics.
    fn finish(&self, py: Python<'_>) -> PyResult<PyBinnedStats> {
        let inner = &self.inner;
        let stats = run_detached(py, || inner.finish())?;
        stats_to_py(py, stats)
    }

    #[getter]
    fn n_bins(&self) -> usize {
        self.inner.n_bins()
    }

    #[getter]
    fn lo_c(&self) -> f64 {
        self.inner.config().lo_c
    }

    #[getter]
    fn hi_c(&self) -> f64 {
        self.inner.config().hi_c
    }

    #[getter]
    fn width_c(&self) -> f64 {
        self.inner.config().width_c
    }

    #[getter]
    fn n_channels(&self) -> usize {
        self.inner.config().n_channels
    }

    fn __repr__(&self) -> String {
        let c = self.inner.config();
        format!(
            "TemperatureBinner(lo_c={}, hi_c={}, width_c={}, n_channels={})",
            c.lo_c, c.hi_c, c.width_c, c.n_channels
        )
    }
}
