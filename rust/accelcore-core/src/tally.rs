//! What a run's raw samples looked like, before decimation: one accumulator,
//! [`RunTally`], shared by the session-log reader, the other readers (through
//! the bindings) and in-memory sessions.
//!
//! # Semantics
//!
//! - **Rows.** Every pushed row counts in [`RawStats::n_rows`]; a row whose time,
//!   temperature or any channel value is not finite also counts in
//!   [`RawStats::n_skipped_nonfinite`] (the [`crate::Decimator`]'s rule, so the two
//!   counts agree).
//! - **Time.** Over the rows with a finite time only: the first and last time
//!   (NaN when there is none), the longest interval between consecutive ones
//!   (0 when fewer than two) and the number of intervals longer than 1.5 nominal
//!   periods, `1.5 * (1 / rate_hz)` (gaps). Time order is not checked here: the
//!   decimator rejects it.
//! - **Channels.** Per channel, the smallest and largest finite value and how
//!   many values are exactly equal to each (many at one value: clipping at a
//!   rail). A channel without a finite value has `min = +inf`, `max = -inf` and
//!   zero counts.
//! - **Chunking and merging.** The result does not depend on how the rows were
//!   cut into `push` calls, and `a.merge(&b)`, with `b`'s rows following `a`'s,
//!   equals one pass over both (the interval across the cut counts as any other).

use ndarray::ArrayView2;

use crate::decimate::check_shapes;
use crate::error::{Error, Result};

/// Range of one channel's finite raw values, to detect clipping at the rails.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelRange {
    /// Smallest finite raw value.
    pub min: f64,
    /// Largest finite raw value.
    pub max: f64,
    /// Samples exactly equal to `min`.
    pub n_at_min: u64,
    /// Samples exactly equal to `max`.
    pub n_at_max: u64,
}

impl Default for ChannelRange {
    fn default() -> Self {
        Self {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
            n_at_min: 0,
            n_at_max: 0,
        }
    }
}

impl ChannelRange {
    /// Count one value (non-finite values are ignored).
    #[inline]
    pub fn push(&mut self, v: f64) {
        if !v.is_finite() {
            return;
        }
        if v < self.min {
            self.min = v;
            self.n_at_min = 1;
        } else if v == self.min {
            self.n_at_min += 1;
        }
        if v > self.max {
            self.max = v;
            self.n_at_max = 1;
        } else if v == self.max {
            self.n_at_max += 1;
        }
    }

    /// Add the values another range has counted.
    pub fn merge(&mut self, other: &ChannelRange) {
        if other.min < self.min {
            (self.min, self.n_at_min) = (other.min, other.n_at_min);
        } else if other.min == self.min {
            self.n_at_min += other.n_at_min;
        }
        if other.max > self.max {
            (self.max, self.n_at_max) = (other.max, other.n_at_max);
        } else if other.max == self.max {
            self.n_at_max += other.n_at_max;
        }
    }
}

/// Whether every value is finite (no early exit: the loop vectorises).
#[inline]
fn all_finite(values: &[f64]) -> bool {
    values.iter().fold(true, |all, v| all & v.is_finite())
}

/// [`ChannelRange::push`] of every value, a column at a time (`ranges.len()` columns).
fn push_columns(ranges: &mut [ChannelRange], channels: &[f64]) {
    let n_channels = ranges.len();
    for (j, range) in ranges.iter_mut().enumerate() {
        for &v in channels.iter().skip(j).step_by(n_channels.max(1)) {
            range.push(v);
        }
    }
}

/// [`push_columns`] of finite rows of `C` channels: each column's smallest and
/// largest value over the rows, then how many equal each, merged into `ranges`.
fn merge_ranges<const C: usize>(ranges: &mut [ChannelRange], channels: &[f64]) {
    let (mut lo, mut hi) = ([f64::INFINITY; C], [f64::NEG_INFINITY; C]);
    for row in channels.chunks_exact(C) {
        for j in 0..C {
            // Strict comparisons, as `ChannelRange::push`: of values that compare
            // equal (zeros of either sign) the first is kept. No NaN here.
            lo[j] = if row[j] < lo[j] { row[j] } else { lo[j] };
            hi[j] = if row[j] > hi[j] { row[j] } else { hi[j] };
        }
    }
    let (mut n_lo, mut n_hi) = ([0u64; C], [0u64; C]);
    for row in channels.chunks_exact(C) {
        for j in 0..C {
            n_lo[j] += u64::from(row[j] == lo[j]);
            n_hi[j] += u64::from(row[j] == hi[j]);
        }
    }
    for (j, range) in ranges.iter_mut().enumerate() {
        if n_lo[j] > 0 {
            range.merge(&ChannelRange {
                min: lo[j],
                max: hi[j],
                n_at_min: n_lo[j],
                n_at_max: n_hi[j],
            });
        }
    }
}

/// What a run's raw samples looked like (the result of a [`RunTally`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RawStats {
    /// Rows pushed.
    pub n_rows: u64,
    /// Rows with a non-finite time, temperature or channel value.
    pub n_skipped_nonfinite: u64,
    /// First finite time, s (NaN when there is none).
    pub first_time_s: f64,
    /// Last finite time, s (NaN when there is none).
    pub last_time_s: f64,
    /// Intervals between consecutive finite times longer than 1.5 nominal periods.
    pub n_gaps: u64,
    /// Longest interval between consecutive finite times, s (0 for fewer than two).
    pub max_interval_s: f64,
    /// Range of each channel's finite values.
    pub channel_ranges: Vec<ChannelRange>,
}

impl RawStats {
    /// The statistics of no rows at all, for `n_channels` channels.
    pub fn empty(n_channels: usize) -> Self {
        Self {
            n_rows: 0,
            n_skipped_nonfinite: 0,
            first_time_s: f64::NAN,
            last_time_s: f64::NAN,
            n_gaps: 0,
            max_interval_s: 0.0,
            channel_ranges: vec![ChannelRange::default(); n_channels],
        }
    }

    /// Count one finite time, s: the first, or an interval from the last (the longest
    /// interval, and a gap when longer than `gap_s`).
    #[inline]
    fn push_time(&mut self, time_s: f64, gap_s: f64) {
        if self.first_time_s.is_nan() {
            self.first_time_s = time_s;
        } else {
            let dt = time_s - self.last_time_s;
            if dt > self.max_interval_s {
                self.max_interval_s = dt;
            }
            self.n_gaps += u64::from(dt > gap_s);
        }
        self.last_time_s = time_s;
    }
}

/// Streaming accumulator of [`RawStats`]: `push` rows, `merge` a following piece,
/// `finish`. See the module docs for the semantics.
///
/// ```
/// use accelcore_core::RunTally;
/// use ndarray::array;
///
/// let mut tally = RunTally::new(1, 20.0)?;
/// tally.push(&[0.0, 0.05, 0.3], &[25.0, 25.0, f64::NAN], array![[1.0], [2.0], [2.0]].view())?;
/// let stats = tally.finish();
/// assert_eq!((stats.n_rows, stats.n_skipped_nonfinite, stats.n_gaps), (3, 1, 1));
/// assert_eq!(stats.channel_ranges[0].n_at_max, 2);
/// # Ok::<(), accelcore_core::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct RunTally {
    rate_hz: f64,
    /// Intervals longer than this are gaps: `1.5 * (1 / rate_hz)`.
    gap_s: f64,
    stats: RawStats,
}

impl RunTally {
    /// A tally of `n_channels` channels sampled at about `rate_hz` (finite, > 0).
    pub fn new(n_channels: usize, rate_hz: f64) -> Result<Self> {
        Self::resume(RawStats::empty(n_channels), rate_hz)
    }

    /// A tally that goes on from statistics already gathered (a finished piece).
    pub fn resume(stats: RawStats, rate_hz: f64) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(Error::InvalidParameter {
                name: "rate_hz",
                reason: format!("must be finite and > 0, got {rate_hz}"),
            });
        }
        Ok(Self {
            rate_hz,
            gap_s: 1.5 * (1.0 / rate_hz),
            stats,
        })
    }

    /// Nominal sample rate, Hz.
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }

    /// Number of channels.
    pub fn n_channels(&self) -> usize {
        self.stats.channel_ranges.len()
    }

    /// The statistics so far.
    pub fn stats(&self) -> &RawStats {
        &self.stats
    }

    /// Count one row: its time (s), temperature and channel values
    /// (`channels.len()` must be [`RunTally::n_channels`]; extra values are ignored).
    #[inline]
    pub fn push_row(&mut self, time_s: f64, temperature_c: f64, channels: &[f64]) {
        let s = &mut self.stats;
        s.n_rows += 1;
        let mut finite = time_s.is_finite() & temperature_c.is_finite();
        for (range, &v) in s.channel_ranges.iter_mut().zip(channels) {
            finite &= v.is_finite();
            range.push(v);
        }
        s.n_skipped_nonfinite += u64::from(!finite);
        if time_s.is_finite() {
            s.push_time(time_s, self.gap_s);
        }
    }

    /// Count rows held column by column: `time_s` and `temperature_c` (one per
    /// row) and `channels`, the rows' [`RunTally::n_channels`] values one row
    /// after another. The same as [`RunTally::push_row`] on each row in turn,
    /// a column at a time: the reader tallies each batch of rows so.
    ///
    /// Panics if `temperature_c` or `channels` does not match `time_s`'s length.
    pub fn push_rows(&mut self, time_s: &[f64], temperature_c: &[f64], channels: &[f64]) {
        let n_channels = self.n_channels();
        assert!(
            temperature_c.len() == time_s.len() && channels.len() == time_s.len() * n_channels,
            "push_rows: {} times, {} temperatures and {} channel values for {n_channels} channels",
            time_s.len(),
            temperature_c.len(),
            channels.len()
        );
        let s = &mut self.stats;
        s.n_rows += time_s.len() as u64;
        if all_finite(time_s) & all_finite(temperature_c) & all_finite(channels) {
            // The usual batch: every value finite, so each channel's batch range
            // (taken a column at a time) merges into the run's exactly.
            match n_channels {
                3 => merge_ranges::<3>(&mut s.channel_ranges, channels),
                4 => merge_ranges::<4>(&mut s.channel_ranges, channels),
                5 => merge_ranges::<5>(&mut s.channel_ranges, channels),
                6 => merge_ranges::<6>(&mut s.channel_ranges, channels),
                _ => push_columns(&mut s.channel_ranges, channels),
            }
        } else {
            if n_channels > 0 {
                let rows = channels.chunks_exact(n_channels);
                for ((&t, &temp), row) in time_s.iter().zip(temperature_c).zip(rows) {
                    let finite = t.is_finite() & temp.is_finite() & all_finite(row);
                    s.n_skipped_nonfinite += u64::from(!finite);
                }
            } else {
                for (&t, &temp) in time_s.iter().zip(temperature_c) {
                    s.n_skipped_nonfinite += u64::from(!(t.is_finite() & temp.is_finite()));
                }
            }
            push_columns(&mut s.channel_ranges, channels);
        }
        if let (Some(&first), Some(&last), true) =
            (time_s.first(), time_s.last(), all_finite(time_s))
        {
            // Every time finite: the first row's interval from the last row tallied,
            // then those within the rows in one pass without a branch per row.
            s.push_time(first, self.gap_s);
            let (mut longest, mut n_gaps) = (s.max_interval_s, 0u64);
            for pair in time_s.windows(2) {
                let dt = pair[1] - pair[0];
                longest = if dt > longest { dt } else { longest };
                n_gaps += u64::from(dt > self.gap_s);
            }
            s.max_interval_s = longest;
            s.n_gaps += n_gaps;
            s.last_time_s = last;
            return;
        }
        for &t in time_s {
            if t.is_finite() {
                s.push_time(t, self.gap_s);
            }
        }
    }

    /// Count a chunk of rows: `time_s`, `temperature_c` and the rows of
    /// `channels` (n, n_channels) must have the same length ([`Error::Shape`]).
    /// On error nothing is changed.
    pub fn push(
        &mut self,
        time_s: &[f64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Result<()> {
        check_shapes(time_s, temperature_c, &channels, self.n_channels())?;
        let mut row = vec![0.0; self.n_channels()];
        for (i, (&t, &temp)) in time_s.iter().zip(temperature_c).enumerate() {
            for (slot, &v) in row.iter_mut().zip(channels.row(i)) {
                *slot = v;
            }
            self.push_row(t, temp, &row);
        }
        Ok(())
    }

    /// Add a piece whose rows follow this tally's (same channel count and rate,
    /// else [`Error::Incompatible`]); the interval across the cut is counted.
    pub fn merge(&mut self, other: &RunTally) -> Result<()> {
        if other.n_channels() != self.n_channels() || other.rate_hz != self.rate_hz {
            return Err(Error::Incompatible {
                reason: format!(
                    "run tallies of {} channels at {} Hz and {} channels at {} Hz",
                    self.n_channels(),
                    self.rate_hz,
                    other.n_channels(),
                    other.rate_hz
                ),
            });
        }
        let (s, o) = (&mut self.stats, &other.stats);
        if o.first_time_s.is_finite() {
            if s.last_time_s.is_finite() {
                let dt = o.first_time_s - s.last_time_s;
                if dt > s.max_interval_s {
                    s.max_interval_s = dt;
                }
                s.n_gaps += u64::from(dt > self.gap_s);
            } else {
                s.first_time_s = o.first_time_s;
            }
            s.last_time_s = o.last_time_s;
        }
        if o.max_interval_s > s.max_interval_s {
            s.max_interval_s = o.max_interval_s;
        }
        s.n_gaps += o.n_gaps;
        s.n_rows += o.n_rows;
        s.n_skipped_nonfinite += o.n_skipped_nonfinite;
        for (acc, r) in s.channel_ranges.iter_mut().zip(&o.channel_ranges) {
            acc.merge(r);
        }
        Ok(())
    }

    /// The statistics of every row pushed (or merged) so far.
    pub fn finish(&self) -> RawStats {
        self.stats.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    #[test]
    fn no_rows_give_nan_times_and_empty_ranges() {
        let s = RunTally::new(2, 20.0).unwrap().finish();
        assert_eq!((s.n_rows, s.n_skipped_nonfinite, s.n_gaps), (0, 0, 0));
        assert!(s.first_time_s.is_nan() && s.last_time_s.is_nan());
        assert_eq!(s.max_interval_s, 0.0);
        assert_eq!(s.channel_ranges, vec![ChannelRange::default(); 2]);
    }

    #[test]
    fn nan_rows_are_counted_and_left_out_of_times_and_ranges() {
        let mut t = RunTally::new(1, 10.0).unwrap();
        let ch = Array2::from_shape_vec((4, 1), vec![1.0, f64::NAN, 3.0, 3.0]).unwrap();
        t.push(
            &[0.0, 0.1, f64::NAN, 0.5],
            &[1.0, 1.0, 1.0, f64::INFINITY],
            ch.view(),
        )
        .unwrap();
        let s = t.finish();
        assert_eq!((s.n_rows, s.n_skipped_nonfinite), (4, 3));
        assert_eq!((s.first_time_s, s.last_time_s), (0.0, 0.5));
        assert_eq!(s.n_gaps, 1); // 0.1 -> 0.5 s at 10 Hz
        assert!((s.max_interval_s - 0.4).abs() < 1e-15);
        let r = &s.channel_ranges[0];
        assert_eq!((r.min, r.n_at_min, r.max, r.n_at_max), (1.0, 1, 3.0, 2));
    }

    #[test]
    fn bad_rate_shapes_and_merges_are_errors() {
        assert!(matches!(
            RunTally::new(1, 0.0),
            Err(Error::InvalidParameter { .. })
        ));
        let mut t = RunTally::new(2, 20.0).unwrap();
        let ch = Array2::<f64>::zeros((2, 3));
        assert!(matches!(
            t.push(&[0.0, 1.0], &[0.0, 0.0], ch.view()),
            Err(Error::Shape { .. })
        ));
        assert_eq!(t.stats().n_rows, 0);
        let other = RunTally::new(2, 10.0).unwrap();
        assert!(matches!(t.merge(&other), Err(Error::Incompatible { .. })));
    }
}
