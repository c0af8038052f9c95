//! Incremental weighted least squares (CONTRACT PLACEHOLDER: bodies to be written).
use crate::error::Result;
use ndarray::ArrayView2;

/// Solution of a least-squares problem.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LstsqSolution {
    /// Column names, as given or `x0`, `x1`, ...
    pub column_names: Vec<String>,
    /// Coefficients, one per column.
    pub coefficients: Vec<f64>,
    /// Covariance of the coefficients, row-major p x p: sigma^2 (X'WX)^-1, sigma^2 = rss / dof.
    /// All NaN when dof == 0.
    pub covariance: Vec<f64>,
    /// Weighted residual sum of squares.
    pub residual_sum_squares: f64,
    /// Degrees of freedom: n_rows - p.
    pub dof: u64,
    /// Rows with non-zero weight.
    pub n_rows: u64,
    /// 2-norm condition number of sqrt(W) X.
    pub condition_number: f64,
    /// Condition number after scaling each column of sqrt(W) X to unit norm.
    pub condition_number_scaled: f64,
}

/// Incremental weighted least squares.
#[derive(Debug, Clone)]
pub struct LeastSquares {
    n_columns: usize,
}

impl LeastSquares {
    /// Create an empty problem with `n_columns` unknowns (1..=64).
    pub fn new(n_columns: usize, column_names: Option<Vec<String>>) -> Result<Self> {
        let _ = column_names;
        Ok(Self { n_columns })
    }
    /// Number of columns.
    pub fn n_columns(&self) -> usize {
        self.n_columns
    }
    /// Push rows: `design` is (n, p), `response` n, `weights` n (>= 0) or None for 1.
    pub fn push(
        &mut self,
        design: ArrayView2<'_, f64>,
        response: &[f64],
        weights: Option<&[f64]>,
    ) -> Result<()> {
        let _ = (design, response, weights);
        todo!()
    }
    /// Merge another problem with the same number of columns.
    pub fn merge(&mut self, other: &LeastSquares) -> Result<()> {
        let _ = other;
        todo!()
    }
    /// Rows with non-zero weight pushed so far.
    pub fn n_rows(&self) -> u64 {
        todo!()
    }
    /// Solve.
    pub fn finish(&self) -> Result<LstsqSolution> {
        todo!()
    }
}
