//! `TimeConstantSearch`: a lag's or warm-up's time constant by held-out error.

use accelcore_core::{
    Error, SampleSeries, SearchResult, SearchSettings, TauColumn, TimeConstantSearch, TrialModel,
    WindowLayout,
};
use ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray2, PyArrayLike1};
use pyo3::prelude::*;

use crate::errors::CoreError;
use crate::gateway::{array1, array2, count, run_detached, slice_or_copy};

/// Time-constant searches over one data set: the full-rate ingredients of the
/// columns built from tau (records, samples) and the windows, blocks and folds.
#[pyclass(name = "TimeConstantSearch", module = "accelcore.core")]
pub(crate) struct PyTimeConstantSearch {
    inner: TimeConstantSearch,
}

/// A model's column triples `(kind, index or order, multiplier)` as the core's columns.
type Columns<'py> = Vec<(String, i64, Option<Bound<'py, PyAny>>)>;

#[pymethods]
impl PyTimeConstantSearch {
    #[new]
    #[pyo3(signature = (
        records, gather, elapsed_s, sample_weight, window_start, window_weight,
        window_block, block_fold, /, *, t_ref_c, stride,
    ))]
    fn new(
        py: Python<'_>,
        records: Vec<(Bound<'_, PyAny>, Bound<'_, PyAny>)>,
        gather: &Bound<'_, PyAny>,
        elapsed_s: &Bound<'_, PyAny>,
        sample_weight: &Bound<'_, PyAny>,
        window_start: &Bound<'_, PyAny>,
        window_weight: &Bound<'_, PyAny>,
        window_block: &Bound<'_, PyAny>,
        block_fold: &Bound<'_, PyAny>,
        t_ref_c: f64,
        stride: i64,
    ) -> PyResult<Self> {
        let records = records
            .iter()
            .map(|(t, x)| {
                Ok((
                    array1(t, "record time_s")?,
                    array1(x, "record temperature_c")?,
                ))
            })
            .collect::<PyResult<Vec<_>>>()?;
        let records: Vec<_> = records
            .iter()
            .map(|(t, x)| (slice_or_copy(t), slice_or_copy(x)))
            .collect();
        let gather = indices(gather, "gather")?;
        let elapsed_s = array1(elapsed_s, "elapsed_s dimensions")?;
        let sample_weight = array1(sample_weight, "sample_weight dimensions")?;
        let window_start = indices(window_start, "window_start")?;
        let window_weight = array1(window_weight, "window_weight dimensions")?;
        let window_block = as_u32(&indices(window_block, "window_block")?, "window_block")?;
        let block_fold = as_u32(&indices(block_fold, "block_fold")?, "block_fold")?;
        let (elapsed_s, sample_weight) = (slice_or_copy(&elapsed_s), slice_or_copy(&sample_weight));
        let window_weight = slice_or_copy(&window_weight);
        let stride = count("stride", stride)?;
        let inner = run_detached(py, || {
            TimeConstantSearch::new(
                SampleSeries {
                    records: records.iter().map(|(t, x)| (&**t, &**x)).collect(),
                    gather: &gather,
                    t_ref_c,
                    elapsed_s: &elapsed_s,
                    sample_weight: &sample_weight,
                },
                WindowLayout {
                    start: &window_start,
                    weight: &window_weight,
                    block: &window_block,
                    block_fold: &block_fold,
                    stride,
                },
            )
        })?;
        Ok(Self { inner })
    }

    /// Search tau for one model; return the best tau and every trial `(tau, score)`.
    #[pyo3(signature = (fixed, response, columns, /, *, range_s, grid_points = 10, steps = 8, tol = 5e-3))]
    fn search<'py>(
        &self,
        py: Python<'py>,
        fixed: &Bound<'py, PyAny>,
        response: &Bound<'py, PyAny>,
        columns: Columns<'py>,
        range_s: (f64, f64),
        grid_points: i64,
        steps: i64,
        tol: f64,
    ) -> PyResult<(f64, Bound<'py, PyArray2<f64>>)> {
        let settings = SearchSettings {
            range_s,
            grid_points: count("grid_points", grid_points)?,
            steps: count("steps", steps)?,
            tol,
        };
        let fixed = array2(fixed, "fixed dimensions")?;
        let response = array1(response, "response dimensions")?;
        let response = slice_or_copy(&response);
        let columns = tau_columns(columns)?;
        let fixed = fixed.as_array();
        let inner = &self.inner;
        let found = run_detached(py, || {
            let model = TrialModel {
                fixed,
                response: &response,
                columns: &columns,
            };
            inner.search(&model, &settings)
        })?;
        Ok(found_pair(py, &found))
    }

    /// Search tau for several models on up to `threads` threads, each as `search`
    /// does alone; one `(best tau, trials)` per model, in order.
    #[pyo3(signature = (models, /, *, range_s, grid_points = 10, steps = 8, tol = 5e-3, threads = 1))]
    fn search_many<'py>(
        &self,
        py: Python<'py>,
        models: Vec<(Bound<'py, PyAny>, Bound<'py, PyAny>, Columns<'py>)>,
        range_s: (f64, f64),
        grid_points: i64,
        steps: i64,
        tol: f64,
        threads: i64,
    ) -> PyResult<Vec<(f64, Bound<'py, PyArray2<f64>>)>> {
        let settings = SearchSettings {
            range_s,
            grid_points: count("grid_points", grid_points)?,
            steps: count("steps", steps)?,
            tol,
        };
        let threads = count("threads", threads)?;
        let mut fixed = Vec::with_capacity(models.len());
        let mut responses = Vec::with_capacity(models.len());
        let mut columns = Vec::with_capacity(models.len());
        for (f, r, c) in models {
            fixed.push(array2(&f, "fixed dimensions")?);
            responses.push(array1(&r, "response dimensions")?);
            columns.push(tau_columns(c)?);
        }
        let responses: Vec<_> = responses.iter().map(slice_or_copy).collect();
        let fixed: Vec<_> = fixed.iter().map(|f| f.as_array()).collect();
        let inner = &self.inner;
        let found = run_detached(py, || {
            let models: Vec<TrialModel<'_>> = fixed
                .iter()
                .zip(&responses)
                .zip(&columns)
                .map(|((fixed, response), columns)| TrialModel {
                    fixed: fixed.view(),
                    response,
                    columns,
                })
                .collect();
            inner.search_many(&models, &settings, threads)
        })?;
        Ok(found.iter().map(|f| found_pair(py, f)).collect())
    }

    /// Score of one model at `tau_s` (not rounded).
    #[pyo3(signature = (fixed, response, columns, tau_s, /))]
    fn score<'py>(
        &self,
        py: Python<'py>,
        fixed: &Bound<'py, PyAny>,
        response: &Bound<'py, PyAny>,
        columns: Columns<'py>,
        tau_s: f64,
    ) -> PyResult<f64> {
        let fixed = array2(fixed, "fixed dimensions")?;
        let response = array1(response, "response dimensions")?;
        let response = slice_or_copy(&response);
        let columns = tau_columns(columns)?;
        let fixed = fixed.as_array();
        let inner = &self.inner;
        run_detached(py, || {
            let model = TrialModel {
                fixed,
                response: &response,
                columns: &columns,
            };
            inner.score(&model, tau_s)
        })
    }

    #[getter]
    fn n_rows(&self) -> usize {
        self.inner.n_rows()
    }

    fn __repr__(&self) -> String {
        format!("TimeConstantSearch(n_rows={})", self.inner.n_rows())
    }
}

/// A search's best tau and its trials `(tau, score)` as an `(n_trials, 2)` array.
fn found_pair<'py>(py: Python<'py>, found: &SearchResult) -> (f64, Bound<'py, PyArray2<f64>>) {
    let mut trials = Array2::zeros((found.trials.len(), 2));
    for (i, (tau, score)) in found.trials.iter().enumerate() {
        trials[[i, 0]] = *tau;
        trials[[i, 1]] = *score;
    }
    (found.best_tau_s, trials.into_pyarray(py))
}

/// The core's columns from their Python triples.
fn tau_columns(columns: Columns<'_>) -> PyResult<Vec<TauColumn>> {
    columns
        .into_iter()
        .map(|(kind, k, m)| column(&kind, k, m.as_ref()))
        .collect()
}

/// One column from its `(kind, index or order, multiplier)` triple.
fn column(kind: &str, k: i64, multiplier: Option<&Bound<'_, PyAny>>) -> PyResult<TauColumn> {
    let multiplier = multiplier
        .map(|m| array1(m, "multiplier dimensions").map(|m| slice_or_copy(&m).into_owned()))
        .transpose()?;
    match kind {
        "fixed" if multiplier.is_none() => Ok(TauColumn::Fixed(count("columns", k)?)),
        "lag" => Ok(TauColumn::LagPower {
            order: u32::try_from(k).map_err(|_| invalid("order", format!("{k} is not >= 0")))?,
            multiplier,
        }),
        "decay" => Ok(TauColumn::Decay { multiplier }),
        _ => Err(invalid(
            "columns",
            format!(
                "{kind:?} is not a column kind (\"fixed\" without a multiplier, \"lag\", \"decay\")"
            ),
        )),
    }
}

/// Indices as usize, refusing negative values.
fn indices(obj: &Bound<'_, PyAny>, name: &'static str) -> PyResult<Vec<usize>> {
    let arr = obj.extract::<PyArrayLike1<'_, i64, AllowTypeChange>>()?;
    arr.as_array()
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            usize::try_from(v).map_err(|_| invalid(name, format!("row {i}: {v} is not an index")))
        })
        .collect()
}

/// Indices as u32 (blocks and folds), refusing values of 2^32 or more.
fn as_u32(values: &[usize], name: &'static str) -> PyResult<Vec<u32>> {
    values
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            u32::try_from(v).map_err(|_| invalid(name, format!("row {i}: {v} is not below 2^32")))
        })
        .collect()
}

fn invalid(name: &'static str, reason: String) -> PyErr {
    CoreError(Error::InvalidParameter { name, reason }).into()
}
