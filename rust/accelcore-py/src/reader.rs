//! `read_run`: the streaming session-log reader, and its result `RunData`;
//! `RunTally`: the statistics of a run's raw rows, for the other readers.

use std::path::PathBuf;

use accelcore_core::{
    merge_runs, plan_split, read_run, read_run_digest, read_run_range, ChannelRange, CsvFormat,
    DecimatorConfig, DigestAlgorithm, RawStats, RunData, RunTally,
};
use numpy::{IntoPyArray, PyArray1, PyArrayMethods};
use pyo3::prelude::*;

use crate::decimate::{blocks_to_py, PyDecimatedBlocks};
use crate::gateway::{count, push_stream, run_detached};

/// What a run's raw rows looked like (see `accelcore.core.RunTally` in the stubs).
#[pyclass(name = "RunTally", module = "accelcore.core")]
pub(crate) struct PyRunTally {
    inner: RunTally,
}

/// The result of a `RunTally`.
#[pyclass(name = "RawStats", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyRawStats {
    n_rows: u64,
    n_skipped_nonfinite: u64,
    first_time_s: f64,
    last_time_s: f64,
    n_gaps: u64,
    max_interval_s: f64,
    channel_min: Py<PyArray1<f64>>,
    channel_max: Py<PyArray1<f64>>,
    n_at_min: Py<PyArray1<u64>>,
    n_at_max: Py<PyArray1<u64>>,
}

/// The four per-channel arrays of channel ranges: min, max, count at min, count at max.
type RangeArrays = (
    Py<PyArray1<f64>>,
    Py<PyArray1<f64>>,
    Py<PyArray1<u64>>,
    Py<PyArray1<u64>>,
);

fn ranges_to_py(py: Python<'_>, ranges: &[ChannelRange]) -> RangeArrays {
    let min: Vec<f64> = ranges.iter().map(|r| r.min).collect();
    let max: Vec<f64> = ranges.iter().map(|r| r.max).collect();
    let at_min: Vec<u64> = ranges.iter().map(|r| r.n_at_min).collect();
    let at_max: Vec<u64> = ranges.iter().map(|r| r.n_at_max).collect();
    (
        min.into_pyarray(py).unbind(),
        max.into_pyarray(py).unbind(),
        at_min.into_pyarray(py).unbind(),
        at_max.into_pyarray(py).unbind(),
    )
}

fn raw_stats_to_py(py: Python<'_>, stats: RawStats) -> PyRawStats {
    let (channel_min, channel_max, n_at_min, n_at_max) = ranges_to_py(py, &stats.channel_ranges);
    PyRawStats {
        n_rows: stats.n_rows,
        n_skipped_nonfinite: stats.n_skipped_nonfinite,
        first_time_s: stats.first_time_s,
        last_time_s: stats.last_time_s,
        n_gaps: stats.n_gaps,
        max_interval_s: stats.max_interval_s,
        channel_min,
        channel_max,
        n_at_min,
        n_at_max,
    }
}

#[pymethods]
impl PyRawStats {
    fn __repr__(&self) -> String {
        format!(
            "RawStats(n_rows={}, n_skipped_nonfinite={}, n_gaps={})",
            self.n_rows, self.n_skipped_nonfinite, self.n_gaps
        )
    }
}

#[pymethods]
impl PyRunTally {
    #[new]
    #[pyo3(signature = (*, n_channels = 3, rate_hz = 20.0))]
    fn new(n_channels: i64, rate_hz: f64) -> PyResult<Self> {
        let inner = RunTally::new(count("n_channels", n_channels)?, rate_hz)
            .map_err(crate::errors::CoreError)?;
        Ok(Self { inner })
    }

    /// Count a chunk of rows.
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

    /// Add a tally whose rows follow this one's.
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyRunTally>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// The statistics of every row counted so far.
    fn finish(&self, py: Python<'_>) -> PyRawStats {
        raw_stats_to_py(py, self.inner.finish())
    }

    #[getter]
    fn n_channels(&self) -> usize {
        self.inner.n_channels()
    }

    #[getter]
    fn rate_hz(&self) -> f64 {
        self.inner.rate_hz()
    }

    #[getter]
    fn n_rows(&self) -> u64 {
        self.inner.stats().n_rows
    }

    fn __repr__(&self) -> String {
        format!(
            "RunTally(n_channels={}, rate_hz={}, n_rows={})",
            self.inner.n_channels(),
            self.inner.rate_hz(),
            self.inner.stats().n_rows
        )
    }
}

/// One log file read and decimated.
#[pyclass(name = "RunData", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyRunData {
    header: Vec<String>,
    channel_names: Vec<String>,
    blocks: Py<PyDecimatedBlocks>,
    n_rows: u64,
    n_skipped_nonfinite: u64,
    n_truncated_rows: u64,
    first_time_s: f64,
    last_time_s: f64,
    n_gaps: u64,
    max_interval_s: f64,
    channel_min: Py<PyArray1<f64>>,
    channel_max: Py<PyArray1<f64>>,
    n_at_min: Py<PyArray1<u64>>,
    n_at_max: Py<PyArray1<u64>>,
    /// Hex digest of the bytes read, when `read_run(..., digest=...)` asked for it.
    digest: Option<String>,
    /// Its algorithm (`"blake3"` or `"sha256"`), when a digest was asked for.
    digest_algorithm: Option<String>,
}

impl PyRunData {
    fn to_core(&self, py: Python<'_>) -> PyResult<RunData> {
        let min = self.channel_min.bind(py).readonly().as_array().to_vec();
        let max = self.channel_max.bind(py).readonly().as_array().to_vec();
        let at_min = self.n_at_min.bind(py).readonly().as_array().to_vec();
        let at_max = self.n_at_max.bind(py).readonly().as_array().to_vec();
        let channel_ranges = (0..min.len())
            .map(|i| ChannelRange {
                min: min[i],
                max: max[i],
                n_at_min: at_min[i],
                n_at_max: at_max[i],
            })
            .collect();
        Ok(RunData {
            header: self.header.clone(),
            channel_names: self.channel_names.clone(),
            blocks: self.blocks.borrow(py).to_core(py)?,
            n_rows: self.n_rows,
            n_skipped_nonfinite: self.n_skipped_nonfinite,
            n_truncated_rows: self.n_truncated_rows,
            first_time_s: self.first_time_s,
            last_time_s: self.last_time_s,
            n_gaps: self.n_gaps,
            max_interval_s: self.max_interval_s,
            channel_ranges,
        })
    }
}

#[pymethods]
impl PyRunData {
    /// Hex SHA-256 of the bytes read, when the digest asked for was SHA-256; else None.
    #[getter]
    fn sha256(&self) -> Option<String> {
        match self.digest_algorithm.as_deref() {
            Some("sha256") => self.digest.clone(),
            _ => None,
        }
    }

    /// Pickle support, so pieces read on Dask workers come back to the client.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let rebuild = py
            .import("accelcore._accelcore")?
            .getattr("_run_from_state")?;
        let state = (
            self.header.clone(),
            self.channel_names.clone(),
            self.blocks.clone_ref(py),
            (
                self.n_rows,
                self.n_skipped_nonfinite,
                self.n_truncated_rows,
                self.n_gaps,
            ),
            (self.first_time_s, self.last_time_s, self.max_interval_s),
            (
                self.channel_min.clone_ref(py),
                self.channel_max.clone_ref(py),
                self.n_at_min.clone_ref(py),
                self.n_at_max.clone_ref(py),
            ),
            self.digest_algorithm.clone().zip(self.digest.clone()),
        );
        Ok((rebuild, (state,).into_pyobject(py)?.into_any()))
    }
}

type RunState<'py> = (
    Vec<String>,
    Vec<String>,
    Py<PyDecimatedBlocks>,
    (u64, u64, u64, u64),
    (f64, f64, f64),
    (Vec<f64>, Vec<f64>, Vec<u64>, Vec<u64>),
    Option<(String, String)>,
);

/// Rebuild `RunData` from `__reduce__`'s state.
#[pyfunction(name = "_run_from_state")]
pub(crate) fn py_run_from_state(py: Python<'_>, state: RunState<'_>) -> PyResult<PyRunData> {
    let (header, channel_names, blocks, counts, times, ranges, digest) = state;
    let channel_ranges = (0..ranges.0.len())
        .map(|i| ChannelRange {
            min: ranges.0[i],
            max: ranges.1.get(i).copied().unwrap_or(f64::NAN),
            n_at_min: ranges.2.get(i).copied().unwrap_or(0),
            n_at_max: ranges.3.get(i).copied().unwrap_or(0),
        })
        .collect();
    let run = RunData {
        header,
        channel_names,
        blocks: blocks.borrow(py).to_core(py)?,
        n_rows: counts.0,
        n_skipped_nonfinite: counts.1,
        n_truncated_rows: counts.2,
        n_gaps: counts.3,
        first_time_s: times.0,
        last_time_s: times.1,
        max_interval_s: times.2,
        channel_ranges,
    };
    run_to_py(py, run, digest)
}

/// `digest`: `(algorithm, hex)` when one was taken.
fn run_to_py(
    py: Python<'_>,
    run: RunData,
    digest: Option<(String, String)>,
) -> PyResult<PyRunData> {
    let (digest_algorithm, digest) = digest.unzip();
    let (channel_min, channel_max, n_at_min, n_at_max) = ranges_to_py(py, &run.channel_ranges);
    Ok(PyRunData {
        blocks: Py::new(py, blocks_to_py(py, run.blocks)?)?,
        header: run.header,
        channel_names: run.channel_names,
        n_rows: run.n_rows,
        n_skipped_nonfinite: run.n_skipped_nonfinite,
        n_truncated_rows: run.n_truncated_rows,
        first_time_s: run.first_time_s,
        last_time_s: run.last_time_s,
        n_gaps: run.n_gaps,
        max_interval_s: run.max_interval_s,
        channel_min,
        channel_max,
        n_at_min,
        n_at_max,
        digest,
        digest_algorithm,
    })
}

fn csv_format(
    delimiter: &str,
    time_column: &str,
    temperature_column: &str,
    channel_columns: Vec<String>,
    keep_extra_columns: bool,
    time_scale_to_s: f64,
) -> PyResult<CsvFormat> {
    let delimiter = match delimiter.as_bytes() {
        [b] if b.is_ascii() => *b,
        _ => {
            return Err(
                crate::errors::CoreError(accelcore_core::Error::InvalidParameter {
                    name: "delimiter",
                    reason: format!("must be one ASCII character, got {delimiter:?}"),
                })
                .into(),
            )
        }
    };
    Ok(CsvFormat {
        delimiter,
        time_column: time_column.to_string(),
        temperature_column: temperature_column.to_string(),
        channel_columns,
        keep_extra_columns,
        time_scale_to_s,
    })
}

/// Read one delimited log file and decimate it on the fly (the file is never held whole).
#[pyfunction(name = "read_run")]
#[pyo3(signature = (
    path, /, *, delimiter = ",", time_column = "time_s", temperature_column = "temp_c",
    channel_columns = vec!["x".to_string(), "y".to_string(), "z".to_string()],
    keep_extra_columns = true, time_scale_to_s = 1.0, factor = 10, rate_hz = 20.0, min_count = 1,
    sha256 = false, digest = None
))]
pub(crate) fn py_read_run(
    py: Python<'_>,
    path: PathBuf,
    delimiter: &str,
    time_column: &str,
    temperature_column: &str,
    channel_columns: Vec<String>,
    keep_extra_columns: bool,
    time_scale_to_s: f64,
    factor: i64,
    rate_hz: f64,
    min_count: i64,
    sha256: bool,
    digest: Option<&str>,
) -> PyResult<PyRunData> {
    let algorithm = match (digest.map(DigestAlgorithm::from_name).transpose(), sha256) {
        (Err(e), _) => return Err(crate::errors::CoreError(e).into()),
        (Ok(None), false) => None,
        (Ok(None | Some(DigestAlgorithm::Sha256)), true) => Some(DigestAlgorithm::Sha256),
        (Ok(Some(algorithm)), false) => Some(algorithm),
        (Ok(Some(other)), true) => {
            return Err(
                crate::errors::CoreError(accelcore_core::Error::InvalidParameter {
                    name: "digest",
                    reason: format!(
                        "sha256=True asks for SHA-256, but digest={:?} was given",
                        other.name()
                    ),
                })
                .into(),
            )
        }
    };
    let format = csv_format(
        delimiter,
        time_column,
        temperature_column,
        channel_columns,
        keep_extra_columns,
        time_scale_to_s,
    )?;
    let config = DecimatorConfig {
        factor: count("factor", factor)?,
        rate_hz,
        n_channels: 0,
        min_count: count("min_count", min_count)?,
        t0_s: None,
    };
    if let Some(algorithm) = algorithm {
        let (run, digest) =
            run_detached(py, || read_run_digest(&path, &format, config, algorithm))?;
        return run_to_py(
            py,
            run,
            Some((algorithm.name().to_string(), to_hex(&digest))),
        );
    }
    let run = run_detached(py, || read_run(&path, &format, config))?;
    run_to_py(py, run, None)
}

const HEX_DIGITS: &[u8; 16] = b"0123456789abcdef";

fn to_hex(digest: &[u8; 32]) -> String {
    digest.iter().fold(String::with_capacity(64), |mut hex, b| {
        hex.push(char::from(HEX_DIGITS[usize::from(b >> 4)]));
        hex.push(char::from(HEX_DIGITS[usize::from(b & 15)]));
        hex
    })
}

/// The hex digest of `data` in one shot (`"blake3"` or `"sha256"`): for files read
/// whole elsewhere (`session.toml`), so that every file of a session carries a
/// digest of the same algorithm.
#[pyfunction(name = "digest_bytes")]
#[pyo3(signature = (data, /, algorithm = "blake3"))]
pub(crate) fn py_digest_bytes(data: &[u8], algorithm: &str) -> PyResult<String> {
    let algorithm = DigestAlgorithm::from_name(algorithm).map_err(crate::errors::CoreError)?;
    Ok(to_hex(&algorithm.digest(data)))
}

/// `(ranges, t0_s)` of a split plan, as Python receives it.
type SplitPlanTuple = (Vec<(u64, u64)>, Option<f64>);

/// Plan the reading of one log in pieces: line-aligned byte ranges and the block origin.
#[pyfunction(name = "plan_split")]
#[pyo3(signature = (
    path, pieces, /, *, delimiter = ",", time_column = "time_s", temperature_column = "temp_c",
    channel_columns = vec!["x".to_string(), "y".to_string(), "z".to_string()],
    time_scale_to_s = 1.0
))]
pub(crate) fn py_plan_split(
    py: Python<'_>,
    path: PathBuf,
    pieces: i64,
    delimiter: &str,
    time_column: &str,
    temperature_column: &str,
    channel_columns: Vec<String>,
    time_scale_to_s: f64,
) -> PyResult<SplitPlanTuple> {
    let format = csv_format(
        delimiter,
        time_column,
        temperature_column,
        channel_columns,
        true,
        time_scale_to_s,
    )?;
    let pieces = count("pieces", pieces)?;
    let plan = run_detached(py, || plan_split(&path, &format, pieces))?;
    Ok((plan.ranges, plan.t0_s))
}

/// Read the data lines in a byte range of a log (a piece of `plan_split`).
#[pyfunction(name = "read_run_range")]
#[pyo3(signature = (
    path, start, end, /, *, t0_s, delimiter = ",", time_column = "time_s",
    temperature_column = "temp_c",
    channel_columns = vec!["x".to_string(), "y".to_string(), "z".to_string()],
    keep_extra_columns = true, time_scale_to_s = 1.0, factor = 10, rate_hz = 20.0
))]
pub(crate) fn py_read_run_range(
    py: Python<'_>,
    path: PathBuf,
    start: u64,
    end: u64,
    t0_s: f64,
    delimiter: &str,
    time_column: &str,
    temperature_column: &str,
    channel_columns: Vec<String>,
    keep_extra_columns: bool,
    time_scale_to_s: f64,
    factor: i64,
    rate_hz: f64,
) -> PyResult<PyRunData> {
    let format = csv_format(
        delimiter,
        time_column,
        temperature_column,
        channel_columns,
        keep_extra_columns,
        time_scale_to_s,
    )?;
    let config = DecimatorConfig {
        factor: count("factor", factor)?,
        rate_hz,
        n_channels: 0,
        min_count: 1,
        t0_s: Some(t0_s),
    };
    let run = run_detached(py, || read_run_range(&path, &format, config, start, end))?;
    run_to_py(py, run, None)
}

/// Combine pieces of one log, in file order, into the one-pass result.
#[pyfunction(name = "merge_runs")]
#[pyo3(signature = (pieces, /, *, min_count = 1, rate_hz = 20.0))]
pub(crate) fn py_merge_runs(
    py: Python<'_>,
    pieces: Vec<PyRef<'_, PyRunData>>,
    min_count: i64,
    rate_hz: f64,
) -> PyResult<PyRunData> {
    let min_count = count("min_count", min_count)?;
    let parts = pieces
        .iter()
        .map(|p| p.to_core(py))
        .collect::<PyResult<Vec<_>>>()?;
    let run = run_detached(py, || merge_runs(&parts, min_count, rate_hz))?;
    run_to_py(py, run, None)
}
