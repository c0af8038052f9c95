//! `LeastSquares` and its result, `LstsqSolution`.

use accelcore_core::{LeastSquares, LstsqSolution};
use ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;

use crate::gateway::{array1, array2, count, run_detached, slice_or_copy};

/// Incremental weighted least squares (see `accelcore.core.LeastSquares` in the stubs).
#[pyclass(name = "LeastSquares", module = "accelcore.core")]
pub(crate) struct PyLeastSquares {
    pub(crate) inner: LeastSquares,
}

/// Solution of a least-squares problem.
#[pyclass(name = "LstsqSolution", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyLstsqSolution {
    column_names: Vec<String>,
    coefficients: Py<PyArray1<f64>>,
    covariance: Py<PyArray2<f64>>,
    residual_sum_squares: f64,
    dof: u64,
    n_rows: u64,
    condition_number: f64,
    condition_number_scaled: f64,
}

pub(crate) fn solution_to_py(py: Python<'_>, s: LstsqSolution) -> PyResult<PyLstsqSolution> {
    let p = s.coefficients.len();
    let covariance = Array2::from_shape_vec((p, p), s.covariance)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))?;
    Ok(PyLstsqSolution {
        column_names: s.column_names,
        coefficients: s.coefficients.into_pyarray(py).unbind(),
        covariance: covariance.into_pyarray(py).unbind(),
        residual_sum_squares: s.residual_sum_squares,
        dof: s.dof,
        n_rows: s.n_rows,
        condition_number: s.condition_number,
        condition_number_scaled: s.condition_number_scaled,
    })
}

#[pymethods]
impl PyLstsqSolution {
    fn __repr__(&self) -> String {
        format!(
            "LstsqSolution(columns={:?}, n_rows={}, dof={}, rss={:.6e}, cond={:.3e})",
            self.column_names,
            self.n_rows,
            self.dof,
            self.residual_sum_squares,
            self.condition_number
        )
    }
}

#[pymethods]
impl PyLeastSquares {
    #[new]
    #[pyo3(signature = (n_columns, *, column_names = None, n_responses = 1))]
    fn new(n_columns: i64, column_names: Option<Vec<String>>, n_responses: i64) -> PyResult<Self> {
        let n_columns = count("n_columns", n_columns)?;
        let n_responses = count("n_responses", n_responses)?;
        let inner = LeastSquares::with_responses(n_columns, n_responses, column_names)
            .map_err(crate::errors::CoreError)?;
        Ok(Self { inner })
    }

    /// Push rows of the design with their responses, (n) or, with several,
    /// (n, n_responses), and optional weights.
    #[pyo3(signature = (design, response, weights = None))]
    fn push(
        &mut self,
        py: Python<'_>,
        design: &Bound<'_, PyAny>,
        response: &Bound<'_, PyAny>,
        weights: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let design = array2(design, "design dimensions")?;
        let weights = weights
            .map(|w| array1(w, "weights dimensions"))
            .transpose()?;
        let weights = weights.as_ref().map(slice_or_copy);
        let design = design.as_array();
        let inner = &mut self.inner;
        if inner.n_responses() > 1 {
            // (n, n_responses); with one response, (n) only.
            let responses = array2(response, "response dimensions")?;
            let responses = responses.as_array();
            return run_detached(py, || {
                inner.push_multi(design, responses, weights.as_deref())
            });
        }
        let response = array1(response, "response dimensions")?;
        let response = slice_or_copy(&response);
        run_detached(py, || inner.push(design, &response, weights.as_deref()))
    }

    /// Push the rows of `source` through a map of its columns (see the stubs).
    #[pyo3(signature = (source, map, responses = None, shift = None))]
    fn push_mapped(
        &mut self,
        py: Python<'_>,
        source: PyRef<'_, PyLeastSquares>,
        map: &Bound<'_, PyAny>,
        responses: Option<Vec<i64>>,
        shift: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let map = array2(map, "map dimensions")?;
        let shift = shift.map(|s| array2(s, "shift dimensions")).transpose()?;
        let responses = match responses {
            None => (0..self.inner.n_responses()).collect(),
            Some(list) => list
                .into_iter()
                .map(|r| count("responses", r))
                .collect::<PyResult<Vec<usize>>>()?,
        };
        let map = map.as_array();
        let shift = shift.as_ref().map(|s| s.as_array());
        let source = &source.inner;
        let inner = &mut self.inner;
        run_detached(py, || inner.push_mapped(source, map, &responses, shift))
    }

    /// Merge another problem with the same columns.
    fn merge(&mut self, py: Python<'_>, other: PyRef<'_, PyLeastSquares>) -> PyResult<()> {
        let other = other.inner.clone();
        let inner = &mut self.inner;
        run_detached(py, || inner.merge(&other))
    }

    /// Solve (for response `response` of several).
    #[pyo3(signature = (response = 0))]
    fn finish(&self, py: Python<'_>, response: i64) -> PyResult<PyLstsqSolution> {
        let response = count("response", response)?;
        let inner = &self.inner;
        let solution = run_detached(py, || inner.finish_response(response))?;
        solution_to_py(py, solution)
    }

    #[getter]
    fn n_columns(&self) -> usize {
        self.inner.n_columns()
    }

    #[getter]
    fn n_rows(&self) -> u64 {
        self.inner.n_rows()
    }

    #[getter]
    fn n_responses(&self) -> usize {
        self.inner.n_responses()
    }

    fn __repr__(&self) -> String {
        format!(
            "LeastSquares(n_columns={}, n_rows={})",
            self.inner.n_columns(),
            self.inner.n_rows()
        )
    }
}
