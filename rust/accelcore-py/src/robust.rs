//! `running_median` and `sliding_median`: the medians of the data-quality checks.

use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayLike1};
use pyo3::prelude::*;

use crate::gateway::{array1, array2, count, run_detached, slice_or_copy};

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

/// Median of ``a`` as ``float(np.median(a))`` gives it, bit for bit.
///
/// The middle value, or the mean of the two middle values ``a <= b`` as NumPy
/// computes it, ``(0.0 + a + b) / 2`` (a zero median is ``+0.0``). NaN for an empty
/// ``a`` or one holding a NaN (without NumPy's warning).
///
/// Parameters
/// ----------
/// a : array_like, shape (n,)
///     The values (converted to float64).
///
/// Returns
/// -------
/// float
///
/// Raises
/// ------
/// ShapeError
///     ``a`` is not 1-D.
#[pyfunction(name = "median")]
#[pyo3(signature = (a, /))]
pub(crate) fn py_median(py: Python<'_>, a: &Bound<'_, PyAny>) -> PyResult<f64> {
    let a = array1(a, "a dimensions")?;
    let a = slice_or_copy(&a);
    run_detached(py, || Ok(accelcore_core::median(&a)))
}

/// ``np.nanmedian(a, axis=0)`` of a 2-D array, bit for bit.
///
/// Each column's median of its values that are not NaN (see :func:`median`); NaN
/// for a column with none (without NumPy's warning).
///
/// Parameters
/// ----------
/// a : array_like, shape (n, k)
///     The values (converted to float64; any memory layout).
///
/// Returns
/// -------
/// ndarray of float64, shape (k,)
///
/// Raises
/// ------
/// ShapeError
///     ``a`` is not 2-D.
#[pyfunction(name = "nanmedian_columns")]
#[pyo3(signature = (a, /))]
pub(crate) fn py_nanmedian_columns<'py>(
    py: Python<'py>,
    a: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let a = array2(a, "a dimensions")?;
    let view = a.as_array();
    let out = run_detached(py, || {
        Ok(view
            .columns()
            .into_iter()
            .map(|column| match column.as_slice() {
                Some(values) => accelcore_core::nanmedian(values),
                None => accelcore_core::nanmedian(&column.to_vec()),
            })
            .collect::<Vec<f64>>())
    })?;
    Ok(out.into_pyarray(py))
}

/// 128-bit fingerprint of a float series and an integer series, for caches.
///
/// XXH3 of the length and little-endian bytes of ``values``, then of ``counts``:
/// equal arrays give equal fingerprints; arrays that differ in any bit or length give
/// different ones, but for chance (odds about 2^-64 among 2^32 arrays). Not a
/// provenance digest (those are BLAKE3 or SHA-256).
///
/// Parameters
/// ----------
/// values : array_like, shape (n,)
///     Converted to float64.
/// counts : array_like of int64, shape (m,)
///
/// Returns
/// -------
/// int
///     In ``0 ... 2**128 - 1``.
///
/// Raises
/// ------
/// ShapeError
///     An input is not 1-D.
#[pyfunction(name = "fingerprint")]
#[pyo3(signature = (values, counts, /))]
pub(crate) fn py_fingerprint(
    py: Python<'_>,
    values: &Bound<'_, PyAny>,
    counts: PyArrayLike1<'_, i64, AllowTypeChange>,
) -> PyResult<u128> {
    let values = array1(values, "values dimensions")?;
    let values = slice_or_copy(&values);
    let counts = slice_or_copy(&counts);
    run_detached(py, || Ok(accelcore_core::fingerprint(&values, &counts)))
}

/// ``np.sort(values)``: ascending, NaN last (a radix sort in the core).
///
/// Values that compare equal come out equal, but ``-0.0`` sorts before ``0.0``
/// (NumPy leaves their order to its algorithm); the NaNs keep their bits and their
/// order, after everything else.
///
/// Parameters
/// ----------
/// values : array_like, shape (n,)
///     Converted to float64.
///
/// Returns
/// -------
/// ndarray of float64, shape (n,)
///
/// Raises
/// ------
/// ShapeError
///     ``values`` is not 1-D.
#[pyfunction(name = "sorted_values")]
#[pyo3(signature = (values, /))]
pub(crate) fn py_sorted_values<'py>(
    py: Python<'py>,
    values: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let values = array1(values, "values dimensions")?;
    let values = slice_or_copy(&values);
    let out = run_detached(py, || Ok(accelcore_core::sorted(&values)))?;
    Ok(out.into_pyarray(py))
}

/// Robust standard deviation of the finite values of ``r``.
///
/// ``1.4826`` times the median absolute deviation from the median; where that is 0
/// (most values equal), ``sqrt(pi / 2)`` times the mean absolute deviation (NumPy's
/// summation order); 0 when no value is finite. The figures of
/// ``accelcore.input.quality``'s NumPy, bit for bit.
///
/// Parameters
/// ----------
/// r : array_like, shape (n,)
///     Converted to float64.
///
/// Returns
/// -------
/// float
///
/// Raises
/// ------
/// ShapeError
///     ``r`` is not 1-D.
#[pyfunction(name = "robust_sigma")]
#[pyo3(signature = (r, /))]
pub(crate) fn py_robust_sigma(py: Python<'_>, r: &Bound<'_, PyAny>) -> PyResult<f64> {
    let r = array1(r, "r dimensions")?;
    let r = slice_or_copy(&r);
    run_detached(py, || Ok(accelcore_core::robust_sigma(&r)))
}

/// Return a run's block residuals about a running median, scaled, and their noise.
///
/// Each block's ``y - running_median(y, window)`` times ``sqrt(count / typical)``
/// (``typical``: the most common count, the smallest of those tied), and the
/// residuals' :func:`robust_sigma`.
///
/// Parameters
/// ----------
/// y : array_like, shape (n,)
///     Block means of one channel (converted to float64).
/// count : array_like of int64, shape (n,)
///     Raw samples in each block.
/// window : int
///     Running median's window, >= 1 (see :func:`running_median`).
///
/// Returns
/// -------
/// resid : ndarray of float64, shape (n,)
/// sigma : float
///
/// Raises
/// ------
/// ParameterError
///     ``window < 1``, or ``count`` and ``y`` differ in length.
/// ShapeError
///     An input is not 1-D.
#[pyfunction(name = "block_noise")]
#[pyo3(signature = (y, count, /, *, window))]
pub(crate) fn py_block_noise<'py>(
    py: Python<'py>,
    y: &Bound<'py, PyAny>,
    count: PyArrayLike1<'py, i64, AllowTypeChange>,
    window: i64,
) -> PyResult<(Bound<'py, PyArray1<f64>>, f64)> {
    let window = crate::gateway::count("window", window)?;
    let y = array1(y, "y dimensions")?;
    let y = slice_or_copy(&y);
    let counts = slice_or_copy(&count);
    let (resid, sigma) = run_detached(py, || accelcore_core::block_noise(&y, &counts, window))?;
    Ok((resid.into_pyarray(py), sigma))
}

/// Return the samples most blocks of a run hold: the most common of ``count``.
///
/// The smallest of the counts tied for most common (``np.bincount(count).argmax()``);
/// 1 when ``count`` is empty.
///
/// Parameters
/// ----------
/// count : array_like of int64, shape (n,)
///     Raw samples in each block.
///
/// Returns
/// -------
/// int
///
/// Raises
/// ------
/// ShapeError
///     ``count`` is not 1-D.
#[pyfunction(name = "typical_count")]
#[pyo3(signature = (count, /))]
pub(crate) fn py_typical_count(
    py: Python<'_>,
    count: PyArrayLike1<'_, i64, AllowTypeChange>,
) -> PyResult<i64> {
    let counts = slice_or_copy(&count);
    run_detached(py, || Ok(accelcore_core::typical_count(&counts)))
}
