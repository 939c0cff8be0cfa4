//! An LSD radix sort on bit ranges of `u64` keys: the sort of a batch's distinct cells.

/// Stable LSD radix sort of `v` by bits `lo..hi` of each word, in as few passes of at most
/// 11-bit digits as the range needs; digits on which every word agrees are skipped. `scratch`
/// is reused between calls.
pub(crate) fn radix_sort_bits(v: &mut Vec<u64>, scratch: &mut Vec<u64>, lo: u32, hi: u32) {
    radix_sort_by_key(v, scratch, |&x| x, lo, hi);
}

/// Stable LSD radix sort of `v` by bits `lo..hi` of `key(element)`, as [`radix_sort_bits`].
pub(crate) fn radix_sort_by_key<T: Copy>(
    v: &mut Vec<T>,
    scratch: &mut Vec<T>,
    key: impl Fn(&T) -> u64,
    lo: u32,
    hi: u32,
) {
    if v.len() < 2 || hi <= lo {
        return;
    }
    let passes = (hi - lo).div_ceil(11);
    let width = (hi - lo).div_ceil(passes);
    let buckets = 1usize << width;
    let digit_mask = buckets as u64 - 1;
    // Histograms of every digit in one pass.
    let mut counts = vec![0usize; buckets * passes as usize];
    for x in v.iter() {
        let y = key(x) >> lo;
        for d in 0..passes {
            counts[d as usize * buckets + ((y >> (width * d)) & digit_mask) as usize] += 1;
        }
    }
    scratch.clear();
    scratch.resize(v.len(), v[0]);
    for (d, c) in counts.chunks_exact_mut(buckets).enumerate() {
        if c.contains(&v.len()) {
            continue;
        }
        // Counts become start positions.
        let mut sum = 0;
        for n in c.iter_mut() {
            let here = *n;
            *n = sum;
            sum += here;
        }
        let s = lo + width * d as u32;
        for x in v.iter() {
            let b = ((key(x) >> s) & digit_mask) as usize;
            scratch[c[b]] = *x;
            c[b] += 1;
        }
        std::mem::swap(v, scratch);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radix_sort_sorts_stably_by_the_bit_range() {
        let mut x = 12345u64;
        let mut v: Vec<u64> = (0..5000u64)
            .map(|i| {
                x = x
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((x >> 40) << 13) | i
            })
            .collect();
        let mut want = v.clone();
        want.sort_by_key(|w| w >> 13);
        radix_sort_bits(&mut v, &mut Vec::new(), 13, 13 + 24);
        assert_eq!(v, want);
    }
}
