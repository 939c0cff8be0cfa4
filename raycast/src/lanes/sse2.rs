//! Two DDA brick walks at once in the 128-bit registers of SSE2, through `safe_arch` (no unsafe
//! code): the path of x86_64 CPUs without AVX2.

use super::brick_walk::{step_up, walk_each, BrickWalk};
use crate::brickset::BrickSink;
use crate::dda::{RaySetup, RayWalk};
use octoquant_octree::Brick;
use safe_arch::{
    add_m128d, bitand_m128d, bitandnot_m128d, bitor_m128d, cmp_eq_mask_m128d, cmp_gt_mask_m128d,
    cmp_lt_mask_m128d, m128d, min_m128d, move_mask_m128d,
};

/// The lanes' `tMax` of one axis as a register.
#[inline(always)]
fn lanes(a: &BrickWalk, b: &BrickWalk, f: impl Fn(&BrickWalk) -> f64) -> m128d {
    m128d::from_array([f(a), f(b)])
}

/// [`super::walk_all`] with two walks in the lanes of each register. A lane whose walk
/// ends is flushed and refilled with the next ray; the last walk finishes alone.
pub(super) fn walk_pairs<F>(rays: &[RaySetup], bufs: &mut [Vec<Brick>; 2], flush: &mut F) -> usize
where
    F: BrickSink,
{
    let mut degenerate = 0;
    let mut next = rays.iter();
    let (Some(ra), Some(rb)) = (next.next(), next.next()) else {
        return walk_each(rays, &mut bufs[0], flush);
    };
    let [buf0, buf1] = bufs;
    let mut w = [BrickWalk::start(ra, buf0), BrickWalk::start(rb, buf1)];
    loop {
        let mut t0 = lanes(&w[0], &w[1], |x| x.t[0]);
        let mut t1 = lanes(&w[0], &w[1], |x| x.t[1]);
        let mut t2 = lanes(&w[0], &w[1], |x| x.t[2]);
        let d0 = lanes(&w[0], &w[1], |x| x.d[0]);
        let d1 = lanes(&w[0], &w[1], |x| x.d[1]);
        let d2 = lanes(&w[0], &w[1], |x| x.d[2]);
        let len = lanes(&w[0], &w[1], |x| x.len);
        // all bits set: x == x for the finite lengths of well-conditioned rays
        let ones = cmp_eq_mask_m128d(len, len);
        // the walks' integer state in locals (kept in registers); both lanes step
        // together, so one counter stands for the smaller budget
        let [mut a, mut b] = w;
        let steps = a.budget.min(b.budget);
        let mut left = steps;
        let ended = loop {
            // OctoMap's chain per lane: x when t0 < t1 and t0 < t2, else y when t1 < t2,
            // else z (ties to z, then y)
            let lt01 = cmp_lt_mask_m128d(t0, t1);
            let s0 = bitand_m128d(lt01, cmp_lt_mask_m128d(t0, t2));
            let s1 = bitandnot_m128d(lt01, cmp_lt_mask_m128d(t1, t2));
            let s2 = bitandnot_m128d(bitor_m128d(s0, s1), ones);
            t0 = add_m128d(t0, bitand_m128d(s0, d0));
            t1 = add_m128d(t1, bitand_m128d(s1, d1));
            t2 = add_m128d(t2, bitand_m128d(s2, d2));
            let a1 = move_mask_m128d(s1) as usize;
            let a2 = move_mask_m128d(s2) as usize;
            a.m = step_up(a.m, (a1 & 1) | ((a2 & 1) << 1));
            b.m = step_up(b.m, (a1 >> 1) | (a2 & 2));
            left -= 1;
            // the smallest tMax beyond the length, per lane (no lane holds a NaN)
            let past = move_mask_m128d(cmp_gt_mask_m128d(min_m128d(min_m128d(t0, t1), t2), len));
            let e0 = (a.m == a.end) | (past & 1 != 0);
            let e1 = (b.m == b.end) | (past & 2 != 0);
            if e0 | e1 | (left == 0) {
                break [e0, e1];
            }
            a.record(buf0);
            b.record(buf1);
        };
        a.budget -= steps - left;
        b.budget -= steps - left;
        w = [a, b];
        let [x0, x1] = [t0.to_array(), t1.to_array()];
        let x2 = t2.to_array();
        let mut live = [true, true];
        for (l, (walk, buf)) in w.iter_mut().zip([&mut *buf0, &mut *buf1]).enumerate() {
            walk.t = [x0[l], x1[l], x2[l]];
            if !ended[l] {
                walk.record(buf);
                if walk.budget > 0 {
                    continue;
                }
                debug_assert!(false, "a well-conditioned ray exhausted its budget");
                degenerate += 1;
            }
            let n = walk.close(buf);
            for &b in &buf[..n] {
                flush.put(b);
            }
            match next.next() {
                Some(r) => *walk = BrickWalk::start(r, buf),
                None => live[l] = false,
            }
        }
        match live {
            [true, true] => continue,
            [false, false] => return degenerate,
            _ => {
                // the rays are used up: the remaining walk ends alone
                let l = if live[0] { 0 } else { 1 };
                let buf = if l == 0 { &mut *buf0 } else { &mut *buf1 };
                let walk = w[l].finish_into(buf, flush);
                return degenerate + (walk != RayWalk::Complete) as usize;
            }
        }
    }
}
