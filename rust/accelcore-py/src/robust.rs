//! `running_median` and `sliding_median`: the medians of the data-quality checks.

use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use crate::gateway::{array1, count, run_detached, slice_or_copy};

/// Centred running median of ``y`` over ``2 * (window // 2) + 1`` values.
///
/// ``y`` is extended by ``half = window // 2`` values at each end as
/// ``np.pad(y, half, mode="reflect")`` would (the end values are not repeated), or
/// with ``mode="edge"`` when ``len(y) <= half``; output ``i`` is the median of padded
/// values ``i`` to ``i + 2 * half``. An even ``window`` is thus rounded up to the next
/// odd size. The median of an odd number of values is one of them, so the result is
/// exact and equals ``accelcore.reference.running_median`` bit for bit.
///
/// Parameters
/// ----------
/// y : array_like, shape (n,)
///     The series (converted to float64).
/// window : int
///     Window length, >= 1.
///
/// Returns
/// -------
/// ndarray of float64, shape (n,)
///     The running median; NaN where the window holds a NaN. Empty for empty ``y``.
///
/// Raises
/// ------
/// ParameterError
///     ``window < 1``.
/// ShapeError
///     ``y`` is not 1-D.
#[pyfunction(name = "running_median")]
#[pyo3(signature = (y, /, *, window))]
pub(crate) fn py_running_median<'py>(
    py: Python<'py>,
    y: &Bound<'py, PyAny>,
    window: i64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let window = count("window", window)?;
    let y = array1(y, "y dimensions")?;
    let y = slice_or_copy(&y);
    let out = run_detached(py, || accelcore_core::running_median(&y, window))?;
    Ok(out.into_pyarray(py))
}

/// Median of every window ``y[j : j + window]``, ``j = 0, ..., len(y) - window``.
///
/// Equals ``np.median(sliding_window_view(y, window), axis=1)`` bit for bit (and
/// ``accelcore.reference.sliding_median``): an odd window gives its middle value, an
/// even one the mean of its two middle values ``a <= b`` as NumPy computes it,
/// ``(0.0 + a + b) / 2`` (a zero median is ``+0.0``).
///
/// Parameters
/// ----------
/// y : array_like, shape (n,)
///     The series (converted to float64).
/// window : int
///     Window length, ``1 <= window <= n``.
///
/// Returns
/// -------
/// ndarray of float64, shape (n - window + 1,)
///     The window medians; NaN where the window holds a NaN.
///
/// Raises
/// ------
/// ParameterError
///     ``window < 1`` or ``window > len(y)``.
/// ShapeError
///     ``y`` is not 1-D.
#[pyfunction(name = "sliding_median")]
#[pyo3(signature = (y, /, *, window))]
pub(crate) fn py_sliding_median<'py>(
    py: Python<'py>,
    y: &Bound<'py, PyAny>,
    window: i64,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let window = count("window", window)?;
    let y = array1(y, "y dimensions")?;
    let y = slice_or_copy(&y);
    let out = run_detached(py, || accelcore_core::sliding_median(&y, window))?;
    Ok(out.into_pyarray(py))
}
