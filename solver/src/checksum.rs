//! A stable 64-bit checksum for fingerprints of a run's inputs and for checkpoint files:
//! FNV-1a (Fowler–Noll–Vo). Not cryptographic: it detects changed inputs and corrupted or
//! truncated files, it does not authenticate them. Written here (eight lines) rather than
//! taken from a crate because its output is stored in checkpoints and must never change with
//! a dependency's version.

/// FNV-1a, 64 bit, of `bytes`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn matches_the_published_test_vectors() {
        assert_eq!(super::fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(super::fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(super::fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
