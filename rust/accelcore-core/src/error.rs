//! Typed errors of the core. Every data-dependent failure is one of these; the
//! binding crate maps them to Python exceptions in one place (`errors.rs`).

/// Errors returned by the core kernels and readers. Variants carry the values
/// that explain the failure, never only a message.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is out of its valid range.
    #[error("invalid parameter `{name}`: {reason}")]
    InvalidParameter {
        /// Parameter name as the user spells it.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// Input arrays do not have the shape the kernel was configured for.
    #[error("shape mismatch in {what}: expected {expected}, got {got}")]
    Shape {
        /// Which input.
        what: &'static str,
        /// Expected length or column count.
        expected: usize,
        /// Length or column count received.
        got: usize,
    },
    /// Time stamps must be strictly increasing within one stream.
    #[error("time is not strictly increasing at sample {index}: {previous_s} s then {time_s} s")]
    TimeNotIncreasing {
        /// Zero-based index of the offending sample in the whole stream.
        index: u64,
        /// Time of the previous valid sample.
        previous_s: f64,
        /// Time of the offending sample.
        time_s: f64,
    },
    /// A value that must be finite is NaN or infinite.
    #[error("non-finite value in {what} at row {row}, column {column}")]
    NonFinite {
        /// Which input.
        what: &'static str,
        /// Zero-based row in the whole stream.
        row: u64,
        /// Zero-based column.
        column: usize,
    },
    /// `finish()` was called before any usable data was pushed.
    #[error("no data: {what}")]
    Empty {
        /// What was empty.
        what: &'static str,
    },
    /// Two accumulators cannot be merged (different configuration).
    #[error("cannot merge: {reason}")]
    Incompatible {
        /// Which settings differ.
        reason: String,
    },
    /// The design cannot identify some columns.
    #[error("rank-deficient design: cannot identify {}", columns.join(", "))]
    RankDeficient {
        /// Names of the columns that are (numerically) linear combinations of earlier ones.
        columns: Vec<String>,
    },
    /// Not enough data for the requested estimate.
    #[error("not enough data for {what}: need {needed}, have {have}")]
    InsufficientData {
        /// What was being estimated.
        what: String,
        /// How many were needed.
        needed: u64,
        /// How many there were.
        have: u64,
    },
    /// A text file could not be parsed. Line and column are 1-based.
    #[error("{path}:{line}:{column}: {reason}")]
    Parse {
        /// File path as given.
        path: String,
        /// 1-based line number.
        line: u64,
        /// 1-based column number (field index for CSV).
        column: u64,
        /// What was found and what was expected.
        reason: String,
    },
    /// A worker thread of the core stopped without a result (it panicked: a bug,
    /// data-dependent paths return the other variants).
    #[error("internal error: {reason}")]
    Internal {
        /// What stopped, and the panic's message when it has one.
        reason: String,
    },
    /// The operating system refused an I/O operation.
    #[error("{path}: {reason}")]
    Io {
        /// File path as given.
        path: String,
        /// The OS error.
        reason: String,
    },
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, Error>;
