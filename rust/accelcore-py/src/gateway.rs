//! One gateway across the boundary: borrow inputs, run the core detached from
//! the interpreter (the GIL is released for the whole closure) and map errors.
//! Every long-running binding goes through [`run_detached`], so the threading
//! and error policy is a one-file change.

use std::borrow::Cow;

use ndarray::ArrayView2;
use numpy::{AllowTypeChange, PyArrayLike1, PyArrayLike2};
use pyo3::prelude::*;

use crate::errors::CoreError;

/// Run `work` with the GIL released and turn a core error into its exception.
///
/// A panic in the core (a bug: data-dependent paths return errors) is caught
/// here and raised as `accelcore.AccelcoreError`, so it never reaches Python as
/// a `PanicException`, which `except Exception` would not catch.
pub(crate) fn run_detached<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> accelcore_core::Result<T> + Send,
{
    match py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(work))) {
        Ok(result) => result.map_err(|e| CoreError(e).into()),
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(ToString::to_string)
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(crate::errors::internal_error(py, &what))
        }
    }
}

/// A 1-D float64 input: any array-like, converted to float64 if needed.
pub(crate) type In1<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;
/// A 2-D float64 input: any array-like, converted to float64 if needed.
pub(crate) type In2<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;

/// Borrow a contiguous 1-D array (float64 samples, int64 counts) as a slice, or make one
/// documented copy of a strided one.
pub(crate) fn slice_or_copy<'a, T: numpy::Element + Copy>(
    array: &'a PyArrayLike1<'_, T, AllowTypeChange>,
) -> Cow<'a, [T]> {
    match array.as_slice() {
        Ok(slice) => Cow::Borrowed(slice),
        Err(_) => Cow::Owned(array.as_array().iter().copied().collect()),
    }
}

/// Turn a failed extraction into a `ShapeError` when the input has another number of
/// dimensions than `ndim` (plain extraction would say `TypeError`).
fn dimension_error(obj: &Bound<'_, PyAny>, ndim: usize, what: &'static str, err: PyErr) -> PyErr {
    let got = obj.getattr("ndim").and_then(|n| n.extract::<usize>()).ok();
    match got {
        Some(got) if got != ndim => CoreError(accelcore_core::Error::Shape {
            what,
            expected: ndim,
            got,
        })
        .into(),
        _ => err,
    }
}

/// A 1-D float64 input, with a `ShapeError` naming `what` for another dimensionality.
pub(crate) fn array1<'py>(obj: &Bound<'py, PyAny>, what: &'static str) -> PyResult<In1<'py>> {
    obj.extract::<In1<'py>>()
        .map_err(|e| dimension_error(obj, 1, what, e))
}

/// A 2-D float64 input, with a `ShapeError` naming `what` for another dimensionality.
pub(crate) fn array2<'py>(obj: &Bound<'py, PyAny>, what: &'static str) -> PyResult<In2<'py>> {
    obj.extract::<In2<'py>>()
        .map_err(|e| dimension_error(obj, 2, what, e))
}

/// Borrow one chunk of a stream — time (s), temperature (°C) and channels
/// `(n, n_channels)` — and run `work` on it with the GIL released. Shared by every
/// kernel's `push`, so all of them accept the same inputs and raise the same errors.
pub(crate) fn push_stream<F>(
    py: Python<'_>,
    time_s: &Bound<'_, PyAny>,
    temperature_c: &Bound<'_, PyAny>,
    channels: &Bound<'_, PyAny>,
    work: F,
) -> PyResult<()>
where
    F: for<'a> FnOnce(&'a [f64], &'a [f64], ArrayView2<'a, f64>) -> accelcore_core::Result<()>
        + Send,
{
    let time_s = array1(time_s, "time_s dimensions")?;
    let temperature_c = array1(temperature_c, "temperature_c dimensions")?;
    let channels = array2(channels, "channels dimensions")?;
    let (time_s, temperature_c) = (slice_or_copy(&time_s), slice_or_copy(&temperature_c));
    let channels = channels.as_array();
    run_detached(py, || work(&time_s, &temperature_c, channels))
}

/// A count argument: negative values are a `ParameterError`, not an `OverflowError`.
pub(crate) fn count(name: &'static str, value: i64) -> PyResult<usize> {
    usize::try_from(value).map_err(|_| {
        CoreError(accelcore_core::Error::InvalidParameter {
            name,
            reason: format!("must be >= 0, got {value}"),
        })
        .into()
    })
}
