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
//!   folds' factors (exact algebra, no row is visited again; prefix and suffix
//!   merges, so `F` folds cost about `3 F` merges);
//! - the held-out error of block `b` at coefficients `β` is
//!   `||R_b β − z_b||² + rss_b` ([`LeastSquares::residual_sum_squares_at`]),
//!   again without its rows;
//! - but a block of fewer rows than a block update's (the usual case: tens of
//!   rows, from 5 columns on) is never factored on its own: its weighted rows,
//!   still staged in its accumulator, go straight into its fold's factor, and
//!   its held-out error is `||X_b β − y_b||²` from those rows (a `p x p`
//!   triangle per block would cost more to make, merge and score than the
//!   rows it holds);
//! - a column a training set cannot identify is held at zero
//!   ([`LeastSquares::solve_identifiable`]) instead of failing the fold.
//!
//! Rows are pushed once with their block index; a fold assignment is only an
//! argument of [`BlockedLeastSquares::cross_validate`], so trying other folds,
//! or the in-sample fit, costs `O(blocks · p²)`, not `O(rows · p²)`.
//!
//! # Many models from one pass
//!
//! To score many candidate models, push the *wide* design of every candidate
//! column once (with several responses, [`BlockedLeastSquares::with_responses`],
//! when they share the design) and fix the folds once
//! ([`BlockedLeastSquares::folds`]: the per-fold training factors, merged once).
//! [`FoldedLeastSquares::cross_validate`] then fits any subset of the columns,
//! in any order, for one response: each training factor is reduced to the
//! subset ([`LeastSquares::select_columns`], exact algebra), and each block is
//! scored from its full factor with the coefficients zero-padded
//! (`||R_b β − z_b||² + rss_b`, exact), or from its rows and the `q` selected
//! columns. A query costs `O(folds · P · q² + blocks · P²)` for `P` columns in
//! all and `q` selected (`O(rows · q)` for the blocks kept as rows), whatever
//! the number of rows.
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
//! // The slope alone (column 1), with the folds merged once.
//! let folds = cv.folds(&[0, 0, 1, 1])?;
//! let slope = folds.cross_validate(&[1], 0)?;
//! assert_eq!(slope.coefficients.len(), 1);
//! assert!(slope.heldout_rss() > 0.0);
//! # Ok::<(), accelcore_core::Error>(())
//! ```

use std::borrow::Cow;

use crate::error::{Error, Result};
use crate::regression::{first_invalid, LeastSquares};
use ndarray::{ArrayView2, Axis, Slice};

/// Per-block least-squares factors of one design and one or more responses.
#[derive(Debug, Clone)]
pub struct BlockedLeastSquares {
    n_columns: usize,
    n_responses: usize,
    blocks: Vec<LeastSquares>,
}

/// The factors of a [`BlockedLeastSquares`] for one fold assignment: each
/// block's, each fold's training data (every other fold, merged) and all data.
/// Made by [`BlockedLeastSquares::folds`]; query with
/// [`FoldedLeastSquares::cross_validate`].
#[derive(Debug, Clone)]
pub struct FoldedLeastSquares {
    n_columns: usize,
    n_responses: usize,
    /// What each block keeps for its held-out error.
    blocks: Vec<HeldOutBlock>,
    /// The weighted rows `sqrt(w) [x | y]` of the blocks kept as rows, each
    /// block column-major (column `c` of a block of `n` rows at `offset + c n`).
    rows: Vec<f64>,
    /// Rows of non-zero weight of each block.
    rows_per_block: Vec<u64>,
    block_fold: Vec<u32>,
    /// Training factor of each fold (`None`: the fold holds no row).
    training: Vec<Option<LeastSquares>>,
    all: LeastSquares,
}

/// What a block of a [`FoldedLeastSquares`] keeps to score a fit on its rows.
#[derive(Debug, Clone)]
enum HeldOutBlock {
    /// No row of non-zero weight.
    Empty,
    /// Its weighted rows, at `offset` in [`FoldedLeastSquares::rows`] (a
    /// block too small to be worth a factor: its error is `||X_b β − y_b||²`).
    Rows { offset: usize, n: usize },
    /// Its settled factor: its error is `||R_b β − z_b||² + rss_b`.
    Factor(LeastSquares),
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
    /// `n_blocks` empty factors of `n_columns` unknowns (1..=64), one response.
    pub fn new(n_columns: usize, n_blocks: usize) -> Result<Self> {
        Self::with_responses(n_columns, 1, n_blocks)
    }

    /// `n_blocks` empty factors of `n_columns` unknowns and `n_responses`
    /// right-hand sides sharing the design (1..=64 each; see
    /// [`LeastSquares::with_responses`]).
    pub fn with_responses(n_columns: usize, n_responses: usize, n_blocks: usize) -> Result<Self> {
        let empty = LeastSquares::with_responses(n_columns, n_responses, None)?;
        Ok(Self {
            n_columns,
            n_responses,
            blocks: vec![empty; n_blocks],
        })
    }

    /// Number of columns.
    pub fn n_columns(&self) -> usize {
        self.n_columns
    }

    /// Number of responses.
    pub fn n_responses(&self) -> usize {
        self.n_responses
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
    /// [`Error::Shape`] for mismatched lengths (or an accumulator of several
    /// responses: use [`BlockedLeastSquares::push_multi`]),
    /// [`Error::InvalidParameter`] for a block index out of range, and those of
    /// [`LeastSquares::push`] (a non-finite value names its row in this chunk).
    pub fn push(
        &mut self,
        design: ArrayView2<'_, f64>,
        response: &[f64],
        weights: Option<&[f64]>,
        block: &[u32],
    ) -> Result<()> {
        if self.n_responses != 1 {
            return Err(Error::Shape {
                what: "responses (use push_multi)",
                expected: self.n_responses,
                got: 1,
            });
        }
        let responses =
            ArrayView2::from_shape((response.len(), 1), response).map_err(|_| Error::Shape {
                what: "response",
                expected: design.nrows(),
                got: response.len(),
            })?;
        self.push_multi(design, responses, weights, block)
    }

    /// Push rows with `n_responses` right-hand sides: `responses` is (n, m);
    /// otherwise as [`BlockedLeastSquares::push`].
    pub fn push_multi(
        &mut self,
        design: ArrayView2<'_, f64>,
        responses: ArrayView2<'_, f64>,
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
        if responses.ncols() != self.n_responses {
            return Err(Error::Shape {
                what: "response columns",
                expected: self.n_responses,
                got: responses.ncols(),
            });
        }
        for (what, len) in [
            ("response", responses.nrows()),
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
        // Validate every value before touching any factor (a chunk is all or nothing):
        // a branch-free screen of contiguous input first, the offending row only if it
        // fails, with the same check and errors as `LeastSquares::push`.
        let all_finite = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
        let screened = design.as_slice().is_some_and(all_finite)
            && responses.as_slice().is_some_and(all_finite)
            && weights.is_none_or(|w| w.iter().all(|&v| v.is_finite() && v >= 0.0));
        if !screened {
            first_invalid(design, responses, weights, 0)?;
        }
        let mut start = 0;
        while start < n {
            let b = block[start];
            let mut stop = start + 1;
            while stop < n && block[stop] == b {
                stop += 1;
            }
            let rows = Slice::from(start..stop);
            self.blocks[b as usize].push_multi(
                design.slice_axis(Axis(0), rows),
                responses.slice_axis(Axis(0), rows),
                weights.map(|w| &w[start..stop]),
            )?;
            start = stop;
        }
        Ok(())
    }

    /// Add another accumulator's blocks to these, block by block (same shape).
    pub fn merge(&mut self, other: &BlockedLeastSquares) -> Result<()> {
        if other.n_columns != self.n_columns
            || other.n_responses != self.n_responses
            || other.blocks.len() != self.blocks.len()
        {
            return Err(Error::Incompatible {
                reason: format!(
                    "shapes differ: {} columns x {} responses x {} blocks vs {} x {} x {}",
                    self.n_columns,
                    self.n_responses,
                    self.blocks.len(),
                    other.n_columns,
                    other.n_responses,
                    other.blocks.len()
                ),
            });
        }
        for (a, b) in self.blocks.iter_mut().zip(&other.blocks) {
            a.merge(b)?;
        }
        Ok(())
    }

    /// Fix a fold assignment: gather the rows of each fold, then for each fold
    /// the other folds (its training data), and all of them. `block_fold[b]` is
    /// the fold of block `b` (folds are numbered 0..=max; a fold may be empty).
    ///
    /// A block whose rows are all still staged (fewer than a block update's,
    /// from 5 columns on) is not factored: its rows go straight into its fold's
    /// factor ([`LeastSquares::absorb`]) and are kept for its held-out error; a
    /// block with a factor is merged, and kept settled. The training factors
    /// are merges of prefixes and suffixes of the folds (fold `k`'s is folds
    /// `0..k` merged with folds `k+1..`), so `F` folds cost about `3 F` merges
    /// of a triangle, not `F²`. Costs `O(rows · P² + folds · P³)` once; every
    /// query of the result is then independent of this cost.
    ///
    /// Errors: [`Error::Shape`] when `block_fold` is not `n_blocks` long.
    pub fn folds(&self, block_fold: &[u32]) -> Result<FoldedLeastSquares> {
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
        let empty = LeastSquares::with_responses(self.n_columns, self.n_responses, None)?;
        let mut folds = vec![empty.clone(); n_folds];
        let width = self.n_columns + self.n_responses;
        let staged: usize = self
            .blocks
            .iter()
            .filter_map(|b| b.staged_columns().map(|_| b.n_rows() as usize * width))
            .sum();
        let mut rows = Vec::with_capacity(staged);
        let mut blocks = Vec::with_capacity(self.blocks.len());
        for (b, &f) in self.blocks.iter().zip(block_fold) {
            folds[f as usize].absorb(b);
            blocks.push(if b.n_rows() == 0 {
                HeldOutBlock::Empty
            } else if let Some(columns) = b.staged_columns() {
                let offset = rows.len();
                for column in columns {
                    rows.extend_from_slice(column);
                }
                HeldOutBlock::Rows {
                    offset,
                    n: b.n_rows() as usize,
                }
            } else {
                let mut settled = b.clone();
                settled.settle();
                HeldOutBlock::Factor(settled)
            });
        }
        // Rows still staged in a fold go in now, once: every query then reads
        // settled factors.
        for f in &mut folds {
            f.settle();
        }
        // prefix[k]: folds 0..=k merged; suffix[k]: folds k.. merged.
        let mut prefix: Vec<LeastSquares> = Vec::with_capacity(n_folds);
        for f in &folds {
            let mut acc = prefix.last().map_or_else(|| f.clone(), Clone::clone);
            if prefix.last().is_some() {
                acc.merge(f)?;
            }
            prefix.push(acc);
        }
        let mut suffix: Vec<LeastSquares> = Vec::with_capacity(n_folds);
        for f in folds.iter().skip(1).rev() {
            let mut acc = suffix.last().map_or_else(|| f.clone(), Clone::clone);
            if suffix.last().is_some() {
                acc.merge(f)?;
            }
            suffix.push(acc);
        }
        suffix.reverse(); // suffix[k - 1]: folds k.. merged, for k >= 1
        let mut training = Vec::with_capacity(n_folds);
        for (k, fold) in folds.iter().enumerate() {
            if fold.n_rows() == 0 {
                training.push(None);
                continue;
            }
            let before = k.checked_sub(1).map(|j| &prefix[j]);
            let after = suffix.get(k); // folds k+1..
            training.push(Some(match (before, after) {
                (None, None) => empty.clone(),
                (Some(a), None) | (None, Some(a)) => a.clone(),
                (Some(a), Some(b)) => {
                    let mut train = a.clone();
                    train.merge(b)?;
                    train
                }
            }));
        }
        let all = prefix.pop().unwrap_or(empty);
        Ok(FoldedLeastSquares {
            n_columns: self.n_columns,
            n_responses: self.n_responses,
            blocks,
            rows,
            rows_per_block: self.blocks.iter().map(LeastSquares::n_rows).collect(),
            block_fold: block_fold.to_vec(),
            training,
            all,
        })
    }

    /// Fit every column on every block, and for each fold the fit on the other
    /// folds and the held-out error of its blocks, for response 0: the same as
    /// `self.folds(block_fold)?.cross_validate(&[0, 1, ..], 0)`.
    ///
    /// Errors: [`Error::Shape`] when `block_fold` is not `n_blocks` long,
    /// [`Error::Empty`] when no block holds a row.
    pub fn cross_validate(&self, block_fold: &[u32]) -> Result<HeldOutFit> {
        let all: Vec<usize> = (0..self.n_columns).collect();
        self.folds(block_fold)?.cross_validate(&all, 0)
    }
}

impl FoldedLeastSquares {
    /// Number of columns of the full design.
    pub fn n_columns(&self) -> usize {
        self.n_columns
    }

    /// Number of folds (the largest fold index + 1).
    pub fn n_folds(&self) -> usize {
        self.training.len()
    }

    /// Cross-validate the model of the columns `columns` (distinct indices, in
    /// the order of the returned coefficients) for response `response`: fit on
    /// every block, and for each fold on the other folds, holding columns those
    /// rows cannot identify at 0 (which of two dependent columns is held
    /// depends on this order: the later one); score each block under the fit
    /// without its fold. Equal, up to rounding, to pushing only those columns.
    ///
    /// Errors: [`Error::InvalidParameter`] for a response out of range or bad
    /// `columns` (see [`LeastSquares::select_columns`]), [`Error::Empty`] when
    /// no block holds a row.
    pub fn cross_validate(&self, columns: &[usize], response: usize) -> Result<HeldOutFit> {
        if response >= self.n_responses {
            return Err(Error::InvalidParameter {
                name: "response",
                reason: format!(
                    "{response} is out of range: {} response(s)",
                    self.n_responses
                ),
            });
        }
        let identity =
            columns.len() == self.n_columns && columns.iter().enumerate().all(|(i, &j)| i == j);
        let select = |ls| reduce(ls, columns, identity);
        let all = select(&self.all)?;
        let (coefficients, not_identified) = all.solve_identifiable(response)?;
        let in_sample_rss = all.residual_sum_squares_at(&coefficients, response)?;
        let q = columns.len();
        let mut fold_coefficients = Vec::with_capacity(self.training.len());
        for train in &self.training {
            fold_coefficients.push(match train {
                None => Vec::new(),
                Some(t) if t.n_rows() == 0 => vec![0.0; q],
                Some(t) => select(t)?.solve_identifiable(response)?.0,
            });
        }
        let mut padded = vec![vec![0.0; self.n_columns]; fold_coefficients.len()];
        for (pad, beta) in padded.iter_mut().zip(&fold_coefficients) {
            for (&j, &b) in columns.iter().zip(beta) {
                pad[j] = b;
            }
        }
        let width = self.n_columns + self.n_responses;
        let mut residual = Vec::new();
        let mut heldout_rss_per_block = Vec::with_capacity(self.blocks.len());
        for (b, &f) in self.blocks.iter().zip(&self.block_fold) {
            heldout_rss_per_block.push(match b {
                HeldOutBlock::Empty => 0.0,
                HeldOutBlock::Factor(ls) => {
                    ls.residual_sum_squares_at(&padded[f as usize], response)?
                }
                &HeldOutBlock::Rows { offset, n } => {
                    let block = &self.rows[offset..offset + n * width];
                    let beta = &fold_coefficients[f as usize];
                    rows_rss(
                        block,
                        n,
                        columns,
                        beta,
                        self.n_columns + response,
                        &mut residual,
                    )
                }
            });
        }
        Ok(HeldOutFit {
            coefficients,
            not_identified,
            in_sample_rss,
            fold_coefficients,
            heldout_rss_per_block,
            rows_per_block: self.rows_per_block.clone(),
        })
    }
}

/// `||X β − y||²` over the `n` weighted rows of a block stored column-major
/// (`block[c n..(c + 1) n]` is column `c`): `X` its columns `columns`, `y` its
/// column `response_column`. `residual` is scratch.
fn rows_rss(
    block: &[f64],
    n: usize,
    columns: &[usize],
    beta: &[f64],
    response_column: usize,
    residual: &mut Vec<f64>,
) -> f64 {
    residual.clear();
    residual.extend(
        block[response_column * n..(response_column + 1) * n]
            .iter()
            .map(|&y| -y),
    );
    for (&j, &b) in columns.iter().zip(beta) {
        for (r, &x) in residual.iter_mut().zip(&block[j * n..(j + 1) * n]) {
            *r += b * x;
        }
    }
    residual.iter().map(|r| r * r).sum()
}

/// A factor reduced to `columns` (borrowed when they are all of its columns, in order).
fn reduce<'a>(
    ls: &'a LeastSquares,
    columns: &[usize],
    identity: bool,
) -> Result<Cow<'a, LeastSquares>> {
    if identity {
        Ok(Cow::Borrowed(ls))
    } else {
        ls.select_columns(columns).map(Cow::Owned)
    }
}
