//! Robust smoothing of a series: a centred running median.

use std::cmp::Ordering;

use crate::error::{Error, Result};

/// Centred running median of `y` over `2 * (window / 2) + 1` values (an even
/// `window` is rounded up to the next odd size).
///
/// The series is first extended by `half = window / 2` values at each end, as
/// NumPy's `np.pad(y, half, mode=...)` would:
///
/// - when `y.len() > half`, by reflection about the end values, which are not
///   repeated (`mode="reflect"`): `y[half], …, y[1]` before, `y[n-2], …, y[n-1-half]` after;
/// - otherwise by repeating the end values (`mode="edge"`): `y[0]` before, `y[n-1]` after.
///
/// Output `i` is the median of padded values `i ..= i + 2 * half`, which is
/// always one of the inputs (the window size is odd), so the result is exact.
///
/// NaN policy: propagate. A window that holds a NaN gives NaN (as `np.median`).
/// Infinities are ordinary values. A zero median is `+0.0` even when the middle
/// value is `-0.0`, again as `np.median` (which averages from `+0.0`); every other
/// output is bitwise one of the inputs. Empty input gives empty output.
///
/// Cost: O(n · window) time (a sorted window; each step ranks the leaving and the
/// entering value and shifts the values between them), O(window) extra memory. When `half >= n` every window holds
/// the whole series, and the medians come from one sort, in O(n log n) whatever
/// the window.
///
/// # Errors
///
/// [`Error::InvalidParameter`] when `window` is 0.
///
/// # Examples
///
/// ```
/// use accelcore_core::running_median;
///
/// let y = [1.0, 9.0, 2.0, 3.0, 8.0];
/// // Padded by reflection: [9, 1, 9, 2, 3, 8, 3].
/// assert_eq!(running_median(&y, 3)?, vec![9.0, 2.0, 3.0, 3.0, 3.0]);
/// // Every window larger than the series holds it whole, padded by its end values.
/// assert_eq!(running_median(&[1.0, 5.0], 9)?, vec![1.0, 5.0]);
/// # Ok::<(), accelcore_core::Error>(())
/// ```
pub fn running_median(y: &[f64], window: usize) -> Result<Vec<f64>> {
    if window == 0 {
        return Err(Error::InvalidParameter {
            name: "window",
            reason: "must be >= 1, got 0".to_string(),
        });
    }
    let n = y.len();
    let half = window / 2;
    if n == 0 {
        return Ok(Vec::new());
    }
    if n <= half {
        return Ok(edge_padded(y, half));
    }
    Ok(reflect_padded(y, half))
}

const SIGN: u64 = 1 << 63;

/// Key of a non-NaN value whose integer order is `f64::total_cmp` order (so
/// `-0.0 < 0.0`, and equal keys are bitwise-equal values): negative values have
/// all bits flipped, the others only the sign bit.
fn key(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits & SIGN == 0 {
        bits | SIGN
    } else {
        !bits
    }
}

/// Inverse of [`key`].
fn value(k: u64) -> f64 {
    f64::from_bits(if k & SIGN == 0 { !k } else { k & !SIGN })
}

/// Sorted keys of the non-NaN values of a window, and how many NaNs it holds.
struct SortedWindow {
    keys: Vec<u64>,
    nans: usize,
}

impl SortedWindow {
    fn new(values: &[f64]) -> Self {
        let mut keys: Vec<u64> = values
            .iter()
            .filter(|v| !v.is_nan())
            .map(|&v| key(v))
            .collect();
        keys.sort_unstable();
        let nans = values.len() - keys.len();
        Self { keys, nans }
    }

    /// Slide by one: `old` leaves the window and `new` enters it.
    fn replace(&mut self, old: f64, new: f64) {
        match (old.is_nan(), new.is_nan()) {
            (true, true) => {}
            (true, false) => {
                self.nans -= 1;
                let k = key(new);
                let at = self.keys.partition_point(|&v| v < k);
                self.keys.insert(at, k);
            }
            (false, true) => {
                self.nans += 1;
                if let Ok(at) = self.keys.binary_search(&key(old)) {
                    self.keys.remove(at);
                }
            }
            (false, false) => {
                let (old, new) = (key(old), key(new));
                // Ranks by counting rather than binary search: branch-free, so faster
                // on the small windows of the quality checks, and O(window) like the shift.
                let (at, below_new) = self.keys.iter().fold((0, 0), |(a, b), &k| {
                    (a + usize::from(k < old), b + usize::from(k < new))
                });
                if new > old {
                    // `old` itself is below `new`; the values between move down one place.
                    let to = below_new - 1;
                    for j in at..to {
                        self.keys[j] = self.keys[j + 1];
                    }
                    self.keys[to] = new;
                } else {
                    for j in (below_new..at).rev() {
                        self.keys[j + 1] = self.keys[j];
                    }
                    self.keys[below_new] = new;
                }
            }
        }
    }

    /// The element of rank `rank` (0-based) of the whole window (`+0.0` for `-0.0`),
    /// NaN if the window holds one.
    fn select(&self, rank: usize) -> f64 {
        match self.keys.get(rank) {
            Some(&k) if self.nans == 0 => value(k) + 0.0,
            _ => f64::NAN,
        }
    }
}

/// `half < n`: slide a sorted window along the reflect-padded series.
fn reflect_padded(y: &[f64], half: usize) -> Vec<f64> {
    let n = y.len();
    // Padded index p maps to y[h - p] before the data and to y[2n - 2 - (p - h)] after it.
    let padded = |p: usize| -> f64 {
        if p < half {
            y[half - p]
        } else if p < half + n {
            y[p - half]
        } else {
            y[2 * n - 2 + half - p]
        }
    };
    let size = 2 * half + 1;
    let first: Vec<f64> = (0..size).map(padded).collect();
    let mut window = SortedWindow::new(&first);
    let mut out = Vec::with_capacity(n);
    out.push(window.select(half));
    for i in 1..n {
        window.replace(padded(i - 1), padded(i - 1 + size));
        out.push(window.select(half));
    }
    out
}

/// `half >= n`: window `i` is `half - i` copies of `y[0]`, all of `y` and
/// `i + half + 1 - n` copies of `y[n-1]`, so its median comes from `y` sorted once.
fn edge_padded(y: &[f64], half: usize) -> Vec<f64> {
    let n = y.len();
    if y.iter().any(|v| v.is_nan()) {
        return vec![f64::NAN; n];
    }
    let (first, last) = (y[0], y[n - 1]);
    let mut sorted = y.to_vec();
    sorted.sort_by(f64::total_cmp);
    (0..n)
        .map(|i| {
            let (copies_first, copies_last) = (half - i, i + half + 1 - n);
            // Number of window values up to sorted[j] when the copies sort before
            // equal values of y: non-decreasing in j, and it first exceeds `half`
            // at the median.
            let count_through = |j: usize| {
                let v = sorted[j];
                let mut count = j + 1;
                if first.total_cmp(&v) != Ordering::Greater {
                    count += copies_first;
                }
                if last.total_cmp(&v) != Ordering::Greater {
                    count += copies_last;
                }
                count
            };
            let (mut lo, mut hi) = (0, n - 1);
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if count_through(mid) > half {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            sorted[lo] + 0.0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `np.pad(y, half, mode=…)` then the middle of each window sorted in full.
    fn naive(y: &[f64], window: usize) -> Vec<f64> {
        let n = y.len();
        let half = window / 2;
        if n == 0 {
            return Vec::new();
        }
        let mut padded = Vec::new();
        for k in 0..half {
            padded.push(if n > half { y[half - k] } else { y[0] });
        }
        padded.extend_from_slice(y);
        for k in 0..half {
            padded.push(if n > half { y[n - 2 - k] } else { y[n - 1] });
        }
        padded
            .windows(2 * half + 1)
            .map(|w| {
                if w.iter().any(|v| v.is_nan()) {
                    return f64::NAN;
                }
                let mut w = w.to_vec();
                w.sort_by(f64::total_cmp);
                w[half] + 0.0
            })
            .collect()
    }

    fn same(a: &[f64], b: &[f64]) -> bool {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| (x.is_nan() && y.is_nan()) || x.to_bits() == y.to_bits())
    }

    #[test]
    fn key_orders_like_total_cmp_and_round_trips() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            5e-324,
            2.0,
        ];
        for pair in xs.windows(2) {
            assert!(key(pair[0]) < key(pair[1]), "{pair:?}");
        }
        for x in xs {
            assert_eq!(value(key(x)).to_bits(), x.to_bits());
        }
    }

    #[test]
    fn window_zero_is_an_invalid_parameter() {
        assert!(matches!(
            running_median(&[1.0], 0),
            Err(Error::InvalidParameter { name: "window", .. })
        ));
    }

    #[test]
    fn empty_input_gives_empty_output() {
        for window in [1, 2, 9, 1000] {
            assert!(running_median(&[], window).unwrap().is_empty());
        }
    }

    #[test]
    fn window_one_is_identity() {
        let y = [3.0, f64::NAN, -1.0, f64::INFINITY, 0.5];
        assert!(same(&running_median(&y, 1).unwrap(), &y));
    }

    #[test]
    fn even_window_rounds_up_to_odd() {
        let y = [5.0, 1.0, 4.0, 2.0, 3.0, 0.0];
        assert_eq!(
            running_median(&y, 2).unwrap(),
            running_median(&y, 3).unwrap()
        );
        assert_eq!(
            running_median(&y, 8).unwrap(),
            running_median(&y, 9).unwrap()
        );
    }

    #[test]
    fn reflect_padding_does_not_repeat_the_end_value() {
        // Padded [2, 1, 2, 9, 0, 9]; the windows of 3 are [2,1,2] [1,2,9] [2,9,0] [9,0,9].
        assert_eq!(
            running_median(&[1.0, 2.0, 9.0, 0.0], 3).unwrap(),
            vec![2.0, 2.0, 2.0, 9.0]
        );
    }

    #[test]
    fn window_larger_than_series_pads_with_end_values() {
        // half = 3 >= n = 3: padded [1,1,1, 1,7,2, 2,2,2].
        assert_eq!(
            running_median(&[1.0, 7.0, 2.0], 7).unwrap(),
            vec![1.0, 2.0, 2.0]
        );
        assert_eq!(running_median(&[4.0], 5).unwrap(), vec![4.0]);
        let y = [3.0, -1.0, 8.0, 8.0, 0.0];
        assert!(same(&running_median(&y, 101).unwrap(), &naive(&y, 101)));
        // A huge window allocates nothing of its size.
        assert_eq!(
            running_median(&[2.0, 1.0], usize::MAX).unwrap(),
            vec![2.0, 1.0]
        );
    }

    #[test]
    fn zero_median_is_positive_zero() {
        let got = running_median(&[-0.0, -0.0, -0.0, 1.0], 3).unwrap();
        assert!(got
            .iter()
            .all(|v| v.to_bits() == 0.0f64.to_bits() || *v == 1.0));
        assert_eq!(
            running_median(&[-0.0], 5).unwrap()[0].to_bits(),
            0.0f64.to_bits()
        );
    }

    #[test]
    fn nan_in_a_window_propagates() {
        let y = [1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0, 7.0];
        let got = running_median(&y, 3).unwrap();
        let nan: Vec<bool> = got.iter().map(|v| v.is_nan()).collect();
        assert_eq!(nan, [false, true, true, true, false, false, false]);
        assert!(running_median(&[1.0, f64::NAN], 9)
            .unwrap()
            .iter()
            .all(|v| v.is_nan()));
    }

    proptest! {
        #[test]
        fn matches_sort_per_window(
            y in prop::collection::vec(
                prop_oneof![
                    4 => (-3i8..4).prop_map(f64::from),
                    4 => -1e3f64..1e3,
                    1 => Just(f64::NAN),
                    1 => Just(f64::INFINITY),
                    1 => Just(f64::NEG_INFINITY),
                    1 => Just(-0.0f64),
                ],
                0..120,
            ),
            window in 1usize..40,
        ) {
            let got = running_median(&y, window).unwrap();
            prop_assert!(same(&got, &naive(&y, window)), "{got:?}");
        }
    }
}
