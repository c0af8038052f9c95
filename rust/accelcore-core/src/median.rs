//! Exact medians of whole series: what `np.median` and `np.nanmedian` give, bit
//! for bit (the quality checks' robust scales, the run levels of the label check
//! and of the diagnosis' run events).

use crate::robust::{key, value};

/// Median of `values`, as `float(np.median(values))` gives it, bit for bit.
///
/// The middle value of an odd count; for an even count the mean of the two
/// middle values `a <= b` as NumPy's `np.mean` computes it, `(0.0 + a + b) / 2`
/// (so it overflows where NumPy's does, is NaN for `-inf` and `inf`, and a zero
/// median is `+0.0`). NaN when `values` is empty or holds a NaN (NumPy also
/// warns); infinities are ordinary values.
///
/// Cost: one copy of the values as integer keys and a selection (introselect):
/// O(n) expected time, O(n) extra memory.
///
/// # Examples
///
/// ```
/// use accelcore_core::median;
///
/// assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
/// assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
/// assert!(median(&[1.0, f64::NAN]).is_nan());
/// assert!(median(&[]).is_nan());
/// ```
#[must_use]
pub fn median(values: &[f64]) -> f64 {
    match keys_of(values) {
        (_, true) => f64::NAN,
        (mut keys, false) => median_of_keys(&mut keys),
    }
}

/// Median of the values of `values` that are not NaN, as `np.nanmedian` gives it,
/// bit for bit: [`median`] of what is left, NaN when nothing is (NumPy also warns).
///
/// # Examples
///
/// ```
/// use accelcore_core::nanmedian;
///
/// assert_eq!(nanmedian(&[f64::NAN, 5.0, 1.0]), 3.0);
/// assert!(nanmedian(&[f64::NAN, -f64::NAN]).is_nan());
/// ```
#[must_use]
pub fn nanmedian(values: &[f64]) -> f64 {
    let (mut keys, nan) = keys_of(values);
    if nan {
        // NaN keys lie outside those of the infinities (either sign of NaN).
        let (lowest, highest) = (key(f64::NEG_INFINITY), key(f64::INFINITY));
        keys.retain(|&k| (lowest..=highest).contains(&k));
    }
    median_of_keys(&mut keys)
}

/// The [`key`] of every value, in one pass, and whether any value is NaN.
fn keys_of(values: &[f64]) -> (Vec<u64>, bool) {
    let mut nan = false;
    let keys = values
        .iter()
        .map(|&v| {
            nan |= v.is_nan();
            key(v)
        })
        .collect();
    (keys, nan)
}

/// Median of non-NaN values given as [`key`]s (reordered in place); NaN when empty.
fn median_of_keys(keys: &mut [u64]) -> f64 {
    let n = keys.len();
    if n == 0 {
        return f64::NAN;
    }
    let k = n / 2;
    let (lower, upper) = if n % 2 == 1 {
        let m = select_pair(keys, k, k);
        // `0.0 +` turns a `-0.0` middle into `+0.0`, as NumPy's mean does.
        return 0.0 + value(m.1);
    } else {
        select_pair(keys, k - 1, k)
    };
    // NumPy's mean: summed from `+0.0`, in this order, then divided (no midpoint).
    #[allow(clippy::manual_midpoint)]
    let mean = (0.0 + value(lower) + value(upper)) / 2.0;
    mean
}

/// Ranks `first` and `second` (`first` or `first + 1`) of `keys` by selection.
fn select_pair(keys: &mut [u64], first: usize, second: usize) -> (u64, u64) {
    let (below, at_second, _) = keys.select_nth_unstable(second);
    let upper = *at_second;
    if first == second {
        return (upper, upper);
    }
    (below.iter().copied().max().unwrap_or(upper), upper)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The median of a sorted copy, as NumPy's mean takes the middle pair.
    #[allow(clippy::manual_midpoint)]
    fn by_sorting(values: &[f64]) -> f64 {
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        if n % 2 == 1 {
            0.0 + sorted[n / 2]
        } else {
            (0.0 + sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
        }
    }

    #[test]
    fn odd_and_even_counts() {
        assert_eq!(median(&[5.0]), 5.0);
        assert_eq!(median(&[2.0, 1.0]), 1.5);
        assert_eq!(median(&[9.0, -1.0, 4.0, 4.0, 0.5]), 4.0);
    }

    #[test]
    fn zeros_and_infinities_as_numpy() {
        let m = median(&[-0.0, 1.0, -0.0]);
        assert_eq!(m.to_bits(), 0.0f64.to_bits());
        let m = median(&[-0.0, -0.0]);
        assert_eq!(m.to_bits(), 0.0f64.to_bits());
        assert!(median(&[f64::NEG_INFINITY, f64::INFINITY]).is_nan());
        assert_eq!(median(&[f64::MAX, f64::MAX]), f64::INFINITY);
        assert_eq!(median(&[f64::INFINITY, 1.0, f64::INFINITY]), f64::INFINITY);
    }

    #[test]
    fn nan_propagates_or_is_skipped() {
        assert!(median(&[1.0, 2.0, f64::NAN]).is_nan());
        assert_eq!(nanmedian(&[1.0, 2.0, f64::NAN]), 1.5);
        assert_eq!(nanmedian(&[-f64::NAN, 2.0, f64::INFINITY]), f64::INFINITY);
        assert!(nanmedian(&[]).is_nan());
    }

    #[test]
    fn long_series_match_a_full_sort() {
        // Smooth, tied, sorted, reversed and two-valued series.
        let n = 5001_u64;
        let series: Vec<Vec<f64>> = vec![
            (0..n)
                .map(|i| ((i * 2_654_435_761) % 1_000_003) as f64)
                .collect(),
            (0..n).map(|i| (i % 3) as f64).collect(),
            (0..n).map(|i| i as f64).collect(),
            (0..n).rev().map(|i| i as f64).collect(),
            (0..n).map(|i| if i < n / 2 { -1.0 } else { 1.0 }).collect(),
        ];
        for values in &series {
            for len in [2048, 2049, 4096, 5001] {
                let (got, want) = (median(&values[..len]), by_sorting(&values[..len]));
                assert_eq!(got.to_bits(), want.to_bits(), "len = {len}");
            }
        }
    }

    #[test]
    fn matches_a_full_sort() {
        // A deterministic scramble with many ties: the median of the sorted copy.
        let values: Vec<f64> = (0..1001_u64)
            .map(|i| ((i * 7919) % 257) as f64 - 128.0)
            .collect();
        for n in [1, 2, 3, 10, 11, 500, 1001] {
            let (got, want) = (median(&values[..n]), by_sorting(&values[..n]));
            assert_eq!(got.to_bits(), want.to_bits(), "n = {n}");
        }
    }
}
