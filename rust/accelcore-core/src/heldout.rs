//! Held-out (cross-validated) least squares from per-block statistics.
//!
//! The diagnosis scores a candidate model by the error it makes on data its fit
//! did not see. Samples are cut into *blocks* (contiguous stretches of a run),
//! blocks are grouped into *folds*, and each fold is predicted by the model
//! fitted on every other fold. [`BlockedLeastSquares`] keeps one
//! [`LeastSquares`] factor per block — the sufficient statistics of its rows in
//! QR form, never normal equations — so that:
//!
//! - the fit without fold `k` is the [`merge`](LeastSquares::merge) of the other
//!   folds' factors (exact algebra, no row is visited again);
//! - the held-out error of block `b` at coefficients `β` is
//!   `||R_b β − z_b||² + rss_b` ([`LeastSquares::residual_sum_squares_at`]),
//!   again without its rows;
//! - a column a training set cannot identify is held at zero
//!   ([`LeastSquares::solve_identifiable`]) instead of failing the fold.
//!
//! Rows are pushed once with their block index; a fold assignment is only an
//! argument of [`BlockedLeastSquares::cross_validate`], so trying other folds,
//! or the in-sample fit, costs `O(blocks · p²)`, not `O(rows · p²)`.
//!
//! # Example
//!
//! ```
//! use accelcore_core::BlockedLeastSquares;
//! use ndarray::array;
//!
//! // y = 1 + 2 t, four blocks of two rows, folds {0, 1} and {2, 3}.
//! let x = array![[1.0, 0.0], [1.0, 1.0], [1.0, 2.0], [1.0, 3.0],
//!                [1.0, 4.0], [1.0, 5.0], [1.0, 6.0], [1.0, 7.0]];
//! let y: Vec<f64> = (0..8).map(|t| 1.0 + 2.0 * t as f64).collect();
//! let mut cv = BlockedLeastSquares::new(2, 4)?;
//! cv.push(x.view(), &y, None, &[0, 0, 1, 1, 2, 2, 3, 3])?;
//! let fit = cv.cross_validate(&[0, 0, 1, 1])?;
//! assert!(fit.heldout_rss_per_block.iter().all(|&e| e < 1e-20));
//! assert!((fit.coefficients[1] - 2.0).abs() < 1e-12);
//! # Ok::<(), accelcore_core::Error>(())
//! ```

use crate::error::{Error, Result};
use crate::regression::LeastSquares;
use ndarray::{ArrayView2, Axis, Slice};

/// Per-block least-squares factors of one design and response.
#[derive(Debug, Clone)]
pub struct BlockedLeastSquares {
    n_columns: usize,
    blocks: Vec<LeastSquares>,
}

/// In-sample and held-out fits of a [`BlockedLeastSquares`] for one fold assignment.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOutFit {
    /// Coefficients fitted on every block (non-identifiable columns at 0).
    pub coefficients: Vec<f64>,
    /// Columns held at 0 in the fit on every block.
    pub not_identified: Vec<usize>,
    /// Weighted residual sum of squares of that fit.
    pub in_sample_rss: f64,
    /// Coefficients of the fit without each fold, one vector per fold
    /// (empty for a fold that holds no rows).
    pub fold_coefficients: Vec<Vec<f64>>,
    /// Weighted squared error of each block under the fit without its fold.
    pub heldout_rss_per_block: Vec<f64>,
    /// Weighted rows of each block (the sum of its weights is not kept; this is
    /// the count of rows with non-zero weight).
    pub rows_per_block: Vec<u64>,
}

impl HeldOutFit {
    /// Sum of the held-out squared errors over every block.
    pub fn heldout_rss(&self) -> f64 {
        self.heldout_rss_per_block.iter().sum()
    }
}

impl BlockedLeastSquares {
    /// `n_blocks` empty factors of `n_columns` unknowns (1..=64).
    pub fn new(n_columns: usize, n_blocks: usize) -> Result<Self> {
        let empty = LeastSquares::new(n_columns, None)?;
        Ok(Self {
            n_columns,
            blocks: vec![empty; n_blocks],
        })
    }

    /// Number of columns.
    pub fn n_columns(&self) -> usize {
        self.n_columns
    }

    /// Number of blocks.
    pub fn n_blocks(&self) -> usize {
        self.blocks.len()
    }

    /// The factor of one block.
    pub fn block(&self, b: usize) -> Option<&LeastSquares> {
        self.blocks.get(b)
    }

    /// Push rows: `design` (n, p), `response` n, `weights` n (>= 0) or None, and the
    /// block of each row (`block[i] < n_blocks`). Consecutive rows of one block
    /// go in as one chunk, so rows sorted by block cost no more than one push.
    ///
    /// The whole chunk is validated first: on error nothing is pushed. Errors:
    /// [`Error::Shape`] for mismatched lengths, [`Error::InvalidParameter`] for
    /// a block index out of range, and those of [`LeastSquares::push`] (a
    /// non-finite value names its row in this chunk).
    pub fn push(
        &mut self,
        design: ArrayView2<'_, f64>,
        response: &[f64],
        weights: Option<&[f64]>,
        block: &[u32],
    ) -> Result<()> {
        let n = design.nrows();
        if design.ncols() != self.n_columns {
            return Err(Error::Shape {
                what: "design columns",
                expected: self.n_columns,
                got: design.ncols(),
            });
        }
        for (what, len) in [
            ("response", response.len()),
            ("block", block.len()),
            ("weights", weights.map_or(n, <[f64]>::len)),
        ] {
            if len != n {
                return Err(Error::Shape {
                    what,
                    expected: n,
                    got: len,
                });
            }
        }
        if let Some((row, &b)) = block
            .iter()
            .enumerate()
            .find(|(_, &b)| b as usize >= self.blocks.len())
        {
            return Err(Error::InvalidParameter {
                name: "block",
                reason: format!(
                    "row {row}: block {b} is out of range ({} blocks)",
                    self.blocks.len()
                ),
            });
        }
        // Validate every value before touching any factor (a chunk is all or nothing).
        for (i, row) in design.outer_iter().enumerate() {
            if let Some(j) = row.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFinite {
                    what: "design",
                    row: i as u64,
                    column: j,
                });
            }
        }
        if let Some(i) = response.iter().position(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                what: "response",
                row: i as u64,
                column: 0,
            });
        }
        if let Some(w) = weights {
            if let Some(i) = w.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFinite {
                    what: "weights",
                    row: i as u64,
                    column: 0,
                });
            }
            if let Some(i) = w.iter().position(|&v| v < 0.0) {
                return Err(Error::InvalidParameter {
                    name: "weights",
                    reason: format!("row {i}: weight {} is negative", w[i]),
                });
            }
        }
        let mut start = 0;
        while start < n {
            let b = block[start];
            let mut stop = start + 1;
            while stop < n && block[stop] == b {
                stop += 1;
            }
            let rows = design.slice_axis(Axis(0), Slice::from(start..stop));
            self.blocks[b as usize].push(
                rows,
                &response[start..stop],
                weights.map(|w| &w[start..stop]),
            )?;
            start = stop;
        }
        Ok(())
    }

    /// Add another accumulator's blocks to these, block by block (same shape).
    pub fn merge(&mut self, other: &BlockedLeastSquares) -> Result<()> {
        if other.n_columns != self.n_columns || other.blocks.len() != self.blocks.len() {
            return Err(Error::Incompatible {
                reason: format!(
                    "shapes differ: {} columns x {} blocks vs {} x {}",
                    self.n_columns,
                    self.blocks.len(),
                    other.n_columns,
                    other.blocks.len()
                ),
            });
        }
        for (a, b) in self.blocks.iter_mut().zip(&other.blocks) {
            a.merge(b)?;
        }
        Ok(())
    }

    /// Fit on every block, and for each fold the fit on the other folds and the
    /// held-out error of its blocks. `block_fold[b]` is the fold of block `b`
    /// (folds are numbered 0..=max; a fold may be empty).
    ///
    /// Errors: [`Error::Shape`] when `block_fold` is not `n_blocks` long,
    /// [`Error::Empty`] when no block holds a row.
    pub fn cross_validate(&self, block_fold: &[u32]) -> Result<HeldOutFit> {
        if block_fold.len() != self.blocks.len() {
            return Err(Error::Shape {
                what: "block_fold",
                expected: self.blocks.len(),
                got: block_fold.len(),
            });
        }
        let n_folds = block_fold
            .iter()
            .map(|&f| f as usize + 1)
            .max()
            .unwrap_or(0);
        let mut folds = vec![LeastSquares::new(self.n_columns, None)?; n_folds];
        for (b, &f) in self.blocks.iter().zip(block_fold) {
            folds[f as usize].merge(b)?;
        }
        let mut all = LeastSquares::new(self.n_columns, None)?;
        for f in &folds {
            all.merge(f)?;
        }
        let (coefficients, not_identified) = all.solve_identifiable(0)?;
        let in_sample_rss = all.residual_sum_squares_at(&coefficients, 0)?;
        let mut fold_coefficients = Vec::with_capacity(n_folds);
        for k in 0..n_folds {
            if folds[k].n_rows() == 0 {
                fold_coefficients.push(Vec::new());
                continue;
            }
            let mut train = LeastSquares::new(self.n_columns, None)?;
            for (j, f) in folds.iter().enumerate() {
                if j != k {
                    train.merge(f)?;
                }
            }
            let beta = if train.n_rows() == 0 {
                vec![0.0; self.n_columns]
            } else {
                train.solve_identifiable(0)?.0
            };
            fold_coefficients.push(beta);
        }
        let mut heldout_rss_per_block = Vec::with_capacity(self.blocks.len());
        for (b, &f) in self.blocks.iter().zip(block_fold) {
            let beta = &fold_coefficients[f as usize];
            heldout_rss_per_block.push(if b.n_rows() == 0 {
                0.0
            } else {
                b.residual_sum_squares_at(beta, 0)?
            });
        }
        Ok(HeldOutFit {
            coefficients,
            not_identified,
            in_sample_rss,
            fold_coefficients,
            heldout_rss_per_block,
            rows_per_block: self.blocks.iter().map(LeastSquares::n_rows).collect(),
        })
    }
}
