//! Eight Bresenham lines at once in the 512-bit registers of AVX-512, chosen at run time: the
//! lines of [`crate::bresenham::walk_bresenham_bricks`], voxel for voxel.
//!
//! Each lane keeps its line's Morton code mirrored on the axes it walks downwards (so every
//! step is an increment, as in [`crate::lanes::avx512`]), the Morton bits of its main and two
//! minor axes, its two error terms and the voxels left. A step moves the minor axes whose
//! error term is positive (masked), then the main axis, and updates the error terms with the
//! scalar walk's integers. Bricks are kept and handed on as in the DDA lanes; a lane whose line
//! ends starts the next line in the same step, its start voxel standing in for the step's.

use super::avx512::{Bricks8, OctScratch};
use crate::brickset::BrickSink;
use crate::cpu::has_avx512;
use crate::dda::{mirror_mask, AXIS_MASK};
use core::arch::x86_64::{
    __m512i, __mmask8, _mm512_add_epi64, _mm512_and_si512, _mm512_andnot_si512,
    _mm512_cmpeq_epi64_mask, _mm512_cmpgt_epi64_mask, _mm512_mask_mov_epi64, _mm512_mask_sub_epi64,
    _mm512_maskz_mov_epi64, _mm512_or_si512, _mm512_set1_epi64, _mm512_setzero_si512,
    _mm512_sub_epi64, _mm512_xor_si512,
};
use octoquant_octree::Key;

/// Eight lanes' codes as an array.
type U8 = [u64; 8];

/// Walk the lines `start -> end` of `lines` (each with at least one voxel) eight at a time
/// when this CPU has AVX-512, handing each brick they enter to `flush`; `None` (nothing done)
/// on CPUs without it.
pub(crate) fn walk_lines<F>(
    lines: &[(Key, Key)],
    scratch: &mut OctScratch,
    flush: &mut F,
) -> Option<()>
where
    F: BrickSink,
{
    if !has_avx512() {
        return None;
    }
    // SAFETY: `walk_lines_avx512` needs AVX-512 Foundation and `popcnt`, and the CPU has been
    // found to support both just above. Nothing else in it is unsafe.
    #[allow(unsafe_code)]
    unsafe {
        walk_lines_avx512(lines, scratch, flush)
    };
    Some(())
}

/// One line's lane state as scalars.
#[derive(Clone, Copy)]
struct LineInit {
    /// The start voxel's code, mirrored by `flip`.
    m: u64,
    flip: u64,
    main: u64,
    minor: [u64; 2],
    err: [i64; 2],
    inc: [i64; 2],
    dec: i64,
    /// Voxels the line visits (its main-axis distance).
    left: i64,
    /// The start voxel's code.
    origin: u64,
}

impl LineInit {
    /// The scalar walk's set-up: main axis the longest (ties to x, then y), error terms
    /// `2·|d_minor| - n`.
    fn new(start: Key, end: Key) -> Self {
        let d = [0, 1, 2].map(|a| end[a] as i64 - start[a] as i64);
        let ad = d.map(i64::abs);
        let main = crate::bresenham::main_axis(ad);
        let (a1, a2) = ((main + 1) % 3, (main + 2) % 3);
        let n = ad[main];
        let flip = mirror_mask(d.map(|x| x < 0));
        let code = start.morton();
        LineInit {
            m: code ^ flip,
            flip,
            main: AXIS_MASK[main],
            minor: [AXIS_MASK[a1], AXIS_MASK[a2]],
            err: [2 * ad[a1] - n, 2 * ad[a2] - n],
            inc: [2 * ad[a1], 2 * ad[a2]],
            dec: 2 * n,
            left: n,
            origin: code,
        }
    }

    /// A lane without a line: no axis moves, no error term changes, it never ends, and it
    /// keeps writing `code`, a voxel already recorded.
    fn idle(code: u64) -> Self {
        LineInit {
            m: code,
            flip: 0,
            main: 0,
            minor: [0; 2],
            err: [0; 2],
            inc: [0; 2],
            dec: 0,
            left: i64::MAX,
            origin: code,
        }
    }
}

/// The eight lanes' registers.
struct Lanes {
    m: __m512i,
    flip: __m512i,
    main: __m512i,
    minor: [__m512i; 2],
    err: [__m512i; 2],
    inc: [__m512i; 2],
    dec: __m512i,
    left: __m512i,
}

impl Lanes {
    /// Overwrite lane `l` with `s` by masked moves of broadcasts.
    #[target_feature(enable = "avx512f")]
    fn set(&mut self, l: usize, s: &LineInit) {
        let k: __mmask8 = 1 << (l & 7);
        let put = |v: &mut __m512i, x: i64| *v = _mm512_mask_mov_epi64(*v, k, _mm512_set1_epi64(x));
        put(&mut self.m, s.m as i64);
        put(&mut self.flip, s.flip as i64);
        put(&mut self.main, s.main as i64);
        for i in 0..2 {
            put(&mut self.minor[i], s.minor[i] as i64);
            put(&mut self.err[i], s.err[i]);
            put(&mut self.inc[i], s.inc[i]);
        }
        put(&mut self.dec, s.dec);
        put(&mut self.left, s.left);
    }
}

/// One step up on the axis bits `mask` (all zero: no step) of the mirrored codes `m`.
#[inline]
#[target_feature(enable = "avx512f")]
fn step_up(m: __m512i, mask: __m512i) -> __m512i {
    let zero = _mm512_setzero_si512();
    let low = _mm512_and_si512(mask, _mm512_sub_epi64(zero, mask));
    let up = _mm512_add_epi64(
        _mm512_or_si512(m, _mm512_xor_si512(mask, _mm512_set1_epi64(-1))),
        low,
    );
    _mm512_or_si512(_mm512_and_si512(up, mask), _mm512_andnot_si512(mask, m))
}

/// [`walk_lines`] once AVX-512 is known to be there.
#[target_feature(enable = "avx512f,popcnt")]
fn walk_lines_avx512<F>(lines: &[(Key, Key)], scratch: &mut OctScratch, flush: &mut F)
where
    F: BrickSink,
{
    let Some(&(s0, e0)) = lines.first() else {
        return;
    };
    let zero = _mm512_setzero_si512();
    let mut q = Lanes {
        m: zero,
        flip: zero,
        main: zero,
        minor: [zero; 2],
        err: [zero; 2],
        inc: [zero; 2],
        dec: zero,
        left: zero,
    };
    // idle lanes repeat the first line's start voxel, which is recorded
    let idle_code = LineInit::new(s0, e0).origin;
    let mut next = lines.iter();
    let mut live = 8;
    let mut codes: U8 = [idle_code; 8];
    for (l, code) in codes.iter_mut().enumerate() {
        let s = match next.next() {
            Some(&(a, b)) => LineInit::new(a, b),
            None => {
                live -= 1;
                LineInit::idle(idle_code)
            }
        };
        *code = s.origin;
        q.set(l, &s);
    }
    let one = _mm512_set1_epi64(1);
    let mut bricks = Bricks8::new(bytemuck::cast(codes), scratch);
    loop {
        // the minor axes whose error term is positive step, then the main axis
        let k1 = _mm512_cmpgt_epi64_mask(q.err[0], zero);
        let k2 = _mm512_cmpgt_epi64_mask(q.err[1], zero);
        q.m = step_up(q.m, _mm512_maskz_mov_epi64(k1, q.minor[0]));
        q.m = step_up(q.m, _mm512_maskz_mov_epi64(k2, q.minor[1]));
        q.m = step_up(q.m, q.main);
        q.err[0] = _mm512_add_epi64(
            _mm512_mask_sub_epi64(q.err[0], k1, q.err[0], q.dec),
            q.inc[0],
        );
        q.err[1] = _mm512_add_epi64(
            _mm512_mask_sub_epi64(q.err[1], k2, q.err[1], q.dec),
            q.inc[1],
        );
        q.left = _mm512_sub_epi64(q.left, one);
        let ended = _mm512_cmpeq_epi64_mask(q.left, zero);
        let mut codes = _mm512_xor_si512(q.m, q.flip);
        let mut finished = false;
        if ended != 0 {
            // the rare step where lines end (on their end voxel, not visited): restart those
            // lanes on the next lines
            let mut written: U8 = bytemuck::cast(codes);
            for (l, code) in written.iter_mut().enumerate() {
                if ended & (1 << l) == 0 {
                    continue;
                }
                let s = match next.next() {
                    Some(&(a, b)) => LineInit::new(a, b),
                    None => {
                        live -= 1;
                        LineInit::idle(idle_code)
                    }
                };
                *code = s.origin;
                q.set(l, &s);
            }
            codes = bytemuck::cast(written);
            finished = live == 0;
        }
        bricks.push(codes, flush);
        if finished {
            bricks.finish(flush);
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoquant_octree::Brick;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    fn add(set: &mut BTreeSet<u64>, b: Brick) {
        let mut m = b.voxels;
        while m != 0 {
            set.insert((b.code << 6) | m.trailing_zeros() as u64);
            m &= m - 1;
        }
    }

    proptest! {
        /// The lanes visit exactly the voxels of the scalar lines, for batches of any size
        /// (idle lanes included), lines in every direction and of every length.
        #[test]
        fn lanes_visit_the_scalar_lines(
            start in prop::array::uniform3(1000u16..64000),
            ends in prop::collection::vec(prop::array::uniform3(-300i32..300), 1..40),
        ) {
            let s = Key(start);
            let lines: Vec<(Key, Key)> = ends
                .iter()
                .map(|d| (s, Key([0, 1, 2].map(|i| (start[i] as i32 + d[i]) as u16))))
                .filter(|(a, b)| a != b)
                .collect();
            prop_assume!(!lines.is_empty());
            let mut want = BTreeSet::new();
            for &(a, b) in &lines {
                crate::bresenham::walk_bresenham_bricks(a, b, &mut |b| add(&mut want, b));
            }
            let mut got = BTreeSet::new();
            let mut scratch = OctScratch::default();
            if walk_lines(&lines, &mut scratch, &mut |b| add(&mut got, b)).is_some() {
                prop_assert_eq!(got, want);
            }
        }
    }
}
