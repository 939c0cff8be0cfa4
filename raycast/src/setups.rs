//! The DDA set-ups of many rays from one origin at once.
//!
//! [`setup_with_keys`](crate::dda::setup_with_keys) spends most of its time in nine
//! divisions (the direction, each axis's `tMax` and `tDelta`), one after another. Here the
//! rays of a scan wait in columns ([`Pending`]) and their set-ups are computed in one loop
//! without branches, which the compiler turns into vector divisions (sixteen `f32` or eight
//! `f64` lanes with AVX-512, eight or four with AVX2, chosen at run time). Every lane makes
//! the same IEEE operations in the same order as the one-ray set-up, so the results are the
//! same bits; the depth-image checks of [`crate::pixel_grid`] (the direction check and the
//! head's time) are done in the same loop.

use crate::dda::{first_watch, step_budget, untold_watch, RaySetup};
use crate::pixel_grid::{fits_dir, SkipPlan};
use nalgebra::Point3;
use octoquant_octree::{Key, KeyConverter};

/// Rays set up together (at most 32, for the columns' derived `Default`).
pub(crate) const PENDING: usize = 32;

/// Rays from one origin (whose key is known) to end points in other voxels, waiting for their
/// set-ups, in columns. Only the first `len` columns hold rays; the others are set up too (the
/// loop has no branches) and never read.
#[derive(Debug, Clone, Default)]
pub(crate) struct Pending {
    len: usize,
    end: [[f32; PENDING]; 3],
    key_end: [Key; PENDING],
    code_end: [u64; PENDING],
    /// The time the head may be skipped up to before the ray's own length caps it; −∞ when
    /// the ray is walked whole.
    cap: [f64; PENDING],
    /// The pixel's ray direction factors `(u − cx)/fx` and `(v − cy)/fy` (for the direction
    /// check; unused where `cap` is −∞).
    col: [f32; PENDING],
    row: [f32; PENDING],
}

/// The set-ups of the pending rays, in columns: what [`setup_with_keys`] computes per ray,
/// plus whether the ray skips its head and up to when.
///
/// [`setup_with_keys`]: crate::dda::setup_with_keys
#[derive(Debug, Clone, Default)]
pub(crate) struct Setups {
    step: [[i32; PENDING]; 3],
    t_max: [[f64; PENDING]; 3],
    t_delta: [[f64; PENDING]; 3],
    length: [f32; PENDING],
    well_conditioned: [bool; PENDING],
    /// The head's time when the ray skips it, else −∞.
    head: [f64; PENDING],
    /// The ray points along its pixel ([`fits_dir`]).
    fits: [bool; PENDING],
    /// The first step at which the ray's walk from its origin voxel may stop
    /// ([`first_watch`]).
    watch: [u64; PENDING],
}

impl Pending {
    /// Whether no more rays fit.
    #[inline]
    pub(crate) fn is_full(&self) -> bool {
        self.len == PENDING
    }

    /// Rays waiting.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Add the ray to `end` (in the map, in another voxel than the origin) with its key and
    /// code, walked whole. The caller checks [`Pending::is_full`] first.
    #[inline]
    pub(crate) fn push(&mut self, end: &Point3<f32>, (key, code): (Key, u64)) {
        let i = self.len.min(PENDING - 1);
        self.end[0][i] = end.x;
        self.end[1][i] = end.y;
        self.end[2][i] = end.z;
        self.key_end[i] = key;
        self.code_end[i] = code;
        self.cap[i] = f64::NEG_INFINITY;
        self.len = i + 1;
    }

    /// Let the ray pushed last skip its head up to `cap` (and its own length's limit), if it
    /// points along the pixel whose direction factors are `col` and `row`.
    #[inline]
    pub(crate) fn may_skip(&mut self, cap: f64, col: f32, row: f32) {
        if let Some(i) = self.len.checked_sub(1) {
            self.cap[i] = cap;
            self.col[i] = col;
            self.row[i] = row;
        }
    }

    /// The end point of pending ray `i`.
    #[inline]
    pub(crate) fn end(&self, i: usize) -> Point3<f32> {
        Point3::new(self.end[0][i], self.end[1][i], self.end[2][i])
    }

    /// Empty the columns.
    #[inline]
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// The set-up of pending ray `i` from `out` (filled by [`set_up`]).
    #[inline]
    pub(crate) fn ray(&self, out: &Setups, i: usize, origin: (Key, u64)) -> RaySetup {
        let (key_origin, code_origin) = origin;
        let key_end = self.key_end[i];
        RaySetup {
            key_origin,
            key_end,
            code_origin,
            code_end: self.code_end[i],
            step: [0, 1, 2].map(|a| out.step[a][i]),
            t_max: [0, 1, 2].map(|a| out.t_max[a][i]),
            t_delta: [0, 1, 2].map(|a| out.t_delta[a][i]),
            length: out.length[i] as f64,
            budget: step_budget(key_origin, key_end),
            well_conditioned: out.well_conditioned[i],
        }
    }

    /// The end keys of the pending rays, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn key_ends(&self) -> &[Key; PENDING] {
        &self.key_end
    }

    /// The end keys' Morton codes, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn code_ends(&self) -> &[u64; PENDING] {
        &self.code_end
    }
}

impl Setups {
    /// Whether pending ray `i` is well-conditioned ([`RaySetup::well_conditioned`]).
    #[inline]
    pub(crate) fn is_well_conditioned(&self, i: usize) -> bool {
        self.well_conditioned[i]
    }

    /// The step direction on axis `a` (−1, 0 or 1), by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn steps(&self, a: usize) -> &[i32; PENDING] {
        &self.step[a]
    }

    /// `tMax` on axis `a`, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn t_maxes(&self, a: usize) -> &[f64; PENDING] {
        &self.t_max[a]
    }

    /// `tDelta` on axis `a`, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn t_deltas(&self, a: usize) -> &[f64; PENDING] {
        &self.t_delta[a]
    }

    /// The rays' `f32` lengths, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn lengths(&self) -> &[f32; PENDING] {
        &self.length
    }

    /// The first step at which each ray's walk from its origin voxel may stop, by column.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) fn watches(&self) -> &[u64; PENDING] {
        &self.watch
    }

    /// Whether pending ray `i` skips its head, and up to when.
    #[inline]
    pub(crate) fn head(&self, i: usize) -> Option<f64> {
        let t = self.head[i];
        (t != f64::NEG_INFINITY).then_some(t)
    }

    /// The length of pending ray `i` when it is well-conditioned (so surely walked, whole or
    /// from its head's end) and points along its pixel, else 0: what a sampled ray of
    /// [`crate::pixel_grid`] contributes to its windows.
    #[inline]
    pub(crate) fn walked_length(&self, i: usize) -> f64 {
        if self.well_conditioned[i] && self.fits[i] {
            self.length[i] as f64
        } else {
            0.0
        }
    }
}

/// What the set-ups share: the origin, its voxel's corners and the skip plan's margins.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shared {
    origin: [f32; 3],
    origin_f64: [f64; 3],
    /// The origin's key.
    origin_key: Key,
    /// Whether the set-ups tell the steps the walks stop at ([`first_watch`]): for LiDAR
    /// scans, whose rays are queued for the AVX-512 lanes from these columns; not for depth
    /// images (a skip plan), whose rays mostly take another path and would pay for nothing.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    tell_stops: bool,
    /// The origin voxel's corner on each axis in the positive and in the negative direction,
    /// as OctoMap computes it (the half-voxel narrowed to `f32`).
    border: [[f64; 2]; 3],
    res: f64,
    /// The rotation's columns (for the direction check).
    axes: [[f32; 3]; 3],
    end_margin: f64,
    min_head: f64,
}

impl Shared {
    /// The shared values of rays from `origin`, whose key is `origin_key`, with `plan` (if
    /// any) deciding the heads.
    pub(crate) fn new(
        conv: &KeyConverter,
        origin: &Point3<f32>,
        origin_key: Key,
        plan: Option<&SkipPlan>,
    ) -> Shared {
        let res = conv.resolution();
        let corner = |a: usize, step: f64| {
            conv.key_to_coord(origin_key[a]) + ((step * res * 0.5) as f32) as f64
        };
        let (axes, end_margin, min_head) = plan.map_or(([[0.0; 3]; 3], 0.0, f64::INFINITY), |p| {
            (p.axes(), p.end_margin(), p.min_head())
        });
        Shared {
            origin: [origin.x, origin.y, origin.z],
            origin_f64: [origin.x as f64, origin.y as f64, origin.z as f64],
            origin_key,
            tell_stops: plan.is_none(),
            border: [0, 1, 2].map(|a| [corner(a, 1.0), corner(a, -1.0)]),
            res,
            axes,
            end_margin,
            min_head,
        }
    }
}

/// Compute the set-ups of the pending rays into `out`: eight or sixteen lanes at a time where
/// the CPU has AVX-512, four or eight with AVX2, else with the target's own vectors.
pub(crate) fn set_up(p: &Pending, s: &Shared, out: &mut Setups) {
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx512() {
        // SAFETY: `set_up_avx512` needs AVX-512 Foundation, found just above; it is the
        // safe `set_up_lanes` compiled for it.
        #[allow(unsafe_code)]
        unsafe {
            set_up_avx512(p, s, out)
        };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        // SAFETY: `set_up_avx2` needs AVX2, found just above; it is the safe `set_up_lanes`
        // compiled for it.
        #[allow(unsafe_code)]
        unsafe {
            set_up_avx2(p, s, out)
        };
        return;
    }
    set_up_lanes::<false>(p, s, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn set_up_avx512(p: &Pending, s: &Shared, out: &mut Setups) {
    if s.tell_stops {
        set_up_lanes::<true>(p, s, out);
    } else {
        set_up_lanes::<false>(p, s, out);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn set_up_avx2(p: &Pending, s: &Shared, out: &mut Setups) {
    set_up_lanes::<false>(p, s, out);
}

/// [`set_up`] for every column (the unused ones too: the loop has a fixed length and no
/// branches, so it vectorises). With `TELL`, [`Setups::watches`] tells the steps the walks
/// stop at where it can ([`first_watch`]); without, it holds four steps before the Manhattan
/// distance for every ray ([`untold_watch`]).
#[inline(always)]
fn set_up_lanes<const TELL: bool>(p: &Pending, s: &Shared, out: &mut Setups) {
    for i in 0..PENDING {
        // `sub_f32`, `norm_f32` and `setup_with_keys`, operation for operation
        let d = [0, 1, 2].map(|a| p.end[a][i] - s.origin[a]);
        let sq: f32 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        let length = (sq as f64).sqrt() as f32;
        let dir = d.map(|v| v / length);
        let mut t_maxes = [0.0; 3];
        let mut t_deltas = [0.0; 3];
        let finite = dir[0].is_finite() & dir[1].is_finite() & dir[2].is_finite();
        let well = length.is_finite() & (length > 0.0) & finite;
        for (a, &da) in dir.iter().enumerate() {
            let (pos, neg) = (da > 0.0, da < 0.0);
            let border = if pos { s.border[a][0] } else { s.border[a][1] };
            let t_max = (border - s.origin_f64[a]) / da as f64;
            let t_delta = s.res / da.abs() as f64;
            let moving = pos | neg;
            out.step[a][i] = pos as i32 - neg as i32;
            t_maxes[a] = if moving { t_max } else { f64::MAX };
            t_deltas[a] = if moving { t_delta } else { f64::MAX };
            out.t_max[a][i] = t_maxes[a];
            out.t_delta[a][i] = t_deltas[a];
        }
        let (ko, ke) = (s.origin_key.0, p.key_end[i].0);
        let keys = [
            u32::from(ko[0].abs_diff(ke[0])),
            u32::from(ko[1].abs_diff(ke[1])),
            u32::from(ko[2].abs_diff(ke[2])),
        ];
        out.watch[i] = if TELL {
            first_watch(t_maxes, t_deltas, length as f64, keys)
        } else {
            untold_watch(u64::from(keys[0]) + u64::from(keys[1]) + u64::from(keys[2]))
        };
        out.length[i] = length;
        out.well_conditioned[i] = well;
        // what `SkipPlan::cap` leaves to the ray: its own length, the shortest head, and the
        // direction check
        let t = p.cap[i].min(length as f64 - s.end_margin);
        let fits = fits_dir(&s.axes, p.col[i], p.row[i], d);
        let skips = (t >= s.min_head) & fits & well;
        out.head[i] = if skips { t } else { f64::NEG_INFINITY };
        out.fits[i] = fits;
    }
}

#[cfg(test)]
#[path = "setups_tests.rs"]
mod tests;
