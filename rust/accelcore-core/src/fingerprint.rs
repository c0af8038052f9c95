//! Fingerprints of arrays for in-memory caches: fast, not provenance.
//!
//! Provenance digests (the logs' content, recorded in calibration files) are
//! BLAKE3 or SHA-256 ([`crate::reader::DigestAlgorithm`]). A cache that keys a
//! result by the content of the arrays it was computed from needs no
//! cryptographic strength, only that distinct arrays get distinct keys: 128-bit
//! XXH3 gives that (a chance collision among 2^32 arrays has odds about 2^-64)
//! at several times BLAKE3's speed.

use xxhash_rust::xxh3::Xxh3;

/// Values converted to bytes per update of the hasher.
const CHUNK: usize = 1024;

/// 128-bit XXH3 of a float series and an integer series: the length and the
/// little-endian bytes of `values`, then those of `counts`.
///
/// Equal inputs give equal fingerprints on every platform; inputs that differ in
/// any bit (`-0.0` and `0.0`, two NaN payloads), in length, or in how the values
/// are split between the two series give different ones, but for chance.
///
/// # Examples
///
/// ```
/// use accelcore_core::fingerprint;
///
/// let a = fingerprint(&[1.0, 2.0], &[10, 10]);
/// assert_eq!(a, fingerprint(&[1.0, 2.0], &[10, 10]));
/// assert_ne!(a, fingerprint(&[1.0, -2.0], &[10, 10]));
/// assert_ne!(fingerprint(&[1.0], &[]), fingerprint(&[], &[1.0_f64.to_bits() as i64]));
/// ```
#[must_use]
pub fn fingerprint(values: &[f64], counts: &[i64]) -> u128 {
    let mut hasher = Xxh3::new();
    let mut buf = [0_u8; 8 * CHUNK];
    hasher.update(&(values.len() as u64).to_le_bytes());
    for chunk in values.chunks(CHUNK) {
        for (out, v) in buf.chunks_exact_mut(8).zip(chunk) {
            out.copy_from_slice(&v.to_le_bytes());
        }
        hasher.update(&buf[..8 * chunk.len()]);
    }
    hasher.update(&(counts.len() as u64).to_le_bytes());
    for chunk in counts.chunks(CHUNK) {
        for (out, v) in buf.chunks_exact_mut(8).zip(chunk) {
            out.copy_from_slice(&v.to_le_bytes());
        }
        hasher.update(&buf[..8 * chunk.len()]);
    }
    hasher.digest128()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bit_and_the_split_count() {
        let base = fingerprint(&[0.0, 1.0, 2.0], &[1, 2, 3]);
        assert_ne!(base, fingerprint(&[-0.0, 1.0, 2.0], &[1, 2, 3]));
        assert_ne!(base, fingerprint(&[0.0, 1.0, 2.0], &[1, 2, 4]));
        assert_ne!(base, fingerprint(&[0.0, 1.0], &[1, 2, 3]));
        assert_ne!(fingerprint(&[], &[]), fingerprint(&[0.0], &[]));
        assert_ne!(fingerprint(&[0.0], &[]), fingerprint(&[], &[0]));
    }

    #[test]
    fn chunk_edges_do_not_matter() {
        // Past one chunk: a value changed on either side of the edge is seen.
        let values: Vec<f64> = (0..2 * CHUNK + 3).map(|i| i as f64).collect();
        let base = fingerprint(&values, &[]);
        for at in [CHUNK - 1, CHUNK, 2 * CHUNK + 2] {
            let mut other = values.clone();
            other[at] += 0.5;
            assert_ne!(base, fingerprint(&other, &[]), "at {at}");
        }
        assert_eq!(base, fingerprint(&values.clone(), &[]));
    }
}
