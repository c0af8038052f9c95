//! # accelcore-core
//!
//! Pure-Rust streaming kernels behind `accelcore`, the thermal-calibration
//! library for MEMS accelerometers. No Python here: the binding crate
//! `accelcore-py` only converts arrays and maps errors.
//!
//! Every kernel is a small struct with `push` (a chunk of samples), `merge`
//! (another accumulator of the same configuration) and `finish` (the result).
//! Results never depend on how the input was chunked.
//!
//! - [`Decimator`]: time-aligned block means (20 Hz to 2 Hz by default).
//! - [`TemperatureBinner`]: per-temperature-bin count, mean and variance.
//! - [`LeastSquares`]: incremental weighted least squares by QR (Givens
//!   rotations, or blocked Householder reflections from 5 columns on).
//! - [`BlockedLeastSquares`]: per-block factors; held-out error of any folds by merging them.
//! - [`read_run`]: a streaming reader of session logs straight into a [`Decimator`].
//! - [`RunTally`]: what a run's raw rows looked like (rows, non-finite rows, time
//!   span, gaps, channel ranges), shared by every reader.
//! - [`running_median`]: a centred running median (the data-quality checks' smoother).
//! - [`sliding_median`]: the median of every window of a series (the step check's).
//! - [`stats`]: the statistics that accept or reject a term of the diagnosis (chi-square,
//!   t and F tails, the paired test, Bonferroni and Holm, the acceptance rule).
//! - [`TimeConstantSearch`]: a lag's or warm-up's time constant by held-out error.

pub mod binning;
pub mod compensate;
pub mod decimate;
pub mod error;
pub mod features;
pub mod fingerprint;
pub mod heldout;
pub mod median;
pub mod noise;
pub mod reader;
pub mod regression;
pub mod robust;
pub mod search;
pub mod sort;
pub mod stats;
pub mod tally;

pub use binning::{BinnedStats, BinnerConfig, TemperatureBinner};
pub use compensate::compensate;
pub use decimate::{DecimatedBlocks, Decimator, DecimatorConfig};
pub use error::{Error, Result};
pub use features::{direction_lag, first_order_lag};
pub use fingerprint::fingerprint;
pub use heldout::{BlockedLeastSquares, FoldedLeastSquares, HeldOutFit};
pub use median::{median, nanmedian};
pub use noise::{block_noise, robust_sigma, typical_count};
pub use reader::{
    merge_runs, plan_split, read_run, read_run_digest, read_run_from, read_run_hashed,
    read_run_range, CsvFormat, DigestAlgorithm, RunData, SplitPlan,
};
pub use regression::{LeastSquares, LstsqSolution};
pub use robust::{running_median, sliding_median};
pub use search::{
    SampleSeries, SearchResult, SearchSettings, TauColumn, TimeConstantSearch, TrialModel,
    WindowLayout,
};
pub use sort::sorted;
pub use tally::{ChannelRange, RawStats, RunTally};
