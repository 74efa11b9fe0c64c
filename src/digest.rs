//! Content digests: FNV-1a over bytes, to tell whether a file a study read
//! (its catalogue) or wrote (trials.csv) is still the one it was. Not a
//! cryptographic hash: it detects change, not tampering.

/// FNV-1a, 64 bit: the start value.
pub const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

/// Continue an FNV-1a hash over `bytes`.
pub fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01B3);
    }
    h
}

/// The digest of `bytes` as 16 hex digits (what manifests record).
pub fn hex(bytes: &[u8]) -> String {
    format!("{:016x}", fnv1a(FNV_START, bytes))
}

#[cfg(test)]
mod tests {
    #[test]
    fn hex_is_the_fnv1a_of_the_bytes() {
        assert_eq!(super::hex(b""), "cbf29ce484222325");
        assert_eq!(super::hex(b"a"), "af63dc4c8601ec8c");
        assert_ne!(super::hex(b"price = 1"), super::hex(b"price = 2"));
    }
}
