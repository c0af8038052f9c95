//! `compensate`: raw output to acceleration in g (vectorised in Rust).

use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::gateway::{run_detached, slice_or_copy, In1, In2};

/// Raw (n, 3) readings to acceleration in g through a linear-in-coefficients model.
#[pyfunction(name = "compensate")]
pub(crate) fn py_compensate<'py>(
    py: Python<'py>,
    raw: In2<'py>,
    basis: In2<'py>,
    offset_coefficients: In2<'py>,
    gain_coefficients: In2<'py>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let (raw, basis) = (raw.as_array(), basis.as_array());
    let (offset, gain) = (offset_coefficients.as_array(), gain_coefficients.as_array());
    let out = run_detached(py, || accelcore_core::compensate(raw, basis, offset, gain))?;
    Ok(out.into_pyarray(py))
}

/// First-order lag of a temperature series (see `accelcore_core::first_order_lag`);
/// with `tau_cool_s`, `tau_s` while heating and `tau_cool_s` while cooling
/// (`accelcore_core::direction_lag`).
#[pyfunction(name = "first_order_lag")]
#[pyo3(signature = (time_s, temperature_c, tau_s, /, initial = None, tau_cool_s = None))]
pub(crate) fn py_first_order_lag<'py>(
    py: Python<'py>,
    time_s: In1<'py>,
    temperature_c: In1<'py>,
    tau_s: f64,
    initial: Option<f64>,
    tau_cool_s: Option<f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (time_s, temperature_c) = (slice_or_copy(&time_s), slice_or_copy(&temperature_c));
    let out = run_detached(py, || match tau_cool_s {
        None => accelcore_core::first_order_lag(&time_s, &temperature_c, tau_s, initial),
        Some(cool) => accelcore_core::direction_lag(&time_s, &temperature_c, tau_s, cool, initial),
    })?;
    Ok(out.into_pyarray(py))
}
