//! Packing of cell indexes into one `u64` whose integer order is the lexicographic order of
//! the indexes: the keys of a batch sort.

use crate::spec::{all_finite, floor_trunc, CellIndex};

/// Packing of cell indexes within a box of cells into `u64` keys, axis 0 most significant, so
/// that the integer order of keys is the lexicographic order of the indexes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Packing<const D: usize> {
    min: CellIndex<D>,
    shift: [u32; D],
    mask: [u64; D],
    /// Total key bits.
    pub bits: u32,
}

impl<const D: usize> Packing<D> {
    /// The packing of the box `lo..=hi` (per axis), or `None` when it needs more than 64 bits.
    pub(crate) fn new(lo: &CellIndex<D>, hi: &CellIndex<D>) -> Option<Self> {
        let mut width = [0u32; D];
        for a in 0..D {
            // Both ends lie within +-2^53, so the span fits in u64.
            let span = hi[a].abs_diff(lo[a]);
            width[a] = 64 - span.leading_zeros();
        }
        let bits: u32 = width.iter().sum();
        if bits > 64 {
            return None;
        }
        let mut shift = [0u32; D];
        let mut mask = [0u64; D];
        let mut s = 0;
        for a in (0..D).rev() {
            shift[a] = s;
            mask[a] = if width[a] == 0 {
                0
            } else {
                u64::MAX >> (64 - width[a])
            };
            s += width[a];
        }
        Some(Packing {
            min: *lo,
            shift,
            mask,
            bits,
        })
    }

    /// The key of `index`, which must lie in the box.
    #[inline]
    pub(crate) fn pack(&self, index: &CellIndex<D>) -> u64 {
        let mut k = 0u64;
        for (a, &v) in index.iter().enumerate() {
            // `shift` is < 64 whenever the axis has a non-zero width; a zero-width axis adds 0.
            if self.mask[a] != 0 {
                k |= v.abs_diff(self.min[a]) << self.shift[a];
            }
        }
        k
    }

    /// The key of the cell holding the finite point `p` (`None` for a NaN or infinite
    /// coordinate), for a packing whose box holds the cells of every finite point of a batch
    /// (`lo..=hi` the cells of the batch's coordinate-wise minimum and maximum, `bits < 64`).
    ///
    /// Same cell as [`GridSpec::cell_index`](crate::GridSpec::cell_index) then `pack`, without
    /// the range checks: `(x - offset) / size` is monotone in `x`, so a finite coordinate's
    /// quotient lies between those of the box's corners, whose floors are in range.
    #[inline]
    pub(crate) fn key_in_box(
        &self,
        p: &[f64; D],
        size: &[f64; D],
        offset: &[f64; D],
    ) -> Option<u64> {
        if !all_finite(p) {
            return None;
        }
        let mut k = 0u64;
        for a in 0..D {
            // Exact floor (|q| <= 2^53 + 1 here).
            let t = floor_trunc((p[a] - offset[a]) / size[a]);
            // `t >= min[a]` by monotonicity, and `shift[a] < bits < 64`; a zero-width axis
            // adds 0 (there `t == min[a]`). Wrapping keeps a violated assumption panic-free.
            k |= (t.wrapping_sub(self.min[a]) as u64) << (self.shift[a] & 63);
        }
        Some(k)
    }

    /// The index of key `k`.
    #[inline]
    pub(crate) fn unpack(&self, k: u64) -> CellIndex<D> {
        let mut index = self.min;
        for (a, v) in index.iter_mut().enumerate() {
            if self.mask[a] != 0 {
                *v += ((k >> self.shift[a]) & self.mask[a]) as i64;
            }
        }
        index
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_keeps_lexicographic_order() {
        let lo = [-3i64, 5, -100];
        let hi = [4i64, 5, 27];
        let p = Packing::new(&lo, &hi).unwrap();
        assert_eq!(p.bits, 3 + 7);
        let mut all = Vec::new();
        for x in lo[0]..=hi[0] {
            for z in lo[2]..=hi[2] {
                all.push([x, 5, z]);
            }
        }
        for w in all.windows(2) {
            assert!(p.pack(&w[0]) < p.pack(&w[1]));
            assert_eq!(p.unpack(p.pack(&w[0])), w[0]);
        }
        let big = 1i64 << 53;
        assert!(Packing::new(&[-big, 0], &[big, 0]).is_some());
        assert!(Packing::new(&[-big, -big], &[big, big]).is_none());
        assert!(Packing::new(&[7i64; 4], &[7i64; 4]).unwrap().bits == 0);
    }
}
