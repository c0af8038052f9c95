//! Fixed-width temperature binning with numerically stable per-bin statistics.
//!
//! A [`TemperatureBinner`] sorts `(time_s, temperature_c, channels…)` rows into
//! temperature bins and keeps, per bin, the sample count, the mean time, the
//! mean temperature and the mean and sample variance of every channel.
//!
//! # Semantics
//!
//! - **Bins.** The window is `[lo_c, hi_c)`, cut into
//!   `n_bins = ceil((hi_c - lo_c) / width_c - 1e-9)` bins (1 ..= 10 000 000).
//!   Edges are `lo_c + i * width_c` for `i < n_bins`, and the last edge is
//!   exactly `hi_c`, so the last bin may be narrower.
//! - **Bin closure `[lo, hi)`.** A temperature `T` with `lo_c <= T < hi_c` goes
//!   to bin `floor((T - lo_c) / width_c)`, clamped to `n_bins - 1`; a value on
//!   an interior edge therefore goes to the upper bin (exactly so when the edge
//!   is representable, e.g. dyadic widths). `T == lo_c` is in bin 0.
//! - **Out of range.** `T < lo_c` is counted in `n_below`, `T >= hi_c` in
//!   `n_above`; neither enters any bin.
//! - **NaN policy: skip.** A row whose time, temperature or any channel value
//!   is NaN or infinite is skipped and counted in `n_nonfinite`.
//! - **Statistics.** Welford's online update per bin (count, means, and sum of
//!   squared deviations `M2` per channel). Channel values enter as deviations
//!   from the first value the bin received (shifted data), so large offsets
//!   with tiny variations (e.g. 16000 ± 1e-6) keep full relative precision,
//!   also through merges. Time and temperature means use plain Welford.
//!   Variance is `M2 / (count - 1)` (ddof = 1), NaN when `count < 2`; means are
//!   NaN for empty bins.
//! - **Merging.** [`TemperatureBinner::merge`] combines bins with the parallel
//!   formula of Chan, Golub and LeVeque; the result equals one pass over both
//!   inputs up to rounding, in any order.
//! - **Empty input.** Chunks with zero rows change nothing;
//!   [`TemperatureBinner::finish`] returns [`Error::Empty`] when no sample fell
//!   inside the window.
use crate::decimate::{all_finite, check_shapes, least_reaching};
use crate::error::{Error, Result};
use ndarray::ArrayView2;

/// Channel counts up to this go through the run-wise fast path of `push`.
const RUN_CHANNELS: usize = 8;

/// Largest number of bins a configuration may produce.
pub const MAX_BINS: usize = 10_000_000;

/// Configuration of a [`TemperatureBinner`].
#[derive(Debug, Clone, PartialEq)]
pub struct BinnerConfig {
    /// Lower edge of the window, °C (inclusive). Default 0.
    pub lo_c: f64,
    /// Upper edge of the window, °C (exclusive). Default 60.
    pub hi_c: f64,
    /// Bin width, °C. Default 0.5.
    pub width_c: f64,
    /// Number of data channels. Default 3.
    pub n_channels: usize,
}

impl Default for BinnerConfig {
    fn default() -> Self {
        Self {
            lo_c: 0.0,
            hi_c: 60.0,
            width_c: 0.5,
            n_channels: 3,
        }
    }
}

impl BinnerConfig {
    /// Validate and return the number of bins.
    fn n_bins(&self) -> Result<usize> {
        for (name, v) in [
            ("lo_c", self.lo_c),
            ("hi_c", self.hi_c),
            ("width_c", self.width_c),
        ] {
            if !v.is_finite() {
                return Err(invalid(name, format!("must be finite, got {v}")));
            }
        }
        if self.hi_c <= self.lo_c {
            return Err(invalid(
                "hi_c",
                format!(
                    "must be greater than lo_c = {}, got {}",
                    self.lo_c, self.hi_c
                ),
            ));
        }
        if self.width_c <= 0.0 {
            return Err(invalid(
                "width_c",
                format!("must be > 0, got {}", self.width_c),
            ));
        }
        let n = ((self.hi_c - self.lo_c) / self.width_c - 1e-9).ceil();
        if !(n >= 1.0 && n <= MAX_BINS as f64) {
            return Err(invalid(
                "width_c",
                format!(
                    "gives {n} bins over [{}, {}); must be between 1 and {MAX_BINS}",
                    self.lo_c, self.hi_c
                ),
            ));
        }
        Ok(n as usize)
    }
}

/// Accumulator values per bin.
fn stride(n_channels: usize) -> usize {
    n_channels.saturating_mul(3).saturating_add(2)
}

fn invalid(name: &'static str, reason: String) -> Error {
    Error::InvalidParameter { name, reason }
}

/// Per-bin statistics. Arrays of length n_bins (row-major n_bins x n_channels for 2-D ones).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BinnedStats {
    /// Number of channels.
    pub n_channels: usize,
    /// Bin edges, n_bins + 1 values: lo + i*width, the last one is hi.
    pub edges_c: Vec<f64>,
    /// Samples per bin.
    pub count: Vec<u64>,
    /// Mean temperature per bin (NaN when empty).
    pub temperature_c: Vec<f64>,
    /// Mean time per bin (NaN when empty).
    pub time_s: Vec<f64>,
    /// Mean per bin and channel (NaN when empty).
    pub mean: Vec<f64>,
    /// Sample variance (ddof = 1) per bin and channel (NaN when count < 2).
    pub variance: Vec<f64>,
    /// Samples with temperature below the window.
    pub n_below: u64,
    /// Samples with temperature at or above the upper edge.
    pub n_above: u64,
    /// Samples skipped because a value was NaN or infinite.
    pub n_nonfinite: u64,
}

/// Fixed-width temperature binner with Welford accumulators.
///
/// See the [module docs](self) for the exact semantics.
#[derive(Debug, Clone)]
pub struct TemperatureBinner {
    config: BinnerConfig,
    n_bins: usize,
    /// Samples per bin.
    count: Vec<u64>,
    /// Per bin, `stride = 2 + 3 * n_channels` values:
    /// `[mean_time, mean_temp, shift[0..nc], mean_dev[0..nc], m2[0..nc]]`.
    /// Channel values are accumulated as deviations from `shift` (the first
    /// value the bin received), which are exact for values close to it, so a
    /// large common offset costs no precision. The channel mean is
    /// `shift + mean_dev`.
    acc: Vec<f64>,
    n_below: u64,
    n_above: u64,
    n_nonfinite: u64,
}

impl TemperatureBinner {
    /// Validate the configuration.
    pub fn new(config: BinnerConfig) -> Result<Self> {
        let n_bins = config.n_bins()?;
        let too_large = || {
            invalid(
                "n_channels",
                format!(
                    "{} channels x {n_bins} bins do not fit in memory",
                    config.n_channels
                ),
            )
        };
        let len = n_bins
            .checked_mul(stride(config.n_channels))
            .ok_or_else(too_large)?;
        let mut acc = Vec::new();
        acc.try_reserve_exact(len).map_err(|_| too_large())?;
        acc.resize(len, 0.0);
        let mut count = Vec::new();
        count.try_reserve_exact(n_bins).map_err(|_| too_large())?;
        count.resize(n_bins, 0);
        Ok(Self {
            config,
            n_bins,
            count,
            acc,
            n_below: 0,
            n_above: 0,
            n_nonfinite: 0,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &BinnerConfig {
        &self.config
    }

    /// Number of bins.
    pub fn n_bins(&self) -> usize {
        self.n_bins
    }

    /// Bin edges (n_bins + 1 values): `lo_c + i * width_c`, the last one `hi_c`.
    pub fn edges_c(&self) -> Vec<f64> {
        let c = &self.config;
        let mut edges: Vec<f64> = (0..self.n_bins)
            .map(|i| c.lo_c + i as f64 * c.width_c)
            .collect();
        edges.push(c.hi_c);
        edges
    }

    /// Push a chunk; `channels` is (n, n_channels).
    ///
    /// Same argument order and shape rules as [`crate::Decimator::push`]
    /// ([`Error::Shape`]); `channels` may have any strides. Time order does not
    /// matter here.
    pub fn push(
        &mut self,
        time_s: &[f64],
        temperature_c: &[f64],
        channels: ArrayView2<'_, f64>,
    ) -> Result<()> {
        let nc = self.config.n_channels;
        check_shapes(time_s, temperature_c, &channels, nc)?;
        if nc == 0 {
            for (&t, &temp) in time_s.iter().zip(temperature_c) {
                self.add(t, temp, &[]);
            }
        } else if let Some(flat) = channels.as_slice() {
            if nc <= RUN_CHANNELS {
                self.push_contiguous(time_s, temperature_c, flat);
            } else {
                for ((&t, &temp), row) in
                    time_s.iter().zip(temperature_c).zip(flat.chunks_exact(nc))
                {
                    self.add(t, temp, row);
                }
            }
        } else {
            let mut row = vec![0.0; nc];
            for ((&t, &temp), view) in time_s.iter().zip(temperature_c).zip(channels.rows()) {
                for (dst, &v) in row.iter_mut().zip(view.iter()) {
                    *dst = v;
                }
                self.add(t, temp, &row);
            }
        }
        Ok(())
    }

    /// Contiguous rows of 1..=[`RUN_CHANNELS`] channels: [`TemperatureBinner::push_runs`]
    /// compiled for the channel count.
    fn push_contiguous(&mut self, time_s: &[f64], temperature_c: &[f64], flat: &[f64]) {
        let (t, temp) = (time_s, temperature_c);
        match self.config.n_channels {
            1 => self.push_runs::<1>(t, temp, flat),
            2 => self.push_runs::<2>(t, temp, flat),
            3 => self.push_runs::<3>(t, temp, flat),
            4 => self.push_runs::<4>(t, temp, flat),
            _ => self.push_runs::<0>(t, temp, flat),
        }
    }

    /// The bin of a row that enters one: finite values, temperature in the window.
    // `&` not `&&`: branch-free (the common case passes every test).
    #[allow(clippy::needless_bitwise_bool)]
    #[inline]
    fn bin_of(&self, t: f64, temp: f64, row: &[f64]) -> Option<usize> {
        let c = &self.config;
        let finite =
            t.is_finite() & temp.is_finite() & row.iter().fold(true, |ok, v| ok & v.is_finite());
        let ok = finite & (temp >= c.lo_c) & (temp < c.hi_c);
        // `temp >= lo_c`, so the quotient is >= 0 and truncation is the floor.
        ok.then(|| (((temp - c.lo_c) / c.width_c) as usize).min(self.n_bins - 1))
    }

    /// The temperatures `[lo, hi)` that fall in `bin` (by the formula of
    /// [`TemperatureBinner::bin_of`]): `(temp - lo_c) / width_c` is monotone in
    /// `temp` (each rounding step is), so the bin's edges are the least
    /// temperatures whose quotient reaches `bin` and `bin + 1`. `None` when an
    /// edge cannot be pinned down within a few ulps (ill-scaled window).
    #[allow(clippy::cast_precision_loss)]
    fn bin_range(&self, bin: usize) -> Option<(f64, f64)> {
        let c = &self.config;
        let (lo_c, width_c) = (c.lo_c, c.width_c);
        let quotient = |temp: f64| (temp - lo_c) / width_c;
        let edge = |m: usize| {
            let m = m as f64;
            least_reaching(quotient, m, lo_c + m * width_c)
        };
        let lo = if bin == 0 { lo_c } else { edge(bin)?.max(lo_c) };
        let hi = if bin + 1 == self.n_bins {
            c.hi_c
        } else {
            edge(bin + 1)?.min(c.hi_c)
        };
        Some((lo, hi))
    }

    /// [`TemperatureBinner::add`] for contiguous rows of at most
    /// [`RUN_CHANNELS`] channels. Temperature drifts slowly, so consecutive
    /// rows mostly share a bin: a run of them is accumulated in local variables
    /// (registers) rather than through memory, with the same operations in the
    /// same order as `add`, so the result is bit-identical.
    ///
    /// A run is the rows whose temperature stays in the bin's range
    /// ([`TemperatureBinner::bin_range`], the two latest kept), so each row
    /// costs two comparisons on top of the update, and the run is summed
    /// without looking for NaN or infinities: such a value makes the run's
    /// means or `M2` non-finite for good (NaN and infinities survive every
    /// later update), and only then is the run done again row by row with
    /// `add`, which skips and counts it. So is a run whose finite values
    /// overflow, as `add` would give.
    ///
    /// `N` is the channel count fixed at compile time (0: from the
    /// configuration).
    fn push_runs<const N: usize>(&mut self, time_s: &[f64], temperature_c: &[f64], flat: &[f64]) {
        let nc = if N == 0 { self.config.n_channels } else { N };
        let stride = stride(nc);
        let n = time_s.len();
        let row_at = |i: usize| &flat[i * nc..(i + 1) * nc];
        // (bin, lo, hi) of the latest two runs: data near a bin edge goes back
        // and forth between two bins.
        let mut ranges = [(usize::MAX, f64::INFINITY, f64::NEG_INFINITY); 2];
        let mut i = 0;
        while i < n {
            let (t, temp, row) = (time_s[i], temperature_c[i], row_at(i));
            let (bin, lo, hi) = if temp >= ranges[0].1 && temp < ranges[0].2 {
                ranges[0]
            } else if temp >= ranges[1].1 && temp < ranges[1].2 {
                ranges.swap(0, 1);
                ranges[0]
            } else {
                let range = self
                    .bin_of(t, temp, row)
                    .and_then(|bin| self.bin_range(bin).map(|(lo, hi)| (bin, lo, hi)));
                let Some(range) = range else {
                    self.add(t, temp, row);
                    i += 1;
                    continue;
                };
                ranges = [range, ranges[0]];
                range
            };
            let a = &self.acc[bin * stride..(bin + 1) * stride];
            let count = self.count[bin];
            let (mut mean_t, mut mean_temp) = (a[0], a[1]);
            let mut shift = [0.0; RUN_CHANNELS];
            let mut mean = [0.0; RUN_CHANNELS];
            let mut m2 = [0.0; RUN_CHANNELS];
            let (shift, mean, m2) = (&mut shift[..nc], &mut mean[..nc], &mut m2[..nc]);
            shift.copy_from_slice(&a[2..2 + nc]);
            mean.copy_from_slice(&a[2 + nc..2 + 2 * nc]);
            m2.copy_from_slice(&a[2 + 2 * nc..2 + 3 * nc]);
            if count == 0 {
                shift.copy_from_slice(row);
            }
            // The count as a float, kept alongside (exact below 2^53; `u64 as
            // f64` takes several instructions on baseline x86-64).
            #[allow(clippy::cast_precision_loss)]
            let mut k = count as f64;
            let mut j = i;
            loop {
                let (t, temp, row) = (time_s[j], temperature_c[j], row_at(j));
                k += 1.0;
                // One division per row, its reciprocal multiplies every update
                // (the divider is the loop's bottleneck otherwise; `add` does the same).
                let inv = 1.0 / k;
                mean_t += (t - mean_t) * inv;
                mean_temp += (temp - mean_temp) * inv;
                for (((s, m), q), &x) in shift
                    .iter()
                    .zip(mean.iter_mut())
                    .zip(m2.iter_mut())
                    .zip(row)
                {
                    let y = x - s;
                    let delta = y - *m;
                    *m += delta * inv;
                    *q += delta * (y - *m);
                }
                j += 1;
                if j == n || !(temperature_c[j] >= lo && temperature_c[j] < hi) {
                    break;
                }
            }
            let finite = mean_t.is_finite()
                & mean_temp.is_finite()
                & all_finite(shift)
                & all_finite(mean)
                & all_finite(m2);
            if finite {
                self.count[bin] = count + (j - i) as u64;
                let a = &mut self.acc[bin * stride..(bin + 1) * stride];
                a[0] = mean_t;
                a[1] = mean_temp;
                a[2..2 + nc].copy_from_slice(shift);
                a[2 + nc..2 + 2 * nc].copy_from_slice(mean);
                a[2 + 2 * nc..2 + 3 * nc].copy_from_slice(m2);
            } else {
                for r in i..j {
                    self.add(time_s[r], temperature_c[r], row_at(r));
                }
            }
            i = j;
        }
    }

    #[inline]
    fn add(&mut self, t: f64, temp: f64, row: &[f64]) {
        if !(t.is_finite() && temp.is_finite() && row.iter().all(|v| v.is_finite())) {
            self.n_nonfinite += 1;
            return;
        }
        let c = &self.config;
        if temp < c.lo_c {
            self.n_below += 1;
            return;
        }
        if temp >= c.hi_c {
            self.n_above += 1;
            return;
        }
        // `temp >= lo_c`, so the quotient is >= 0 and truncation is the floor.
        let bin = (((temp - c.lo_c) / c.width_c) as usize).min(self.n_bins - 1);
        let nc = c.n_channels;
        let stride = stride(nc);
        let count = &mut self.count[bin];
        *count += 1;
        let inv = 1.0 / *count as f64;
        let a = &mut self.acc[bin * stride..(bin + 1) * stride];
        a[0] += (t - a[0]) * inv;
        a[1] += (temp - a[1]) * inv;
        let (shift, rest) = a[2..].split_at_mut(nc);
        let (mean, m2) = rest.split_at_mut(nc);
        if *count == 1 {
            shift.copy_from_slice(row);
        }
        for (((k, m), s), &x) in shift
            .iter()
            .zip(mean.iter_mut())
            .zip(m2.iter_mut())
            .zip(row)
        {
            let y = x - k;
            let delta = y - *m;
            *m += delta * inv;
            *s += delta * (y - *m);
        }
    }

    /// Merge another binner of identical configuration.
    ///
    /// `lo_c`, `hi_c`, `width_c` (bitwise) and `n_channels` must be equal, else
    /// [`Error::Incompatible`]. Bins are combined with Chan et al.'s parallel
    /// formula; the out-of-window and non-finite counters add.
    pub fn merge(&mut self, other: &TemperatureBinner) -> Result<()> {
        let (a, b) = (&self.config, &other.config);
        for (name, x, y) in [
            ("lo_c", a.lo_c, b.lo_c),
            ("hi_c", a.hi_c, b.hi_c),
            ("width_c", a.width_c, b.width_c),
        ] {
            if x.to_bits() != y.to_bits() {
                return Err(Error::Incompatible {
                    reason: format!("{name} differs: {x} vs {y}"),
                });
            }
        }
        if a.n_channels != b.n_channels {
            return Err(Error::Incompatible {
                reason: format!("n_channels differs: {} vs {}", a.n_channels, b.n_channels),
            });
        }
        let nc = a.n_channels;
        let stride = stride(nc);
        let bins = self
            .count
            .iter_mut()
            .zip(self.acc.chunks_exact_mut(stride))
            .zip(other.count.iter().zip(other.acc.chunks_exact(stride)));
        for ((na, acc_a), (&nb, acc_b)) in bins {
            if nb == 0 {
                continue;
            }
            if *na == 0 {
                *na = nb;
                acc_a.copy_from_slice(acc_b);
                continue;
            }
            let n = na.saturating_add(nb);
            let (fa, fb, f) = (*na as f64, nb as f64, n as f64);
            let wb = fb / f;
            let cross = fa * fb / f;
            acc_a[0] += (acc_b[0] - acc_a[0]) * wb;
            acc_a[1] += (acc_b[1] - acc_a[1]) * wb;
            let (shift_a, rest_a) = acc_a[2..].split_at_mut(nc);
            let (mean_a, m2_a) = rest_a.split_at_mut(nc);
            let (shift_b, rest_b) = acc_b[2..].split_at(nc);
            let (mean_b, m2_b) = rest_b.split_at(nc);
            let a_iter = shift_a.iter().zip(mean_a.iter_mut()).zip(m2_a.iter_mut());
            let b_iter = shift_b.iter().zip(mean_b).zip(m2_b);
            for (((ka, ma), sa), ((kb, mb), sb)) in a_iter.zip(b_iter) {
                // b's mean as a deviation from a's shift
                let delta = ((kb - ka) + mb) - *ma;
                *ma += delta * wb;
                *sa += sb + delta * delta * cross;
            }
            *na = n;
        }
        self.n_below = self.n_below.saturating_add(other.n_below);
        self.n_above = self.n_above.saturating_add(other.n_above);
        self.n_nonfinite = self.n_nonfinite.saturating_add(other.n_nonfinite);
        Ok(())
    }

    /// Statistics; error if no sample fell in the window.
    ///
    /// All `n_bins` bins are reported; empty bins have count 0 and NaN means
    /// and variances. Does not change the binner.
    pub fn finish(&self) -> Result<BinnedStats> {
        if self.count.iter().all(|&c| c == 0) {
            return Err(Error::Empty {
                what: "temperature binner: no sample inside [lo_c, hi_c)",
            });
        }
        let nc = self.config.n_channels;
        let stride = stride(nc);
        let nb = self.n_bins;
        let mut out = BinnedStats {
            n_channels: nc,
            edges_c: self.edges_c(),
            count: self.count.clone(),
            temperature_c: Vec::with_capacity(nb),
            time_s: Vec::with_capacity(nb),
            mean: Vec::with_capacity(nb * nc),
            variance: Vec::with_capacity(nb * nc),
            n_below: self.n_below,
            n_above: self.n_above,
            n_nonfinite: self.n_nonfinite,
        };
        for (&count, a) in self.count.iter().zip(self.acc.chunks_exact(stride)) {
            if count == 0 {
                out.time_s.push(f64::NAN);
                out.temperature_c.push(f64::NAN);
                out.mean.extend(std::iter::repeat_n(f64::NAN, nc));
                out.variance.extend(std::iter::repeat_n(f64::NAN, nc));
                continue;
            }
            out.time_s.push(a[0]);
            out.temperature_c.push(a[1]);
            let (shift, rest) = a[2..].split_at(nc);
            let (mean, m2) = rest.split_at(nc);
            out.mean.extend(shift.iter().zip(mean).map(|(k, m)| k + m));
            if count < 2 {
                out.variance.extend(std::iter::repeat_n(f64::NAN, nc));
            } else {
                let dof = (count - 1) as f64;
                out.variance.extend(m2.iter().map(|s| s / dof));
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array2;

    #[test]
    fn config_validation() {
        let ok = BinnerConfig::default();
        assert_eq!(TemperatureBinner::new(ok.clone()).unwrap().n_bins(), 120);
        for bad in [
            BinnerConfig {
                lo_c: f64::NAN,
                ..ok.clone()
            },
            BinnerConfig {
                hi_c: f64::INFINITY,
                ..ok.clone()
            },
            BinnerConfig {
                width_c: f64::NAN,
                ..ok.clone()
            },
            BinnerConfig {
                hi_c: 0.0,
                ..ok.clone()
            },
            BinnerConfig {
                hi_c: -1.0,
                ..ok.clone()
            },
            BinnerConfig {
                width_c: 0.0,
                ..ok.clone()
            },
            BinnerConfig {
                width_c: -0.5,
                ..ok.clone()
            },
            BinnerConfig {
                width_c: 1e-9,
                ..ok.clone()
            },
            BinnerConfig {
                lo_c: -1e308,
                hi_c: 1e308,
                width_c: 1.0,
                ..ok.clone()
            },
        ] {
            assert!(matches!(
                TemperatureBinner::new(bad),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }

    #[test]
    fn n_bins_tolerance_and_narrow_last_bin() {
        // 0.3 / 0.1 = 2.9999999999999996 -> 3 bins.
        let b = TemperatureBinner::new(BinnerConfig {
            lo_c: 0.0,
            hi_c: 0.3,
            width_c: 0.1,
            n_channels: 0,
        })
        .unwrap();
        assert_eq!(b.n_bins(), 3);
        let b = TemperatureBinner::new(BinnerConfig {
            lo_c: 0.0,
            hi_c: 1.25,
            width_c: 0.5,
            n_channels: 0,
        })
        .unwrap();
        assert_eq!(b.edges_c(), vec![0.0, 0.5, 1.0, 1.25]);
    }

    #[test]
    fn strided_channels() {
        let cfg = BinnerConfig {
            lo_c: 0.0,
            hi_c: 4.0,
            width_c: 1.0,
            n_channels: 2,
        };
        let mut c = TemperatureBinner::new(cfg.clone()).unwrap();
        let mut f = TemperatureBinner::new(cfg).unwrap();
        let t = [0.0, 1.0, 2.0, 3.0, 3.5];
        let data = Array2::from_shape_fn((5, 2), |(i, j)| (i * i + 7 * j) as f64);
        let fortran = data.t().as_standard_layout().to_owned();
        c.push(&t, &t, data.view()).unwrap();
        f.push(&t, &t, fortran.t()).unwrap();
        let (x, y) = (c.finish().unwrap(), f.finish().unwrap());
        assert_eq!(x.count, y.count);
        assert_eq!(x.mean, y.mean);
        assert_eq!(x.variance[6..], y.variance[6..]);
    }
}
