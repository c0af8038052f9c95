//! `BlockedLeastSquares`, its folds `FoldedLeastSquares`, and their result, `HeldOutFit`.

use accelcore_core::{BlockedLeastSquares, Error, FoldedLeastSquares, HeldOutFit};
use ndarray::Array2;
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyUntypedArrayMethods,
};
use pyo3::prelude::*;

use crate::errors::CoreError;
use crate::gateway::{array1, array2, count, run_detached, slice_or_copy};

/// Per-block least-squares factors; held-out error of any folds by merging them.
#[pyclass(name = "BlockedLeastSquares", module = "accelcore.core")]
pub(crate) struct PyBlockedLeastSquares {
    inner: BlockedLeastSquares,
}

/// The factors of a `BlockedLeastSquares` for one fold assignment; any subset of
/// its columns cross-validated without visiting a row.
#[pyclass(name = "FoldedLeastSquares", module = "accelcore.core", frozen)]
pub(crate) struct PyFoldedLeastSquares {
    inner: FoldedLeastSquares,
}

/// In-sample and held-out fits for one fold assignment.
#[pyclass(name = "HeldOutFit", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyHeldOutFit {
    coefficients: Py<PyArray1<f64>>,
    not_identified: Vec<usize>,
    in_sample_rss: f64,
    heldout_rss: f64,
    fold_coefficients: Py<PyArray2<f64>>,
    heldout_rss_per_block: Py<PyArray1<f64>>,
    rows_per_block: Py<PyArray1<u64>>,
}

fn fit_to_py(py: Python<'_>, fit: HeldOutFit, p: usize) -> PyResult<PyHeldOutFit> {
    let n_folds = fit.fold_coefficients.len();
    let mut folds = Array2::from_elem((n_folds, p), f64::NAN);
    for (k, beta) in fit.fold_coefficients.iter().enumerate() {
        for (j, &b) in beta.iter().enumerate() {
            folds[[k, j]] = b;
        }
    }
    let heldout_rss = fit.heldout_rss();
    Ok(PyHeldOutFit {
        coefficients: fit.coefficients.into_pyarray(py).unbind(),
        not_identified: fit.not_identified,
        in_sample_rss: fit.in_sample_rss,
        heldout_rss,
        fold_coefficients: folds.into_pyarray(py).unbind(),
        heldout_rss_per_block: fit.heldout_rss_per_block.into_pyarray(py).unbind(),
        rows_per_block: fit.rows_per_block.into_pyarray(py).unbind(),
    })
}

/// Indices (blocks or folds) as u32, refusing negative or too large values.
fn indices(obj: &Bound<'_, PyAny>, name: &'static str) -> PyResult<Vec<u32>> {
    let arr = obj.extract::<PyArrayLike1<'_, i64, AllowTypeChange>>()?;
    let mut out = Vec::with_capacity(arr.len());
    for (i, &v) in arr.as_array().iter().enumerate() {
        let ok = u32::try_from(v).map_err(|_| {
            CoreError(Error::InvalidParameter {
                name,
                reason: format!("row {i}: {v} is not an index in 0..2^32"),
            })
        })?;
        out.push(ok);
    }
    Ok(out)
}

/// Column indices (`None`: every column, in order).
fn columns(obj: Option<&Bound<'_, PyAny>>, n_columns: usize) -> PyResult<Vec<usize>> {
    match obj {
        None => Ok((0..n_columns).collect()),
        Some(obj) => Ok(indices(obj, "columns")?
            .into_iter()
            .map(|j| j as usize)
            .collect()),
    }
}

#[pymethods]
impl PyFoldedLeastSquares {
    /// In-sample fit and held-out error of every block, for the columns `columns`
    /// (in that order; default all) and response `response`.
    #[pyo3(signature = (columns = None, *, response = 0))]
    fn cross_validate(
        &self,
        py: Python<'_>,
        columns: Option<&Bound<'_, PyAny>>,
        response: i64,
    ) -> PyResult<PyHeldOutFit> {
        let columns = self::columns(columns, self.inner.n_columns())?;
        let response = count("response", response)?;
        let inner = &self.inner;
        let fit = run_detached(py, || inner.cross_validate(&columns, response))?;
        fit_to_py(py, fit, columns.len())
    }

    #[getter]
    fn n_columns(&self) -> usize {
        self.inner.n_columns()
    }

    #[getter]
    fn n_folds(&self) -> usize {
        self.inner.n_folds()
    }

    fn __repr__(&self) -> String {
        format!(
            "FoldedLeastSquares(n_columns={}, n_folds={})",
            self.inner.n_columns(),
            self.inner.n_folds()
        )
    }
}

#[pymethods]
impl PyHeldOutFit {
    fn __repr__(&self, py: Python<'_>) -> String {
        format!(
            "HeldOutFit(n_folds={}, in_sample_rss={:.6e}, heldout_rss={:.6e}, not_identified={:?})",
            self.fold_coefficients.bind(py).shape()[0],
            self.in_sample_rss,
            self.heldout_rss,
            self.not_identified
        )
    }
}

#[pymethods]
impl PyBlockedLeastSquares {
    #[new]
    #[pyo3(signature = (n_columns, n_blocks, *, n_responses = 1))]
    fn new(n_columns: i64, n_blocks: i64, n_responses: i64) -> PyResult<Self> {
        let n_columns = count("n_columns", n_columns)?;
        let n_blocks = count("n_blocks", n_blocks)?;
        let n_responses = count("n_responses", n_responses)?;
        let inner = BlockedLeastSquares::with_responses(n_columns, n_responses, n_blocks)
            .map_err(CoreError)?;
        Ok(Self { inner })
    }

    /// Push rows with their responses (n) or (n, n_responses), optional weights and blocks.
    #[pyo3(signature = (design, response, block, weights = None))]
    fn push(
        &mut self,
        py: Python<'_>,
        design: &Bound<'_, PyAny>,
        response: &Bound<'_, PyAny>,
        block: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let design = array2(design, "design dimensions")?;
        let block = indices(block, "block")?;
        let weights = weights
            .map(|w| array1(w, "weights dimensions"))
            .transpose()?;
        let weights = weights.as_ref().map(slice_or_copy);
        let design = design.as_array();
        let inner = &mut self.inner;
        if response
            .getattr("ndim")
            .and_then(|n| n.extract::<usize>())
            .ok()
            == Some(2)
        {
            let responses = array2(response, "response dimensions")?;
            let responses = responses.as_array();
            return run_detached(py, || {
                inner.push_multi(design, responses, weights.as_deref(), &block)
            });
        }
        let response = array1(response, "response dimensions")?;
        let response = slice_or_copy(&response);
        run_detached(py, || {
            inner.push(design, &response, weights.as_deref(), &block)
        })
    }

    /// Merge another accumulator of the same shape, block by block.
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyBlockedLeastSquares>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// Fix a fold assignment: the per-fold training factors, merged once.
    fn folds(
        &self,
        py: Python<'_>,
        block_fold: &Bound<'_, PyAny>,
    ) -> PyResult<PyFoldedLeastSquares> {
        let block_fold = indices(block_fold, "block_fold")?;
        let inner = &self.inner;
        let folded = run_detached(py, || inner.folds(&block_fold))?;
        Ok(PyFoldedLeastSquares { inner: folded })
    }

    /// In-sample fit and held-out error of every block for a fold assignment,
    /// for the columns `columns` (default all) and response `response`.
    #[pyo3(signature = (block_fold, *, columns = None, response = 0))]
    fn cross_validate(
        &self,
        py: Python<'_>,
        block_fold: &Bound<'_, PyAny>,
        columns: Option<&Bound<'_, PyAny>>,
        response: i64,
    ) -> PyResult<PyHeldOutFit> {
        let block_fold = indices(block_fold, "block_fold")?;
        let columns = self::columns(columns, self.inner.n_columns())?;
        let response = count("response", response)?;
        let inner = &self.inner;
        let fit = run_detached(py, || {
            inner.folds(&block_fold)?.cross_validate(&columns, response)
        })?;
        fit_to_py(py, fit, columns.len())
    }

    #[getter]
    fn n_columns(&self) -> usize {
        self.inner.n_columns()
    }

    #[getter]
    fn n_responses(&self) -> usize {
        self.inner.n_responses()
    }

    #[getter]
    fn n_blocks(&self) -> usize {
        self.inner.n_blocks()
    }

    fn __repr__(&self) -> String {
        format!(
            "BlockedLeastSquares(n_columns={}, n_blocks={}, n_responses={})",
            self.inner.n_columns(),
            self.inner.n_blocks(),
            self.inner.n_responses()
        )
    }
}
