//! Robust smoothing of a series: a centred running median, and the medians of
//! every window of a series (the step check's).

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
/// Cost: for windows up to 15, a selection network (pruned from Batcher's sorting
/// network) applied to blocks of positions at once, so that it vectorises, two
/// outputs per network: O(n · window · log² window) comparisons without a branch,
/// O(n) extra memory. Wider windows slide a sorted window (each step ranks the
/// leaving and the entering value and shifts the values between them): O(n · window)
/// time, O(window) extra memory. When `half >= n` every window holds the whole
/// series, and the medians come from one sort, in O(n log n) whatever the window.
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
    if half == 0 {
        return Ok(y.iter().map(|&v| v + 0.0).collect());
    }
    Ok(reflect_padded(y, half))
}

/// Median of every window `y[j..j + window]`, `j = 0 ..= n - window`: the
/// `n - window + 1` values that `np.median(sliding_window_view(y, window), axis=1)`
/// gives, bit for bit.
///
/// An odd window's median is its middle value; an even window's is the mean of
/// its two middle values `a <= b`, computed as NumPy's `np.mean` does,
/// `(0.0 + a + b) / 2`: so it overflows to infinity when `a + b` does, is NaN for
/// `-inf` and `inf`, and a zero median is `+0.0`. A window that holds a NaN gives
/// NaN (as `np.median`); infinities are ordinary values.
///
/// Cost: a sorted window slides along the series, each step ranking the leaving
/// and the entering value and shifting the values between them: O(n · window)
/// time, O(window) extra memory.
///
/// # Errors
///
/// [`Error::InvalidParameter`] when `window` is 0 or exceeds `y.len()`.
///
/// # Examples
///
/// ```
/// use accelcore_core::sliding_median;
///
/// let y = [1.0, 9.0, 2.0, 3.0, 8.0];
/// assert_eq!(sliding_median(&y, 3)?, vec![2.0, 3.0, 3.0]);
/// // An even window: the mean of the two middle values.
/// assert_eq!(sliding_median(&y, 2)?, vec![5.0, 5.5, 2.5, 5.5]);
/// # Ok::<(), accelcore_core::Error>(())
/// ```
pub fn sliding_median(y: &[f64], window: usize) -> Result<Vec<f64>> {
    let n = y.len();
    if window == 0 || window > n {
        return Err(Error::InvalidParameter {
            name: "window",
            reason: format!("must be >= 1 and <= the series length {n}, got {window}"),
        });
    }
    let mut sorted = SortedWindow::new(&y[..window]);
    let k = window / 2;
    // `select` gives `+0.0` for `-0.0`, as the `0.0 +` of NumPy's mean does; the sum
    // overflows where NumPy's does (`f64::midpoint` would not).
    #[allow(clippy::manual_midpoint)]
    let median = |w: &SortedWindow| {
        if window % 2 == 1 {
            w.select(k)
        } else {
            (w.select(k - 1) + w.select(k)) / 2.0
        }
    };
    let mut out = Vec::with_capacity(n - window + 1);
    out.push(median(&sorted));
    for (&old, &new) in y.iter().zip(&y[window..]) {
        sorted.replace(old, new);
        out.push(median(&sorted));
    }
    Ok(out)
}

/// Output pairs per evaluation of a selection network: each row of the network
/// is then two SSE2 registers, and a whole network stays in registers. (The lane
/// arrays below are written out for four; another value does not compile.)
const LANES: usize = 4;
/// Rows of a network: the `2 * half` values two neighbouring windows share, `half <= 7`.
type Rows = [[f64; LANES]; 14];

/// The smaller of two non-NaN values (`minpd`); either of them when they are `±0.0`.
#[inline]
fn lo(a: f64, b: f64) -> f64 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of two non-NaN values (`maxpd`); either of them when they are `±0.0`.
#[inline]
fn hi(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// `f` lane by lane.
#[inline]
fn lanes(a: [f64; LANES], b: [f64; LANES], f: impl Fn(f64, f64) -> f64) -> [f64; LANES] {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
}

/// One comparator of a selection network on rows `i < j`: `both` leaves the
/// minimum in row `i` and the maximum in row `j`; `min` and `max` write only the
/// row that a later comparator (or the result) reads.
macro_rules! exchange {
    ($v:ident, both, $i:literal, $j:literal) => {{
        let (a, b) = ($v[$i], $v[$j]);
        $v[$i] = lanes(a, b, lo);
        $v[$j] = lanes(a, b, hi);
    }};
    ($v:ident, min, $i:literal, $j:literal) => {
        $v[$i] = lanes($v[$i], $v[$j], lo)
    };
    ($v:ident, max, $i:literal, $j:literal) => {
        $v[$j] = lanes($v[$i], $v[$j], hi)
    };
}

/// A selection network written out comparator by comparator, so that every row
/// index is a constant and the rows live in registers.
macro_rules! network {
    ($v:ident; $($op:ident($i:literal, $j:literal))*) => {{
        $(exchange!($v, $op, $i, $j);)*
    }};
}

/// `0 < half < n`: the running median of the reflect-padded series.
///
/// For `half <= 7` (windows up to 15), by a selection network per pair of windows
/// ([`by_network`]); each network leaves ranks `half - 1` and `half` of `2 * half`
/// values in rows `half - 1` and `half`. They are Batcher's merge-exchange sorting
/// network of `2 * half` wires (Knuth, TAOCP 5.2.2, Algorithm M) less every
/// comparator, or half of one, that cannot reach those two rows; the tests check
/// each on every 0-1 input, which by the 0-1 principle proves it for all inputs.
/// Wider windows slide a sorted window ([`sorted_window`]).
fn reflect_padded(y: &[f64], half: usize) -> Vec<f64> {
    match half {
        1 => by_network(y, 1, |v| {
            network!(v;
                both(0, 1)
            );
        }),
        2 => by_network(y, 2, |v| {
            network!(v;
                both(0, 2) both(1, 3) max(0, 1) min(2, 3) both(1, 2)
            );
        }),
        3 => by_network(y, 3, |v| {
            network!(v;
                both(0, 4) both(1, 5) both(0, 2) both(1, 3) both(2, 4) both(3, 5) max(0, 1)
                both(2, 3) min(4, 5) both(1, 4) max(1, 2) min(3, 4)
            );
        }),
        4 => by_network(y, 4, |v| {
            network!(v;
                both(0, 4) both(1, 5) both(2, 6) both(3, 7) both(0, 2) both(1, 3) both(4, 6)
                both(5, 7) both(2, 4) both(3, 5) max(0, 1) max(2, 3) min(4, 5) min(6, 7)
                max(1, 4) min(3, 6) both(3, 4)
            );
        }),
        5 => by_network(y, 5, |v| {
            network!(v;
                both(0, 8) both(1, 9) both(0, 4) both(1, 5) both(2, 6) both(3, 7) both(4, 8)
                both(5, 9) both(0, 2) both(1, 3) both(4, 6) both(5, 7) both(2, 8) both(3, 9)
                both(2, 4) both(3, 5) both(6, 8) both(7, 9) max(0, 1) max(2, 3) both(4, 5)
                min(6, 7) min(8, 9) both(1, 8) max(1, 4) both(3, 6) min(5, 8) max(3, 4)
                min(5, 6)
            );
        }),
        6 => by_network(y, 6, |v| {
            network!(v;
                both(0, 8) both(1, 9) both(2, 10) both(3, 11) both(0, 4) both(1, 5) both(2, 6)
                both(3, 7) both(4, 8) both(5, 9) both(6, 10) both(7, 11) both(0, 2) both(1, 3)
                both(4, 6) both(5, 7) both(8, 10) both(9, 11) both(2, 8) both(3, 9) both(2, 4)
                both(3, 5) both(6, 8) both(7, 9) max(0, 1) max(2, 3) max(4, 5) min(6, 7)
                min(8, 9) min(10, 11) max(1, 8) min(3, 10) max(3, 6) min(5, 8) both(5, 6)
            );
        }),
        7 => by_network(y, 7, |v| {
            network!(v;
                both(0, 8) both(1, 9) both(2, 10) both(3, 11) both(4, 12) both(5, 13) both(0, 4)
                both(1, 5) both(2, 6) both(3, 7) both(8, 12) both(9, 13) both(4, 8) both(5, 9)
                both(6, 10) both(7, 11) both(0, 2) both(1, 3) both(4, 6) both(5, 7) both(8, 10)
                both(9, 11) both(2, 8) both(3, 9) both(6, 12) both(7, 13) both(2, 4) both(3, 5)
                both(6, 8) both(7, 9) both(10, 12) both(11, 13) max(0, 1) max(2, 3) max(4, 5)
                both(6, 7) min(8, 9) min(10, 11) min(12, 13) max(1, 8) both(3, 10) min(5, 12)
                max(3, 6) both(5, 8) min(7, 10) max(5, 6) min(7, 8)
            );
        }),
        _ => sorted_window(y, half),
    }
}

/// `0 < half < n`, `half <= 7`: two outputs per evaluation of the selection network
/// `select_middle_pair`, over `LANES` pairs of windows at once, without a branch.
///
/// Windows `2k` and `2k + 1` share the `2 * half` padded values `S` between the
/// first of one and the last of the other; with `S` ranked, the median of `S` and
/// one more value `a` is `max(S[half - 1], min(a, S[half]))`. NaN does not order, so
/// a window that holds one is set to NaN afterwards from a running count. Values
/// that compare equal are bitwise equal except `±0.0`, which the final `+ 0.0` makes
/// `+0.0`; so the result is the sorted window's, bit for bit.
fn by_network(y: &[f64], half: usize, select_middle_pair: impl Fn(&mut Rows)) -> Vec<f64> {
    let n = y.len();
    let size = 2 * half + 1;
    let pairs = n.div_ceil(2);
    let groups = pairs.div_ceil(LANES);
    // Reflect-padded series, then zeros to complete the last group (outputs dropped).
    let mut padded = Vec::with_capacity(n + 2 * half + 2 * LANES + 1);
    padded.extend((0..half).map(|p| y[half - p]));
    padded.extend_from_slice(y);
    padded.extend((0..half).map(|k| y[n - 2 - k]));
    padded.resize(n + 2 * half + 2 * LANES + 1, 0.0);
    let mut out = vec![0.0; 2 * LANES * groups];
    for (g, group) in out.chunks_exact_mut(2 * LANES).enumerate() {
        let win = &padded[2 * LANES * g..2 * LANES * (g + 1) + 2 * half];
        let mut v: Rows = [[0.0; LANES]; 14];
        for (r, row) in v[..2 * half].iter_mut().enumerate() {
            *row = [win[1 + r], win[3 + r], win[5 + r], win[7 + r]];
        }
        select_middle_pair(&mut v);
        let (below, above) = (v[half - 1], v[half]);
        for (l, pair) in group.chunks_exact_mut(2).enumerate() {
            pair[0] = hi(below[l], lo(win[2 * l], above[l])) + 0.0;
            pair[1] = hi(below[l], lo(win[2 * l + size], above[l])) + 0.0;
        }
    }
    out.truncate(n);
    if y.iter().fold(false, |any, v| any | v.is_nan()) {
        // NaN count of the padded values before each index; a window with one is NaN.
        let mut before = Vec::with_capacity(n + 2 * half + 1);
        before.push(0usize);
        for v in &padded[..n + 2 * half] {
            before.push(before[before.len() - 1] + usize::from(v.is_nan()));
        }
        for (i, o) in out.iter_mut().enumerate() {
            if before[i + size] > before[i] {
                *o = f64::NAN;
            }
        }
    }
    out
}

const SIGN: u64 = 1 << 63;

/// Key of a non-NaN value whose integer order is `f64::total_cmp` order (so
/// `-0.0 < 0.0`, and equal keys are bitwise-equal values): negative values have
/// all bits flipped, the others only the sign bit.
pub(crate) fn key(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits & SIGN == 0 {
        bits | SIGN
    } else {
        !bits
    }
}

/// Inverse of [`key`].
pub(crate) fn value(k: u64) -> f64 {
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
fn sorted_window(y: &[f64], half: usize) -> Vec<f64> {
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

    #[test]
    fn networks_select_the_median_of_every_zero_one_window() {
        // Each window of 0s and 1s, back to back: every output is a median of 0-1
        // values, and each window of 2 * half + 1 of them is an output's. A network of
        // comparators right on all 0-1 inputs is right on all inputs (the 0-1 principle).
        for half in 1..=7usize {
            let size = 2 * half + 1;
            let y: Vec<f64> = (0u32..1 << size)
                .flat_map(|bits| (0..size).map(move |k| f64::from((bits >> k) & 1)))
                .collect();
            assert_eq!(reflect_padded(&y, half), naive(&y, size), "half = {half}");
        }
    }

    #[test]
    fn network_and_sorted_window_agree_across_blocks() {
        // Long enough for several blocks of LANES pairs, odd and even lengths.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for n in [
            8,
            2 * LANES - 1,
            2 * LANES,
            2 * LANES + 1,
            50 * LANES + 3,
            50 * LANES + 4,
        ] {
            let y: Vec<f64> = (0..n)
                .map(|_| match next() % 10 {
                    0 => -0.0,
                    1 => 0.0,
                    2 => f64::INFINITY,
                    3 => (next() % 5) as f64,
                    _ => (next() % 2001) as f64 / 7.0 - 140.0,
                })
                .collect();
            for half in 1..=7.min(n - 1) {
                let got = reflect_padded(&y, half);
                assert!(
                    same(&got, &sorted_window(&y, half)),
                    "n = {n}, half = {half}"
                );
                assert!(
                    same(&got, &naive(&y, 2 * half + 1)),
                    "n = {n}, half = {half}"
                );
            }
        }
    }

    /// `np.median` of each window sorted in full: the middle value, or
    /// `(0.0 + a + b) / 2` of the two middle values.
    fn naive_sliding(y: &[f64], window: usize) -> Vec<f64> {
        y.windows(window)
            .map(|w| {
                if w.iter().any(|v| v.is_nan()) {
                    return f64::NAN;
                }
                let mut w = w.to_vec();
                w.sort_by(f64::total_cmp);
                let k = window / 2;
                if window % 2 == 1 {
                    0.0 + w[k]
                } else {
                    (0.0 + w[k - 1] + w[k]) / 2.0
                }
            })
            .collect()
    }

    #[test]
    fn sliding_window_zero_or_wider_than_the_series_is_an_invalid_parameter() {
        for (y, window) in [(&[1.0, 2.0][..], 0), (&[1.0, 2.0][..], 3), (&[][..], 1)] {
            assert!(matches!(
                sliding_median(y, window),
                Err(Error::InvalidParameter { name: "window", .. })
            ));
        }
    }

    #[test]
    fn sliding_median_of_the_whole_series_and_of_single_values() {
        let y = [4.0, -1.0, 7.0, 2.0];
        assert_eq!(sliding_median(&y, 4).unwrap(), vec![3.0]);
        assert_eq!(sliding_median(&y, 1).unwrap(), y.to_vec());
        assert_eq!(sliding_median(&y, 3).unwrap(), vec![4.0, 2.0]);
    }

    #[test]
    fn sliding_even_median_is_numpys_mean_of_the_two_middles() {
        // (a + b) / 2 overflows where a + (b - a) / 2 would not; NumPy's mean does.
        let big = sliding_median(&[1e308, 1.5e308], 2).unwrap();
        assert_eq!(big, vec![f64::INFINITY]);
        let tiny = sliding_median(&[5e-324, 5e-324], 2).unwrap();
        assert_eq!(tiny[0].to_bits(), 5e-324f64.to_bits());
        assert!(sliding_median(&[f64::NEG_INFINITY, f64::INFINITY], 2).unwrap()[0].is_nan());
        let zeros = sliding_median(&[-0.0, -0.0, -0.0], 2).unwrap();
        assert!(zeros.iter().all(|v| v.to_bits() == 0.0f64.to_bits()));
        assert_eq!(
            sliding_median(&[-0.0], 1).unwrap()[0].to_bits(),
            0.0f64.to_bits()
        );
    }

    #[test]
    fn sliding_nan_in_a_window_propagates() {
        let y = [1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0];
        let nan: Vec<bool> = sliding_median(&y, 2)
            .unwrap()
            .iter()
            .map(|v| v.is_nan())
            .collect();
        assert_eq!(nan, [false, true, true, false, false]);
    }

    /// Series of up to `max_len` values: small integers (many ties), reals,
    /// NaN, infinities and -0.0.
    fn series(max_len: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(
            prop_oneof![
                4 => (-3i8..4).prop_map(f64::from),
                4 => -1e3f64..1e3,
                1 => Just(f64::NAN),
                1 => Just(f64::INFINITY),
                1 => Just(f64::NEG_INFINITY),
                1 => Just(-0.0f64),
            ],
            0..max_len,
        )
    }

    proptest! {
        #[test]
        fn network_matches_sort_per_window_on_long_series(
            y in series(700),
            window in 1usize..18,
        ) {
            let got = running_median(&y, window).unwrap();
            prop_assert!(same(&got, &naive(&y, window)), "{got:?}");
        }

        #[test]
        fn sliding_matches_sort_per_window(
            y in series(300),
            window in 1usize..45,
        ) {
            prop_assume!(window <= y.len());
            let got = sliding_median(&y, window).unwrap();
            prop_assert!(same(&got, &naive_sliding(&y, window)), "{got:?}");
        }

        #[test]
        fn matches_sort_per_window(
            y in series(120),
            window in 1usize..40,
        ) {
            let got = running_median(&y, window).unwrap();
            prop_assert!(same(&got, &naive(&y, window)), "{got:?}");
        }
    }
}
