//! Four Bresenham lines at once in the 256-bit registers of AVX2, chosen at run time: the
//! lines of [`crate::bresenham::walk_bresenham_bricks`], voxel for voxel, on CPUs without
//! AVX-512 (where [`crate::lanes::bresenham_avx512`] walks eight).
//!
//! Each lane keeps its line's Morton code mirrored on the axes it walks downwards (so every
//! step is an increment, as in [`crate::lanes::avx2`]) and one error term per axis, x, y and
//! z in that order in every lane, so that no lane needs its own axis masks: an axis steps when
//! its error term is positive. The main axis's term stays at 1 (it steps every time; its
//! increment equals the shared decrement `2n`), the minor axes' terms are the scalar walk's
//! integers. The three axes' increments of the code are made side by side (each on its own
//! Morton bits, `((m | !axis) + low) & axis`) and joined, which keeps the chain carried from
//! step to step short.
//!
//! A line's last step is known when it starts (its main-axis distance after it), so the lanes
//! keep the step at which each ends and the loop compares one scalar, the earliest of them,
//! with the step count; only steps where lines end take a branch. A lane whose line ends
//! starts the next line in the same step, its start voxel standing in for the step's (the end
//! voxel, which the line excludes); when the lines run out, the lane idles on a voxel already
//! recorded. Each lane's open brick and its voxels stay in registers; the bricks the lanes
//! leave go to the front of a register by the permutation table of [`crate::lanes::avx2`],
//! are appended with one store and handed on to the brick set in batches.
//!
//! The module's one `unsafe` is the call into [`walk_lines_avx2`] after the run-time check for
//! AVX2.

use super::avx2::COMPRESS;
use crate::brickset::BrickSink;
use crate::cpu::has_avx2;
use crate::dda::{mirror_mask, AXIS_MASK};
use core::arch::x86_64::{
    __m256i, _mm256_add_epi64, _mm256_and_si256, _mm256_blendv_epi8, _mm256_castsi256_pd,
    _mm256_cmpeq_epi64, _mm256_cmpgt_epi64, _mm256_movemask_pd, _mm256_or_si256,
    _mm256_permutevar8x32_epi32, _mm256_set1_epi64x, _mm256_setzero_si256, _mm256_sllv_epi64,
    _mm256_srli_epi64, _mm256_sub_epi64, _mm256_xor_si256,
};
use octoquant_octree::{Brick, Key};

/// Bricks left by the lanes that are collected before they are handed on.
const LEFT: usize = 1024;

/// Four lanes' values as an array.
type U4 = [u64; 4];

/// The per-thread buffers of the four-lane lines, kept from batch to batch: the bricks the
/// lanes left and their voxels, side by side, with room for one more step's four. Fixed-size,
/// so a step's store needs no bounds check.
#[derive(Debug, Clone)]
pub(crate) struct QuadLineScratch {
    bricks: Box<[u64; LEFT + 4]>,
    bits: Box<[u64; LEFT + 4]>,
}

impl Default for QuadLineScratch {
    fn default() -> Self {
        QuadLineScratch {
            bricks: Box::new([0; LEFT + 4]),
            bits: Box::new([0; LEFT + 4]),
        }
    }
}

/// Walk the lines `start -> end` of `lines` four at a time when this CPU has AVX2, handing
/// each brick they enter to `flush`; `None` (nothing done) on CPUs without it. Lines whose
/// start and end are equal have no voxel and are skipped.
pub(crate) fn walk_lines<F>(
    lines: &[(Key, Key)],
    scratch: &mut QuadLineScratch,
    flush: &mut F,
) -> Option<()>
where
    F: BrickSink,
{
    if !has_avx2() {
        return None;
    }
    // SAFETY: `walk_lines_avx2` needs AVX2 (and the AVX it implies), and the CPU has been
    // found to support AVX2 just above. Nothing else in it is unsafe.
    #[allow(unsafe_code)]
    unsafe {
        walk_lines_avx2(lines, scratch, flush)
    };
    Some(())
}

/// One line's lane state as scalars, axes in the order x, y, z.
#[derive(Clone, Copy)]
struct LineInit {
    /// The start voxel's code, mirrored by `flip`.
    m: u64,
    flip: u64,
    /// The error terms: 1 on the main axis (always positive), `2·|d_a| - n` on the others.
    err: [i64; 3],
    /// What each step adds to the error terms: `2n` on the main axis, `2·|d_a|` on the others.
    inc: [i64; 3],
    /// What a step of a minor axis takes from its term (and every step from the main axis's).
    dec: i64,
    /// The step at which the line reaches its end voxel (`u64::MAX`: never).
    due: u64,
    /// The start voxel's code.
    origin: u64,
}

impl LineInit {
    /// The scalar walk's set-up, for a line that starts after step `now`: main axis the
    /// longest (ties to x, then y), error terms `2·|d_minor| - n`.
    fn new(start: Key, end: Key, now: u64) -> Self {
        let d = [0, 1, 2].map(|a| end[a] as i64 - start[a] as i64);
        let ad = d.map(i64::abs);
        let main = crate::bresenham::main_axis(ad);
        let n = ad[main];
        let flip = mirror_mask(d.map(|x| x < 0));
        let code = start.morton();
        LineInit {
            m: code ^ flip,
            flip,
            err: [0, 1, 2].map(|a| if a == main { 1 } else { 2 * ad[a] - n }),
            inc: [0, 1, 2].map(|a| 2 * if a == main { n } else { ad[a] }),
            dec: 2 * n,
            due: now.saturating_add(n as u64),
            origin: code,
        }
    }

    /// A lane without a line: no axis moves (no error term is positive or changes), it never
    /// ends, and it keeps writing `code`, a voxel already recorded.
    fn idle(code: u64) -> Self {
        LineInit {
            m: code,
            flip: 0,
            err: [0; 3],
            inc: [0; 3],
            dec: 0,
            due: u64::MAX,
            origin: code,
        }
    }
}

/// The four lanes' registers.
struct Lanes {
    m: __m256i,
    flip: __m256i,
    err: [__m256i; 3],
    inc: [__m256i; 3],
    dec: __m256i,
    due: __m256i,
}

impl Lanes {
    /// Overwrite lane `l` with `s` by blending broadcasts under the lane's mask `lane[l]`
    /// (all ones in lane `l` only).
    #[target_feature(enable = "avx2")]
    fn set(&mut self, lane: &[__m256i; 4], l: usize, s: &LineInit) {
        let mi = lane[l & 3];
        let put = |v: &mut __m256i, x: i64| {
            *v = _mm256_blendv_epi8(*v, _mm256_set1_epi64x(x), mi);
        };
        put(&mut self.m, s.m as i64);
        put(&mut self.flip, s.flip as i64);
        for a in 0..3 {
            put(&mut self.err[a], s.err[a]);
            put(&mut self.inc[a], s.inc[a]);
        }
        put(&mut self.dec, s.dec);
        put(&mut self.due, s.due as i64);
    }

    /// The first step at which some lane's line ends.
    fn next_due(&self) -> u64 {
        let due: U4 = bytemuck::cast(self.due);
        due.into_iter().min().unwrap_or(u64::MAX)
    }
}

/// The four lanes' open bricks and the voxels met in them, and the bricks the lanes left,
/// collected in the scratch buffers until they are handed on.
///
/// Nothing takes its address in the step loop (the hand-on gets its fields), so the open
/// bricks, the count and the buffers' addresses stay in registers from step to step.
struct Bricks4<'a> {
    brick: __m256i,
    bits: __m256i,
    left: usize,
    bricks_left: &'a mut [u64; LEFT + 4],
    bits_left: &'a mut [u64; LEFT + 4],
}

impl<'a> Bricks4<'a> {
    /// Each lane's open brick holding the voxel of `first` (one code per lane).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn new(first: __m256i, scratch: &'a mut QuadLineScratch) -> Self {
        Bricks4 {
            brick: _mm256_srli_epi64::<6>(first),
            bits: _mm256_sllv_epi64(
                _mm256_set1_epi64x(1),
                _mm256_and_si256(first, _mm256_set1_epi64x(63)),
            ),
            left: 0,
            bricks_left: &mut scratch.bricks,
            bits_left: &mut scratch.bits,
        }
    }

    /// Add each lane's voxel `codes`: it joins the lane's open brick, or the lane leaves that
    /// brick, which is moved to the front with the others left (a permutation looked up by
    /// the set of lanes) and appended with one store; full buffers go to `flush`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn push<F: BrickSink>(&mut self, codes: __m256i, flush: &mut F) {
        let b = _mm256_srli_epi64::<6>(codes);
        let same = _mm256_cmpeq_epi64(b, self.brick);
        let moved = (_mm256_movemask_pd(_mm256_castsi256_pd(same)) ^ 0xF) as usize;
        let (order, count) = COMPRESS[moved & 0xF];
        let order: __m256i = bytemuck::cast(order);
        let left_b: U4 = bytemuck::cast(_mm256_permutevar8x32_epi32(self.brick, order));
        let left_m: U4 = bytemuck::cast(_mm256_permutevar8x32_epi32(self.bits, order));
        // `left` stays below LEFT between steps; the `min` lets the compiler see it
        let i = self.left.min(LEFT);
        self.bricks_left[i..i + 4].copy_from_slice(&left_b);
        self.bits_left[i..i + 4].copy_from_slice(&left_m);
        self.left = i + count;
        let voxel = _mm256_sllv_epi64(
            _mm256_set1_epi64x(1),
            _mm256_and_si256(codes, _mm256_set1_epi64x(63)),
        );
        // a lane that stayed adds its voxel to the open brick's; one that moved starts anew
        self.bits = _mm256_or_si256(_mm256_and_si256(self.bits, same), voxel);
        self.brick = b;
        if self.left >= LEFT {
            hand_on(self.bricks_left, self.bits_left, self.left, flush);
            self.left = 0;
        }
    }

    /// Hand every brick to `flush`: those left, then the open ones.
    fn finish<F: BrickSink>(self, flush: &mut F) {
        hand_on(self.bricks_left, self.bits_left, self.left, flush);
        let (brick, bits): (U4, U4) = (bytemuck::cast(self.brick), bytemuck::cast(self.bits));
        for (code, voxels) in brick.into_iter().zip(bits) {
            flush.put(Brick { code, voxels });
        }
    }
}

/// Hand the first `n` bricks left (`bricks[i]`, voxels `bits[i]`) to `flush`.
fn hand_on<F: BrickSink>(bricks: &[u64], bits: &[u64], n: usize, flush: &mut F) {
    let n = n.min(bricks.len()).min(bits.len());
    flush.put_all(&bricks[..n], &bits[..n]);
}

/// [`walk_lines`] once AVX2 is known to be there.
#[target_feature(enable = "avx2")]
fn walk_lines_avx2<F>(lines: &[(Key, Key)], scratch: &mut QuadLineScratch, flush: &mut F)
where
    F: BrickSink,
{
    let mut next = lines.iter().filter(|(a, b)| a != b);
    let Some(&(s0, _)) = next.clone().next() else {
        return;
    };
    let zero = _mm256_setzero_si256();
    let mut q = Lanes {
        m: zero,
        flip: zero,
        err: [zero; 3],
        inc: [zero; 3],
        dec: zero,
        due: zero,
    };
    let lane: [__m256i; 4] = core::array::from_fn(|l| {
        bytemuck::cast(core::array::from_fn::<u64, 4, _>(|k| {
            if k == l {
                u64::MAX
            } else {
                0
            }
        }))
    });
    // idle lanes repeat the first line's start voxel, which is recorded
    let idle_code = s0.morton();
    let mut live = 4;
    let mut codes: U4 = [idle_code; 4];
    for (l, code) in codes.iter_mut().enumerate() {
        let s = match next.next() {
            Some(&(a, b)) => LineInit::new(a, b, 0),
            None => {
                live -= 1;
                LineInit::idle(idle_code)
            }
        };
        *code = s.origin;
        q.set(&lane, l, &s);
    }
    let mut due = q.next_due();
    let mut bricks = Bricks4::new(bytemuck::cast(codes), scratch);
    // each axis's Morton bits, their complement and their lowest bit
    let axis = AXIS_MASK.map(|m| _mm256_set1_epi64x(m as i64));
    let fill = AXIS_MASK.map(|m| _mm256_set1_epi64x(!m as i64));
    let low = [0, 1, 2].map(|a| _mm256_set1_epi64x(1 << a));
    let mut now = 0u64;
    loop {
        now += 1;
        // the axes whose error term is positive step (the main axis always), each on its own
        // Morton bits; the terms then take the scalar walk's integers
        let mut m = zero;
        for a in 0..3 {
            let step = _mm256_cmpgt_epi64(q.err[a], zero);
            q.err[a] = _mm256_add_epi64(
                _mm256_sub_epi64(q.err[a], _mm256_and_si256(step, q.dec)),
                q.inc[a],
            );
            let up = _mm256_add_epi64(
                _mm256_or_si256(q.m, fill[a]),
                _mm256_and_si256(step, low[a]),
            );
            m = _mm256_or_si256(m, _mm256_and_si256(up, axis[a]));
        }
        q.m = m;
        let mut codes = _mm256_xor_si256(q.m, q.flip);
        let mut finished = false;
        if now == due {
            // the rare step where lines end (on their end voxel, not visited): restart those
            // lanes on the next lines
            let ended = _mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpeq_epi64(
                q.due,
                _mm256_set1_epi64x(now as i64),
            )));
            let mut written: U4 = bytemuck::cast(codes);
            for (l, code) in written.iter_mut().enumerate() {
                if ended & (1 << l) == 0 {
                    continue;
                }
                let s = match next.next() {
                    Some(&(a, b)) => LineInit::new(a, b, now),
                    None => {
                        live -= 1;
                        LineInit::idle(idle_code)
                    }
                };
                *code = s.origin;
                q.set(&lane, l, &s);
            }
            codes = bytemuck::cast(written);
            due = q.next_due();
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
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    fn add(set: &mut BTreeSet<u64>, b: Brick) {
        let mut m = b.voxels;
        while m != 0 {
            set.insert((b.code << 6) | m.trailing_zeros() as u64);
            m &= m - 1;
        }
    }

    /// The voxels of `lines` by the scalar walk, and by the four lanes (`None` without AVX2,
    /// which this crate's x86-64 test hosts have: asserted, so the lanes cannot go untested).
    fn both(lines: &[(Key, Key)]) -> (BTreeSet<u64>, Option<BTreeSet<u64>>) {
        let mut want = BTreeSet::new();
        for &(a, b) in lines {
            crate::bresenham::walk_bresenham_keys(a, b, |k| {
                want.insert(k.morton());
            });
        }
        let mut got = BTreeSet::new();
        let mut scratch = QuadLineScratch::default();
        let ran = walk_lines(lines, &mut scratch, &mut |b| add(&mut got, b)).is_some();
        assert_eq!(ran, has_avx2());
        (want, ran.then_some(got))
    }

    /// Lines at the map's edges and corners (keys 0 and 65535), along each axis and the
    /// diagonals, of every length from one voxel, with empty lines (start = end) among them;
    /// and more lines than [`LEFT`] bricks, so the buffer is handed on mid-batch.
    #[test]
    fn lanes_walk_edges_empty_lines_and_long_batches() {
        let corners = [0u16, 1, 32768, 65534, 65535];
        let mut lines = Vec::new();
        for &a in &corners {
            for &b in &corners {
                lines.push((Key::new(a, b, a), Key::new(b, a, b)));
                lines.push((Key::new(a, a, a), Key::new(a, a, b)));
                lines.push((Key::new(a, b, b), Key::new(a, b, b)));
            }
        }
        let (want, got) = both(&lines);
        assert!(want.len() > 100_000);
        if let Some(got) = got {
            assert_eq!(got, want);
        }
        // only empty lines: nothing at all
        let o = Key::new(5, 6, 7);
        let (want, got) = both(&[(o, o), (o, o)]);
        assert!(want.is_empty());
        if let Some(got) = got {
            assert!(got.is_empty());
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The lanes visit exactly the voxels of the scalar lines, for batches of any size
        /// (idle lanes included), lines in every direction and of every length, empty ones
        /// among them.
        #[test]
        fn lanes_visit_the_scalar_lines(
            start in prop::array::uniform3(1000u16..64000),
            ends in prop::collection::vec(prop::array::uniform3(-300i32..300), 0..40),
            empty in prop::collection::vec(any::<bool>(), 40),
        ) {
            let s = Key(start);
            let lines: Vec<(Key, Key)> = ends
                .iter()
                .zip(&empty)
                .map(|(d, &e)| {
                    let d = if e { [0; 3] } else { *d };
                    (s, Key([0, 1, 2].map(|i| (start[i] as i32 + d[i]) as u16)))
                })
                .collect();
            let (want, got) = both(&lines);
            if let Some(got) = got {
                prop_assert_eq!(got, want);
            }
        }

        /// Lines from anywhere to anywhere in the map, lengths up to the whole map.
        #[test]
        fn lanes_visit_long_lines(
            lines in prop::collection::vec(
                (any::<[u16; 3]>(), any::<[u16; 3]>()).prop_map(|(a, b)| (Key(a), Key(b))),
                1..6,
            ),
        ) {
            let (want, got) = both(&lines);
            if let Some(got) = got {
                prop_assert_eq!(got, want);
            }
        }
    }
}
