//! The statistics that accept or reject a term: survival functions, the paired test,
//! multiple-testing adjustment and the acceptance rule (`accelcore_core::stats`).

use accelcore_core::stats;
use numpy::{IntoPyArray, PyArray1};
use pyo3::prelude::*;

use crate::gateway::{array1, count, run_detached, slice_or_copy};

/// Survival function of the chi-square distribution, ``P(X > x)`` with ``dof``
/// degrees of freedom (need not be an integer).
///
/// 1 for ``x <= 0`` and for ``dof <= 0`` (nothing tested); 0 for ``x = inf``; NaN for
/// a NaN argument or an infinite ``dof``.
#[pyfunction(name = "chi2_sf")]
#[pyo3(signature = (x, /, *, dof))]
pub(crate) fn py_chi2_sf(x: f64, dof: f64) -> f64 {
    stats::chi2_sf(x, dof)
}

/// One-sided upper tail of Student's t, ``P(T > t)`` with ``dof`` degrees of freedom.
///
/// 0.5 at ``t = 0``; ``t_sf(-t) = 1 - t_sf(t)``. NaN for a NaN argument, ``dof <= 0``
/// or an infinite ``dof``.
#[pyfunction(name = "t_sf")]
#[pyo3(signature = (t, /, *, dof))]
pub(crate) fn py_t_sf(t: f64, dof: f64) -> f64 {
    stats::t_sf(t, dof)
}

/// Survival function of Fisher's F, ``P(F > f)`` with ``dfn`` and ``dfd`` degrees of
/// freedom: the p-value of a nested-model F test.
///
/// 1 for ``f <= 0``, 0 for ``f = inf``; NaN for a NaN argument or degrees of freedom
/// that are not positive and finite.
#[pyfunction(name = "f_sf")]
#[pyo3(signature = (f, /, *, dfn, dfd))]
pub(crate) fn py_f_sf(f: f64, dfn: f64, dfd: f64) -> f64 {
    stats::f_sf(f, dfn, dfd)
}

/// Result of :func:`paired_test`: Student's ``t``, its one-sided p-value ``p`` and the
/// number of differences ``n``.
#[pyclass(name = "PairedTest", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyPairedTest {
    t: f64,
    p: f64,
    n: usize,
}

#[pymethods]
impl PyPairedTest {
    fn __repr__(&self) -> String {
        format!(
            "PairedTest(t={:.6}, p={:.6e}, n={})",
            self.t, self.p, self.n
        )
    }
}

/// One-sided paired t-test that the mean of ``diff`` is positive.
///
/// ``t = mean / (sd / sqrt(n))`` (sample sd), ``p = t_sf(t, dof=n - 1)``. Fewer than two
/// differences: ``t = nan``, ``p = 1``. A NaN or infinite difference: ``t = p = nan``.
/// Every difference equal: ``t = inf``, ``p = 0`` when positive, else ``t = 0``, ``p = 1``.
#[pyfunction(name = "paired_test")]
#[pyo3(signature = (diff, /))]
pub(crate) fn py_paired_test(py: Python<'_>, diff: &Bound<'_, PyAny>) -> PyResult<PyPairedTest> {
    let diff = array1(diff, "diff dimensions")?;
    let diff = slice_or_copy(&diff);
    let test = run_detached(py, || Ok(stats::paired_test(&diff)))?;
    Ok(PyPairedTest {
        t: test.t,
        p: test.p,
        n: test.n,
    })
}

fn n_tests_of(n_tests: Option<i64>) -> PyResult<Option<usize>> {
    n_tests.map(|m| count("n_tests", m)).transpose()
}

/// Bonferroni-adjusted p-values ``min(1, m p)`` over ``m = n_tests`` tests (default: as
/// many as ``p``). NaN stays NaN.
#[pyfunction(name = "bonferroni")]
#[pyo3(signature = (p, /, *, n_tests = None))]
pub(crate) fn py_bonferroni<'py>(
    py: Python<'py>,
    p: &Bound<'py, PyAny>,
    n_tests: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n_tests = n_tests_of(n_tests)?;
    let p = array1(p, "p dimensions")?;
    let p = slice_or_copy(&p);
    Ok(run_detached(py, || stats::bonferroni(&p, n_tests))?.into_pyarray(py))
}

/// Holm's step-down adjusted p-values over ``m = n_tests`` tests, in the order given.
#[pyfunction(name = "holm")]
#[pyo3(signature = (p, /, *, n_tests = None))]
pub(crate) fn py_holm<'py>(
    py: Python<'py>,
    p: &Bound<'py, PyAny>,
    n_tests: Option<i64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let n_tests = n_tests_of(n_tests)?;
    let p = array1(p, "p dimensions")?;
    let p = slice_or_copy(&p);
    Ok(run_detached(py, || stats::holm(&p, n_tests))?.into_pyarray(py))
}

/// The verdict of an :class:`AcceptanceRule` and its figures.
#[pyclass(name = "Acceptance", module = "accelcore.core", frozen, get_all)]
pub(crate) struct PyAcceptance {
    accepted: bool,
    cut: f64,
    t: f64,
    p: f64,
    p_sum: f64,
    p_log: f64,
    p_sign: f64,
    n: usize,
}

#[pymethods]
impl PyAcceptance {
    fn __repr__(&self) -> String {
        format!(
            "Acceptance(accepted={}, cut={:.6}, t={:.6}, p={:.6e}, p_sum={:.6e}, p_log={:.6e}, \
             p_sign={:.6e}, n={})",
            if self.accepted { "True" } else { "False" },
            self.cut,
            self.t,
            self.p,
            self.p_sum,
            self.p_log,
            self.p_sign,
            self.n
        )
    }
}

/// When the diagnosis adds a term to an axis: the held-out RMS error falls by at least
/// ``min_improvement`` and the paired one-sided test over blocks (the change of squared
/// error, its log ratio and its sign, Bonferroni-combined) gives ``p < alpha``.
#[pyclass(name = "AcceptanceRule", module = "accelcore.core", frozen)]
pub(crate) struct PyAcceptanceRule {
    inner: stats::AcceptanceRule,
}

#[pymethods]
impl PyAcceptanceRule {
    #[new]
    #[pyo3(signature = (*, min_improvement, alpha))]
    fn new(min_improvement: f64, alpha: f64) -> PyResult<Self> {
        let inner =
            stats::AcceptanceRule::new(min_improvement, alpha).map_err(crate::errors::CoreError)?;
        Ok(Self { inner })
    }

    #[getter]
    fn min_improvement(&self) -> f64 {
        self.inner.min_improvement()
    }

    #[getter]
    fn alpha(&self) -> f64 {
        self.inner.alpha()
    }

    /// Judge a candidate from the held-out squared error per block, before and after.
    #[pyo3(signature = (current_sse, candidate_sse, /))]
    fn judge(
        &self,
        py: Python<'_>,
        current_sse: &Bound<'_, PyAny>,
        candidate_sse: &Bound<'_, PyAny>,
    ) -> PyResult<PyAcceptance> {
        let current = array1(current_sse, "current_sse dimensions")?;
        let candidate = array1(candidate_sse, "candidate_sse dimensions")?;
        let (current, candidate) = (slice_or_copy(&current), slice_or_copy(&candidate));
        let rule = self.inner;
        let v = run_detached(py, || rule.judge(&current, &candidate))?;
        Ok(PyAcceptance {
            accepted: v.accepted,
            cut: v.cut,
            t: v.t,
            p: v.p,
            p_sum: v.p_sum,
            p_log: v.p_log,
            p_sign: v.p_sign,
            n: v.n,
        })
    }

    fn __repr__(&self) -> String {
        format!(
            "AcceptanceRule(min_improvement={}, alpha={})",
            self.inner.min_improvement(),
            self.inner.alpha()
        )
    }
}
