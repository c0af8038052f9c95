//! The statistics that accept or reject a term of the diagnosis.
//!
//! - Survival functions (upper tails): [`chi2_sf`] (the generic structure check and the
//!   step search), [`t_sf`] (one-sided Student t: the paired test and the run-level
//!   test), [`f_sf`] (Fisher's F, for nested-model F tests).
//! - [`paired_test`]: the one-sided paired t-test that the mean of a vector of
//!   differences is positive; [`sign_test`]: the one-sided exact sign test that a
//!   difference is more often positive than not.
//! - [`bonferroni`] and [`holm`]: p-values adjusted for multiple testing, over the
//!   p-values given or over a larger number of tests of which only the smallest p-values
//!   were computed.
//! - [`AcceptanceRule`]: the diagnosis' rule for adding a term to an axis, from the
//!   per-block held-out squared error before and after.
//!
//! The special functions beneath ([`ln_gamma`], [`gamma_p`], [`gamma_q`], [`beta_inc`])
//! are written here, with no dependency; see their module for the methods and their
//! accuracy (about 1e-13 relative in either tail, down to the smallest normal double).
//! `accelcore.reference.stats` is the same specification written plainly in Python.
//!
//! Conventions (named tests in Rust and Python check each): NaN in, NaN out; a
//! chi-square with no degrees of freedom (`dof <= 0`) gives p = 1 (nothing was tested,
//! so no evidence); a t or F with `dof <= 0` or an infinite `dof` gives NaN.
//!
//! # Example
//!
//! ```
//! use accelcore_core::stats::{chi2_sf, paired_test, t_sf, AcceptanceRule};
//!
//! assert!((chi2_sf(3.841_458_820_694_124, 1.0) - 0.05).abs() < 1e-15);
//! assert!((t_sf(2.0, 10.0) - 0.036_694_017_385_370_18).abs() < 1e-15);
//! let test = paired_test(&[1.0, 2.0, 3.0]);
//! assert!((test.t - 2.0 * 3f64.sqrt()).abs() < 1e-14 && test.n == 3);
//! let rule = AcceptanceRule::new(0.10, 0.01)?;
//! let verdict = rule.judge(&[4.0, 5.0, 4.5, 5.5, 4.8], &[1.0, 1.2, 0.9, 1.1, 1.0])?;
//! assert!(verdict.accepted && verdict.cut > 0.5 && verdict.p < 0.01);
//! # Ok::<(), accelcore_core::Error>(())
//! ```

mod special;

pub use special::{beta_inc, gamma_p, gamma_q, ln_gamma};

use std::cmp::Ordering;

use crate::error::{Error, Result};
use special::{beta_pair, BetaArg};

/// Survival function of the chi-square distribution, `P(X > x)` for `dof` degrees of
/// freedom (`Q(dof/2, x/2)`; `dof` need not be an integer).
///
/// 1 for `x <= 0` and for `dof <= 0` (nothing tested); 0 for `x = +inf`; NaN for a NaN
/// argument or an infinite `dof`.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    if x.is_nan() || dof.is_nan() || dof.is_infinite() {
        return f64::NAN;
    }
    if dof <= 0.0 || x <= 0.0 {
        return 1.0;
    }
    gamma_q(0.5 * dof, 0.5 * x)
}

/// One-sided upper tail of Student's t with `dof` degrees of freedom, `P(T > t)`.
///
/// `t_sf(-t) = 1 - t_sf(t)`, each computed without cancellation; 0.5 at `t = 0`, 0 at
/// `+inf`, 1 at `-inf`. NaN for a NaN argument, `dof <= 0` or an infinite `dof`.
pub fn t_sf(t: f64, dof: f64) -> f64 {
    if t.is_nan() || !valid_dof(dof) {
        return f64::NAN;
    }
    if t == 0.0 {
        return 0.5;
    }
    if t.is_infinite() {
        return if t > 0.0 { 0.0 } else { 1.0 };
    }
    // P(|T| > |t|) = I_x(dof/2, 1/2) with x = dof / (dof + t²): the ratio r = t² / dof.
    let at = t.abs();
    let sq = at * at;
    let r = if sq.is_finite() {
        sq / dof
    } else {
        (at / dof.sqrt()).powi(2)
    };
    let ln_r = if r > 0.0 && r.is_finite() {
        r.ln()
    } else {
        2.0 * (at.ln() - 0.5 * dof.ln())
    };
    // u = x / x0 - 1 = (1 - t²) / (dof + t²).
    let u = if sq.is_finite() {
        (1.0 - at) * (1.0 + at) / (dof + sq)
    } else {
        -1.0
    };
    let (a, b) = (0.5 * dof, 0.5);
    let (both, rest) = beta_pair(a, b, &BetaArg::from_ratio(a, b, r, ln_r, u));
    if t > 0.0 {
        0.5 * both
    } else {
        0.5f64.mul_add(rest, 0.5)
    }
}

/// Survival function of Fisher's F with `dfn` (numerator) and `dfd` (denominator)
/// degrees of freedom, `P(F > f)`: the p-value of a nested-model F test.
///
/// 1 for `f <= 0`, 0 for `f = +inf`; NaN for a NaN argument or a `dfn` or `dfd` that is
/// not positive and finite.
pub fn f_sf(f: f64, dfn: f64, dfd: f64) -> f64 {
    if f.is_nan() || !valid_dof(dfn) || !valid_dof(dfd) {
        return f64::NAN;
    }
    if f <= 0.0 {
        return 1.0;
    }
    if f.is_infinite() {
        return 0.0;
    }
    // P(F > f) = I_x(dfd/2, dfn/2) with x = dfd / (dfd + dfn f): the ratio r = dfn f / dfd.
    let r = dfn * f / dfd;
    let ln_r = if r > 0.0 && r.is_finite() {
        r.ln()
    } else {
        dfn.ln() + f.ln() - dfd.ln()
    };
    // u = x / x0 - 1 = dfn (1 - f) / (dfd + dfn f).
    let u = (1.0 - f) / (dfd / dfn + f);
    let (a, b) = (0.5 * dfd, 0.5 * dfn);
    beta_pair(a, b, &BetaArg::from_ratio(a, b, r, ln_r, u)).0
}

fn valid_dof(dof: f64) -> bool {
    dof > 0.0 && dof.is_finite()
}

/// Result of [`paired_test`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairedTest {
    /// Student's t of the mean difference, `mean / (sd / sqrt(n))`.
    pub t: f64,
    /// One-sided p-value that the mean is positive, `P(T > t)` with `n - 1` dof.
    pub p: f64,
    /// Number of differences.
    pub n: usize,
}

/// One-sided paired t-test that the mean of `diff` is positive.
///
/// `t = mean / (sd / sqrt(n))` with the sample standard deviation (`n - 1` in the
/// denominator) and `p = t_sf(t, n - 1)`. Conventions:
///
/// - fewer than two differences: `t = NaN`, `p = 1` (nothing to test);
/// - a NaN or infinite difference: `t = NaN`, `p = NaN` (a comparison that fails);
/// - every difference equal (zero variance): `t = +inf`, `p = 0` when they are
///   positive, else `t = 0`, `p = 1`.
///
/// The differences are divided by their largest magnitude first (`t` does not change),
/// so that squares neither overflow nor underflow.
pub fn paired_test(diff: &[f64]) -> PairedTest {
    let n = diff.len();
    if n < 2 {
        return PairedTest {
            t: f64::NAN,
            p: 1.0,
            n,
        };
    }
    if diff.iter().any(|d| !d.is_finite()) {
        return PairedTest {
            t: f64::NAN,
            p: f64::NAN,
            n,
        };
    }
    let first = diff[0];
    if diff.iter().all(|&d| d == first) {
        let (t, p) = if first > 0.0 {
            (f64::INFINITY, 0.0)
        } else {
            (0.0, 1.0)
        };
        return PairedTest { t, p, n };
    }
    let scale = diff.iter().fold(0.0f64, |m, d| m.max(d.abs()));
    let count = n as f64;
    let mean = diff.iter().map(|d| d / scale).sum::<f64>() / count;
    let ss: f64 = diff.iter().map(|d| (d / scale - mean).powi(2)).sum();
    let sd = (ss / (count - 1.0)).sqrt();
    let t = mean / (sd / count.sqrt());
    PairedTest {
        t,
        p: t_sf(t, count - 1.0),
        n,
    }
}

/// Check p-values (in [0, 1] or NaN) and the number of tests (at least as many).
fn tests_of(p: &[f64], n_tests: Option<usize>) -> Result<f64> {
    if let Some((i, v)) = p.iter().enumerate().find(|(_, v)| **v < 0.0 || **v > 1.0) {
        return Err(Error::InvalidParameter {
            name: "p",
            reason: format!("p-value {v} at index {i} is outside [0, 1]"),
        });
    }
    let m = n_tests.unwrap_or(p.len());
    if m < p.len() {
        return Err(Error::InvalidParameter {
            name: "n_tests",
            reason: format!("{m} tests cannot hold {} p-values", p.len()),
        });
    }
    Ok(m as f64)
}

/// Bonferroni-adjusted p-values, `min(1, m p)` for `m` tests.
///
/// `m` is `n_tests` when given (it must be at least `p.len()`: the p-values of the
/// other tests were not computed), else `p.len()`. A NaN p-value stays NaN.
///
/// # Errors
///
/// [`Error::InvalidParameter`] for a p-value outside [0, 1] or `n_tests < p.len()`.
pub fn bonferroni(p: &[f64], n_tests: Option<usize>) -> Result<Vec<f64>> {
    let m = tests_of(p, n_tests)?;
    Ok(p.iter()
        .map(|&v| if v.is_nan() { v } else { (v * m).min(1.0) })
        .collect())
}

/// Holm's step-down adjusted p-values for `m` tests, in the order given.
///
/// With the p-values sorted increasing, the `k`-th (from 0) is adjusted to
/// `max_{j <= k} min(1, (m - j) p_(j))`; a hypothesis is rejected at level `alpha`
/// when its adjusted p-value is below `alpha`. Never larger than [`bonferroni`]; ties
/// get equal values. `m` is `n_tests` when given (the untested hypotheses rank after
/// every given one), else `p.len()`. A NaN p-value stays NaN and ranks last.
///
/// # Errors
///
/// [`Error::InvalidParameter`] for a p-value outside [0, 1] or `n_tests < p.len()`.
pub fn holm(p: &[f64], n_tests: Option<usize>) -> Result<Vec<f64>> {
    let m = tests_of(p, n_tests)?;
    let mut order: Vec<usize> = (0..p.len()).filter(|&i| !p[i].is_nan()).collect();
    order.sort_by(|&i, &j| p[i].partial_cmp(&p[j]).unwrap_or(Ordering::Equal));
    let mut out = vec![f64::NAN; p.len()];
    let mut running = 0.0f64;
    for (rank, &i) in order.iter().enumerate() {
        running = running.max(((m - rank as f64) * p[i]).min(1.0));
        out[i] = running;
    }
    Ok(out)
}

/// One-sided exact sign test that the differences are more often positive than not.
///
/// `P(K >= k)` for `K ~ Binomial(n, 1/2)`, where `n` counts the non-zero differences and
/// `k` the positive ones (a zero is no evidence either way). No difference gives 1; a
/// NaN anywhere gives NaN. Exact: the binomial tail summed in log space.
///
/// ```
/// use accelcore_core::stats::sign_test;
/// assert_eq!(sign_test(&[1.0; 9]), 0.5_f64.powi(9));
/// assert_eq!(sign_test(&[1.0, -1.0]), 0.75);
/// assert_eq!(sign_test(&[0.0, 0.0]), 1.0);
/// ```
pub fn sign_test(diff: &[f64]) -> f64 {
    if diff.iter().any(|d| d.is_nan()) {
        return f64::NAN;
    }
    let n = diff.iter().filter(|d| **d != 0.0).count();
    let k = diff.iter().filter(|d| **d > 0.0).count();
    if n == 0 {
        return 1.0;
    }
    // P(K = j) = C(n, j) / 2^n, summed from j = k to n. Up to n = 1000 the binomial
    // coefficients and 2^n are finite doubles (C(n, j) exact below 2^53); beyond, in
    // log space.
    if n <= 1000 {
        let mut c = 1.0_f64; // C(n, j), from j = 0
        let mut tail = 0.0;
        for j in 0..=n {
            if j >= k {
                tail += c;
            }
            c = c * (n - j) as f64 / (j + 1) as f64;
        }
        return (tail / 2f64.powi(n as i32)).min(1.0);
    }
    let ln_half_n = n as f64 * std::f64::consts::LN_2;
    let ln_choose = |j: usize| {
        ln_gamma(n as f64 + 1.0) - ln_gamma(j as f64 + 1.0) - ln_gamma((n - j) as f64 + 1.0)
    };
    let tail: f64 = (k..=n).map(|j| (ln_choose(j) - ln_half_n).exp()).sum();
    tail.min(1.0)
}

/// When the diagnosis adds a term to an axis: the held-out RMS error falls by at least
/// `min_improvement` (a fraction) *and* the paired one-sided test over the held-out
/// blocks is significant at `alpha`. That test is three paired tests, Bonferroni-combined
/// (`p = min(1, 3 min(p_sum, p_log, p_sign))`): t-tests on the per-block change of
/// held-out squared error (blocks weigh by their error: the test of the total) and on its
/// log ratio (every block alike: a cut that holds on most blocks while a few dominate
/// the total), and the exact sign test of the change (how many blocks it cuts at all,
/// whatever by: a curvature that cuts the two coldest of nine blocks of a heating sweep
/// 100-fold and every other a little gives t-tests of p 0.04 on both, and a sign test
/// of 2^-9).
///
/// The tested hypotheses are not adjusted for the number of candidates compared:
/// `min_improvement` is the guard against picking a lucky one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcceptanceRule {
    min_improvement: f64,
    alpha: f64,
}

/// The verdict of an [`AcceptanceRule`] and its figures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Acceptance {
    /// The term is added.
    pub accepted: bool,
    /// Fraction of the held-out RMS error cut, `1 - sqrt(Σ candidate / Σ current)`
    /// (0 when the current error is not positive; negative when the candidate is worse).
    pub cut: f64,
    /// Student's t of the paired test on `current - candidate` per block.
    pub t: f64,
    /// The rule's one-sided p-value: the three paired tests (`p_sum`, `p_log`,
    /// `p_sign`) Bonferroni-combined, `min(1, 3 min(p_sum, p_log, p_sign))`; NaN when
    /// `p_sum` is.
    pub p: f64,
    /// One-sided p-value of the paired test on `current - candidate` (the total).
    pub p_sum: f64,
    /// One-sided p-value of the paired test on `ln(current / candidate)` over the
    /// blocks where both are positive (every block alike).
    pub p_log: f64,
    /// One-sided p-value of the exact sign test on `current - candidate`
    /// ([`sign_test`]).
    pub p_sign: f64,
    /// Blocks compared.
    pub n: usize,
}

impl AcceptanceRule {
    /// A rule; `0 <= min_improvement < 1` and `0 < alpha < 1`.
    ///
    /// # Errors
    ///
    /// [`Error::InvalidParameter`] naming the value out of range.
    pub fn new(min_improvement: f64, alpha: f64) -> Result<Self> {
        if !(0.0..1.0).contains(&min_improvement) {
            return Err(Error::InvalidParameter {
                name: "min_improvement",
                reason: format!("must be in [0, 1), got {min_improvement}"),
            });
        }
        if !(alpha > 0.0 && alpha < 1.0) {
            return Err(Error::InvalidParameter {
                name: "alpha",
                reason: format!("must be in (0, 1), got {alpha}"),
            });
        }
        Ok(Self {
            min_improvement,
            alpha,
        })
    }

    /// Least fraction of the held-out RMS error an accepted term cuts.
    pub fn min_improvement(&self) -> f64 {
        self.min_improvement
    }

    /// Level of the paired test.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }

    /// Judge a candidate from the held-out squared error of each block under the current
    /// model and under the candidate (same blocks, same order).
    ///
    /// Accepted when `cut >= min_improvement`, `p < alpha` and `cut` is finite. A NaN
    /// anywhere gives a NaN figure and a rejection; fewer than two blocks give `p = 1`.
    /// The log-ratio test reads the blocks where both errors are positive.
    ///
    /// # Errors
    ///
    /// [`Error::Shape`] when the two vectors differ in length.
    pub fn judge(&self, current_sse: &[f64], candidate_sse: &[f64]) -> Result<Acceptance> {
        if current_sse.len() != candidate_sse.len() {
            return Err(Error::Shape {
                what: "candidate_sse blocks",
                expected: current_sse.len(),
                got: candidate_sse.len(),
            });
        }
        let before: f64 = current_sse.iter().sum();
        let after: f64 = candidate_sse.iter().sum();
        let cut = if before > 0.0 {
            1.0 - (after / before).sqrt()
        } else {
            0.0
        };
        let diff: Vec<f64> = current_sse
            .iter()
            .zip(candidate_sse)
            .map(|(c, k)| c - k)
            .collect();
        let test = paired_test(&diff);
        let log_ratio: Vec<f64> = current_sse
            .iter()
            .zip(candidate_sse)
            .filter(|(c, k)| **c > 0.0 && **k > 0.0)
            .map(|(c, k)| c.ln() - k.ln())
            .collect();
        let p_log = paired_test(&log_ratio).p;
        let p_sign = sign_test(&diff);
        let p = if test.p.is_nan() {
            f64::NAN
        } else {
            let least = [p_log, p_sign]
                .into_iter()
                .filter(|p| !p.is_nan())
                .fold(test.p, f64::min);
            (3.0 * least).min(1.0)
        };
        Ok(Acceptance {
            accepted: cut.is_finite() && cut >= self.min_improvement && p < self.alpha,
            cut,
            t: test.t,
            p,
            p_sum: test.p,
            p_log,
            p_sign,
            n: test.n,
        })
    }
}

#[cfg(test)]
mod tests;
