//! Sorting a long series of floats: a radix sort of order-preserving integer keys.
//!
//! The diagnosis sorts each observable's samples once per engine (its knots are then
//! found by bisection); NumPy's comparison sort takes about 40 ns a value there.

use crate::robust::{key, value};

/// Bits of the key sorted per pass.
const DIGIT_BITS: u32 = 11;
/// Buckets of one digit.
const BUCKETS: usize = 1 << DIGIT_BITS;
/// Passes that cover the 64 bits of a key.
const PASSES: u32 = 64_u32.div_ceil(DIGIT_BITS);

/// Return `values` sorted ascending, NaN last: the order of `np.sort(values)`.
///
/// Values that compare equal come out equal but for the sign of a zero: `-0.0` sorts
/// before `0.0` (NumPy leaves their order to its algorithm). Every other value is
/// bitwise an input; the NaNs keep their bits and their order, after everything else.
///
/// Cost: an LSD radix sort of [`DIGIT_BITS`]-bit digits over keys whose integer order
/// is `f64::total_cmp`'s: one pass counts every digit, then one stable pass per digit
/// that is not the same in every key. O(n) time, O(n) extra memory.
///
/// # Examples
///
/// ```
/// use accelcore_core::sorted;
///
/// let s = sorted(&[3.0, f64::NAN, -1.5, 0.0, -0.0, f64::NEG_INFINITY]);
/// assert_eq!(&s[..5], &[f64::NEG_INFINITY, -1.5, -0.0, 0.0, 3.0]);
/// assert!(s[5].is_nan());
/// ```
#[must_use]
pub fn sorted(values: &[f64]) -> Vec<f64> {
    let nans: Vec<f64> = values.iter().copied().filter(|v| v.is_nan()).collect();
    let mut keys: Vec<u64> = values
        .iter()
        .filter(|v| !v.is_nan())
        .map(|&v| key(v))
        .collect();
    radix_sort(&mut keys);
    let mut out: Vec<f64> = keys.into_iter().map(value).collect();
    out.extend(nans);
    out
}

/// Sort `keys` ascending (LSD radix; see [`sorted`]).
fn radix_sort(keys: &mut Vec<u64>) {
    let n = keys.len();
    if n < 2 {
        return;
    }
    let mut counts = vec![[0_usize; BUCKETS]; PASSES as usize];
    for &k in keys.iter() {
        for (pass, count) in counts.iter_mut().enumerate() {
            count[digit(k, pass as u32)] += 1;
        }
    }
    let mut scratch = vec![0_u64; n];
    for (pass, count) in counts.iter().enumerate() {
        if count.contains(&n) {
            continue; // every key has this digit: the pass would move nothing
        }
        let mut next = [0_usize; BUCKETS];
        let mut total = 0;
        for (slot, &c) in next.iter_mut().zip(count.iter()) {
            *slot = total;
            total += c;
        }
        for &k in keys.iter() {
            let d = digit(k, pass as u32);
            scratch[next[d]] = k;
            next[d] += 1;
        }
        std::mem::swap(keys, &mut scratch);
    }
}

/// Digit `pass` (least significant first) of a key.
#[inline]
fn digit(k: u64, pass: u32) -> usize {
    ((k >> (pass * DIGIT_BITS)) & (BUCKETS as u64 - 1)) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn by_total_cmp(values: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| !x.is_nan()).collect();
        v.sort_by(f64::total_cmp);
        v
    }

    #[test]
    fn matches_a_comparison_sort() {
        let series: Vec<Vec<f64>> = vec![
            (0..5000_u64)
                .map(|i| ((i * 2_654_435_761) % 1_000_003) as f64 * 1e-3 - 500.0)
                .collect(),
            (0..5000_u64).map(|i| (i % 7) as f64 - 3.0).collect(),
            (0..5000_u64).rev().map(|i| i as f64 * 1e300).collect(),
            (0..5000_u64)
                .map(|i| if i % 2 == 0 { -0.0 } else { 0.0 })
                .collect(),
            vec![f64::INFINITY, f64::MIN_POSITIVE, -f64::MAX, 5e-324, -5e-324],
            vec![],
            vec![1.0],
        ];
        for values in &series {
            let got = sorted(values);
            let want = by_total_cmp(values);
            assert_eq!(got.len(), values.len());
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want));
        }
    }

    #[test]
    fn nans_last_in_input_order() {
        let a = f64::from_bits(0x7ff8_0000_0000_0001);
        let b = -f64::NAN;
        let got = sorted(&[a, 2.0, b, -1.0]);
        assert_eq!(&got[..2], &[-1.0, 2.0]);
        assert_eq!(got[2].to_bits(), a.to_bits());
        assert_eq!(got[3].to_bits(), b.to_bits());
    }
}
