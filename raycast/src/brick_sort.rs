//! Sorting a frame's bricks by code: a least-significant-digit radix sort over only the bits
//! in which the codes differ.
//!
//! A frame's bricks are listed in Morton order for the tree update ([`crate::brickset`]).
//! A comparison sort of a LiDAR frame's 170 000 free bricks at 0.2 m took about 5 ms, an
//! eighth of the frame's casting time (and 20-30 ms of 720 000 bricks at 0.1 m). The codes of
//! one frame share their high bits (the frame covers a small part of the key space), so two
//! or three passes of up to 12 bits each sort them, each pass one read and one scattered
//! write of every brick; the histograms of all passes come from one read before the first.

use octoquant_octree::Brick;

/// Fewer bricks than this are sorted by comparison: the histograms would cost more.
const RADIX_MIN: usize = 256;

/// Widest digit of a pass: 4 096 counters, 16 KiB, stay in the first-level cache.
const MAX_DIGIT_BITS: u32 = 12;

/// Sort `bricks` by code, ascending, using `scratch` (at least as long) as the other buffer
/// of the passes. The codes must be distinct (a set's bricks are), so the order is the one
/// order by code; the scratch's contents afterwards are unspecified.
pub(crate) fn sort_by_code(bricks: &mut [Brick], scratch: &mut [Brick]) {
    let n = bricks.len();
    if n < RADIX_MIN {
        bricks.sort_unstable_by_key(|b| b.code);
        return;
    }
    let scratch = &mut scratch[..n];
    // the bits in which some code differs from the first: every higher bit is the same in all
    let first = bricks[0].code;
    let differ = bricks.iter().fold(0u64, |acc, b| acc | (b.code ^ first));
    let bits = 64 - differ.leading_zeros();
    if bits == 0 {
        return;
    }
    let passes = bits.div_ceil(MAX_DIGIT_BITS);
    let width = bits.div_ceil(passes);
    let radix = 1usize << width;
    let mask = (radix - 1) as u64;
    // every pass's histogram in one read
    let mut counts = vec![0u32; radix * passes as usize];
    for b in bricks.iter() {
        for p in 0..passes {
            let digit = ((b.code >> (p * width)) & mask) as usize;
            counts[p as usize * radix + digit] += 1;
        }
    }
    let (mut from, mut to): (&mut [Brick], &mut [Brick]) = (bricks, scratch);
    for p in 0..passes {
        let hist = &mut counts[p as usize * radix..(p as usize + 1) * radix];
        // counts to starting offsets
        let mut at = 0u32;
        for c in hist.iter_mut() {
            let k = *c;
            *c = at;
            at += k;
        }
        for b in from.iter() {
            let digit = ((b.code >> (p * width)) & mask) as usize;
            to[hist[digit] as usize] = *b;
            hist[digit] += 1;
        }
        std::mem::swap(&mut from, &mut to);
    }
    // after an odd number of passes the sorted bricks are in the scratch
    if passes % 2 == 1 {
        to.copy_from_slice(from);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(codes: Vec<u64>) {
        let mut bricks: Vec<Brick> = codes
            .iter()
            .enumerate()
            .map(|(i, &code)| Brick {
                code,
                voxels: i as u64 + 1,
            })
            .collect();
        let mut want = bricks.clone();
        // the definition: the standard library's comparison sort by code
        want.sort_by_key(|b| b.code);
        let mut scratch = vec![Brick { code: 0, voxels: 0 }; bricks.len()];
        sort_by_code(&mut bricks, &mut scratch);
        assert!(bricks == want);
    }

    fn distinct(mut codes: Vec<u64>) -> Vec<u64> {
        let mut seen = std::collections::HashSet::new();
        codes.retain(|c| seen.insert(*c));
        codes
    }

    proptest! {
        /// Any distinct codes of up to 42 bits (a brick code's width), around any base.
        #[test]
        fn sorts_like_a_comparison_sort(
            base in 0u64..(1 << 42),
            spread in 0u32..42,
            offs in proptest::collection::vec(any::<u64>(), 0..3000),
        ) {
            let m = (1u64 << spread) - 1;
            let codes = offs.iter().map(|o| (base ^ (o & m)) & ((1 << 42) - 1)).collect();
            check(distinct(codes));
        }
    }

    #[test]
    fn passes_of_every_count() {
        // one, two, three and four passes (bits 1..=42), at and around the radix threshold
        for bits in [1u32, 5, 12, 13, 24, 25, 36, 37, 42] {
            for n in [RADIX_MIN - 1, RADIX_MIN, 5000] {
                let mut s = 0x9E37_79B9_7F4A_7C15u64 ^ bits as u64;
                let codes = (0..n)
                    .map(|_| {
                        s ^= s << 13;
                        s ^= s >> 7;
                        s ^= s << 17;
                        (s & ((1 << bits) - 1)) | (7 << 42)
                    })
                    .collect();
                check(distinct(codes));
            }
        }
    }
}
