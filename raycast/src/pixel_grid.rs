//! Frames from a depth camera: rays through neighbouring pixels cross the same voxels near the
//! camera, so most of a ray need not be walked.
//!
//! Every fourth pixel's ray (in u and in v) is walked whole, as always. Another ray `R` skips
//! its head, the crossings before a time `T`, when every voxel it enters there is provably
//! entered by sampled rays too; it is walked from its exact DDA state at `T` on. The free set
//! is a union, so the map is the same, bit for bit. There are two levels: the other even
//! pixels are covered by the rays every fourth pixel; the odd pixels by the rays of every even
//! pixel (whole or skipped: all their voxels are in the union either way), whose windows are
//! a quarter the size.
//!
//! Why a sampled ray enters such a voxel `V` (centre `C` at distance `d` from the origin `O`,
//! side `h`), when `V` lies outside the 3x3x3 voxels around the origin's:
//! - `d ≥ 1.5h`, so the angle `θ` between `R` and `C` is below 90° with
//!   `sin θ ≤ (√3h/2)/d = √3·sin α`, where `α` is the half-angle under which `V`'s inscribed
//!   ball is seen.
//! - The directions through `V` form a convex cone holding `R` and the cap of radius `α`
//!   around `C`, hence (spherical right triangles) a cap of radius `ρ` around the point of
//!   the arc from `R` to `C` at angle `x` from `R`, where `sin ρ = sin x·sin α / sin θ`.
//! - The sampled directions form a `δ`-net: every direction of the image is within `δ` of a
//!   sampled ray's actual direction (half the diagonal of a sampled cell, plus the tolerance
//!   of the direction check below). With `α ≥ δ'` (`d ≤ h / (2 sin δ')`) a cap of radius
//!   `δ'` exists at `sin x ≤ √3·sin δ'`, and it holds a sampled direction strictly inside
//!   the cone, within `x + δ'` of `R`: by the gnomonic projection's largest stretch (`sec²`
//!   of the angle to the optical axis, at the image's corner), within a pixel radius `L` of
//!   `R`'s pixel.
//! - That sampled ray crosses `V`'s inscribed ball, so its DDA visits `V` (with a margin far
//!   above the DDA's rounding) provided it is longer than `d + √3h/2`. `R` enters `V` before
//!   `T`, so `d < T + √3h/2`: a sampled length of `T + √3h` suffices.
//!
//! So `T` is the smallest sampled length in the window of pixel radius `L` minus `√3h`,
//! capped by the distance up to which `α ≥ δ'` and by `R`'s own length minus `2h` (so that
//! `R` does not end in its head); margins of `h/50` are kept on all three. The voxels of
//! the 3x3x3 block around the origin voxel are not covered by the argument; `R`'s few steps
//! inside it are walked exactly and collected in a 27-bit mask. Rays near the image border,
//! rays whose direction does not match their pixel, and rays with a short `T` are walked
//! whole.
//!
//! The DDA state at `T` is exact, not approximated: the crossings processed before `T` are
//! exactly those earlier than `T` (the DDA takes crossings in time order), and each axis's
//! `tMax` is the same chain of `f64` additions, replayed per axis. The tail's walk then makes
//! the very comparisons the whole walk would.

use crate::dda::{min_axis, step_budget, RaySetup};
use crate::lanes::{ReplayPath, REPLAY_RAYS};
use nalgebra::Rotation3;
use octoquant_octree::Key;

/// A pinhole depth camera: its image size, intrinsics and orientation in the map. A pixel
/// `(u, v)` looks along the map direction `rotation · ((u − cx)/fx, (v − cy)/fy, 1)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Focal length in pixels along u.
    pub fx: f64,
    /// Focal length in pixels along v.
    pub fy: f64,
    /// Principal point, u.
    pub cx: f64,
    /// Principal point, v.
    pub cy: f64,
    /// The camera's orientation in the map.
    pub rotation: Rotation3<f64>,
}

/// How the points of a frame lie on a pinhole camera's pixel grid, for
/// [`crate::compute_update_grid_f32`]: point `i` was measured through pixel `pixels[i]`
/// (`v·width + u`). Wrong information costs speed, never exactness: points whose direction
/// from the origin does not match their pixel are walked whole.
#[derive(Debug, Clone, Copy)]
pub struct PixelGrid<'a> {
    /// The camera that measured the points.
    pub camera: PinholeCamera,
    /// The pixel of each point, `v·width + u`, in point order.
    pub pixels: &'a [u32],
}

/// Pixels between the rays walked whole, in u and in v: `1 << SAMPLE_SHIFT`.
const SAMPLE_SHIFT: u32 = 2;
const SAMPLE: usize = 1 << SAMPLE_SHIFT;
/// Largest angle (radians) between a point's direction and its pixel's for the point to count
/// as measured through that pixel.
const DIRECTION_TOL: f64 = 1e-4;
/// Rays whose skippable head is shorter than this many voxels are walked whole.
const MIN_HEAD_VOXELS: f64 = 3.0;

/// One level of sampled rays: those through every `spacing`-th pixel in u and in v. The
/// coarse level (4) is walked whole and covers the other even pixels; the fine level (2:
/// every even pixel, whole or skipped, whose voxels are all in the union either way) covers
/// the odd pixels, with a window a quarter the size.
#[derive(Debug, Clone, Default)]
struct Level {
    /// The spacing is `1 << shift` pixels (a power of two, so a pixel's block is found with
    /// shifts, not divisions).
    shift: u32,
    /// Blocks (sampled pixels) per row and per column.
    blocks_w: usize,
    blocks_h: usize,
    /// Per block: the shortest sampled ray length within the window, 0 where one is missing.
    block_min: Vec<f64>,
    /// Sampled ray lengths (scratch for `block_min`).
    lens: Vec<f64>,
    /// Rays within this many pixels of the border are walked whole.
    border: usize,
    /// The window around a block: this many sampled pixels before it and after it.
    radius_blocks: (usize, usize),
    /// `T` stays below this (where the voxels' inscribed balls still hold a `δ'` cap).
    head_limit: f64,
}

impl Level {
    /// The geometry of the level with spacing `1 << shift` for `camera` at resolution `res`;
    /// `None` when the argument does not hold for it.
    fn new(shift: u32, camera: &PinholeCamera, res: f64, margin: f64) -> Option<Level> {
        let spacing = 1usize << shift;
        let (w, h) = (camera.width as usize, camera.height as usize);
        let half = spacing as f64 / 2.0;
        let net = ((half / camera.fx).powi(2) + (half / camera.fy).powi(2)).sqrt() + DIRECTION_TOL;
        let cap = net + DIRECTION_TOL;
        let sin_x = 3f64.sqrt() * cap.sin();
        // (NaN fails too)
        let small = sin_x < 0.5;
        if !small {
            return None;
        }
        let spread = sin_x.asin() + cap + 2.0 * DIRECTION_TOL;
        let du = camera.cx.abs().max((w as f64 - 1.0 - camera.cx).abs()) / camera.fx;
        let dv = camera.cy.abs().max((h as f64 - 1.0 - camera.cy).abs()) / camera.fy;
        let stretch = 1.0 + du * du + dv * dv;
        let radius = camera.fx.max(camera.fy) * spread * stretch;
        if !(radius.is_finite() && radius < (w.min(h) / 2) as f64) {
            return None;
        }
        let s = spacing as f64;
        let (blocks_w, blocks_h) = (w.div_ceil(spacing), h.div_ceil(spacing));
        Some(Level {
            shift,
            blocks_w,
            blocks_h,
            block_min: Vec::new(),
            lens: vec![f64::INFINITY; blocks_w * blocks_h],
            border: radius.ceil() as usize,
            radius_blocks: (
                (radius / s).floor() as usize,
                ((s - 1.0 + radius) / s).floor() as usize,
            ),
            head_limit: res / (2.0 * cap.sin()) - 3f64.sqrt() * res / 2.0 - margin,
        })
    }

    /// The block of the pixel at `(u, v)`, when it is one of this level's sampled pixels.
    #[inline]
    fn sampled(&self, (u, v): (usize, usize)) -> Option<usize> {
        let (k, low) = (self.shift, (1 << self.shift) - 1);
        ((u | v) & low == 0).then(|| (v >> k) * self.blocks_w + (u >> k))
    }

    /// After every sampled ray is recorded: the shortest length within each block's window
    /// (a square of sampled pixels holding every sampled pixel within the radius of any pixel
    /// of the block). Sampled pixels without a point count as length 0.
    fn finish(&mut self, row_min: &mut Vec<f64>) {
        let (bw, bh) = (self.blocks_w, self.blocks_h);
        for l in self.lens.iter_mut() {
            if !l.is_finite() {
                *l = 0.0;
            }
        }
        // a window is blocks i − lo ..= i + hi, cut at the edges: the minimum of shifted
        // copies, one shift at a time (plain element-wise minima, which vectorise)
        let (lo, hi) = self.radius_blocks;
        row_min.clear();
        row_min.extend_from_slice(&self.lens);
        for j in 0..bh {
            let line = &self.lens[j * bw..(j + 1) * bw];
            let out = &mut row_min[j * bw..(j + 1) * bw];
            for k in 1..=lo.min(bw) {
                for (o, &l) in out[k..].iter_mut().zip(line) {
                    *o = o.min(l);
                }
            }
            for k in 1..=hi.min(bw) {
                for (o, &l) in out.iter_mut().zip(&line[k..]) {
                    *o = o.min(l);
                }
            }
        }
        self.block_min.clear();
        self.block_min.extend_from_slice(row_min);
        for j in 0..bh {
            let out = j * bw..(j + 1) * bw;
            for jj in j.saturating_sub(lo)..(j + hi + 1).min(bh) {
                if jj == j {
                    continue;
                }
                let (dst, src) = (out.clone(), jj * bw..(jj + 1) * bw);
                for (o, &l) in self.block_min[dst].iter_mut().zip(&row_min[src]) {
                    *o = o.min(l);
                }
            }
        }
    }
}

/// What a frame's rays may skip: the shortest sampled length around every pixel block, on
/// two levels.
#[derive(Debug, Clone, Default)]
pub(crate) struct SkipPlan {
    width: usize,
    height: usize,
    /// Spacing 4 (for the even pixels) and 2 (for the others).
    levels: [Level; 2],
    /// Scratch for the window minima.
    row_min: Vec<f64>,
    /// A sampled length covers voxels entered up to this much before it.
    cover_margin: f64,
    /// `R`'s own end: `T` stays this much before it.
    end_margin: f64,
    /// The shortest head worth skipping.
    min_head: f64,
    /// `1 / width`.
    inv_width: f64,
    /// `(u − cx)/fx` per column and `(v − cy)/fy` per row.
    col: Vec<f32>,
    row: Vec<f32>,
    /// The rotation's columns.
    axes: [[f32; 3]; 3],
}

impl SkipPlan {
    /// Set up the window geometry for `grid` at resolution `res`; `false` (nothing to skip)
    /// when the grid is unusable or too coarse for the argument.
    pub(crate) fn prepare(&mut self, grid: &PixelGrid<'_>, points: usize, res: f64) -> bool {
        let camera = &grid.camera;
        let (w, h) = (camera.width as usize, camera.height as usize);
        let finite = [camera.fx, camera.fy, camera.cx, camera.cy]
            .iter()
            .all(|v| v.is_finite());
        if !finite || camera.fx <= 0.0 || camera.fy <= 0.0 || w < SAMPLE || h < SAMPLE {
            return false;
        }
        if grid.pixels.len() != points || w.checked_mul(h).is_none_or(|n| n > u32::MAX as usize) {
            return false;
        }
        let margin = res / 50.0;
        let (Some(coarse), Some(fine)) = (
            Level::new(SAMPLE_SHIFT, camera, res, margin),
            Level::new(SAMPLE_SHIFT - 1, camera, res, margin),
        ) else {
            return false;
        };
        self.levels = [coarse, fine];
        self.width = w;
        self.height = h;
        self.cover_margin = 3f64.sqrt() * res + margin;
        self.end_margin = 2.0 * res + margin;
        self.min_head = MIN_HEAD_VOXELS * res;
        self.inv_width = 1.0 / w as f64;
        self.col = (0..w)
            .map(|u| ((u as f64 - camera.cx) / camera.fx) as f32)
            .collect();
        self.row = (0..h)
            .map(|v| ((v as f64 - camera.cy) / camera.fy) as f32)
            .collect();
        let m = camera.rotation.matrix();
        self.axes = [0, 1, 2].map(|c| [0, 1, 2].map(|r| m[(r, c)] as f32));
        self.levels[0].head_limit > self.min_head
    }

    /// The column and row of `pixel`, when it lies on the grid (without a division:
    /// `(pixel + ½)·(1/width)` in `f64` floors exactly for any `u32` pixel and width).
    #[inline]
    pub(crate) fn locate(&self, pixel: u32) -> Option<(usize, usize)> {
        let v = ((pixel as f64 + 0.5) * self.inv_width) as usize;
        let u = pixel as usize - v * self.width;
        (v < self.height).then_some((u, v))
    }

    /// Whether the pixel at `(u, v)` is sampled on some level (its length is recorded).
    #[inline]
    pub(crate) fn sampled(&self, at: (usize, usize)) -> bool {
        self.levels[1].sampled(at).is_some()
    }

    /// Record the length of the ray through the sampled pixel at `(u, v)` (0 for a ray that
    /// is not walked, or does not match its pixel) on every level that samples it.
    #[inline]
    pub(crate) fn record(&mut self, at: (usize, usize), length: f64) {
        for level in self.levels.iter_mut() {
            if let Some(block) = level.sampled(at) {
                let l = &mut level.lens[block];
                *l = l.min(length);
            }
        }
    }

    /// After every sampled ray is recorded: the window minima of both levels.
    pub(crate) fn finish(&mut self) {
        for level in self.levels.iter_mut() {
            level.finish(&mut self.row_min);
        }
    }

    /// What the ray through the pixel at `(u, v)` may skip before its own length is taken
    /// into account, with the pixel's direction factors `(u − cx)/fx` and `(v − cy)/fy`, or
    /// `None` when it is to be walked whole: pixels of the coarse level always, the other even
    /// pixels by the coarse level's windows, the odd ones by the fine level's. The time is
    /// then capped by the ray's length ([`SkipPlan::end_margin`]), checked against
    /// [`SkipPlan::min_head`], and the direction is checked with [`fits_dir`].
    #[inline]
    pub(crate) fn cap(&self, (u, v): (usize, usize)) -> Option<(f64, f32, f32)> {
        if (u | v) & (SAMPLE - 1) == 0 {
            return None;
        }
        let level = &self.levels[(u | v) & 1];
        let b = level.border;
        if u < b || v < b || u + b >= self.width || v + b >= self.height {
            return None;
        }
        let k = level.shift;
        let cover = level.block_min[(v >> k) * level.blocks_w + (u >> k)];
        let t = (cover - self.cover_margin).min(level.head_limit);
        let (a, b) = self.factors((u, v));
        Some((t, a, b))
    }

    /// The direction factors `(u − cx)/fx` and `(v − cy)/fy` of the pixel at `(u, v)`, for
    /// [`fits_dir`].
    #[inline]
    pub(crate) fn factors(&self, (u, v): (usize, usize)) -> (f32, f32) {
        (self.col[u], self.row[v])
    }

    /// A ray skips nothing closer than this to its own end (its length).
    pub(crate) fn end_margin(&self) -> f64 {
        self.end_margin
    }

    /// The shortest head worth skipping.
    pub(crate) fn min_head(&self) -> f64 {
        self.min_head
    }

    /// The camera rotation's columns, for [`fits_dir`].
    pub(crate) fn axes(&self) -> [[f32; 3]; 3] {
        self.axes
    }
}

/// Whether `diff` (end minus origin) points along the ray of the pixel whose direction factors
/// are `a = (u − cx)/fx` and `b = (v − cy)/fy` under the rotation with columns `axes`, within
/// the tolerance. In `f32`: its rounding (about 1e-7 radians) stays far inside the tenth of
/// the tolerance kept as margin. Branch-free, so that it vectorises (see [`crate::setups`]).
#[inline(always)]
pub(crate) fn fits_dir(axes: &[[f32; 3]; 3], a: f32, b: f32, diff: [f32; 3]) -> bool {
    let [x, y, z] = axes;
    let w = [0, 1, 2].map(|i| x[i] * a + y[i] * b + z[i]);
    let d = diff;
    let along = d[0] * w[0] + d[1] * w[1] + d[2] * w[2];
    let c = [
        d[1] * w[2] - d[2] * w[1],
        d[2] * w[0] - d[0] * w[2],
        d[0] * w[1] - d[1] * w[0],
    ];
    let across = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    let ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    let tol = (0.9 * DIRECTION_TOL) as f32;
    (along > 0.0) & (across <= tol * tol * dd * ww)
}

/// The 27 voxels around the origin voxel, as bits `9·(dz+1) + 3·(dy+1) + (dx+1)`.
pub(crate) fn near_bit(offset: [i32; 3]) -> Option<u32> {
    if offset.iter().any(|o| o.abs() > 1) {
        return None;
    }
    Some((9 * (offset[2] + 1) + 3 * (offset[1] + 1) + (offset[0] + 1)) as u32)
}

/// The key of bit `bit` of a near mask around `origin`.
pub(crate) fn near_key(origin: Key, bit: u32) -> Key {
    let off = [
        (bit % 3) as i32 - 1,
        ((bit / 3) % 3) as i32 - 1,
        (bit / 9) as i32 - 1,
    ];
    Key(std::array::from_fn(|i| {
        (origin.0[i] as i32 + off[i]) as u16
    }))
}

/// Walk `r`'s crossings before `t` inside the 3x3x3 block around its origin voxel, setting
/// their bits in `near` (the origin voxel's too).
#[inline]
pub(crate) fn near_steps(r: &RaySetup, t: f64, near: &mut u32) {
    let mut key = [0i32; 3];
    let mut tm = r.t_max;
    *near |= 1 << 13;
    loop {
        let a = min_axis(&tm);
        // the DDA takes the crossing only when it is earlier than `t` (not NaN)
        let earlier = tm[a] < t;
        if !earlier {
            break;
        }
        key[a] += r.step[a];
        tm[a] += r.t_delta[a];
        match near_bit(key) {
            Some(bit) => *near |= 1 << bit,
            None => break,
        }
    }
}

/// Append to `out` each ray `r` of `rays` at its exact DDA state at its time `t`: every
/// crossing earlier than `t` taken, each axis's `tMax` replayed by the same additions. Returns
/// the near bits of their steps before `t` (see [`near_steps`]). In the lanes of AVX-512 or
/// AVX2 where the CPU has them, else one by one.
pub(crate) fn jump(rays: &[(RaySetup, f64)], out: &mut Vec<RaySetup>) -> u32 {
    jump_with(rays, out, ReplayPath::Avx512)
}

/// [`jump`] through the `widest` replay path at most.
fn jump_with(rays: &[(RaySetup, f64)], out: &mut Vec<RaySetup>, widest: ReplayPath) -> u32 {
    const K: usize = REPLAY_RAYS;
    let mut near = 0;
    for group in rays.chunks(K) {
        let mut t = [[f64::INFINITY; K]; 3];
        let mut d = [[0.0; K]; 3];
        let mut step = [[0.0; K]; 3];
        let mut until = [f64::NEG_INFINITY; K];
        let mut n = [[0.0; K]; 3];
        for (l, (r, at)) in group.iter().enumerate() {
            for a in 0..3 {
                t[a][l] = r.t_max[a];
                d[a][l] = r.t_delta[a];
                step[a][l] = r.step[a] as f64;
            }
            until[l] = *at;
        }
        let done = crate::lanes::replay_rays(&mut t, &d, &step, &until, &mut n, widest);
        match done {
            Some(bits) => near |= bits,
            None => {
                for (l, (r, at)) in group.iter().enumerate() {
                    near_steps(r, *at, &mut near);
                    for a in 0..3 {
                        while t[a][l] < until[l] {
                            t[a][l] += d[a][l];
                            n[a][l] += 1.0;
                        }
                    }
                }
            }
        }
        for (l, &(r, _)) in group.iter().enumerate() {
            let mut r = r;
            let mut k = r.key_origin;
            for a in 0..3 {
                r.t_max[a] = t[a][l];
                // whole numbers below 2^21; the walk stays in the map (both ends are in it),
                // so this is the key it reaches
                k.0[a] = (k.0[a] as i64 + n[a][l] as i64 * r.step[a] as i64) as u16;
            }
            r.key_origin = k;
            r.code_origin = k.morton();
            r.budget = step_budget(k, r.key_end);
            out.push(r);
        }
    }
    near
}

#[cfg(test)]
#[path = "pixel_grid_tests.rs"]
mod tests;
