//! `read_run`: the streaming session-log reader, and its result `RunData`.

use std::path::PathBuf;

use accelcore_core::{read_run, CsvFormat, DecimatorConfig, RunData};
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use crate::decimate::{blocks_to_py, PyDecimatedBlocks};
use crate::gateway::run_detached;

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
}

fn run_to_py(py: Python<'_>, run: RunData) -> PyResult<PyRunData> {
    let ranges = &run.channel_ranges;
    let channel_min: Vec<f64> = ranges.iter().map(|r| r.min).collect();
    let channel_max: Vec<f64> = ranges.iter().map(|r| r.max).collect();
    let n_at_min: Vec<u64> = ranges.iter().map(|r| r.n_at_min).collect();
    let n_at_max: Vec<u64> = ranges.iter().map(|r| r.n_at_max).collect();
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
        channel_min: channel_min.into_pyarray(py).unbind(),
        channel_max: channel_max.into_pyarray(py).unbind(),
        n_at_min: n_at_min.into_pyarray(py).unbind(),
        n_at_max: n_at_max.into_pyarray(py).unbind(),
    })
}

/// Read one delimited log file and decimate it on the fly (the file is never held whole).
#[pyfunction(name = "read_run")]
#[pyo3(signature = (
    path, /, *, delimiter = ",", time_column = "time_s", temperature_column = "temp_c",
    channel_columns = vec!["x".to_string(), "y".to_string(), "z".to_string()],
    keep_extra_columns = true, time_scale_to_s = 1.0, factor = 10, rate_hz = 20.0, min_count = 1
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
    factor: usize,
    rate_hz: f64,
    min_count: usize,
) -> PyResult<PyRunData> {
    let delimiter = match delimiter.as_bytes() {
        [b] if b.is_ascii() => *b,
        _ => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "delimiter must be one ASCII character, got {delimiter:?}"
            )))
        }
    };
    let format = CsvFormat {
        delimiter,
        time_column: time_column.to_string(),
        temperature_column: temperature_column.to_string(),
        channel_columns,
        keep_extra_columns,
        time_scale_to_s,
    };
    let config = DecimatorConfig {
        factor,
        rate_hz,
        n_channels: 0,
        min_count,
        t0_s: None,
    };
    let run = run_detached(py, || read_run(&path, &format, config))?;
    run_to_py(py, run)
}
