//! Eight DDA brick walks at once in the 512-bit registers of AVX-512, chosen at run time: the
//! walk of [`crate::lanes::avx2`] with twice the lanes, where comparisons give mask registers,
//! a masked move picks each lane's new `tMax`, and the bricks the lanes leave are compressed to
//! the front of a register by the CPU (`vpcompressq`) instead of by a permutation table.
//! Lanes whose walks stop take the next walks of the batch all at once: the batch's states are
//! laid out one array per register beforehand ([`LaneInits`]), and a masked expand
//! (`vpexpandq`) moves the next ones into the stopped lanes, lowest lane first. Short rays
//! (indoor LiDAR, the tails of depth-image rays) restart a lane every few steps, and a restart
//! lane by lane (the AVX2 lanes' [`crate::lanes::refill::restart`]) cost a sixth of the walk.
//!
//! The comparisons, additions and tie rules are OctoMap's, lane by lane, so every walk visits
//! exactly the voxels of [`crate::dda::walk_ray_codes_f32`].

use super::brick_walk::lane_start;
use super::refill::{first_stop, LaneInit, VOXEL_CODE};
use crate::brickset::BrickSink;
use crate::cpu::has_avx512;
use crate::dda::{mirror_mask, step_budget, RaySetup, AXIS_MASK};
use crate::setups::{Pending, Setups};
use core::arch::x86_64::{
    __m512d, __m512i, _mm512_add_epi64, _mm512_add_pd, _mm512_and_si512, _mm512_andnot_si512,
    _mm512_cmp_pd_mask, _mm512_cmpeq_epu64_mask, _mm512_cmplt_epu64_mask, _mm512_cmpneq_epu64_mask,
    _mm512_mask_add_epi64, _mm512_mask_expand_epi64, _mm512_mask_expand_pd, _mm512_mask_mov_epi64,
    _mm512_mask_mov_pd, _mm512_mask_or_epi64, _mm512_maskz_compress_epi64, _mm512_maskz_mov_epi64,
    _mm512_min_pd, _mm512_or_si512, _mm512_reduce_min_epu64, _mm512_set1_epi64,
    _mm512_setzero_si512, _mm512_sllv_epi64, _mm512_srli_epi64, _mm512_sub_epi64, _mm512_xor_si512,
    _CMP_GT_OQ, _CMP_LT_OQ,
};
use octoquant_octree::{Brick, Key};

/// Bricks left by the lanes that are collected before they are handed on.
const LEFT: usize = 1024;

type U8 = [u64; 8];

/// The per-thread buffers of the eight-lane walks (DDA and Bresenham), kept from batch to
/// batch: the bricks the lanes left and their voxels, side by side, with room for one more
/// step's eight. Fixed-size, so a step's store needs no bounds check.
#[derive(Debug, Clone)]
pub(crate) struct OctScratch {
    left: LeftBricks,
    /// The DDA walks' states of a batch (unused by the Bresenham lanes).
    inits: LaneInits,
}

impl Default for OctScratch {
    fn default() -> Self {
        OctScratch {
            left: LeftBricks {
                bricks: Box::new([0; LEFT + 8]),
                bits: Box::new([0; LEFT + 8]),
            },
            inits: LaneInits::default(),
        }
    }
}

/// The bricks the lanes left and their voxels, side by side, with room for one more step's
/// eight.
#[derive(Debug, Clone)]
pub(crate) struct LeftBricks {
    bricks: Box<[u64; LEFT + 8]>,
    bits: Box<[u64; LEFT + 8]>,
}

/// The eight lanes' open bricks and the voxels met in them, and the bricks the lanes left,
/// collected in the scratch buffers until they are handed on.
///
/// Nothing takes its address in the step loop (the hand-on gets its fields), so the open
/// bricks stay in registers from step to step.
pub(crate) struct Bricks8<'a> {
    brick: __m512i,
    bits: __m512i,
    left: usize,
    scratch: &'a mut LeftBricks,
}

impl<'a> Bricks8<'a> {
    /// Each lane's open brick holding the voxel of `first` (one code per lane).
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub(crate) fn new(first: __m512i, scratch: &'a mut OctScratch) -> Self {
        Self::over(first, &mut scratch.left)
    }

    /// [`Bricks8::new`] over the buffers alone.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn over(first: __m512i, scratch: &'a mut LeftBricks) -> Self {
        Bricks8 {
            brick: _mm512_srli_epi64::<6>(first),
            bits: _mm512_sllv_epi64(
                _mm512_set1_epi64(1),
                _mm512_and_si512(first, _mm512_set1_epi64(63)),
            ),
            left: 0,
            scratch,
        }
    }

    /// Add each lane's voxel `codes`: it joins the lane's open brick, or the lane leaves that
    /// brick, which is compressed to the front with the others left (`vpcompressq`) and
    /// appended with one store; full buffers go to `flush`.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    pub(crate) fn push<F: BrickSink>(&mut self, codes: __m512i, flush: &mut F) {
        let b = _mm512_srli_epi64::<6>(codes);
        let moved = _mm512_cmpneq_epu64_mask(b, self.brick);
        let left_b: U8 = bytemuck::cast(_mm512_maskz_compress_epi64(moved, self.brick));
        let left_m: U8 = bytemuck::cast(_mm512_maskz_compress_epi64(moved, self.bits));
        // `left` stays below LEFT between steps; the `min` lets the compiler see it
        let i = self.left.min(LEFT);
        let s = &mut *self.scratch;
        s.bricks[i..i + 8].copy_from_slice(&left_b);
        s.bits[i..i + 8].copy_from_slice(&left_m);
        self.left = i + moved.count_ones() as usize;
        let voxel = _mm512_sllv_epi64(
            _mm512_set1_epi64(1),
            _mm512_and_si512(codes, _mm512_set1_epi64(63)),
        );
        // a lane that stayed adds its voxel to the open brick's; one that moved starts anew
        self.bits = _mm512_mask_or_epi64(voxel, !moved, self.bits, voxel);
        self.brick = b;
        if self.left >= LEFT {
            hand_on(self.scratch, self.left, flush);
            self.left = 0;
        }
    }

    /// Hand every brick to `flush`: those left, then the open ones.
    #[target_feature(enable = "avx512f,popcnt")]
    pub(crate) fn finish<F: BrickSink>(self, flush: &mut F) {
        hand_on(self.scratch, self.left, flush);
        let (brick, bits): (U8, U8) = (bytemuck::cast(self.brick), bytemuck::cast(self.bits));
        for (code, voxels) in brick.into_iter().zip(bits) {
            flush.put(Brick { code, voxels });
        }
    }
}

/// Hand the first `n` bricks left in `s` to `flush`.
#[inline]
fn hand_on<F: BrickSink>(s: &LeftBricks, n: usize, flush: &mut F) {
    let n = n.min(LEFT + 8);
    flush.put_all(&s.bricks[..n], &s.bits[..n]);
}

/// Walk `rays` eight at a time when this CPU has AVX-512 and return the number of degenerate
/// walks, or `None` (nothing done) on CPUs without it.
pub(crate) fn walk_octs<F>(
    rays: &[RaySetup],
    scratch: &mut OctScratch,
    flush: &mut F,
) -> Option<usize>
where
    F: BrickSink,
{
    if !has_avx512() {
        return None;
    }
    // SAFETY: `walk_octs_avx512` needs AVX-512 Foundation and `popcnt`, and the CPU has been
    // found to support both just above. Nothing else in it is unsafe.
    #[allow(unsafe_code)]
    let degenerate = unsafe { walk_octs_avx512(rays, scratch, flush) };
    Some(degenerate)
}

/// A batch's walk states side by side, one array per register of the lanes
/// ([`LaneInit`]'s fields), then eight idle walks: a restart moves the next walks into the
/// lanes that stopped with one masked expand per register (`vpexpandq`), not lane by lane.
#[derive(Debug, Clone, Default)]
pub(crate) struct LaneInits {
    t: [Vec<f64>; 3],
    d: [Vec<f64>; 3],
    len: Vec<f64>,
    m: Vec<u64>,
    end: Vec<u64>,
    flip: Vec<u64>,
    budget: Vec<u64>,
    /// The first step at which each walk may stop: [`first_stop`] of its budget, or for
    /// walks queued from set-up columns the step their set-up tells
    /// ([`crate::dda::first_watch`]).
    watch: Vec<u64>,
}

/// An idle lane's budget: far beyond any step count, so it never runs out, and small enough
/// that adding a step count cannot overflow.
const IDLE_BUDGET: u64 = 1 << 62;

impl LaneInits {
    /// The walks of `rays` at their origin voxels, then eight idle lanes writing `idle_code`.
    /// The arrays keep their capacity from batch to batch. Each array is filled in a pass of
    /// its own over the batch (which sits in the first-level cache): an `extend` over a slice
    /// reserves once, where pushing a ray's fields one by one checked eleven capacities a ray
    /// (a fourteenth of an Ouster frame's time).
    fn fill(&mut self, rays: &[RaySetup], idle_code: u64) {
        self.clear();
        for a in 0..3 {
            self.t[a].extend(rays.iter().map(|r| r.t_max[a]));
            self.d[a].extend(rays.iter().map(|r| r.t_delta[a]));
        }
        self.len.extend(rays.iter().map(|r| r.length));
        self.flip.extend(rays.iter().map(|r| lane_start(r).2));
        let flips = &self.flip[..rays.len()];
        let starts = rays.iter().zip(flips);
        self.m
            .extend(starts.clone().map(|(r, f)| r.code_origin ^ f));
        self.end.extend(starts.map(|(r, f)| r.code_end ^ f));
        // a ray's budget (a `u32`) is far below an idle lane's
        self.budget
            .extend(rays.iter().map(|r| u64::from(r.budget).min(IDLE_BUDGET)));
        self.watch
            .extend(self.budget.iter().map(|&b| first_stop(b)));
        self.close(idle_code);
    }

    /// No walks.
    fn clear(&mut self) {
        let LaneInits {
            t,
            d,
            len,
            m,
            end,
            flip,
            budget,
            watch,
        } = self;
        for v in t.iter_mut().chain(d.iter_mut()).chain([len]) {
            v.clear();
        }
        for v in [m, end, flip, budget, watch] {
            v.clear();
        }
    }

    /// Walks held (before [`LaneInits::close`]).
    fn walks(&self) -> usize {
        self.len.len()
    }

    /// Append the walks of the first `count` pending rays from `origin` (key and code) at
    /// their origin voxels: the same states as [`LaneInits::fill`] of their
    /// [`Pending::ray`]s, copied column by column (each a slice copy or a loop over a range,
    /// which reserves once and vectorises).
    fn append(&mut self, p: &Pending, s: &Setups, origin: (Key, u64), count: usize) {
        let count = count.min(crate::setups::PENDING);
        for a in 0..3 {
            self.t[a].extend_from_slice(&s.t_maxes(a)[..count]);
            self.d[a].extend_from_slice(&s.t_deltas(a)[..count]);
        }
        let lengths = &s.lengths()[..count];
        self.len.extend(lengths.iter().map(|&l| f64::from(l)));
        let steps = [0, 1, 2].map(|a| &s.steps(a)[..count]);
        let first = self.flip.len();
        self.flip.extend(
            (0..count).map(|i| mirror_mask([steps[0][i] < 0, steps[1][i] < 0, steps[2][i] < 0])),
        );
        let flips = &self.flip[first..];
        let (codes, keys) = (&p.code_ends()[..count], &p.key_ends()[..count]);
        self.m.extend(flips.iter().map(|f| origin.1 ^ f));
        self.end.extend(codes.iter().zip(flips).map(|(c, f)| c ^ f));
        self.budget.extend(
            keys.iter()
                .map(|&k| u64::from(step_budget(origin.0, k)).min(IDLE_BUDGET)),
        );
        self.watch.extend_from_slice(&s.watches()[..count]);
    }

    /// End the arrays with eight idle lanes writing `idle_code`.
    fn close(&mut self, idle_code: u64) {
        let idle = LaneInit::idle(idle_code);
        for a in 0..3 {
            self.t[a].extend([idle.t[a]; 8]);
            self.d[a].extend([idle.d[a]; 8]);
        }
        self.len.extend([idle.len; 8]);
        self.m.extend([idle.m; 8]);
        self.end.extend([idle.end; 8]);
        self.flip.extend([idle.flip; 8]);
        self.budget.extend([IDLE_BUDGET; 8]);
        self.watch.extend([IDLE_BUDGET; 8]);
    }
}

/// Well-conditioned DDA walks from one origin queued straight from their set-ups' columns
/// ([`Pending`], [`Setups`]) in the eight lanes' layout, without a [`RaySetup`] in between:
/// building each ray's set-up and reading it back into the lanes' arrays took 5 % of the
/// samples of a `map` run on the Ouster recording; queued from the columns, its insertion is
/// 4 % faster (history, session 43).
#[derive(Debug, Clone, Default)]
pub(crate) struct QueuedWalks {
    inits: LaneInits,
    /// The origin voxel's code: idle lanes write it (it is recorded by every walk).
    idle_code: u64,
}

impl QueuedWalks {
    /// Queue the walks of the first `count` pending rays (all well-conditioned) from
    /// `origin`, when this CPU has AVX-512; `false` (nothing queued) on CPUs without it.
    pub(crate) fn queue(
        &mut self,
        p: &Pending,
        s: &Setups,
        origin: (Key, u64),
        count: usize,
    ) -> bool {
        if !has_avx512() {
            return false;
        }
        if self.inits.walks() > 0 && self.idle_code != origin.1 & VOXEL_CODE {
            // one origin per queue: the caller walks the queue before another origin's rays
            return false;
        }
        self.idle_code = origin.1 & VOXEL_CODE;
        self.inits.append(p, s, origin, count);
        true
    }

    /// Walks queued.
    pub(crate) fn len(&self) -> usize {
        self.inits.walks()
    }

    /// Walk the queued walks into `flush` and empty the queue; returns the number of
    /// degenerate walks.
    pub(crate) fn walk<F: BrickSink>(&mut self, scratch: &mut OctScratch, flush: &mut F) -> usize {
        let n = self.inits.walks();
        if n == 0 || !has_avx512() {
            return 0;
        }
        self.inits.close(self.idle_code);
        // SAFETY: `walk_inits` needs AVX-512 Foundation and `popcnt`, found just above.
        #[allow(unsafe_code)]
        let degenerate = unsafe { walk_inits(&self.inits, n, &mut scratch.left, flush) };
        self.inits.clear();
        degenerate
    }
}

/// Eight entries of `v` from `at` (which leaves at least eight), as a register.
#[inline(always)]
fn eight<T: Copy + Default + bytemuck::Pod>(v: &[T], at: usize) -> [T; 8] {
    let mut a = [T::default(); 8];
    a.copy_from_slice(&v[at..at + 8]);
    a
}

/// [`walk_octs`] once AVX-512 is known to be there.
#[target_feature(enable = "avx512f,popcnt")]
fn walk_octs_avx512<F>(rays: &[RaySetup], scratch: &mut OctScratch, flush: &mut F) -> usize
where
    F: BrickSink,
{
    let Some(first) = rays.first() else {
        return 0;
    };
    // idle lanes repeat the first walk's origin voxel, which is recorded
    let idle_code = LaneInit::new(first).origin & VOXEL_CODE;
    let OctScratch { left, inits } = scratch;
    inits.fill(rays, idle_code);
    walk_inits(inits, rays.len(), left, flush)
}

/// Walk the `n` walks of `q` (closed by eight idle lanes), handing the bricks to `flush`
/// through `left`; returns the number of degenerate walks.
#[target_feature(enable = "avx512f,popcnt")]
fn walk_inits<F>(q: &LaneInits, n: usize, left: &mut LeftBricks, flush: &mut F) -> usize
where
    F: BrickSink,
{
    if n == 0 {
        return 0;
    }
    let ld = |v: &[f64], at: usize| -> __m512d { bytemuck::cast(eight(v, at)) };
    let li = |v: &[u64], at: usize| -> __m512i { bytemuck::cast(eight(v, at)) };
    // the first eight walks (idle lanes past the last ray)
    let [mut t0, mut t1, mut t2] = [0, 1, 2].map(|a| ld(&q.t[a], 0));
    let [mut d0, mut d1, mut d2] = [0, 1, 2].map(|a| ld(&q.d[a], 0));
    let mut len = ld(&q.len, 0);
    let mut m = li(&q.m, 0);
    let mut end = li(&q.end, 0);
    let mut flip = li(&q.flip, 0);
    // the step at which each lane's walk runs out of budget (`LaneInit::due`)
    let mut due = li(&q.budget, 0);
    // idle lanes are those with an idle walk's budget (whatever a walk's length)
    let far = _mm512_set1_epi64(IDLE_BUDGET as i64);
    let mut active = _mm512_cmplt_epu64_mask(due, far);
    let mut pos = n.min(8);
    // the steps taken so far
    let mut now = 0u64;
    // the first step at which each lane's walk may stop, and the earliest of them
    let mut watch = li(&q.watch, 0);
    let mut near = _mm512_reduce_min_epu64(watch);
    let ones_i = _mm512_set1_epi64(-1);
    let zero_i = _mm512_setzero_si512();
    let axis = AXIS_MASK.map(|m| _mm512_set1_epi64(m as i64));
    // each lane's open brick starts with its origin voxel
    let mut lanes = Bricks8::over(_mm512_xor_si512(m, flip), left);
    let mut degenerate = 0;
    loop {
        now += 1;
        // OctoMap's chain per lane: x when t0 < t1 and t0 < t2, else y when t1 < t2, else z
        let (n0, n1, n2) = (
            _mm512_add_pd(t0, d0),
            _mm512_add_pd(t1, d1),
            _mm512_add_pd(t2, d2),
        );
        let lt01 = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t0, t1);
        let s0 = lt01 & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t0, t2);
        let s1 = !lt01 & _mm512_cmp_pd_mask::<_CMP_LT_OQ>(t1, t2);
        let s01 = s0 | s1;
        t0 = _mm512_mask_mov_pd(t0, s0, n0);
        t1 = _mm512_mask_mov_pd(t1, s1, n1);
        t2 = _mm512_mask_mov_pd(n2, s01, t2);
        // the chosen axis's Morton bits (none in idle lanes), and their lowest bit: a step up
        // is `((m | !mask) + low) & mask` on those bits, the others kept
        let mask = _mm512_maskz_mov_epi64(
            active,
            _mm512_mask_mov_epi64(_mm512_mask_mov_epi64(axis[2], s1, axis[1]), s0, axis[0]),
        );
        let low = _mm512_and_si512(mask, _mm512_sub_epi64(zero_i, mask));
        let up = _mm512_add_epi64(_mm512_or_si512(m, _mm512_xor_si512(mask, ones_i)), low);
        m = _mm512_or_si512(_mm512_and_si512(up, mask), _mm512_andnot_si512(mask, m));
        // a walk is over on its end voxel or once the smallest tMax passes the length (no
        // lane holds a NaN); it is cut off (degenerate) when its budget runs out
        let mut codes = _mm512_xor_si512(m, flip);
        if now < near {
            // no walk can stop yet (see `LaneInits::watch`)
            lanes.push(codes, flush);
            continue;
        }
        let tmin = _mm512_min_pd(_mm512_min_pd(t0, t1), t2);
        let done = _mm512_cmpeq_epu64_mask(m, end) | _mm512_cmp_pd_mask::<_CMP_GT_OQ>(tmin, len);
        let now_v = _mm512_set1_epi64(now as i64);
        let stopped = done | _mm512_cmpeq_epu64_mask(due, now_v);
        if stopped != 0 {
            // the rare step where walks end. A walk that stopped without being done ran out
            // of budget: the voxel it just entered is handed on and it counts as degenerate
            let mut cut = stopped & !done;
            if cut != 0 {
                let written: U8 = bytemuck::cast(codes);
                while cut != 0 {
                    let l = cut.trailing_zeros() as usize;
                    cut &= cut - 1;
                    flush.put(Brick::of_voxel(written[l & 7]));
                    degenerate += 1;
                }
            }
            // the next walks move into the stopped lanes, lowest lane first, as many as
            // there are (idle walks past the last)
            let k = stopped;
            t0 = _mm512_mask_expand_pd(t0, k, ld(&q.t[0], pos));
            t1 = _mm512_mask_expand_pd(t1, k, ld(&q.t[1], pos));
            t2 = _mm512_mask_expand_pd(t2, k, ld(&q.t[2], pos));
            d0 = _mm512_mask_expand_pd(d0, k, ld(&q.d[0], pos));
            d1 = _mm512_mask_expand_pd(d1, k, ld(&q.d[1], pos));
            d2 = _mm512_mask_expand_pd(d2, k, ld(&q.d[2], pos));
            len = _mm512_mask_expand_pd(len, k, ld(&q.len, pos));
            m = _mm512_mask_expand_epi64(m, k, li(&q.m, pos));
            end = _mm512_mask_expand_epi64(end, k, li(&q.end, pos));
            flip = _mm512_mask_expand_epi64(flip, k, li(&q.flip, pos));
            let budget = _mm512_mask_expand_epi64(zero_i, k, li(&q.budget, pos));
            due = _mm512_mask_add_epi64(due, k, budget, now_v);
            let next_watch = _mm512_mask_expand_epi64(zero_i, k, li(&q.watch, pos));
            watch = _mm512_mask_add_epi64(watch, k, next_watch, now_v);
            pos = (pos + k.count_ones() as usize).min(n);
            active = _mm512_cmplt_epu64_mask(due, far);
            near = _mm512_reduce_min_epu64(watch);
            // a restarted lane's voxel is its new walk's origin
            codes = _mm512_mask_mov_epi64(codes, k, _mm512_xor_si512(m, flip));
            if active == 0 {
                lanes.push(codes, flush);
                lanes.finish(flush);
                return degenerate;
            }
        }
        lanes.push(codes, flush);
    }
}
