//! `FusedPipeline` (decimate → bin → fit in one pass) and its result, `PipelineResult`.

use accelcore_core::{BinnerConfig, DecimatorConfig, FusedPipeline, PipelineConfig};
use pyo3::prelude::*;

use crate::binning::{stats_to_py, PyBinnedStats};
use crate::gateway::{push_stream, run_detached};
use crate::regression::{solution_to_py, PyLstsqSolution};

/// Fused streaming pipeline (see `accelcore.core.FusedPipeline` in the stubs).
#[pyclass(name = "FusedPipeline", module = "accelcore.core")]
pub(crate) struct PyFusedPipeline {
    inner: FusedPipeline,
}

/// Binned statistics and per-channel line fits of a fused pipeline.
#[pyclass(name = "PipelineResult", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyPipelineResult {
    binned: Py<PyBinnedStats>,
    fits: Vec<Py<PyLstsqSolution>>,
    n_samples: u64,
    n_skipped_nonfinite: u64,
    n_blocks: u64,
    n_blocks_dropped: u64,
}

#[pymethods]
impl PyPipelineResult {
    fn __repr__(&self) -> String {
        format!(
            "PipelineResult(n_samples={}, n_blocks={}, n_blocks_dropped={}, n_fits={})",
            self.n_samples,
            self.n_blocks,
            self.n_blocks_dropped,
            self.fits.len()
        )
    }
}

#[pymethods]
impl PyFusedPipeline {
    #[new]
    #[pyo3(signature = (
        *, factor = 10, rate_hz = 20.0, n_channels = 3, min_count = 1, t0_s = None,
        lo_c = 0.0, hi_c = 60.0, width_c = 0.5, t_ref_c = 25.0
    ))]
    fn new(
        factor: usize,
        rate_hz: f64,
        n_channels: usize,
        min_count: usize,
        t0_s: Option<f64>,
        lo_c: f64,
        hi_c: f64,
        width_c: f64,
        t_ref_c: f64,
    ) -> PyResult<Self> {
        let config = PipelineConfig {
            decimator: DecimatorConfig {
                factor,
                rate_hz,
                n_channels,
                min_count,
                t0_s,
            },
            binner: BinnerConfig {
                lo_c,
                hi_c,
                width_c,
                n_channels,
            },
            t_ref_c,
        };
        let inner = FusedPipeline::new(config).map_err(crate::errors::CoreError)?;
        Ok(Self { inner })
    }

    /// Push a chunk of raw samples.
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

    /// Merge another piece of the same log (shared `t0_s`, non-overlapping times).
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyFusedPipeline>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// Binned statistics and line fits of everything pushed so far.
    fn finish(&self, py: Python<'_>) -> PyResult<PyPipelineResult> {
        let inner = &self.inner;
        let r = run_detached(py, || inner.finish())?;
        let fits = r
            .fits
            .into_iter()
            .map(|s| Py::new(py, solution_to_py(py, s)?))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(PyPipelineResult {
            binned: Py::new(py, stats_to_py(py, r.binned)?)?,
            fits,
            n_samples: r.n_samples,
            n_skipped_nonfinite: r.n_skipped_nonfinite,
            n_blocks: r.n_blocks,
            n_blocks_dropped: r.n_blocks_dropped,
        })
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
    fn t0_s(&self) -> Option<f64> {
        self.inner.config().decimator.t0_s
    }

    #[getter]
    fn t_ref_c(&self) -> f64 {
        self.inner.config().t_ref_c
    }

    #[getter]
    fn n_channels(&self) -> usize {
        self.inner.config().decimator.n_channels
    }

    fn __repr__(&self) -> String {
        let c = self.inner.config();
        format!(
            "FusedPipeline(factor={}, rate_hz={}, n_channels={}, min_count={}, t0_s={:?}, \
             lo_c={}, hi_c={}, width_c={}, t_ref_c={}, n_samples={})",
            c.decimator.factor,
            c.decimator.rate_hz,
            c.decimator.n_channels,
            c.decimator.min_count,
            c.decimator.t0_s,
            c.binner.lo_c,
            c.binner.hi_c,
            c.binner.width_c,
            c.t_ref_c,
            self.inner.n_samples()
        )
    }
}
