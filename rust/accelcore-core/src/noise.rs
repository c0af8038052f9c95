//! The noise of a run's decimated blocks, as the quality checks' spike screen takes it:
//! each block's residual about a running median, scaled to a full block, and the
//! residuals' robust standard deviation.
//!
//! The same floats as the NumPy of `accelcore.input.quality` (`_block_noise`,
//! `_robust_sigma`), in one pass of the core instead of a dozen of NumPy's.

use crate::error::Result;
use crate::median::{median, nanmedian};
use crate::robust::running_median;
use crate::search::pairwise_sum;

/// The median absolute deviation of Gaussian noise times this is its standard deviation.
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The most common of `counts` (the smallest of those tied); 1 when there is none.
///
/// A run's full blocks: the raw samples most blocks hold (`np.bincount(count).argmax()`).
#[must_use]
pub fn typical_count(counts: &[i64]) -> i64 {
    // By runs of equal counts (most neighbouring blocks hold the same): one pass, then
    // a tally of the runs, not a chain of adds to one counter per block.
    let mut runs: Vec<(i64, usize)> = counts
        .chunk_by(|a, b| a == b)
        .map(|run| (run[0], run.len()))
        .collect();
    runs.sort_unstable_by_key(|&(c, _)| c);
    let mut best = (1, 0);
    for same in runs.chunk_by(|a, b| a.0 == b.0) {
        let n: usize = same.iter().map(|&(_, len)| len).sum();
        if n > best.1 {
            best = (same[0].0, n); // ascending counts: the smallest of those tied stays
        }
    }
    best.0
}

/// Robust standard deviation of the finite values of `r`: [`MAD_TO_SIGMA`] times the
/// median absolute deviation from the median; where that is 0 (most values equal),
/// `sqrt(pi / 2)` times the mean absolute deviation (summed in NumPy's order, in input
/// order); 0 when no value is finite.
#[must_use]
pub fn robust_sigma(r: &[f64]) -> f64 {
    let finite: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    // Residuals about a running median are exactly 0 at many blocks (the median is one
    // of its window's values), so 0 is usually their median: checked by counting.
    let center = if middle_is(&finite, 0.0) {
        0.0
    } else {
        median(&finite)
    };
    let deviation: Vec<f64> = finite.iter().map(|&v| (v - center).abs()).collect();
    let sigma = MAD_TO_SIGMA * nanmedian(&deviation);
    if sigma != 0.0 {
        return sigma;
    }
    (std::f64::consts::PI / 2.0).sqrt() * (pairwise_sum(&deviation) / deviation.len() as f64)
}

/// Whether `guess` is the median of the non-NaN `values` (their middle rank(s) among
/// the values equal to it): then the median is `guess` (a zero median is `+0.0`,
/// which `0.0` is).
fn middle_is(values: &[f64], guess: f64) -> bool {
    let n = values.len();
    let (below, equal) = values.iter().fold((0_usize, 0_usize), |(b, e), &v| {
        (b + usize::from(v < guess), e + usize::from(v == guess))
    });
    let k = n / 2;
    below < n - k && below + equal > k
}

/// Each block's residual about a centred running median of `window` blocks (see
/// [`running_median`]), times `sqrt(count / typical)` (a block of fewer samples than
/// most is noisier: its residual is scaled to a full block's noise), and the
/// residuals' [`robust_sigma`].
///
/// # Errors
///
/// Those of [`running_median`]; [`crate::Error::InvalidParameter`] when `counts` and
/// `y` differ in length.
pub fn block_noise(y: &[f64], counts: &[i64], window: usize) -> Result<(Vec<f64>, f64)> {
    if counts.len() != y.len() {
        return Err(crate::Error::InvalidParameter {
            name: "counts",
            reason: format!("has {} values for {} blocks", counts.len(), y.len()),
        });
    }
    let full = typical_count(counts);
    let typical = full as f64;
    let level = running_median(y, window)?;
    // A full block's scale is sqrt(1) = 1 exactly: no square root to take.
    let resid: Vec<f64> = y
        .iter()
        .zip(&level)
        .zip(counts)
        .map(|((&v, &m), &c)| {
            let scale = if c == full {
                1.0
            } else {
                (c as f64 / typical).sqrt()
            };
            (v - m) * scale
        })
        .collect();
    let sigma = robust_sigma(&resid);
    Ok((resid, sigma))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typical_is_the_most_common_smallest_on_ties() {
        assert_eq!(typical_count(&[10, 10, 9, 10, 3]), 10);
        assert_eq!(typical_count(&[4, 5, 5, 4]), 4);
        assert_eq!(typical_count(&[]), 1);
        // Beyond the histogram's range: by sorting, the same rule.
        assert_eq!(typical_count(&[1 << 20, 7, 1 << 20, 7, -3]), 7);
    }

    #[test]
    fn sigma_of_equal_values_falls_back_to_the_mean_deviation() {
        // Half the values equal: the MAD is 0, the mean absolute deviation is not.
        let r = [0.0, 0.0, 0.0, 3.0, -3.0, f64::NAN, f64::INFINITY];
        let want = (std::f64::consts::PI / 2.0).sqrt() * (6.0 / 5.0);
        assert_eq!(robust_sigma(&r), want);
        assert_eq!(robust_sigma(&[f64::NAN]), 0.0);
        assert_eq!(robust_sigma(&[1.0, 2.0, 4.0]), MAD_TO_SIGMA);
    }

    #[test]
    fn a_short_block_is_scaled_to_a_full_one() {
        let y = [0.0, 0.0, 4.0, 0.0, 0.0];
        let (resid, _) = block_noise(&y, &[10, 10, 10, 10, 10], 3).unwrap();
        let (short, _) = block_noise(&y, &[10, 10, 5, 10, 10], 3).unwrap();
        assert_eq!(resid[2], 4.0);
        assert_eq!(short[2], 4.0 * 0.5_f64.sqrt());
        assert!(block_noise(&y, &[10], 3).is_err());
    }
}
