//! PyO3 bindings of `accelcore-core`. This crate only converts arrays,
//! releases the GIL around compute (through `gateway::run_detached`) and maps
//! core errors to the Python exception hierarchy (`errors.rs`).

mod binning;
mod compensation;
mod decimate;
mod errors;
mod gateway;
mod heldout;
mod reader;
mod regression;
mod robust;
mod search;
mod stats;

use pyo3::prelude::*;

/// The compiled extension `accelcore._accelcore`; users import `accelcore`.
#[pymodule]
mod _accelcore {
    #[pymodule_export]
    use super::binning::{PyBinnedStats, PyTemperatureBinner};
    #[pymodule_export]
    use super::compensation::{py_compensate, py_first_order_lag};
    #[pymodule_export]
    use super::decimate::{py_blocks_from_arrays, PyDecimatedBlocks, PyDecimator};
    #[pymodule_export]
    use super::heldout::{PyBlockedLeastSquares, PyFoldedLeastSquares, PyHeldOutFit};
    #[pymodule_export]
    use super::reader::{
        py_digest_bytes, py_merge_runs, py_plan_split, py_read_run, py_read_run_range,
        py_run_from_state, PyRawStats, PyRunData, PyRunTally,
    };
    #[pymodule_export]
    use super::regression::{PyLeastSquares, PyLstsqSolution};
    #[pymodule_export]
    use super::robust::{
        py_block_noise, py_fingerprint, py_median, py_nanmedian_columns, py_robust_sigma,
        py_running_median, py_sliding_median, py_sorted_values, py_typical_count,
    };
    #[pymodule_export]
    use super::search::PyTimeConstantSearch;
    #[pymodule_export]
    use super::stats::{
        py_bonferroni, py_chi2_sf, py_f_sf, py_holm, py_paired_test, py_t_sf, PyAcceptance,
        PyAcceptanceRule, PyPairedTest,
    };

    use pyo3::prelude::*;

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        m.add("__version__", env!("CARGO_PKG_VERSION"))?;
        // Lines the reader reads looking for a header below a logger's preamble.
        m.add(
            "MAX_PREAMBLE_LINES",
            accelcore_core::reader::MAX_PREAMBLE_LINES,
        )?;
        // The temperatures a log may hold, °C: beyond them a value is corrupt.
        m.add(
            "MIN_TEMPERATURE_C",
            accelcore_core::reader::MIN_TEMPERATURE_C,
        )?;
        m.add(
            "MAX_TEMPERATURE_C",
            accelcore_core::reader::MAX_TEMPERATURE_C,
        )
    }
}
