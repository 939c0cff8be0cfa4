//! One DDA brick walk at a time: the state of a walk between two steps, its scalar walk to the
//! end, and [`walk_each`], the path of targets without SSE2 and of batches of one ray.
//!
//! Axes stepped downwards are mirrored (their Morton bits inverted), so that every step is an
//! increment of the chosen axis's bits ([`step_up`]); the SIMD lanes start from the same
//! mirrored codes ([`lane_start`]).

use crate::brickset::BrickSink;
use crate::dda::{cmin, mirror_mask, RaySetup, RayWalk, AXIS_MASK};
use octoquant_octree::Brick;

/// Per axis (and a harmless fourth entry): the axis's bits of a Morton code, their
/// complement and the axis's lowest bit; a step up is `((m | !mask) + low) & mask`.
const MASK4: [u64; 4] = [AXIS_MASK[0], AXIS_MASK[1], AXIS_MASK[2], 0];
const NOT_MASK4: [u64; 4] = [!AXIS_MASK[0], !AXIS_MASK[1], !AXIS_MASK[2], 0];
const LOW4: [u64; 4] = [1, 2, 4, 0];

/// One step up on axis `a` (0, 1 or 2) of a Morton code, wrapping within the axis, chosen by
/// table rather than by branch.
#[inline(always)]
pub(super) fn step_up(m: u64, a: usize) -> u64 {
    let a = a & 3;
    let mask = MASK4[a];
    (((m | NOT_MASK4[a]).wrapping_add(LOW4[a])) & mask) | (m & !mask)
}

/// A walk's mirrored Morton code at its origin, its end's, and the mirror: the Morton bits of
/// the axes stepped downwards (`m ^ flip` is the true code).
#[inline]
pub(crate) fn lane_start(r: &RaySetup) -> (u64, u64, u64) {
    let flip = mirror_mask(r.step.map(|s| s < 0));
    (r.code_origin ^ flip, r.code_end ^ flip, flip)
}

/// The state of one brick walk between two steps.
///
/// Axes stepped downwards are mirrored (their Morton bits inverted) so that every step is an
/// increment; `m ^ flip` is the true code. Bricks are written to the walk's buffer as the walk
/// leaves them: the bricks before `n`, and the current one in `open`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BrickWalk {
    pub(super) m: u64,
    pub(super) end: u64,
    flip: u64,
    pub(super) t: [f64; 3],
    pub(super) d: [f64; 3],
    pub(super) len: f64,
    open: Brick,
    n: usize,
    pub(super) budget: u32,
}

impl BrickWalk {
    /// The walk of a well-conditioned ray at its origin voxel; `buf` is made long enough for
    /// every brick the walk can enter (one per step, plus the origin's).
    pub(crate) fn start(r: &RaySetup, buf: &mut Vec<Brick>) -> Self {
        let need = r.budget as usize + 1;
        if buf.len() < need {
            buf.resize(need, Brick::default());
        }
        let (m, end, flip) = lane_start(r);
        BrickWalk {
            m,
            end,
            flip,
            t: r.t_max,
            d: r.t_delta,
            len: r.length,
            open: Brick::of_voxel(m ^ flip),
            n: 0,
            budget: r.budget,
        }
    }

    /// Record the voxel just stepped into, without a branch: the current brick is written at
    /// `n` every time and kept (`n` advanced) only when the walk left it.
    #[inline(always)]
    pub(super) fn record(&mut self, out: &mut [Brick]) {
        let code = self.m ^ self.flip;
        let b = code >> 6;
        let moved = b != self.open.code;
        if let Some(slot) = out.get_mut(self.n) {
            *slot = self.open;
        }
        self.n += moved as usize;
        self.open.voxels =
            (self.open.voxels & (moved as u64).wrapping_sub(1)) | (1u64 << (code & 63));
        self.open.code = b;
    }

    /// Write the current brick and return the number of bricks in `out`.
    #[inline(always)]
    pub(super) fn close(&mut self, out: &mut [Brick]) -> usize {
        if let Some(slot) = out.get_mut(self.n) {
            *slot = self.open;
            self.n += 1;
        }
        self.n
    }

    /// Walk to the end one step at a time (OctoMap's comparison chain as branches, which
    /// costs little when the steps are predictable); returns the outcome and the bricks.
    pub(crate) fn finish(&mut self, out: &mut [Brick]) -> (RayWalk, usize) {
        let [mut t0, mut t1, mut t2] = self.t;
        let [d0, d1, d2] = self.d;
        let mut walk = RayWalk::Degenerate;
        while self.budget > 0 {
            self.budget -= 1;
            let a = if t0 < t1 {
                if t0 < t2 {
                    t0 += d0;
                    0
                } else {
                    t2 += d2;
                    2
                }
            } else if t1 < t2 {
                t1 += d1;
                1
            } else {
                t2 += d2;
                2
            };
            self.m = step_up(self.m, a);
            if self.m == self.end || cmin(cmin(t0, t1), t2) > self.len {
                walk = RayWalk::Complete;
                break;
            }
            self.record(out);
        }
        self.t = [t0, t1, t2];
        debug_assert!(
            walk == RayWalk::Complete,
            "a well-conditioned ray exhausted its budget"
        );
        (walk, self.close(out))
    }

    /// [`BrickWalk::finish`], then hand every brick of the walk to `flush`.
    pub(crate) fn finish_into<F>(&mut self, buf: &mut [Brick], flush: &mut F) -> RayWalk
    where
        F: BrickSink,
    {
        let (walk, n) = self.finish(buf);
        for &b in &buf[..n] {
            flush.put(b);
        }
        walk
    }
}

/// [`super::walk_all`] one ray after another: the path of targets without SSE2, and of batches of
/// fewer than two rays.
pub(super) fn walk_each<F>(rays: &[RaySetup], buf: &mut Vec<Brick>, flush: &mut F) -> usize
where
    F: BrickSink,
{
    rays.iter()
        .filter(|r| BrickWalk::start(r, buf).finish_into(buf, flush) != RayWalk::Complete)
        .count()
}
