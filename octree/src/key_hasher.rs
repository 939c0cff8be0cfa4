//! A fast hasher for the maps keyed by voxel keys or node ids: the colour and stamped trees'
//! side tables (a lookup for every node an update passes) and OctoMap's key containers
//! ([`crate::key_table::KeyTable`], and the keys of a colour scan outside its
//! [`crate::KeySetLog`] window: a lookup per ray step).
//!
//! The standard `HashMap` hashes with SipHash, built to resist keys chosen against it; these
//! keys are the map's own voxels, and SipHash took a fifth of a stamped map's insertion and a
//! fifth of a colour map's. Keeping neighbours in neighbouring buckets (the Morton index as the
//! table index) was measured too and was slower: the clusters it makes lengthen the probes.

/// The `BuildHasher` of [`KeyHasher`], for `HashMap<_, _, KeyHashing>`.
pub(crate) type KeyHashing = std::hash::BuildHasherDefault<KeyHasher>;

/// The hasher: what a key's or node id's `Hash` writes (a depth byte, a length, the key's
/// six bytes) folded into one word, then mixed once (murmur3's finaliser).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct KeyHasher(u64);

impl KeyHasher {
    #[inline]
    fn add(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(17) ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

impl std::hash::Hasher for KeyHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(word));
        }
    }

    #[inline]
    fn write_u8(&mut self, i: u8) {
        self.add(u64::from(i));
    }

    #[inline]
    fn write_u16(&mut self, i: u16) {
        self.add(u64::from(i));
    }

    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }

    #[inline]
    fn finish(&self) -> u64 {
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^ (h >> 33)
    }
}
