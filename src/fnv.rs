//! FNV-1a, 64 bit (Fowler, Noll & Vo): the stable hash of a job's text (the
//! `job_hash` of outputs and state files) and the checksum of state files.
//! One step folds a value into the hash: h ← (h ⊕ v)·p.

/// The offset basis: the hash of nothing.
pub const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
/// The 64-bit FNV prime.
const PRIME: u64 = 0x0000_0100_0000_01b3;

/// Folds `v` into the hash `h`.
#[inline]
pub fn step(h: u64, v: u64) -> u64 {
    (h ^ v).wrapping_mul(PRIME)
}

/// FNV-1a over bytes, one byte per step (the standard form).
pub fn bytes(data: &[u8]) -> u64 {
    data.iter().fold(OFFSET, |h, &b| step(h, u64::from(b)))
}

/// FNV-1a over little-endian 8-byte words, one word per step (`data.len()`
/// a multiple of 8; a shorter tail is ignored).
pub fn words(data: &[u8]) -> u64 {
    data.chunks_exact(8).fold(OFFSET, |h, w| {
        step(h, u64::from_le_bytes(w.try_into().expect("8 bytes")))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn published_test_vectors() {
        // The FNV-1a 64 test vectors of the reference implementation.
        assert_eq!(bytes(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(bytes(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(bytes(b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn words_fold_each_word_as_one_value() {
        let data: Vec<u8> = [3u64, 5].iter().flat_map(|w| w.to_le_bytes()).collect();
        assert_eq!(words(&data), step(step(OFFSET, 3), 5));
    }
}
