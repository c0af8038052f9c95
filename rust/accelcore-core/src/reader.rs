//! Streaming reader of session log files (delimited text) straight into a
//! [`Decimator`]: the log is never held in memory whole.
//!
//! Rules, each with its error:
//! - an optional UTF-8 byte-order mark is dropped; `\r\n` and `\n` line ends are both accepted;
//! - line 1 is the header; every requested column must be present
//!   ([`Error::Parse`] at line 1 names the missing one and lists those found,
//!   and suggests the delimiter when the header looks split by another one), and no
//!   name may appear twice ([`Error::Parse`] at line 1, at the column of the repeat);
//! - blank lines are skipped; a data line with a field count other than the header's is an
//!   error naming its line, except a last line without a newline that is shorter than the
//!   header (a log cut off mid-write), which is dropped and counted in
//!   [`RunData::n_truncated_rows`];
//! - a cell is parsed as a decimal number (`nan` and `inf` are accepted and then skipped
//!   by the decimator, counted); an empty cell is read as NaN (missing); anything else
//!   is an error naming line and column (1-based field index) and the text found;
//! - time must strictly increase: an error names the line (the decimator's rule).

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use ndarray::ArrayView2;
use sha2::{Digest, Sha256};

use crate::decimate::{DecimatedBlocks, Decimator, DecimatorConfig};
use crate::error::{Error, Result};
use crate::tally::{ChannelRange, RawStats, RunTally};

mod cells;
use cells::{fast_delimiter, parse_line_fast, Layout};

/// How to read one log file.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvFormat {
    /// Field separator: `b','`, `b'\t'` or `b';'`.
    pub delimiter: u8,
    /// Name of the time column.
    pub time_column: String,
    /// Name of the temperature column.
    pub temperature_column: String,
    /// Names of the required data channels (x, y, z), in output order.
    pub channel_columns: Vec<String>,
    /// Keep every other numeric column as an extra channel after the required ones.
    pub keep_extra_columns: bool,
    /// Factor that turns the time column's unit into seconds (1 for s, 1e-3 for ms, ...).
    pub time_scale_to_s: f64,
}

impl Default for CsvFormat {
    fn default() -> Self {
        Self {
            delimiter: b',',
            time_column: "time_s".into(),
            temperature_column: "temp_c".into(),
            channel_columns: vec!["x".into(), "y".into(), "z".into()],
            keep_extra_columns: true,
            time_scale_to_s: 1.0,
        }
    }
}

/// One run read and decimated.
#[derive(Debug, Clone, PartialEq)]
pub struct RunData {
    /// Header fields as found.
    pub header: Vec<String>,
    /// Names of the decimated channels: the required ones, then the extras.
    pub channel_names: Vec<String>,
    /// Decimated blocks (time in seconds from the file's own origin).
    pub blocks: DecimatedBlocks,
    /// Data rows read (excluding the header, blank lines and a dropped truncated line).
    pub n_rows: u64,
    /// Rows skipped because a value was NaN, infinite or empty.
    pub n_skipped_nonfinite: u64,
    /// A last line cut off mid-write (0 or 1).
    pub n_truncated_rows: u64,
    /// Time of the first and last rows, seconds (file's origin).
    pub first_time_s: f64,
    /// Time of the last row, seconds.
    pub last_time_s: f64,
    /// Intervals between consecutive rows longer than 1.5 nominal periods.
    pub n_gaps: u64,
    /// Longest interval between consecutive rows, s.
    pub max_interval_s: f64,
    /// Raw range of each decimated channel (clipping detection).
    pub channel_ranges: Vec<ChannelRange>,
}

impl RunData {
    /// A run from its blocks and the statistics of its raw rows.
    pub fn new(
        header: Vec<String>,
        channel_names: Vec<String>,
        blocks: DecimatedBlocks,
        stats: RawStats,
        n_truncated_rows: u64,
    ) -> Self {
        Self {
            header,
            channel_names,
            blocks,
            n_rows: stats.n_rows,
            n_skipped_nonfinite: stats.n_skipped_nonfinite,
            n_truncated_rows,
            first_time_s: stats.first_time_s,
            last_time_s: stats.last_time_s,
            n_gaps: stats.n_gaps,
            max_interval_s: stats.max_interval_s,
            channel_ranges: stats.channel_ranges,
        }
    }

    /// The statistics of the raw rows (everything but `n_truncated_rows`).
    pub fn raw_stats(&self) -> RawStats {
        RawStats {
            n_rows: self.n_rows,
            n_skipped_nonfinite: self.n_skipped_nonfinite,
            first_time_s: self.first_time_s,
            last_time_s: self.last_time_s,
            n_gaps: self.n_gaps,
            max_interval_s: self.max_interval_s,
            channel_ranges: self.channel_ranges.clone(),
        }
    }
}

const BATCH_ROWS: usize = 8192;
/// Values (rows x channels) per batch: a wide header gets fewer rows per batch,
/// so the batch stays about 0.5 MB whatever the column count.
const BATCH_VALUES: usize = BATCH_ROWS * 8;
/// Longest accepted line, bytes. A longer one (a binary file, or a log without
/// line ends) is an error instead of being buffered whole.
pub const MAX_LINE_BYTES: usize = 1 << 20;
/// The body's read buffer, bytes: small enough that the bytes read stay in the
/// core's cache until they are parsed; it grows for a longer line.
const BLOCK_BYTES: usize = 1 << 17;
/// Header names shown in a "missing column" message.
const MAX_NAMES_SHOWN: usize = 32;

/// A value as a message shows it: plain, or in exponent form when huge (`1e30`).
fn shown_value(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Lowest temperature a log may hold, °C (absolute zero): below it a cell is corrupt.
pub const MIN_TEMPERATURE_C: f64 = -273.15;

/// Highest temperature a log may hold, °C: far above any chamber's or part's rating
/// (a logger's garbage, or a temperature in another unit, reads beyond it).
pub const MAX_TEMPERATURE_C: f64 = 1000.0;

/// Most lines read looking for the header below a preamble ([`read_header`]).
pub const MAX_PREAMBLE_LINES: u64 = 64;

/// Read one line (with its `\n`, if any) into `line`; `Ok(0)` at the end of input.
/// `line_no` is the number of the line being read, for the error message.
fn read_line<R: BufRead>(
    reader: &mut R,
    line: &mut Vec<u8>,
    path: &str,
    line_no: u64,
) -> Result<usize> {
    line.clear();
    let n = reader
        .by_ref()
        .take(MAX_LINE_BYTES as u64 + 1)
        .read_until(b'\n', line)
        .map_err(|e| io_error(path, &e))?;
    if n > MAX_LINE_BYTES && line.last() != Some(&b'\n') {
        return Err(line_too_long(path, line_no));
    }
    Ok(n)
}

/// The error for a line over [`MAX_LINE_BYTES`] (a binary file, or no line ends).
fn line_too_long(path: &str, line_no: u64) -> Error {
    parse_error(
        path,
        line_no,
        1,
        format!(
            "line longer than {MAX_LINE_BYTES} bytes: not a delimited text log \
             (binary data, or missing line ends?)"
        ),
    )
}

fn io_error(path: &str, err: &std::io::Error) -> Error {
    Error::Io {
        path: path.to_string(),
        reason: err.to_string(),
    }
}

fn parse_error(path: &str, line: u64, column: u64, reason: String) -> Error {
    Error::Parse {
        path: path.to_string(),
        line,
        column,
        reason,
    }
}

/// Parse one cell; empty is NaN (missing).
#[inline]
fn parse_cell(cell: &[u8]) -> Option<f64> {
    let cell = cell.trim_ascii();
    if cell.is_empty() {
        return Some(f64::NAN);
    }
    parse_plain_decimal(cell).or_else(|| fast_float2::parse::<f64, _>(cell).ok())
}

/// Split and parse one row in a single pass over its bytes: most cells are plain
/// decimals, parsed while scanning for the delimiter; any other cell is cut at the
/// next delimiter (`memchr`) and given to [`parse_cell`]. Returns the number of
/// fields (`fields.len() + 1` when there are more), or the index and text of a
/// cell that is not a number. Empty cells are NaN, as in [`parse_cell`].
fn parse_row<'a>(
    text: &'a [u8],
    delimiter: u8,
    fields: &mut [f64],
) -> std::result::Result<usize, (usize, &'a [u8])> {
    let mut pos = 0;
    for (i, slot) in fields.iter_mut().enumerate() {
        let (value, end) = if let Some(fast) = scan_plain(text, pos, delimiter) {
            fast
        } else {
            let end = memchr::memchr(delimiter, &text[pos..]).map_or(text.len(), |k| pos + k);
            let cell = &text[pos..end];
            (parse_cell(cell).ok_or((i, cell))?, end)
        };
        *slot = value;
        if end >= text.len() {
            return Ok(i + 1);
        }
        pos = end + 1;
    }
    Ok(fields.len() + 1)
}

/// The plain-decimal fast path of [`parse_plain_decimal`], scanning from `pos` to
/// the delimiter or the end of the row. Returns the value and where it stopped.
#[inline]
fn scan_plain(text: &[u8], pos: usize, delimiter: u8) -> Option<(f64, usize)> {
    let mut k = pos;
    let negative = match text.get(k) {
        Some(b'-') => {
            k += 1;
            true
        }
        Some(b'+') => {
            k += 1;
            false
        }
        _ => false,
    };
    let mut mantissa: u64 = 0;
    let mut n_digits = 0usize;
    let mut fraction_digits = 0usize;
    let mut seen_point = false;
    while let Some(&b) = text.get(k) {
        let d = b.wrapping_sub(b'0');
        if d < 10 {
            mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
            n_digits += 1;
            fraction_digits += usize::from(seen_point);
        } else if b == b'.' && !seen_point {
            seen_point = true;
        } else if b == delimiter {
            break;
        } else {
            return None;
        }
        k += 1;
    }
    if n_digits == 0 || n_digits > 15 {
        return None;
    }
    let value = mantissa as f64 / POW10[fraction_digits];
    Some((if negative { -value } else { value }, k))
}

/// Exact powers of ten up to 10^15 (all exactly representable in f64).
const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// Fast path for the cells logs are made of: `[+-]digits[.digits]` with at most
/// 15 digits in all. The digits form an integer `m < 10^15 < 2^53` and the value
/// is `m / 10^k` with both operands exact, so one correctly rounded IEEE division
/// gives the correctly rounded decimal value (Clinger's fast path): bit for bit
/// what a full parser returns. Anything else (exponents, more digits, `nan`,
/// `inf`) returns None and goes to the full parser.
#[inline]
fn parse_plain_decimal(cell: &[u8]) -> Option<f64> {
    let (negative, digits) = match cell.first() {
        Some(b'-') => (true, &cell[1..]),
        Some(b'+') => (false, &cell[1..]),
        _ => (false, cell),
    };
    if digits.is_empty() || digits.len() > 16 {
        return None;
    }
    let mut mantissa: u64 = 0;
    let mut n_digits = 0usize;
    let mut point: Option<usize> = None;
    for (i, &b) in digits.iter().enumerate() {
        let d = b.wrapping_sub(b'0');
        if d < 10 {
            mantissa = mantissa * 10 + u64::from(d);
            n_digits += 1;
        } else if b == b'.' && point.is_none() {
            point = Some(i);
        } else {
            return None;
        }
    }
    if n_digits == 0 || n_digits > 15 {
        return None;
    }
    let fraction_digits = point.map_or(0, |p| digits.len() - p - 1);
    let value = mantissa as f64 / POW10[fraction_digits];
    Some(if negative { -value } else { value })
}

/// Where parsed rows go: the raw-row tally and the batch of rows for the decimator.
struct RowSink<'a> {
    tally: RunTally,
    batch: Batch,
    decimator: Decimator,
    time_scale_to_s: f64,
    /// 1-based field index of the time column, for error messages.
    time_field: u64,
    path: &'a str,
    columns: &'a ColumnMap,
}

impl RowSink<'_> {
    /// Where the next row's fields go (header order), parsed in place.
    #[inline]
    fn slot(&mut self) -> &mut [f64] {
        let batch = &mut self.batch;
        let start = batch.filled * batch.n_fields;
        &mut batch.raw[start..start + batch.n_fields]
    }

    /// Keep the row parsed into [`Self::slot`], read from line `line_no`.
    #[inline]
    fn commit(&mut self, line_no: u64) -> Result<()> {
        let batch = &mut self.batch;
        batch.lines.push(line_no);
        batch.filled += 1;
        if batch.filled == batch.rows {
            batch.flush(
                self.columns,
                self.time_scale_to_s,
                &mut self.tally,
                &mut self.decimator,
                self.path,
                self.time_field,
            )?;
        }
        Ok(())
    }

    /// Take one row parsed elsewhere (`fields` in header order) read from line `line_no`.
    fn take(&mut self, fields: &[f64], line_no: u64) -> Result<()> {
        self.slot().copy_from_slice(fields);
        self.commit(line_no)
    }
}

/// Lines straight out of a large block buffer: no copy per line, and the line
/// end is found with `memchr` (SIMD) rather than byte by byte. A line longer than
/// [`MAX_LINE_BYTES`] is an error, as with [`read_line`].
struct BlockLines<R> {
    reader: R,
    buf: Vec<u8>,
    start: usize,
    end: usize,
    eof: bool,
}

impl<R: Read> BlockLines<R> {
    fn new(reader: R) -> Self {
        Self {
            reader,
            buf: vec![0; BLOCK_BYTES],
            start: 0,
            end: 0,
            eof: false,
        }
    }

    /// The buffered bytes not handed out yet (whole lines, then maybe part of one).
    fn pending(&self) -> &[u8] {
        &self.buf[self.start..self.end]
    }

    /// Mark the first `n` bytes of [`Self::pending`] as read.
    fn consume(&mut self, n: usize) {
        self.start += n;
    }

    /// The next line including its `\n` (the last line may lack it), or None at the end.
    fn next_line(&mut self, path: &str, line_no: u64) -> Result<Option<&[u8]>> {
        loop {
            if let Some(pos) = memchr::memchr(b'\n', &self.buf[self.start..self.end]) {
                let line_start = self.start;
                self.start += pos + 1;
                return Ok(Some(&self.buf[line_start..self.start]));
            }
            if self.eof {
                if self.start == self.end {
                    return Ok(None);
                }
                let line_start = self.start;
                self.start = self.end;
                return Ok(Some(&self.buf[line_start..self.end]));
            }
            if self.end - self.start > MAX_LINE_BYTES {
                return Err(line_too_long(path, line_no));
            }
            self.buf.copy_within(self.start..self.end, 0);
            self.end -= self.start;
            self.start = 0;
            if self.end == self.buf.len() {
                // A line longer than the buffer: grow it, up to the longest line accepted.
                let longer = (2 * self.buf.len()).min(MAX_LINE_BYTES + (1 << 16));
                self.buf.resize(longer, 0);
            }
            let n = loop {
                match self.reader.read(&mut self.buf[self.end..]) {
                    Ok(n) => break n,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(io_error(path, &e)),
                }
            };
            if n == 0 {
                self.eof = true;
            } else {
                self.end += n;
            }
        }
    }
}

fn split_fields(line: &[u8], delimiter: u8) -> impl Iterator<Item = &[u8]> {
    line.split(move |&b| b == delimiter)
}

fn strip_line_end(line: &[u8]) -> &[u8] {
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    line.strip_suffix(b"\r").unwrap_or(line)
}

/// Where each wanted column sits in a row, from the header.
struct ColumnMap {
    time: usize,
    temperature: usize,
    /// The temperature column's name; None when the log has none (the time column
    /// stands in its place).
    temperature_name: Option<String>,
    /// Field index of every decimated channel, required first.
    channels: Vec<usize>,
    names: Vec<String>,
}

/// Where each wanted column is. Missing columns are reported first, then a repeated
/// name (see [`check_unique_names`]).
fn map_columns(
    path: &str,
    header: &[String],
    header_line: u64,
    format: &CsvFormat,
) -> Result<ColumnMap> {
    let find = |name: &str| header.iter().position(|h| h == name);
    let mut missing = Vec::new();
    let mut need = |name: &str| {
        let found = find(name);
        // A name asked for twice (the time and the temperature both "n") is missing once.
        if found.is_none() && !missing.iter().any(|m| m == name) {
            missing.push(name.to_string());
        }
        found.unwrap_or(0)
    };
    let time = need(&format.time_column);
    let temperature = need(&format.temperature_column);
    let mut channels: Vec<usize> = format.channel_columns.iter().map(|c| need(c)).collect();
    if !missing.is_empty() {
        let mut reason = format!(
            "missing column(s) {} in the header; found {}",
            missing
                .iter()
                .map(|m| format!("'{m}'"))
                .collect::<Vec<_>>()
                .join(", "),
            header
                .iter()
                .take(MAX_NAMES_SHOWN)
                .map(|m| format!("'{m}'"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        if header.len() > MAX_NAMES_SHOWN {
            reason.push_str(", ... (");
            reason.push_str(&header.len().to_string());
            reason.push_str(" in all)");
        }
        if header.len() == 1 {
            for (d, name) in [(b',', "','"), (b'\t', "tab"), (b';', "';'")] {
                if d != format.delimiter && header[0].as_bytes().contains(&d) {
                    reason.push_str("; the header is one field containing ");
                    reason.push_str(name);
                    reason.push_str(": is the delimiter ");
                    reason.push_str(name);
                    reason.push('?');
                }
            }
        }
        return Err(parse_error(path, 1, 1, reason));
    }
    check_unique_names(path, header_line, header)?;
    let mut names = format.channel_columns.clone();
    if format.keep_extra_columns {
        // A mask, not `channels.contains`: linear in the header width.
        let mut used = vec![false; header.len()];
        for &i in [time, temperature].iter().chain(&channels) {
            used[i] = true;
        }
        for (i, h) in header.iter().enumerate() {
            if !used[i] {
                channels.push(i);
                names.push(h.clone());
            }
        }
    }
    Ok(ColumnMap {
        time,
        temperature,
        temperature_name: (temperature != time).then(|| header[temperature].clone()),
        channels,
        names,
    })
}

/// A batch of parsed rows waiting to be pushed: the fields as parsed, row after
/// row, and at the flush the columns the decimator takes, column by column.
struct Batch {
    /// Rows per batch (see [`BATCH_VALUES`]).
    rows: usize,
    /// Fields per row (the header's).
    n_fields: usize,
    /// `rows` rows of `n_fields` values; the first `filled` are parsed rows.
    raw: Vec<f64>,
    filled: usize,
    time_s: Vec<f64>,
    temperature_c: Vec<f64>,
    channels: Vec<f64>,
    lines: Vec<u64>,
}

impl Batch {
    fn new(n_fields: usize, n_channels: usize) -> Self {
        let rows = (BATCH_VALUES / n_fields.max(1)).clamp(1, BATCH_ROWS);
        Self {
            rows,
            n_fields,
            raw: vec![0.0; rows * n_fields],
            filled: 0,
            time_s: Vec::with_capacity(rows),
            temperature_c: Vec::with_capacity(rows),
            channels: Vec::with_capacity(rows * n_channels),
            lines: Vec::with_capacity(rows),
        }
    }

    /// Gather the rows' time (scaled to s), temperature and channels, tally them,
    /// then push them to the decimator.
    fn flush(
        &mut self,
        columns: &ColumnMap,
        time_scale_to_s: f64,
        tally: &mut RunTally,
        decimator: &mut Decimator,
        path: &str,
        time_field: u64,
    ) -> Result<()> {
        let n_channels = columns.channels.len();
        self.time_s.clear();
        self.temperature_c.clear();
        self.channels.clear();
        if self.n_fields > 0 {
            let rows = self.raw[..self.filled * self.n_fields].chunks_exact(self.n_fields);
            for row in rows {
                self.time_s.push(row[columns.time] * time_scale_to_s);
                self.temperature_c.push(row[columns.temperature]);
                self.channels
                    .extend(columns.channels.iter().map(|&i| row[i]));
            }
        }
        if let Some(name) = &columns.temperature_name {
            // A value no thermometer reads is a corrupt cell, not a temperature: one
            // would poison its block's mean (and every bin and fit after it).
            if let Some(k) = self.temperature_c.iter().position(|&t| {
                t.is_finite() && !(MIN_TEMPERATURE_C..=MAX_TEMPERATURE_C).contains(&t)
            }) {
                return Err(parse_error(
                    path,
                    self.lines.get(k).copied().unwrap_or(0),
                    columns.temperature as u64 + 1,
                    format!(
                        "column '{name}': {} is not a temperature in °C (below absolute zero \
                         or above {MAX_TEMPERATURE_C} °C): a corrupt cell, or another unit",
                        shown_value(self.temperature_c[k])
                    ),
                ));
            }
        }
        let n = self.time_s.len();
        tally.push_rows(&self.time_s, &self.temperature_c, &self.channels);
        let view = ArrayView2::from_shape((n, n_channels), &self.channels).map_err(|e| {
            Error::InvalidParameter {
                name: "channels",
                reason: e.to_string(),
            }
        })?;
        let before = decimator.n_samples();
        decimator
            .push(&self.time_s, &self.temperature_c, view)
            .map_err(|e| match e {
                Error::TimeNotIncreasing {
                    index,
                    previous_s,
                    time_s,
                } => {
                    let local = (index - before) as usize;
                    let line = self.lines.get(local).copied().unwrap_or(0);
                    let what = if time_s == previous_s {
                        "repeats"
                    } else {
                        "goes backwards"
                    };
                    parse_error(
                        path,
                        line,
                        time_field,
                        format!("time {what}: {time_s} s after {previous_s} s"),
                    )
                }
                other => other,
            })?;
        self.lines.clear();
        self.filled = 0;
        Ok(())
    }
}

/// Read one log file and decimate it on the fly.
pub fn read_run(path: &Path, format: &CsvFormat, decimator: DecimatorConfig) -> Result<RunData> {
    let shown = path.display().to_string();
    let file = File::open(path).map_err(|e| io_error(&shown, &e))?;
    read_run_from(file, &shown, format, decimator)
}

/// The content digest taken of a log as it is read (provenance).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum DigestAlgorithm {
    /// BLAKE3 (256-bit output), the default: a tree hash, vectorised inside the
    /// `blake3` crate, several times faster than SHA-256.
    #[default]
    Blake3,
    /// SHA-256 (FIPS 180-4), for users who need it.
    Sha256,
}

impl DigestAlgorithm {
    /// The algorithm's name as recorded in provenance: `"blake3"` or `"sha256"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Blake3 => "blake3",
            Self::Sha256 => "sha256",
        }
    }

    /// The algorithm named `name` (`"blake3"` or `"sha256"`, as [`Self::name`] gives).
    ///
    /// Errors: [`Error::InvalidParameter`] for any other name.
    pub fn from_name(name: &str) -> Result<Self> {
        match name {
            "blake3" => Ok(Self::Blake3),
            "sha256" => Ok(Self::Sha256),
            other => Err(Error::InvalidParameter {
                name: "digest",
                reason: format!("must be \"blake3\" or \"sha256\", got {other:?}"),
            }),
        }
    }

    /// The one-shot digest of `data` (the reference the streamed digest must equal).
    pub fn digest(self, data: &[u8]) -> [u8; 32] {
        let mut hasher = Hasher::new(self);
        hasher.update(data);
        hasher.finalize()
    }
}

/// An incremental hasher of either algorithm.
enum Hasher {
    Blake3(Box<blake3::Hasher>),
    Sha256(Sha256),
}

impl Hasher {
    fn new(algorithm: DigestAlgorithm) -> Self {
        match algorithm {
            DigestAlgorithm::Blake3 => Self::Blake3(Box::new(blake3::Hasher::new())),
            DigestAlgorithm::Sha256 => Self::Sha256(Sha256::new()),
        }
    }

    fn update(&mut self, bytes: &[u8]) {
        match self {
            Self::Blake3(h) => {
                h.update(bytes);
            }
            Self::Sha256(h) => h.update(bytes),
        }
    }

    fn finalize(self) -> [u8; 32] {
        match self {
            Self::Blake3(h) => *h.finalize().as_bytes(),
            Self::Sha256(h) => h.finalize().into(),
        }
    }
}

/// [`read_run`], and the SHA-256 of the file's bytes, hashed as they are parsed
/// ([`read_run_digest`] with [`DigestAlgorithm::Sha256`]).
pub fn read_run_hashed(
    path: &Path,
    format: &CsvFormat,
    decimator: DecimatorConfig,
) -> Result<(RunData, [u8; 32])> {
    read_run_digest(path, format, decimator, DigestAlgorithm::Sha256)
}

/// [`read_run`], and the digest of the file's bytes, hashed as they are parsed:
/// the digest is that of exactly the bytes the result was read from, even if the
/// file is being appended to meanwhile (bytes after a cut-off last line included).
/// The reader's buffer is 128 KiB, so each update hands the hasher a large slice
/// (BLAKE3 hashes many 1 KiB chunks of it at once with SIMD).
pub fn read_run_digest(
    path: &Path,
    format: &CsvFormat,
    decimator: DecimatorConfig,
    algorithm: DigestAlgorithm,
) -> Result<(RunData, [u8; 32])> {
    let shown = path.display().to_string();
    let file = File::open(path).map_err(|e| io_error(&shown, &e))?;
    let mut hashing = HashingReader {
        inner: file,
        hasher: Hasher::new(algorithm),
    };
    let run = read_run_from(&mut hashing, &shown, format, decimator)?;
    // The reader stops at the end of the file; this only makes sure of it.
    std::io::copy(&mut hashing, &mut std::io::sink()).map_err(|e| io_error(&shown, &e))?;
    Ok((run, hashing.hasher.finalize()))
}

/// A reader that feeds every byte it returns to a hasher.
struct HashingReader<R> {
    inner: R,
    hasher: Hasher,
}

impl<R: Read> Read for HashingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }
}

/// Read a log from any reader (`path` is only used in messages).
pub fn read_run_from<R: Read>(
    reader: R,
    path: &str,
    format: &CsvFormat,
    decimator: DecimatorConfig,
) -> Result<RunData> {
    check_format(format)?;
    // Small: only the header is read through it; the body's reads bypass it.
    let mut reader = BufReader::with_capacity(1 << 13, reader);
    let (header, header_line, _) = read_header(&mut reader, path, format)?;
    read_body(
        reader,
        path,
        format,
        header,
        header_line,
        Some(header_line),
        decimator,
        false,
    )
}

fn check_format(format: &CsvFormat) -> Result<()> {
    if !(format.time_scale_to_s.is_finite() && format.time_scale_to_s > 0.0) {
        return Err(Error::InvalidParameter {
            name: "time_scale_to_s",
            reason: format!("must be finite and > 0, got {}", format.time_scale_to_s),
        });
    }
    Ok(())
}

/// Read the header: the first line that names every required column, within the first
/// [`MAX_PREAMBLE_LINES`] lines (a logger's preamble of settings lines above it,
/// `Fs,100`, is skipped); blank lines are skipped. When no line names them all, the
/// first non-blank line is the header, and [`map_columns`] says what it lacks.
/// Returns the header's names, its line number and the bytes consumed through it.
fn read_header<R: BufRead>(
    reader: &mut R,
    path: &str,
    format: &CsvFormat,
) -> Result<(Vec<String>, u64, u64)> {
    let mut line = Vec::with_capacity(256);
    let mut line_no: u64 = 0;
    let mut consumed: u64 = 0;
    let mut first: Option<(Vec<String>, u64, u64)> = None;
    loop {
        let n = read_line(reader, &mut line, path, line_no + 1)?;
        if n == 0 {
            return first.ok_or_else(|| {
                parse_error(path, line_no.max(1), 1, "empty file: no header".into())
            });
        }
        consumed += n as u64;
        line_no += 1;
        let mut text = strip_line_end(&line);
        if line_no == 1 {
            text = text.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(text);
        }
        if text.trim_ascii().is_empty() {
            continue;
        }
        let names = match std::str::from_utf8(text) {
            Ok(text) => text
                .split(format.delimiter as char)
                .map(|h| h.trim().to_string())
                .collect::<Vec<_>>(),
            // A preamble line may be anything; a header must be UTF-8.
            Err(e) if first.is_none() => {
                return Err(parse_error(
                    path,
                    line_no,
                    1,
                    format!("header is not valid UTF-8: {e}"),
                ))
            }
            Err(_) => Vec::new(),
        };
        if names_required(&names, format) {
            return Ok((names, line_no, consumed));
        }
        if first.is_none() {
            first = Some((names, line_no, consumed));
        }
        if line_no >= MAX_PREAMBLE_LINES {
            // No header below a preamble: the first line is the header. It lacks
            // required columns, which `map_columns` names; the data start after it.
            return Ok(first.expect("set on the first non-blank line"));
        }
    }
}

/// Whether a line's names hold every column the format requires.
fn names_required(names: &[String], format: &CsvFormat) -> bool {
    let has = |c: &str| names.iter().any(|h| h == c);
    has(&format.time_column)
        && has(&format.temperature_column)
        && format.channel_columns.iter().all(|c| has(c))
}

/// Refuse a header that repeats a name: otherwise the first column of that name
/// would be read in silence and the other ignored. The error names the second
/// occurrence's column. A map, not a pairwise scan: linear in the header width.
fn check_unique_names(path: &str, line_no: u64, header: &[String]) -> Result<()> {
    let mut seen: HashMap<&str, usize> = HashMap::with_capacity(header.len());
    for (i, name) in header.iter().enumerate() {
        if let Some(&first) = seen.get(name.as_str()) {
            return Err(parse_error(
                path,
                line_no,
                i as u64 + 1,
                format!(
                    "column name '{name}' appears twice in the header (columns {} and {}); \
                     every column needs a distinct name",
                    first + 1,
                    i + 1
                ),
            ));
        }
        seen.insert(name, i);
    }
    Ok(())
}

/// The data lines after the header. `first_line` is the line number of the line
/// before the first one read (None when reading a piece whose position in lines is
/// unknown: errors then count lines relative to the piece, fixed up by the caller).
#[allow(clippy::too_many_lines)]
fn read_body<R: BufRead>(
    mut reader: R,
    path: &str,
    format: &CsvFormat,
    header: Vec<String>,
    header_line: u64,
    first_line: Option<u64>,
    decimator: DecimatorConfig,
    allow_empty: bool,
) -> Result<RunData> {
    let mut line_no: u64 = first_line.unwrap_or(0);
    let columns = map_columns(path, &header, header_line, format)?;
    let n_fields = header.len();
    let n_channels = columns.channels.len();
    let decimator = Decimator::new(DecimatorConfig {
        n_channels,
        ..decimator
    })?;
    let mut sink = RowSink {
        tally: RunTally::new(n_channels, decimator.config().rate_hz)?,
        batch: Batch::new(n_fields, n_channels),
        decimator,
        time_scale_to_s: format.time_scale_to_s,
        time_field: columns.time as u64 + 1,
        path,
        columns: &columns,
    };
    let mut fields: Vec<f64> = vec![0.0; n_fields];
    let mut layouts = vec![Layout::default(); n_fields];
    let mut n_truncated = 0u64;
    let fast = fast_delimiter(format.delimiter);
    let mut lines = BlockLines::new(&mut reader);
    loop {
        if fast {
            // Every row the fast path takes, straight from the buffer: no line search.
            let mut used = 0;
            while let Some(n) = parse_line_fast(
                &lines.pending()[used..],
                format.delimiter,
                sink.slot(),
                &mut layouts,
            ) {
                used += n;
                line_no += 1;
                sink.commit(line_no)?;
            }
            lines.consume(used);
        }
        // Anything else (blank lines, other cells, errors, a line cut by the
        // buffer's end) one line at a time.
        let Some(line) = lines.next_line(path, line_no + 1)? else {
            break;
        };
        line_no += 1;
        let ends_with_newline = line.last() == Some(&b'\n');
        let text = strip_line_end(line);
        if text.trim_ascii().is_empty() {
            continue;
        }
        let count = match parse_row(text, format.delimiter, &mut fields) {
            Ok(count) => count,
            Err((i, cell)) => {
                let shown = String::from_utf8_lossy(cell.trim_ascii());
                let name = &header[i];
                return Err(parse_error(
                    path,
                    line_no,
                    i as u64 + 1,
                    format!("column '{name}': '{shown}' is not a number"),
                ));
            }
        };
        if count != n_fields {
            if count < n_fields && !ends_with_newline {
                n_truncated += 1;
                break;
            }
            return Err(parse_error(
                path,
                line_no,
                count.min(n_fields + 1) as u64,
                format!(
                    "{count}{} fields where the header (line {header_line}) has {n_fields}",
                    if count > n_fields { "+" } else { "" }
                ),
            ));
        }
        sink.take(&fields, line_no)?;
    }
    let RowSink {
        mut tally,
        mut batch,
        mut decimator,
        time_field,
        time_scale_to_s,
        ..
    } = sink;
    batch.flush(
        &columns,
        time_scale_to_s,
        &mut tally,
        &mut decimator,
        path,
        time_field,
    )?;
    let stats = tally.finish();
    let n_rows = stats.n_rows;
    if n_rows == 0 && !allow_empty {
        return Err(parse_error(
            path,
            header_line,
            1,
            "no data rows after the header".into(),
        ));
    }
    let blocks = if allow_empty && decimator.n_samples() == decimator.n_skipped_nonfinite() {
        DecimatedBlocks {
            n_channels,
            ..DecimatedBlocks::default()
        }
    } else {
        decimator.finish().map_err(|_| {
            parse_error(
                path,
                header_line + 1,
                1,
                format!("none of the {n_rows} rows has finite values in every column"),
            )
        })?
    };
    Ok(RunData::new(
        header,
        columns.names,
        blocks,
        stats,
        n_truncated,
    ))
}

/// How to read one log in pieces: byte ranges that start at line starts, and the
/// time of the first data row, which every piece must use as the block grid's
/// origin (`DecimatorConfig::t0_s`) so that blocks line up across pieces.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitPlan {
    /// `[start, end)` byte ranges covering every data line once, in file order.
    pub ranges: Vec<(u64, u64)>,
    /// Time of the first data row with a finite time, seconds; None if there is none.
    pub t0_s: Option<f64>,
}

/// Plan the reading of one log in up to `pieces` parallel pieces (see [`SplitPlan`]).
pub fn plan_split(path: &Path, format: &CsvFormat, pieces: usize) -> Result<SplitPlan> {
    use std::io::{Seek, SeekFrom};
    check_format(format)?;
    if pieces == 0 {
        return Err(Error::InvalidParameter {
            name: "pieces",
            reason: "must be >= 1".into(),
        });
    }
    let shown = path.display().to_string();
    let file = File::open(path).map_err(|e| io_error(&shown, &e))?;
    let size = file.metadata().map_err(|e| io_error(&shown, &e))?.len();
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let (header, header_line, data_start) = read_header(&mut reader, &shown, format)?;
    let columns = map_columns(&shown, &header, header_line, format)?;
    // The first finite time: the block grid's origin of a one-pass read.
    let mut t0_s = None;
    let mut line = Vec::with_capacity(256);
    let mut line_no = header_line;
    loop {
        let n = read_line(&mut reader, &mut line, &shown, line_no + 1)?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let cell = split_fields(strip_line_end(&line), format.delimiter).nth(columns.time);
        if let Some(t) = cell
            .and_then(parse_cell)
            .map(|t| t * format.time_scale_to_s)
        {
            if t.is_finite() {
                t0_s = Some(t);
                break;
            }
        }
    }
    let mut file = reader.into_inner();
    let mut bounds = vec![data_start];
    for k in 1..pieces as u64 {
        let guess = data_start + (size - data_start) * k / pieces as u64;
        if guess <= *bounds.last().unwrap_or(&data_start) || guess >= size {
            continue;
        }
        file.seek(SeekFrom::Start(guess - 1))
            .map_err(|e| io_error(&shown, &e))?;
        let mut rest = BufReader::with_capacity(1 << 16, &mut file);
        let n = read_line(&mut rest, &mut line, &shown, 0)?;
        let aligned = guess - 1 + n as u64;
        if aligned > *bounds.last().unwrap_or(&data_start) && aligned < size {
            bounds.push(aligned);
        }
    }
    bounds.push(size);
    let ranges = bounds.windows(2).map(|w| (w[0], w[1])).collect();
    Ok(SplitPlan { ranges, t0_s })
}

/// Read the data lines in the byte range `[start, end)` of a log (a range of a
/// [`SplitPlan`]); the header is read from the top of the file. `decimator.t0_s`
/// must be the plan's `t0_s` and `min_count` 1, so that the pieces' blocks can be
/// combined by [`merge_runs`]. A piece may hold no data. Errors name the line in
/// the whole file.
pub fn read_run_range(
    path: &Path,
    format: &CsvFormat,
    decimator: DecimatorConfig,
    start: u64,
    end: u64,
) -> Result<RunData> {
    use std::io::{Seek, SeekFrom};
    check_format(format)?;
    if decimator.t0_s.is_none() {
        return Err(Error::InvalidParameter {
            name: "t0_s",
            reason: "a piece of a log needs the log's block origin (SplitPlan::t0_s)".into(),
        });
    }
    let shown = path.display().to_string();
    let file = File::open(path).map_err(|e| io_error(&shown, &e))?;
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let (header, header_line, data_start) = read_header(&mut reader, &shown, format)?;
    // Header errors here, where their line is known (the body's are counted from `start`).
    map_columns(&shown, &header, header_line, format)?;
    let start = start.max(data_start);
    let mut file = reader.into_inner();
    file.seek(SeekFrom::Start(start))
        .map_err(|e| io_error(&shown, &e))?;
    let body = BufReader::with_capacity(1 << 13, file.take(end.saturating_sub(start)));
    let first_line = (start == data_start).then_some(header_line);
    read_body(
        body,
        &shown,
        format,
        header,
        header_line,
        first_line,
        decimator,
        true,
    )
    .map_err(|err| match err {
        Error::Parse {
            path,
            line,
            column,
            reason,
        } if first_line.is_none() => {
            // Lines were counted from the piece's start: add the lines before it.
            let before = count_newlines(&shown, start).unwrap_or(0);
            Error::Parse {
                path,
                line: line + before,
                column,
                reason,
            }
        }
        other => other,
    })
}

/// Number of `\n` bytes in the first `limit` bytes of a file.
fn count_newlines(path: &str, limit: u64) -> Result<u64> {
    let file = File::open(path).map_err(|e| io_error(path, &e))?;
    let mut reader = BufReader::with_capacity(1 << 20, file.take(limit));
    let mut total = 0u64;
    loop {
        let buf = reader.fill_buf().map_err(|e| io_error(path, &e))?;
        if buf.is_empty() {
            return Ok(total);
        }
        // Runs once, on an error only: a plain count is enough (no bytecount dependency).
        #[allow(clippy::naive_bytecount)]
        let found = buf.iter().filter(|&&b| b == b'\n').count() as u64;
        total += found;
        let n = buf.len();
        reader.consume(n);
    }
}

/// Combine the pieces of one log, read by [`read_run_range`] in file order, into
/// the result of one pass: blocks cut by a piece boundary are joined (means
/// weighted by their counts), then blocks under `min_count` samples are dropped;
/// counters add, and the interval across each boundary counts for gaps.
pub fn merge_runs(pieces: &[RunData], min_count: usize, rate_hz: f64) -> Result<RunData> {
    let Some(first) = pieces.first() else {
        return Err(Error::Empty {
            what: "merge_runs: no pieces",
        });
    };
    let nc = first.blocks.n_channels;
    let mut tally = RunTally::new(first.channel_ranges.len(), rate_hz)?;
    let mut n_truncated = 0u64;
    let mut blocks = DecimatedBlocks {
        n_channels: nc,
        ..DecimatedBlocks::default()
    };
    let b = &mut blocks;
    for piece in pieces {
        if piece.channel_names != first.channel_names || piece.blocks.n_channels != nc {
            return Err(Error::Incompatible {
                reason: "pieces of one log must have the same columns".into(),
            });
        }
        let p = &piece.blocks;
        for k in 0..p.block_index.len() {
            let (idx, count) = (p.block_index[k], p.count[k]);
            let row = &p.channels[k * nc..(k + 1) * nc];
            if b.block_index.last() == Some(&idx) {
                let j = b.block_index.len() - 1;
                let (c0, c1) = (b.count[j] as f64, count as f64);
                let total = c0 + c1;
                let mix = |a: f64, x: f64| (a * c0 + x * c1) / total;
                b.time_s[j] = mix(b.time_s[j], p.time_s[k]);
                b.temperature_c[j] = mix(b.temperature_c[j], p.temperature_c[k]);
                for (a, &x) in b.channels[j * nc..(j + 1) * nc].iter_mut().zip(row) {
                    *a = mix(*a, x);
                }
                b.count[j] += count;
            } else if b.block_index.last().is_some_and(|&last| last > idx) {
                return Err(Error::Incompatible {
                    reason: "pieces are not in file order (or overlap)".into(),
                });
            } else {
                b.block_index.push(idx);
                b.count.push(count);
                b.time_s.push(p.time_s[k]);
                b.temperature_c.push(p.temperature_c[k]);
                b.channels.extend_from_slice(row);
            }
        }
        tally.merge(&RunTally::resume(piece.raw_stats(), rate_hz)?)?;
        n_truncated += piece.n_truncated_rows;
    }
    // Drop blocks under min_count, now that cut blocks are whole again.
    let keep: Vec<bool> = b.count.iter().map(|&c| c >= min_count as u64).collect();
    let mut j = 0;
    for (k, &kept) in keep.iter().enumerate() {
        if kept {
            b.block_index[j] = b.block_index[k];
            b.count[j] = b.count[k];
            b.time_s[j] = b.time_s[k];
            b.temperature_c[j] = b.temperature_c[k];
            b.channels.copy_within(k * nc..(k + 1) * nc, j * nc);
            j += 1;
        }
    }
    b.block_index.truncate(j);
    b.count.truncate(j);
    b.time_s.truncate(j);
    b.temperature_c.truncate(j);
    b.channels.truncate(j * nc);
    if j == 0 {
        return Err(Error::Empty {
            what: "merge_runs: no block with enough valid samples",
        });
    }
    Ok(RunData::new(
        first.header.clone(),
        first.channel_names.clone(),
        blocks,
        tally.finish(),
        n_truncated,
    ))
}

#[cfg(test)]
mod plain_decimal_tests {
    use super::parse_plain_decimal;
    use proptest::prelude::*;

    fn full(s: &str) -> Option<f64> {
        fast_float2::parse::<f64, _>(s.as_bytes()).ok()
    }

    #[test]
    fn examples_match_the_full_parser_bit_for_bit() {
        for s in [
            "0",
            "-0",
            "0.05",
            "-1.906",
            "1.496582",
            "16714",
            "-16534",
            "+3.5",
            "1.",
            ".5",
            "-.25",
            "123456789012345",
            "0.00000000000001",
            "9.99999999999999",
        ] {
            let fast = parse_plain_decimal(s.as_bytes()).expect(s);
            assert_eq!(fast.to_bits(), full(s).unwrap().to_bits(), "{s}");
        }
    }

    #[test]
    fn other_text_goes_to_the_full_parser() {
        for s in [
            "",
            ".",
            "-",
            "1e5",
            "nan",
            "inf",
            "1.2.3",
            "1,5",
            "1234567890123456",
            "0x10",
            "0.000000000000001",
        ] {
            assert!(parse_plain_decimal(s.as_bytes()).is_none(), "{s}");
        }
    }

    #[test]
    fn rows_parse_like_split_then_parse() {
        let mut f = [0.0; 4];
        assert_eq!(super::parse_row(b"1.5,-2,,nan", b',', &mut f), Ok(4));
        assert_eq!(f[0], 1.5);
        assert_eq!(f[1], -2.0);
        assert!(f[2].is_nan() && f[3].is_nan());
        assert_eq!(super::parse_row(b"1,2", b',', &mut f), Ok(2));
        assert_eq!(super::parse_row(b"1,2,3,4,5", b',', &mut f), Ok(5));
        assert_eq!(super::parse_row(b"1,2,", b',', &mut f), Ok(3));
        assert_eq!(super::parse_row(b" 1.5 ;1e3", b';', &mut f), Ok(2));
        assert_eq!(f[1], 1000.0);
        assert_eq!(
            super::parse_row(b"1,x2,3", b',', &mut f),
            Err((1, &b"x2"[..]))
        );
    }

    /// The obvious way: split at the delimiter, then parse each cell.
    fn split_then_parse(text: &[u8], fields: &mut [f64]) -> Result<usize, usize> {
        let mut count = 0;
        for (i, cell) in super::split_fields(text, b',').enumerate() {
            if i >= fields.len() {
                return Ok(fields.len() + 1);
            }
            fields[i] = super::parse_cell(cell).ok_or(i)?;
            count = i + 1;
        }
        Ok(count)
    }

    proptest! {
        #[test]
        fn one_pass_rows_equal_split_then_parse(
            cells in proptest::collection::vec(
                prop_oneof![
                    "[+-]?[0-9]{1,12}(\\.[0-9]{0,6})?",
                    "[+-]?[0-9]{1,3}\\.[0-9]{1,3}[eE][+-]?[0-9]{1,2}",
                    Just(String::new()),
                    Just(" 1.25 ".to_string()),
                    Just("nan".to_string()),
                    Just("-inf".to_string()),
                    "[0-9]{16,20}",
                    "[a-z.]{1,3}",
                ],
                1..8,
            ),
            n_fields in 1usize..8,
        ) {
            let row = cells.join(",");
            let (mut a, mut b) = (vec![0.0; n_fields], vec![0.0; n_fields]);
            let one = super::parse_row(row.as_bytes(), b',', &mut a).map_err(|(i, _)| i);
            let two = split_then_parse(row.as_bytes(), &mut b);
            prop_assert_eq!(one, two);
            if let Ok(n) = one {
                for k in 0..n.min(n_fields) {
                    prop_assert_eq!(a[k].to_bits(), b[k].to_bits(), "{} field {}", row, k);
                }
            }
        }

        #[test]
        fn random_decimals_match_the_full_parser(
            negative in any::<bool>(),
            int_part in "[0-9]{1,9}",
            frac_part in "[0-9]{0,8}",
        ) {
            let s = format!("{}{}.{}", if negative { "-" } else { "" }, int_part, frac_part);
            let fast = parse_plain_decimal(s.as_bytes());
            if let Some(v) = fast {
                prop_assert_eq!(v.to_bits(), full(&s).unwrap().to_bits(), "{}", s);
            }
        }
    }
}
