//! A time-constant search: one nonlinear parameter of a linear model, chosen by held-out error.
//!
//! The diagnosis finds a lag's or a warm-up's time constant `tau` by scoring trial
//! values: each trial is a linear model whose columns are *fixed* (they do not depend
//! on `tau`) or *built from `tau`* (a lagged temperature power, a decay since the run's
//! start), fitted on window means of consecutive samples and cross-validated by folds
//! of blocks ([`BlockedLeastSquares`]). The score of a trial is the sum of the
//! held-out weighted squared errors of its blocks, on every `stride`-th window.
//!
//! [`TimeConstantSearch`] holds what every model of one data set shares: the
//! full-rate ingredients of the `tau` columns ([`SampleSeries`]) and the windows,
//! blocks and folds ([`WindowLayout`]); a model ([`TrialModel`]) brings its fixed
//! window columns, its response and the order of its columns ([`TauColumn`]). A trial
//! ([`TimeConstantSearch::score`]):
//!
//! 1. builds each `tau` column at full rate: `(lag(T, tau) - t_ref)^k` (the
//!    temperature through a first-order lag, one pass per record, with the floats of
//!    [`first_order_lag`], gathered to the samples, the power as repeated products
//!    `p_k = p_(k-1) · p_1`), or `exp(-t / tau)`, `t` the time since the run's start;
//! 2. averages it over each window: the weighted sum of the window's samples over
//!    the window's weight (a window of zero weight: the sum, over 1), the sum taken in
//!    NumPy's order (`np.add.reduceat`: the first value plus the pairwise sum of the
//!    rest, [`pairwise_sum`]);
//! 3. multiplies it by its per-window multiplier (a gain column's gravity), if any;
//! 4. pushes the design, its columns in the model's order, into a new
//!    [`BlockedLeastSquares`] and cross-validates it: a column the training data cannot
//!    identify is held at zero, the later of two dependent ones;
//! 5. sums the held-out error of the folds.
//!
//! The engine's trial (its `cv_coarse`) scores each block and sums the blocks; the
//! score is that sum only, so here the blocks of one fold are pushed as one block
//! (the same algebra: a fold's held-out error is the sum of its blocks'), which
//! spares most of the factors and their merges. So a trial gives the engine's score
//! to rounding (a few eps relative on well-posed designs: the rows are brought in in the
//! same order, into fewer factors), with its columns the same floats, up to the
//! exponential of a decay (NumPy's vectorised `exp` and the C library's may differ in
//! the last bit). The window means of steps 1–2 depend on `tau` only, not on the
//! model: the search keeps them (up to [`CACHED_TAUS`] values of `tau` per kind), so
//! the models of every axis, which try the same grid, build each column once.
//!
//! [`TimeConstantSearch::search`] runs the search of the Python diagnosis
//! (`accelcore.diagnosis.search.search_1d`), step for step: `tau` rounded to three
//! significant digits as Python's `float(f"{tau:.3g}")` does (trials of one rounded
//! value are scored once), a log grid, then parabolic steps in `log tau` with
//! golden-section steps where a parabola leaves the bracket.
//!
//! [`TimeConstantSearch::search_many`] runs the searches of several models on up to
//! `threads` threads, each search the same trials and scores as alone: a trial is
//! evaluated from `&self` and its own scratch (the lagged temperature), and the kept
//! window means, shared by the threads, are a function of `tau` only (a value is
//! built the same way whichever thread builds it, and whether or not it was kept).

use std::collections::HashMap;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread;

use ndarray::{Array2, ArrayView2};

use crate::error::{Error, Result};
use crate::features::first_order_lag;
use crate::heldout::BlockedLeastSquares;

/// Values of `tau` whose window means a [`TimeConstantSearch`] keeps, per kind of
/// column (all are dropped when one more is needed).
pub const CACHED_TAUS: usize = 64;

/// How one column of a trial's design is made, in the design's column order.
#[derive(Debug, Clone, PartialEq)]
pub enum TauColumn {
    /// Column `j` of the model's fixed window design.
    Fixed(usize),
    /// `(lag(T, tau) - t_ref)^order`, window-averaged, times the multiplier (one
    /// value per window) if any.
    LagPower {
        /// Power of the lagged temperature difference, 1 or more.
        order: u32,
        /// Per-window factor (a gain column's gravity), `None` for 1.
        multiplier: Option<Vec<f64>>,
    },
    /// `exp(-t / tau)`, `t` the time since the run's start, window-averaged, times the
    /// multiplier if any.
    Decay {
        /// Per-window factor, `None` for 1.
        multiplier: Option<Vec<f64>>,
    },
}

/// The full-rate ingredients of the columns built from `tau`.
#[derive(Debug, Clone)]
pub struct SampleSeries<'a> {
    /// Time (s) and temperature (°C) of every record, whole (a lag runs over a
    /// record unbroken).
    pub records: Vec<(&'a [f64], &'a [f64])>,
    /// For each sample, its index in the records laid end to end.
    pub gather: &'a [usize],
    /// Reference temperature subtracted from the lagged temperature, °C.
    pub t_ref_c: f64,
    /// Time since its run's start of each sample, s (a decay's time).
    pub elapsed_s: &'a [f64],
    /// Weight of each sample.
    pub sample_weight: &'a [f64],
}

/// Windows of the samples, their blocks and the blocks' folds.
#[derive(Debug, Clone, Copy)]
pub struct WindowLayout<'a> {
    /// First sample of each window: windows are the contiguous stretches
    /// `start[i]..start[i + 1]` (the last one to the end), none empty.
    pub start: &'a [usize],
    /// Weight of each window (the sum of its samples' weights).
    pub weight: &'a [f64],
    /// Block of each window.
    pub block: &'a [u32],
    /// Fold of each block (`n_blocks` values).
    pub block_fold: &'a [u32],
    /// Trials use windows `0, stride, 2 stride, ...` (>= 1).
    pub stride: usize,
}

/// One model of a search: its fixed columns, its response and its column order.
#[derive(Debug, Clone, Copy)]
pub struct TrialModel<'a> {
    /// Columns that do not depend on `tau`, one row per window (`n_windows`, `p0`).
    pub fixed: ArrayView2<'a, f64>,
    /// Response of each window (window means).
    pub response: &'a [f64],
    /// The design's columns in order (1 to 64).
    pub columns: &'a [TauColumn],
}

/// Settings of [`TimeConstantSearch::search`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchSettings {
    /// Smallest and largest `tau` of the grid, s (`0 < lo <= hi`, finite).
    pub range_s: (f64, f64),
    /// Points of the log grid (>= 1).
    pub grid_points: usize,
    /// Most parabolic or golden-section steps after the grid.
    pub steps: usize,
    /// A step that moves less than this in `log tau`, or a bracket narrower than
    /// twice it, ends the search.
    pub tol: f64,
}

/// What [`TimeConstantSearch::search`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchResult {
    /// The scored `tau` of least score (the first one tried among equals).
    pub best_tau_s: f64,
    /// Every distinct rounded `tau` scored, `(tau, score)`, in the order tried.
    pub trials: Vec<(f64, f64)>,
}

/// One record's samples for the lag: its temperature, and the class of each step's
/// interval (intervals of equal bits share one filter factor per trial).
#[derive(Debug, Clone)]
struct Record {
    temperature_c: Vec<f64>,
    step_class: Vec<u32>,
    intervals: Vec<f64>,
    offset: usize,
}

/// Window means kept per `tau` (its bits), shared by the threads of
/// [`TimeConstantSearch::search_many`]: looked up and stored under the lock, built
/// outside it.
#[derive(Debug, Default)]
struct MeansCache<T>(Mutex<HashMap<u64, Arc<T>>>);

impl<T> Clone for MeansCache<T> {
    fn clone(&self) -> Self {
        Self(Mutex::new(self.lock().clone()))
    }
}

impl<T> MeansCache<T> {
    /// The map; a thread that panicked holding the lock left it whole (a lookup or
    /// one insert), so its poison is ignored.
    fn lock(&self) -> MutexGuard<'_, HashMap<u64, Arc<T>>> {
        self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn get(&self, key: u64) -> Option<Arc<T>> {
        self.lock().get(&key).cloned()
    }

    /// Keep `value` for `key` unless what is kept already does (`covers`); all are
    /// dropped when [`CACHED_TAUS`] are kept and one more is needed.
    fn insert(&self, key: u64, value: &Arc<T>, covers: impl FnOnce(&T) -> bool) {
        let mut map = self.lock();
        if map.get(&key).is_some_and(|kept| covers(kept)) {
            return;
        }
        if map.len() >= CACHED_TAUS && !map.contains_key(&key) {
            map.clear();
        }
        map.insert(key, Arc::clone(value));
    }

    fn len(&self) -> usize {
        self.lock().len()
    }

    fn clear(&self) {
        self.lock().clear();
    }
}

/// A model checked against the search, its rows taken: what each of its trials shares.
struct Prepared {
    template: Array2<f64>,
    response: Vec<f64>,
    max_order: u32,
    decay: bool,
}

/// Time-constant searches over one data set (see the module docs).
#[derive(Debug, Clone)]
pub struct TimeConstantSearch {
    records: Vec<Record>,
    total: usize,
    gather: Vec<usize>,
    t_ref_c: f64,
    elapsed_s: Vec<f64>,
    sample_weight: Vec<f64>,
    /// The samples of each trial window.
    spans: Vec<(usize, usize)>,
    /// The trial windows.
    rows: Vec<usize>,
    n_windows: usize,
    /// The weight of each trial window, zero weights replaced by 1 (a mean's divisor).
    divisor: Vec<f64>,
    weight: Vec<f64>,
    /// The fold of each trial window: a trial's blocks are the folds.
    fold: Vec<u32>,
    /// Each fold is its own fold (`0..n_folds`).
    folds: Vec<u32>,
    /// Window means of `(lag - t_ref)^k` (index k - 1) per `tau` (bits), trial rows.
    lag_cache: MeansCache<Vec<Vec<f64>>>,
    /// Window means of `exp(-t / tau)` per `tau` (bits), trial rows.
    decay_cache: MeansCache<Vec<f64>>,
    /// What the filter says of the records (non-finite values, time going back).
    lag_error: Option<Error>,
}

impl TimeConstantSearch {
    /// Check the inputs against each other and keep what every search shares.
    ///
    /// Errors: [`Error::Shape`] for lengths that disagree; [`Error::InvalidParameter`]
    /// for a zero stride, a block out of range, windows that are not contiguous
    /// non-empty stretches from sample 0, or a gather index past the records. The
    /// errors of [`first_order_lag`] for a record's time or temperature (non-finite
    /// values, time going back) are those of a model with a lag column.
    pub fn new(samples: SampleSeries<'_>, windows: WindowLayout<'_>) -> Result<Self> {
        let n = samples.gather.len();
        let n_windows = windows.start.len();
        check_len("elapsed_s", n, samples.elapsed_s.len())?;
        check_len("sample_weight", n, samples.sample_weight.len())?;
        check_len("window weight", n_windows, windows.weight.len())?;
        check_len("window block", n_windows, windows.block.len())?;
        if windows.stride == 0 {
            return Err(invalid("stride", "must be >= 1".to_string()));
        }
        let n_blocks = windows.block_fold.len();
        let n_folds = windows.block_fold.iter().map(|&f| f + 1).max().unwrap_or(0);
        if let Some(b) = windows.block.iter().find(|&&b| b as usize >= n_blocks) {
            return Err(invalid(
                "window block",
                format!("block {b} is out of range ({n_blocks} blocks)"),
            ));
        }
        let starts = windows.start;
        let contiguous = starts.first().is_none_or(|&s| s == 0)
            && starts.windows(2).all(|w| w[0] < w[1])
            && starts.last().is_none_or(|&s| s < n);
        if !contiguous || (n_windows == 0 && n > 0) {
            return Err(invalid(
                "window start",
                "windows must be non-empty contiguous stretches from sample 0".to_string(),
            ));
        }
        let mut records = Vec::with_capacity(samples.records.len());
        let mut total = 0;
        let mut lag_error = None;
        for &(time_s, temperature_c) in &samples.records {
            // The filter's own checks, once; their error is that of any lag column (a
            // decay needs no temperature).
            if let (Err(e), None) = (
                first_order_lag(time_s, temperature_c, 1.0, None),
                &lag_error,
            ) {
                lag_error = Some(e);
            }
            let mut classes: HashMap<u64, u32> = HashMap::new();
            let mut intervals = Vec::new();
            let mut step_class = Vec::with_capacity(time_s.len());
            for (i, &t) in time_s.iter().enumerate() {
                let dt = if i == 0 { 0.0 } else { t - time_s[i - 1] };
                let class = *classes.entry(dt.to_bits()).or_insert_with(|| {
                    intervals.push(dt);
                    (intervals.len() - 1) as u32
                });
                step_class.push(class);
            }
            records.push(Record {
                temperature_c: temperature_c.to_vec(),
                step_class,
                intervals,
                offset: total,
            });
            total += time_s.len();
        }
        if let Some(g) = samples.gather.iter().find(|&&g| g >= total) {
            return Err(invalid(
                "gather",
                format!("index {g} is past the records ({total} samples)"),
            ));
        }
        let rows: Vec<usize> = (0..n_windows).step_by(windows.stride).collect();
        let weight: Vec<f64> = rows.iter().map(|&i| windows.weight[i]).collect();
        Ok(Self {
            records,
            total,
            gather: samples.gather.to_vec(),
            t_ref_c: samples.t_ref_c,
            elapsed_s: samples.elapsed_s.to_vec(),
            sample_weight: samples.sample_weight.to_vec(),
            spans: rows
                .iter()
                .map(|&i| (starts[i], starts.get(i + 1).copied().unwrap_or(n)))
                .collect(),
            n_windows,
            divisor: weight
                .iter()
                .map(|&w| if w > 0.0 { w } else { 1.0 })
                .collect(),
            weight,
            fold: rows
                .iter()
                .map(|&i| windows.block_fold[windows.block[i] as usize])
                .collect(),
            folds: (0..n_folds).collect(),
            rows,
            lag_cache: MeansCache::default(),
            decay_cache: MeansCache::default(),
            lag_error,
        })
    }

    /// Number of windows a trial fits (every `stride`-th).
    pub fn n_rows(&self) -> usize {
        self.rows.len()
    }

    /// The design of one trial: the model's fixed columns and those built from `tau_s`
    /// (not rounded), one row per trial window.
    ///
    /// Errors: those of [`TimeConstantSearch::score`].
    pub fn design(&self, model: &TrialModel<'_>, tau_s: f64) -> Result<Array2<f64>> {
        let prepared = self.prepare(model)?;
        self.assemble(model, &prepared, tau_s, &mut Vec::new())
    }

    /// Score of one `tau_s` (not rounded): the held-out weighted squared error of
    /// every block, summed in NumPy's pairwise order.
    ///
    /// Errors: [`Error::Shape`] for a model whose fixed columns, response or
    /// multipliers are not one value per window; [`Error::InvalidParameter`] for no
    /// column or more than 64, a fixed column out of range, an order of 0, or a
    /// `tau_s` that is not finite and positive; those of [`first_order_lag`] on the
    /// records for a model with a lag column; those of [`BlockedLeastSquares::push`]
    /// (a non-finite fixed column).
    pub fn score(&self, model: &TrialModel<'_>, tau_s: f64) -> Result<f64> {
        let prepared = self.prepare(model)?;
        self.trial(model, &prepared, tau_s, &mut Vec::new())
    }

    /// Search `tau` for `model` as the Python diagnosis does (see the module docs).
    ///
    /// Errors: [`Error::InvalidParameter`] for a range that is not `0 < lo <= hi`
    /// (finite), no grid point, or a non-finite or negative `tol`; those of
    /// [`TimeConstantSearch::score`].
    pub fn search(
        &self,
        model: &TrialModel<'_>,
        settings: &SearchSettings,
    ) -> Result<SearchResult> {
        check_settings(settings)?;
        let prepared = self.prepare(model)?;
        self.search_prepared(model, &prepared, settings, &mut Vec::new())
    }

    /// Search `tau` for each model, as [`TimeConstantSearch::search`] does for each
    /// alone, on up to `threads` threads; the results in the models' order.
    ///
    /// Each model's search makes the same trials in the same order, and each trial
    /// gives the same floats, as alone: a trial's arithmetic does not depend on the
    /// thread. With more than one thread, the window means of the grid's values of
    /// `tau` (every model tries the same grid) are built first, one value per thread
    /// at a time, then the models are searched, one per thread at a time. One thread:
    /// the searches one after the other on this one.
    ///
    /// Errors: [`Error::InvalidParameter`] for `threads` of 0; those of
    /// [`TimeConstantSearch::search`], of the first model (in order) that has one;
    /// [`Error::Internal`] for a thread that panicked.
    pub fn search_many(
        &self,
        models: &[TrialModel<'_>],
        settings: &SearchSettings,
        threads: usize,
    ) -> Result<Vec<SearchResult>> {
        if threads == 0 {
            return Err(invalid("threads", "must be >= 1".to_string()));
        }
        check_settings(settings)?;
        if threads == 1 || models.len() <= 1 {
            let mut lagged = Vec::new();
            return models
                .iter()
                .map(|model| {
                    let prepared = self.prepare(model)?;
                    self.search_prepared(model, &prepared, settings, &mut lagged)
                })
                .collect();
        }
        let prepared: Vec<Result<Prepared>> = models.iter().map(|m| self.prepare(m)).collect();
        self.fill_grid(&prepared, settings, threads)?;
        let searched = parallel_map(models.len(), threads, |i, lagged| match &prepared[i] {
            Ok(p) => self.search_prepared(&models[i], p, settings, lagged),
            Err(e) => Err(e.clone()),
        })?;
        searched.into_iter().collect()
    }

    /// Build and keep, on up to `threads` threads, the window means of the grid's
    /// values of `tau` that the prepared models need and that are not kept; nothing
    /// when the grid would crowd the others out of the cache.
    fn fill_grid(
        &self,
        prepared: &[Result<Prepared>],
        settings: &SearchSettings,
        threads: usize,
    ) -> Result<()> {
        let ready = prepared.iter().flatten();
        let max_order = ready.clone().map(|p| p.max_order).max().unwrap_or(0);
        let decay = ready.clone().any(|p| p.decay);
        let (lo, hi) = settings.range_s;
        let mut taus: Vec<f64> = Vec::new();
        for g in linspace(lo.ln(), hi.ln(), settings.grid_points) {
            let tau = round_significant(g.exp(), 3);
            if tau.is_finite() && tau > 0.0 && !taus.contains(&tau) {
                taus.push(tau);
            }
        }
        if taus.len() > CACHED_TAUS / 2 {
            return Ok(());
        }
        // (tau, whether a decay's means): the ones not kept (lags of too few orders).
        let mut wanted: Vec<(f64, bool)> = Vec::new();
        for &tau in &taus {
            let key = tau.to_bits();
            if max_order > 0
                && self
                    .lag_cache
                    .get(key)
                    .is_none_or(|m| m.len() < max_order as usize)
            {
                wanted.push((tau, false));
            }
            if decay && self.decay_cache.get(key).is_none() {
                wanted.push((tau, true));
            }
        }
        let lags = wanted.iter().filter(|w| !w.1).count();
        if self.lag_cache.len() + lags > CACHED_TAUS {
            self.lag_cache.clear();
        }
        if self.decay_cache.len() + (wanted.len() - lags) > CACHED_TAUS {
            self.decay_cache.clear();
        }
        parallel_map(wanted.len(), threads, |i, lagged| {
            let (tau, is_decay) = wanted[i];
            if is_decay {
                self.keep_decay_means(tau);
            } else {
                self.keep_lag_means(tau, max_order, lagged);
            }
            Ok(())
        })?;
        Ok(())
    }

    /// The search of a prepared model (its settings checked).
    fn search_prepared(
        &self,
        model: &TrialModel<'_>,
        prepared: &Prepared,
        settings: &SearchSettings,
        lagged: &mut Vec<f64>,
    ) -> Result<SearchResult> {
        let (lo, hi) = settings.range_s;
        let tol = settings.tol;
        let mut trials: Vec<(f64, f64)> = Vec::new();
        let mut score = |tau: f64| -> Result<f64> {
            let tau = round_significant(tau, 3);
            if let Some(&(_, s)) = trials.iter().find(|(t, _)| *t == tau) {
                return Ok(s);
            }
            let s = self.trial(model, prepared, tau, lagged)?;
            trials.push((tau, s));
            Ok(s)
        };
        let grid = linspace(lo.ln(), hi.ln(), settings.grid_points);
        let mut vals = Vec::with_capacity(grid.len());
        for &g in &grid {
            vals.push(score(g.exp())?);
        }
        let i = argmin(&vals);
        let last = grid.len() - 1;
        let (mut a, mut fa) = (grid[i.saturating_sub(1)], vals[i.saturating_sub(1)]);
        let (mut b, mut fb) = (grid[(i + 1).min(last)], vals[(i + 1).min(last)]);
        let (mut x, mut fx) = (grid[i], vals[i]);
        let golden = (3.0 - 5.0_f64.sqrt()) / 2.0;
        for _ in 0..settings.steps {
            let num = square(x - a) * (fx - fb) - square(x - b) * (fx - fa);
            let den = (x - a) * (fx - fb) - (x - b) * (fx - fa);
            let mut u = if den == 0.0 {
                f64::NAN
            } else {
                x - 0.5 * num / den
            };
            if !(a < u && u < b) || (u - x).abs() < 0.5 * tol {
                u = if (b - x) > (x - a) {
                    x + golden * (b - x)
                } else {
                    x - golden * (x - a)
                };
            }
            let fu = score(u.exp())?;
            let moved = (u - x).abs();
            if fu < fx {
                if u < x {
                    (b, fb) = (x, fx);
                } else {
                    (a, fa) = (x, fx);
                }
                (x, fx) = (u, fu);
            } else if u < x {
                (a, fa) = (u, fu);
            } else {
                (b, fb) = (u, fu);
            }
            if moved < tol || b - a < 2.0 * tol {
                break;
            }
        }
        let mut best = trials[0];
        for &trial in &trials[1..] {
            if trial.1 < best.1 {
                best = trial;
            }
        }
        Ok(SearchResult {
            best_tau_s: best.0,
            trials,
        })
    }

    /// Check a model and fill in its fixed columns on the trial rows.
    fn prepare(&self, model: &TrialModel<'_>) -> Result<Prepared> {
        let p0 = model.fixed.ncols();
        check_len("fixed rows", self.n_windows, model.fixed.nrows())?;
        check_len("response", self.n_windows, model.response.len())?;
        let columns = model.columns;
        if columns.is_empty() || columns.len() > 64 {
            return Err(invalid(
                "columns",
                format!("a trial needs 1 to 64 columns, got {}", columns.len()),
            ));
        }
        let mut template = Array2::zeros((self.rows.len(), columns.len()));
        let (mut max_order, mut decay) = (0, false);
        for (c, column) in columns.iter().enumerate() {
            let multiplier = match column {
                TauColumn::Fixed(j) => {
                    if *j >= p0 {
                        return Err(invalid(
                            "columns",
                            format!("fixed column {j} is out of range ({p0} columns)"),
                        ));
                    }
                    for (r, &i) in self.rows.iter().enumerate() {
                        template[[r, c]] = model.fixed[[i, *j]];
                    }
                    None
                }
                TauColumn::LagPower { order, multiplier } => {
                    if *order == 0 {
                        return Err(invalid("order", "must be >= 1".to_string()));
                    }
                    max_order = max_order.max(*order);
                    multiplier.as_ref()
                }
                TauColumn::Decay { multiplier } => {
                    decay = true;
                    multiplier.as_ref()
                }
            };
            if let Some(m) = multiplier {
                check_len("multiplier", self.n_windows, m.len())?;
            }
        }
        if let (Some(e), true) = (&self.lag_error, max_order > 0) {
            return Err(e.clone());
        }
        Ok(Prepared {
            template,
            response: self.rows.iter().map(|&i| model.response[i]).collect(),
            max_order,
            decay,
        })
    }

    /// The design of a prepared model at `tau_s` (`lagged`: scratch of the lag pass).
    fn assemble(
        &self,
        model: &TrialModel<'_>,
        prepared: &Prepared,
        tau_s: f64,
        lagged: &mut Vec<f64>,
    ) -> Result<Array2<f64>> {
        if !(tau_s.is_finite() && tau_s > 0.0) {
            return Err(invalid(
                "tau_s",
                format!("must be finite and > 0, got {tau_s}"),
            ));
        }
        let lag = (prepared.max_order > 0)
            .then(|| self.keep_lag_means(tau_s, prepared.max_order, lagged));
        let decay = prepared.decay.then(|| self.keep_decay_means(tau_s));
        let mut design = prepared.template.clone();
        for (c, column) in model.columns.iter().enumerate() {
            let (means, multiplier): (&[f64], _) = match (column, &lag, &decay) {
                (TauColumn::LagPower { order, multiplier }, Some(lag), _) => {
                    (&lag[*order as usize - 1], multiplier)
                }
                (TauColumn::Decay { multiplier }, _, Some(decay)) => (decay, multiplier),
                _ => continue,
            };
            for (r, &mean) in means.iter().enumerate() {
                design[[r, c]] = match multiplier {
                    Some(m) => mean * m[self.rows[r]],
                    None => mean,
                };
            }
        }
        Ok(design)
    }

    /// The window means of the lag's powers `1..=max_order` at `tau_s`: the kept ones,
    /// else new ones, kept.
    fn keep_lag_means(
        &self,
        tau_s: f64,
        max_order: u32,
        lagged: &mut Vec<f64>,
    ) -> Arc<Vec<Vec<f64>>> {
        let key = tau_s.to_bits();
        let order = max_order as usize;
        if let Some(means) = self.lag_cache.get(key).filter(|m| m.len() >= order) {
            return means;
        }
        let means = Arc::new(self.lag_means(tau_s, max_order, lagged));
        self.lag_cache
            .insert(key, &means, |kept| kept.len() >= order);
        means
    }

    /// The window means of the decay at `tau_s`: the kept ones, else new ones, kept.
    fn keep_decay_means(&self, tau_s: f64) -> Arc<Vec<f64>> {
        let key = tau_s.to_bits();
        if let Some(means) = self.decay_cache.get(key) {
            return means;
        }
        let means = Arc::new(self.decay_means(tau_s));
        self.decay_cache.insert(key, &means, |_| true);
        means
    }

    /// Score a prepared model at `tau_s` (not rounded).
    fn trial(
        &self,
        model: &TrialModel<'_>,
        prepared: &Prepared,
        tau_s: f64,
        lagged: &mut Vec<f64>,
    ) -> Result<f64> {
        let design = self.assemble(model, prepared, tau_s, lagged)?;
        let mut lsq = BlockedLeastSquares::new(model.columns.len(), self.folds.len())?;
        lsq.push(
            design.view(),
            &prepared.response,
            Some(&self.weight),
            &self.fold,
        )?;
        let fit = lsq.cross_validate(&self.folds)?;
        Ok(pairwise_sum(&fit.heldout_rss_per_block))
    }

    /// Window means of `(lag(T, tau) - t_ref)^k`, `k = 1..=max_order`, on the trial rows.
    fn lag_means(&self, tau_s: f64, max_order: u32, lagged: &mut Vec<f64>) -> Vec<Vec<f64>> {
        self.lag_pass(tau_s, lagged);
        let mut means: Vec<Vec<f64>> = (0..max_order)
            .map(|_| Vec::with_capacity(self.rows.len()))
            .collect();
        let (mut d, mut p, mut terms) = (Vec::new(), Vec::new(), Vec::new());
        for (&(start, stop), &divisor) in self.spans.iter().zip(&self.divisor) {
            let w = &self.sample_weight[start..stop];
            d.clear();
            d.extend(
                self.gather[start..stop]
                    .iter()
                    .map(|&g| lagged[g] - self.t_ref_c),
            );
            p.clear();
            p.extend_from_slice(&d);
            for (k, column) in means.iter_mut().enumerate() {
                if k > 0 {
                    // p_k = p_(k-1) · d, as the engine's products.
                    for (pk, dk) in p.iter_mut().zip(&d) {
                        *pk *= dk;
                    }
                }
                terms.clear();
                terms.extend(w.iter().zip(&p).map(|(w, p)| w * p));
                column.push(reduceat_sum(&terms) / divisor);
            }
        }
        means
    }

    /// Window means of `exp(-t / tau)` on the trial rows.
    fn decay_means(&self, tau_s: f64) -> Vec<f64> {
        let mut terms = Vec::new();
        self.spans
            .iter()
            .zip(&self.divisor)
            .map(|(&(start, stop), &divisor)| {
                let t = &self.elapsed_s[start..stop];
                let w = &self.sample_weight[start..stop];
                terms.clear();
                terms.extend(t.iter().zip(w).map(|(&t, &w)| w * (-t / tau_s).exp()));
                reduceat_sum(&terms) / divisor
            })
            .collect()
    }

    /// The lagged temperature of every record sample into `lagged`: the floats of
    /// [`first_order_lag`] (`y += alpha (x - y)`, one factor `alpha = -expm1(-dt / tau)`
    /// per interval's bits), the records' recursions interleaved (they are independent,
    /// so the processor overlaps them).
    fn lag_pass(&self, tau_s: f64, lagged: &mut Vec<f64>) {
        lagged.clear();
        lagged.resize(self.total, 0.0);
        let alphas: Vec<Vec<f64>> = self
            .records
            .iter()
            .map(|r| {
                r.intervals
                    .iter()
                    .map(|&dt| -(-dt / tau_s).exp_m1())
                    .collect()
            })
            .collect();
        let mut state: Vec<f64> = self
            .records
            .iter()
            .map(|r| r.temperature_c.first().copied().unwrap_or(0.0))
            .collect();
        let longest = self.records.iter().map(|r| r.temperature_c.len()).max();
        for i in 0..longest.unwrap_or(0) {
            for ((record, alpha), y) in self.records.iter().zip(&alphas).zip(&mut state) {
                let Some(&x) = record.temperature_c.get(i) else {
                    continue;
                };
                if i > 0 {
                    *y += alpha[record.step_class[i] as usize] * (x - *y);
                }
                lagged[record.offset + i] = *y;
            }
        }
    }
}

/// Check the settings of a search (see [`TimeConstantSearch::search`]).
fn check_settings(settings: &SearchSettings) -> Result<()> {
    let (lo, hi) = settings.range_s;
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
        return Err(invalid(
            "range_s",
            format!("must be 0 < lo <= hi, finite; got ({lo}, {hi})"),
        ));
    }
    if settings.grid_points == 0 {
        return Err(invalid("grid_points", "must be >= 1".to_string()));
    }
    if !(settings.tol.is_finite() && settings.tol >= 0.0) {
        return Err(invalid(
            "tol",
            format!("must be finite and >= 0, got {}", settings.tol),
        ));
    }
    Ok(())
}

/// What one thread of [`parallel_map`] did: `(i, work(i))`.
type Done<R> = Vec<(usize, Result<R>)>;

/// `work(i, scratch)` for `i` in `0..n` on up to `threads` threads (this one and
/// helpers), each taking the next `i` when done with one, with its own scratch; the
/// results in the order of `i`. One thread (or one item): a plain loop on this one.
/// A helper that cannot start leaves its share to the others.
///
/// Errors: [`Error::Internal`] when a thread panics (a bug: `work` returns its
/// errors); the panic is caught, every thread joined, and the process goes on.
fn parallel_map<R, F>(n: usize, threads: usize, work: F) -> Result<Vec<Result<R>>>
where
    R: Send,
    F: Fn(usize, &mut Vec<f64>) -> Result<R> + Sync,
{
    let threads = threads.min(n);
    if threads <= 1 {
        let mut scratch = Vec::new();
        return Ok((0..n).map(|i| work(i, &mut scratch)).collect());
    }
    let next = AtomicUsize::new(0);
    let worker = || {
        let mut scratch = Vec::new();
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= n {
                return done;
            }
            done.push((i, work(i, &mut scratch)));
        }
    };
    let parts: Vec<thread::Result<Done<R>>> = thread::scope(|scope| {
        let helpers: Vec<_> = (1..threads)
            .filter_map(|_| thread::Builder::new().spawn_scoped(scope, worker).ok())
            .collect();
        let own = panic::catch_unwind(AssertUnwindSafe(worker));
        // Every helper is joined here: a panicked one gives its payload, not a panic
        // of the scope.
        let mut parts: Vec<_> = helpers
            .into_iter()
            .map(thread::ScopedJoinHandle::join)
            .collect();
        parts.push(own);
        parts
    });
    let mut out: Vec<Option<Result<R>>> = (0..n).map(|_| None).collect();
    for part in parts {
        let part = part.map_err(|payload| {
            let what = payload
                .downcast_ref::<&str>()
                .map(ToString::to_string)
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Error::Internal {
                reason: format!("a search thread panicked: {what}"),
            }
        })?;
        for (i, result) in part {
            out[i] = Some(result);
        }
    }
    out.into_iter()
        .map(|r| {
            r.ok_or_else(|| Error::Internal {
                reason: "a search item was not run".to_string(),
            })
        })
        .collect()
}

/// `x` rounded to `digits` significant digits as Python's `float(f"{x:.{digits}g}")`:
/// the decimal nearest the binary value (ties to even), read back to the nearest double.
pub fn round_significant(x: f64, digits: usize) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x;
    }
    let text = format!("{:.*e}", digits.max(1) - 1, x);
    text.parse().unwrap_or(x)
}

/// Sum in NumPy's order for a contiguous float64 array (`np.sum`): pairwise, eight
/// running sums per block of at most 128 values.
pub fn pairwise_sum(values: &[f64]) -> f64 {
    let n = values.len();
    if n < 8 {
        values.iter().fold(-0.0, |acc, &v| acc + v)
    } else if n <= 128 {
        let mut r = [0.0; 8];
        r.copy_from_slice(&values[..8]);
        let whole = n - n % 8;
        let mut i = 8;
        while i < whole {
            for (j, acc) in r.iter_mut().enumerate() {
                *acc += values[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for &v in &values[whole..] {
            res += v;
        }
        res
    } else {
        let mut half = n / 2;
        half -= half % 8;
        pairwise_sum(&values[..half]) + pairwise_sum(&values[half..])
    }
}

/// Sum of one segment in NumPy's `np.add.reduceat` order: the first value plus the
/// pairwise sum of the rest.
fn reduceat_sum(values: &[f64]) -> f64 {
    match values {
        [] => 0.0,
        [first] => *first,
        [first, rest @ ..] => first + pairwise_sum(rest),
    }
}

/// `v ** 2` as Python computes it: the C library's `pow(v, 2.0)`, which is not always
/// `v * v` in the last bit (the exponent is hidden from the optimiser so that it
/// calls `pow`).
fn square(v: f64) -> f64 {
    v.powf(std::hint::black_box(2.0))
}

/// `np.linspace(lo, hi, n)`: `i · step + lo`, the last point `hi`.
fn linspace(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![lo];
    }
    let step = (hi - lo) / (n - 1) as f64;
    let mut out: Vec<f64> = (0..n).map(|i| i as f64 * step + lo).collect();
    out[n - 1] = hi;
    out
}

/// `np.argmin`: the first NaN, else the first least value.
fn argmin(values: &[f64]) -> usize {
    if let Some(i) = values.iter().position(|v| v.is_nan()) {
        return i;
    }
    let mut best = 0;
    for (i, &v) in values.iter().enumerate() {
        if v < values[best] {
            best = i;
        }
    }
    best
}

fn check_len(what: &'static str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::Shape {
            what,
            expected,
            got,
        })
    }
}

fn invalid(name: &'static str, reason: String) -> Error {
    Error::InvalidParameter { name, reason }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    /// Two records of a slow temperature swing (0.5 s samples, a few irregular
    /// intervals), every sample kept but the first 10 of the second record; windows of
    /// 4 samples, blocks of 10 windows, three folds.
    struct Data {
        time: Vec<Vec<f64>>,
        temp: Vec<Vec<f64>>,
        gather: Vec<usize>,
        elapsed: Vec<f64>,
        weight: Vec<f64>,
        window_start: Vec<usize>,
        window_weight: Vec<f64>,
        window_block: Vec<u32>,
        block_fold: Vec<u32>,
        gravity: Vec<f64>,
    }

    fn data() -> Data {
        let lens = [800_usize, 640];
        let mut d = Data {
            time: Vec::new(),
            temp: Vec::new(),
            gather: Vec::new(),
            elapsed: Vec::new(),
            weight: Vec::new(),
            window_start: Vec::new(),
            window_weight: Vec::new(),
            window_block: Vec::new(),
            block_fold: Vec::new(),
            gravity: Vec::new(),
        };
        let mut offset = 0;
        for (r, &len) in lens.iter().enumerate() {
            let t: Vec<f64> = (0..len)
                .map(|i| 0.5 * i as f64 + if i % 50 == 7 { 0.013 } else { 0.0 })
                .collect();
            let temp: Vec<f64> = t
                .iter()
                .map(|&s| 25.0 + 20.0 * (s / 120.0 + r as f64).sin() + 0.01 * (s * 7.0).cos())
                .collect();
            let skip = if r == 1 { 10 } else { 0 };
            for (i, &ti) in t.iter().enumerate().skip(skip) {
                d.gather.push(offset + i);
                d.elapsed.push(ti);
                d.weight.push(if i % 97 == 5 {
                    0.0
                } else {
                    1.0 + 0.25 * (i % 3) as f64
                });
            }
            offset += len;
            d.time.push(t);
            d.temp.push(temp);
        }
        let n = d.gather.len();
        for (i, s) in (0..n).step_by(4).enumerate() {
            d.window_start.push(s);
            d.window_weight
                .push(d.weight[s..(s + 4).min(n)].iter().sum());
            d.window_block.push((i / 10) as u32);
            d.gravity.push(if (i / 10) % 2 == 0 { 1.0 } else { -1.0 });
        }
        let n_blocks = *d.window_block.last().unwrap() as usize + 1;
        d.block_fold = (0..n_blocks).map(|b| (b % 3) as u32).collect();
        d
    }

    fn searcher(d: &Data, stride: usize) -> Result<TimeConstantSearch> {
        TimeConstantSearch::new(
            SampleSeries {
                records: d
                    .time
                    .iter()
                    .zip(&d.temp)
                    .map(|(t, x)| (t.as_slice(), x.as_slice()))
                    .collect(),
                gather: &d.gather,
                t_ref_c: 25.0,
                elapsed_s: &d.elapsed,
                sample_weight: &d.weight,
            },
            WindowLayout {
                start: &d.window_start,
                weight: &d.window_weight,
                block: &d.window_block,
                block_fold: &d.block_fold,
                stride,
            },
        )
    }

    fn model<'a>(fixed: &'a Array2<f64>, y: &'a [f64], columns: &'a [TauColumn]) -> TrialModel<'a> {
        TrialModel {
            fixed: fixed.view(),
            response: y,
            columns,
        }
    }

    fn lag(order: u32) -> TauColumn {
        TauColumn::LagPower {
            order,
            multiplier: None,
        }
    }

    /// Window means written plainly: sequential sums over each window's samples.
    fn plain_window_means(d: &Data, values: &[f64]) -> Vec<f64> {
        let n = values.len();
        (0..d.window_start.len())
            .map(|i| {
                let stop = d.window_start.get(i + 1).copied().unwrap_or(n);
                let s: f64 = (d.window_start[i]..stop)
                    .map(|j| d.weight[j] * values[j])
                    .sum();
                let w = d.window_weight[i];
                s / if w > 0.0 { w } else { 1.0 }
            })
            .collect()
    }

    /// The fixed columns (1 and plain dT as window means) and the lag's first two powers.
    fn fixed_and_lag(d: &Data, tau: f64) -> (Array2<f64>, Vec<f64>, Vec<f64>) {
        let temp: Vec<f64> = d.temp.concat();
        let mut lagged = Vec::new();
        for (t, x) in d.time.iter().zip(&d.temp) {
            // The lag written out: y += (1 - exp(-dt / tau)) (x - y).
            let mut y = x[0];
            for i in 0..t.len() {
                if i > 0 {
                    y += (1.0 - (-(t[i] - t[i - 1]) / tau).exp()) * (x[i] - y);
                }
                lagged.push(y);
            }
        }
        let dt: Vec<f64> = d.gather.iter().map(|&g| temp[g] - 25.0).collect();
        let lag: Vec<f64> = d.gather.iter().map(|&g| lagged[g] - 25.0).collect();
        let n_win = d.window_start.len();
        let mut fixed = Array2::ones((n_win, 2));
        for (i, v) in plain_window_means(d, &dt).into_iter().enumerate() {
            fixed[[i, 1]] = v;
        }
        let lag2: Vec<f64> = lag.iter().map(|v| v * v).collect();
        (
            fixed,
            plain_window_means(d, &lag),
            plain_window_means(d, &lag2),
        )
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()).max(1e-300)
    }

    #[test]
    fn the_lag_pass_is_the_filter_bit_for_bit() {
        let d = data();
        let s = searcher(&d, 1).unwrap();
        let mut lagged = Vec::new();
        for tau in [0.7, 60.0, 3600.0] {
            s.lag_pass(tau, &mut lagged);
            let want: Vec<f64> = d
                .time
                .iter()
                .zip(&d.temp)
                .flat_map(|(t, x)| first_order_lag(t, x, tau, None).unwrap())
                .collect();
            assert_eq!(lagged, want);
        }
    }

    #[test]
    fn trial_columns_are_the_window_means_of_the_lag_and_decay() {
        let d = data();
        let (fixed, lag1, lag2) = fixed_and_lag(&d, 60.0);
        let y = vec![0.0; fixed.nrows()];
        let columns = [
            TauColumn::Fixed(1),
            TauColumn::LagPower {
                order: 2,
                multiplier: Some(d.gravity.clone()),
            },
            TauColumn::Decay { multiplier: None },
            TauColumn::Fixed(0),
            lag(1),
        ];
        let s = searcher(&d, 3).unwrap();
        let x = s.design(&model(&fixed, &y, &columns), 60.0).unwrap();
        assert_eq!(s.n_rows(), fixed.nrows().div_ceil(3));
        let decay: Vec<f64> = d.elapsed.iter().map(|t| (-t / 60.0).exp()).collect();
        let decay = plain_window_means(&d, &decay);
        for (r, i) in (0..fixed.nrows()).step_by(3).enumerate() {
            assert_eq!(x[[r, 0]], fixed[[i, 1]]);
            assert_eq!(x[[r, 3]], 1.0);
            // Sums of <= 4 terms in another order, lags written another way: a few eps.
            assert!(close(x[[r, 1]], lag2[i] * d.gravity[i], 1e-12), "{r}");
            assert!(close(x[[r, 2]], decay[i], 1e-13), "{r}");
            assert!(close(x[[r, 4]], lag1[i], 1e-12), "{r}");
        }
    }

    #[test]
    fn the_score_is_the_heldout_error_of_the_pushed_design() {
        let d = data();
        let (fixed, lag1, _) = fixed_and_lag(&d, 60.0);
        let y: Vec<f64> = (0..fixed.nrows())
            .map(|i| 0.5 + 0.1 * fixed[[i, 1]] + 2.0 * lag1[i] + 0.01 * ((i * 13 % 7) as f64))
            .collect();
        let columns = [TauColumn::Fixed(0), TauColumn::Fixed(1), lag(1)];
        let m = model(&fixed, &y, &columns);
        let s = searcher(&d, 2).unwrap();
        let x = s.design(&m, 45.0).unwrap();
        let rows: Vec<usize> = (0..fixed.nrows()).step_by(2).collect();
        let mut lsq = BlockedLeastSquares::new(3, d.block_fold.len()).unwrap();
        let yr: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
        let wr: Vec<f64> = rows.iter().map(|&i| d.window_weight[i]).collect();
        let br: Vec<u32> = rows.iter().map(|&i| d.window_block[i]).collect();
        lsq.push(x.view(), &yr, Some(&wr), &br).unwrap();
        let fit = lsq.cross_validate(&d.block_fold).unwrap();
        let at_45 = s.score(&m, 45.0).unwrap();
        // The folds' errors, each one factor, against the blocks': the same rows rotated
        // into fewer factors, a well-conditioned design (1, dT, a lag): a few eps.
        let blocks = pairwise_sum(&fit.heldout_rss_per_block);
        assert!(close(at_45, blocks, 1e-13), "{at_45} {blocks}");
        assert!(s.score(&m, 60.0).unwrap() < at_45);
        // Kept window means give the floats of new ones: other models and taus between.
        let other = [lag(2), TauColumn::Fixed(0), lag(1)];
        s.score(&model(&fixed, &y, &other), 45.0).unwrap();
        assert_eq!(s.score(&m, 45.0).unwrap(), at_45);
        assert_eq!(searcher(&d, 2).unwrap().score(&m, 45.0).unwrap(), at_45);
    }

    #[test]
    fn a_dependent_later_column_is_held_at_zero() {
        let d = data();
        let (fixed, lag1, _) = fixed_and_lag(&d, 60.0);
        let y: Vec<f64> = lag1.iter().map(|v| 1.0 + v).collect();
        let s = searcher(&d, 1).unwrap();
        let once = [TauColumn::Fixed(0), lag(1)];
        let twice = [TauColumn::Fixed(0), lag(1), lag(1)];
        let a = s.score(&model(&fixed, &y, &once), 60.0).unwrap();
        let b = s.score(&model(&fixed, &y, &twice), 60.0).unwrap();
        assert!(close(a, b, 1e-9) || (a < 1e-20 && b < 1e-20), "{a} {b}");
    }

    #[test]
    fn the_search_finds_the_lag_and_the_decay() {
        let d = data();
        let (fixed, lag1, _) = fixed_and_lag(&d, 90.0);
        let y: Vec<f64> = lag1.iter().map(|v| 0.3 + 1.5 * v).collect();
        let columns = [TauColumn::Fixed(0), lag(1)];
        let settings = SearchSettings {
            range_s: (5.0, 3600.0),
            grid_points: 10,
            steps: 8,
            tol: 5e-3,
        };
        let s = searcher(&d, 1).unwrap();
        let found = s.search(&model(&fixed, &y, &columns), &settings).unwrap();
        assert!(close(found.best_tau_s, 90.0, 0.02), "{found:?}");
        // The grid first, each point rounded to three digits.
        let (lo, hi) = (5.0_f64.ln(), 3600.0_f64.ln());
        for (k, trial) in found.trials.iter().take(10).enumerate() {
            let g = if k == 9 {
                hi
            } else {
                k as f64 * ((hi - lo) / 9.0) + lo
            };
            assert_eq!(trial.0, round_significant(g.exp(), 3));
        }
        assert!(found.trials.len() > 10 && found.trials.len() <= 18);
        let best = found
            .trials
            .iter()
            .map(|t| t.1)
            .fold(f64::INFINITY, f64::min);
        let at_best = found.trials.iter().find(|t| t.0 == found.best_tau_s);
        assert_eq!(at_best.unwrap().1, best);

        let decay: Vec<f64> = d.elapsed.iter().map(|t| (-t / 250.0).exp()).collect();
        let decay = plain_window_means(&d, &decay);
        let y: Vec<f64> = decay.iter().map(|v| 1.0 - 3.0 * v).collect();
        let columns = [TauColumn::Fixed(0), TauColumn::Decay { multiplier: None }];
        let found = s.search(&model(&fixed, &y, &columns), &settings).unwrap();
        assert!(close(found.best_tau_s, 250.0, 0.02), "{found:?}");
    }

    /// A search's result as bits: equal results are the same floats.
    fn bits(found: &SearchResult) -> (u64, Vec<(u64, u64)>) {
        (
            found.best_tau_s.to_bits(),
            found
                .trials
                .iter()
                .map(|(t, v)| (t.to_bits(), v.to_bits()))
                .collect(),
        )
    }

    #[test]
    fn searches_on_threads_are_the_searches_alone_bit_for_bit() {
        let d = data();
        let (fixed, lag1, lag2) = fixed_and_lag(&d, 90.0);
        let decay: Vec<f64> = d.elapsed.iter().map(|t| (-t / 250.0).exp()).collect();
        let decay = plain_window_means(&d, &decay);
        let g = Some(d.gravity.clone());
        let lag_y: Vec<f64> = (0..fixed.nrows())
            .map(|i| 0.3 + 1.5 * lag1[i] - 0.02 * lag2[i] * d.gravity[i])
            .collect();
        let decay_y: Vec<f64> = (0..fixed.nrows())
            .map(|i| 1.0 - 3.0 * decay[i] * d.gravity[i] + 0.1 * fixed[[i, 1]])
            .collect();
        // Lag powers, a decay, both, with and without multipliers; responses that
        // follow them and one that does not.
        let columns: Vec<(Vec<TauColumn>, &[f64])> = vec![
            (vec![TauColumn::Fixed(0), lag(1)], &lag_y),
            (
                vec![
                    TauColumn::Fixed(0),
                    TauColumn::Fixed(1),
                    lag(1),
                    TauColumn::LagPower {
                        order: 3,
                        multiplier: g.clone(),
                    },
                ],
                &lag_y,
            ),
            (
                vec![TauColumn::Decay { multiplier: None }, TauColumn::Fixed(0)],
                &decay_y,
            ),
            (
                vec![
                    TauColumn::Fixed(0),
                    TauColumn::Fixed(1),
                    TauColumn::Decay { multiplier: g },
                ],
                &decay_y,
            ),
            (
                vec![
                    TauColumn::Fixed(0),
                    lag(2),
                    TauColumn::Decay { multiplier: None },
                ],
                &lag2,
            ),
        ];
        let models: Vec<TrialModel<'_>> =
            columns.iter().map(|(c, y)| model(&fixed, y, c)).collect();
        let settings = SearchSettings {
            range_s: (5.0, 3600.0),
            grid_points: 10,
            steps: 8,
            tol: 5e-3,
        };
        // Each alone, on a search of its own (nothing kept from another model).
        let alone: Vec<_> = models
            .iter()
            .map(|m| bits(&searcher(&d, 2).unwrap().search(m, &settings).unwrap()))
            .collect();
        assert!(alone.iter().all(|(_, trials)| trials.len() > 10));
        for threads in [1, 2, 3] {
            let s = searcher(&d, 2).unwrap();
            let found = s.search_many(&models, &settings, threads).unwrap();
            let found: Vec<_> = found.iter().map(bits).collect();
            assert_eq!(found, alone, "{threads} threads");
            // Again on the same search: every grid value kept, most steps' too.
            let again = s.search_many(&models, &settings, threads).unwrap();
            assert_eq!(again.iter().map(bits).collect::<Vec<_>>(), alone);
            // And one model alone after the batch, from what the batch kept.
            assert_eq!(bits(&s.search(&models[1], &settings).unwrap()), alone[1]);
        }
        // A grid too fine to keep whole, and more threads than models.
        let fine = SearchSettings {
            grid_points: 40,
            ..settings
        };
        let s = searcher(&d, 3).unwrap();
        let many = s.search_many(&models[..2], &fine, 4).unwrap();
        for (m, found) in models.iter().zip(&many) {
            let one = searcher(&d, 3).unwrap().search(m, &fine).unwrap();
            assert_eq!(bits(found), bits(&one));
        }
        assert!(s.search_many(&[], &settings, 2).unwrap().is_empty());
    }

    #[test]
    fn a_batch_gives_the_first_models_error() {
        let d = data();
        let (fixed, _, _) = fixed_and_lag(&d, 60.0);
        let y = vec![0.0; fixed.nrows()];
        let good = [TauColumn::Fixed(0), lag(1)];
        let out_of_range = [TauColumn::Fixed(5), lag(1)];
        let short = [TauColumn::Decay {
            multiplier: Some(vec![1.0; 3]),
        }];
        let models = [
            model(&fixed, &y, &good),
            model(&fixed, &y, &out_of_range),
            model(&fixed, &y, &short),
        ];
        let settings = SearchSettings {
            range_s: (5.0, 3600.0),
            grid_points: 10,
            steps: 8,
            tol: 5e-3,
        };
        let s = searcher(&d, 1).unwrap();
        for threads in [1, 2, 3] {
            assert!(matches!(
                s.search_many(&models, &settings, threads),
                Err(Error::InvalidParameter {
                    name: "columns",
                    ..
                })
            ));
            assert!(matches!(
                s.search_many(&models[2..], &settings, threads),
                Err(Error::Shape {
                    what: "multiplier",
                    ..
                })
            ));
        }
        assert!(matches!(
            s.search_many(&models[..1], &settings, 0),
            Err(Error::InvalidParameter {
                name: "threads",
                ..
            })
        ));
        let bad_range = SearchSettings {
            range_s: (10.0, 5.0),
            ..settings
        };
        assert!(matches!(
            s.search_many(&models[..1], &bad_range, 2),
            Err(Error::InvalidParameter {
                name: "range_s",
                ..
            })
        ));
        // A lag model on records the filter refuses; the decay of the same batch runs.
        let mut bad = data();
        bad.temp[0][3] = f64::NAN;
        let s = searcher(&bad, 1).unwrap();
        let decay = [TauColumn::Fixed(0), TauColumn::Decay { multiplier: None }];
        let batch = [model(&fixed, &y, &decay), model(&fixed, &y, &good)];
        assert!(matches!(
            s.search_many(&batch, &settings, 2),
            Err(Error::NonFinite { row: 3, .. })
        ));
        assert!(s.search_many(&batch[..1], &settings, 2).is_ok());
    }

    #[test]
    fn a_panicking_thread_is_an_internal_error() {
        for threads in [2, 3] {
            let got = parallel_map(6, threads, |i, _| {
                assert!(i != 4, "item {i} panics");
                Ok(i)
            });
            match got {
                Err(Error::Internal { reason }) => assert!(reason.contains("item 4 panics")),
                other => panic!("{other:?}"),
            }
        }
        let squares = parallel_map(7, 3, |i, scratch| {
            scratch.push(0.0);
            Ok(i * i)
        })
        .unwrap();
        let squares: Vec<usize> = squares.into_iter().map(Result::unwrap).collect();
        assert_eq!(squares, (0..7).map(|i| i * i).collect::<Vec<_>>());
    }

    #[test]
    fn rounding_is_pythons_three_significant_digits() {
        // float(f"{x:.3g}") in Python for each x (ties to even on the binary value).
        let cases = [
            (0.125, 0.125),
            (12.25, 12.2),
            (1.005, 1.0),
            (2.675, 2.67),
            (1235.0, 1240.0),
            (1245.0, 1240.0),
            (0.000_123_5, 0.000_123),
            (99.95, 100.0),
            (999.5, 1000.0),
            (3599.999, 3600.0),
        ];
        for (x, want) in cases {
            assert_eq!(round_significant(x, 3), want, "{x}");
        }
    }

    #[test]
    fn sums_follow_numpys_order() {
        // np.sum of these (pairwise, eight running sums) and the plain sum differ.
        let mut v = vec![1.0; 24];
        v[0] = 1e16;
        v[8] = -1e16;
        assert_eq!(pairwise_sum(&v), 22.0);
        assert_eq!(v.iter().sum::<f64>(), 15.0);
        let ints: Vec<f64> = (1..=1000).map(f64::from).collect();
        assert_eq!(pairwise_sum(&ints), 500_500.0);
        assert_eq!(reduceat_sum(&[]), 0.0);
        assert_eq!(reduceat_sum(&[2.5]), 2.5);
        assert_eq!(linspace(1.0, 2.0, 1), vec![1.0]);
        assert_eq!(linspace(1.0, 1.0, 3), vec![1.0; 3]);
        assert_eq!(argmin(&[3.0, 1.0, f64::NAN, 1.0]), 2);
        assert_eq!(argmin(&[3.0, 1.0, 2.0, 1.0]), 1);
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let d = data();
        let (fixed, _, _) = fixed_and_lag(&d, 60.0);
        let y = vec![0.0; fixed.nrows()];
        assert!(matches!(
            searcher(&d, 0),
            Err(Error::InvalidParameter { name: "stride", .. })
        ));
        let mut bad = data();
        bad.time[1][5] = bad.time[1][4] - 1.0;
        bad.temp[0][3] = f64::NAN;
        let (f, y0) = (fixed.clone(), y.clone());
        let s = searcher(&bad, 1).unwrap();
        // The first record's error, for a lag only: a decay needs no temperature.
        let decay = [TauColumn::Fixed(0), TauColumn::Decay { multiplier: None }];
        assert!(s.score(&model(&f, &y0, &decay), 60.0).is_ok());
        assert!(matches!(
            s.score(&model(&f, &y0, &[lag(1)]), 60.0),
            Err(Error::NonFinite { row: 3, .. })
        ));
        bad = data();
        bad.gather[3] = 10_000;
        assert!(matches!(
            searcher(&bad, 1),
            Err(Error::InvalidParameter { name: "gather", .. })
        ));
        let s = searcher(&d, 1).unwrap();
        let one = [lag(1)];
        assert!(matches!(
            s.score(&model(&fixed, &y[1..], &one), 60.0),
            Err(Error::Shape {
                what: "response",
                ..
            })
        ));
        for columns in [vec![TauColumn::Fixed(2)], Vec::new()] {
            assert!(matches!(
                s.score(&model(&fixed, &y, &columns), 60.0),
                Err(Error::InvalidParameter {
                    name: "columns",
                    ..
                })
            ));
        }
        let short = [TauColumn::Decay {
            multiplier: Some(vec![1.0; 3]),
        }];
        assert!(matches!(
            s.score(&model(&fixed, &y, &short), 60.0),
            Err(Error::Shape {
                what: "multiplier",
                ..
            })
        ));
        assert!(matches!(
            s.score(&model(&fixed, &y, &one), 0.0),
            Err(Error::InvalidParameter { name: "tau_s", .. })
        ));
        for range_s in [(0.0, 10.0), (10.0, 5.0), (1.0, f64::INFINITY)] {
            let settings = SearchSettings {
                range_s,
                grid_points: 10,
                steps: 8,
                tol: 5e-3,
            };
            assert!(matches!(
                s.search(&model(&fixed, &y, &one), &settings),
                Err(Error::InvalidParameter {
                    name: "range_s",
                    ..
                })
            ));
        }
    }
}
