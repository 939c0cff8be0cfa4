//! The free-space ray: OctoMap's 3D DDA (`OcTreeBaseImpl::computeRayKeys`), bit for bit.
//!
//! [`walk_ray_keys_f32`] visits the keys of the voxels a segment crosses, from the origin voxel
//! up to but excluding the end voxel, without allocating; [`compute_ray_keys_f32`] collects them
//! into a caller-owned [`KeyRay`] that is reused from ray to ray. Both take OctoMap's `f32`
//! points; the `f64` door is [`crate::compute_ray_keys`].
//!
//! The arithmetic follows OctoMap exactly, because the voxels a ray grazes depend on it:
//! the direction and the length are `f32` (squared sum in `f32`, square root in `f64` cast to
//! `f32`, `f32` division per axis); the voxel border is the key's centre in `f64` plus
//! `(f32)(step·res·0.5)`; `tMax`/`tDelta` are `f64`; ties go to z, then y, then x. The walk stops
//! on the end voxel (not emitted) or, when rounding made it miss that voxel, as soon as the next
//! border lies beyond the segment's length (the "overshoot" key is not emitted either).

use nalgebra::Point3;
use octoquant_octree::{Key, KeyConverter};

/// Capacity of OctoMap's `KeyRay` (`KeyRay::maxSize`). OctoMap aborts (an `assert`) on a ray
/// that reaches 99 999 keys; octoquant has no such limit (see [`compute_ray_keys_f32`]).
pub const OCTOMAP_KEY_RAY_CAPACITY: usize = 100_000;

/// Extra iterations beyond the Manhattan key distance that a walk may take before it is
/// declared degenerate. A well-conditioned walk overshoots each axis by at most one voxel, so
/// it needs at most `manhattan + 3`; the margin only matters for rays OctoMap never finishes.
pub(crate) const STEP_MARGIN: u32 = 16;

/// A caller-owned, reusable list of ray keys (OctoMap's `KeyRay`).
///
/// [`compute_ray_keys_f32`] clears and refills it; its allocation is kept between rays, so one
/// `KeyRay` per thread avoids any allocation in the ray loop.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct KeyRay {
    keys: Vec<Key>,
}

impl KeyRay {
    /// An empty ray without allocation.
    pub fn new() -> Self {
        KeyRay { keys: Vec::new() }
    }

    /// An empty ray with room for `n` keys.
    pub fn with_capacity(n: usize) -> Self {
        KeyRay {
            keys: Vec::with_capacity(n),
        }
    }

    /// Remove all keys, keeping the allocation.
    pub fn clear(&mut self) {
        self.keys.clear();
    }

    /// Number of keys.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// `true` when the ray holds no key.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The keys in ray order (origin voxel first).
    pub fn keys(&self) -> &[Key] {
        &self.keys
    }

    /// Iterate over the keys in ray order.
    pub fn iter(&self) -> std::slice::Iter<'_, Key> {
        self.keys.iter()
    }

    /// The keys as a vector, consuming the ray.
    pub fn into_vec(self) -> Vec<Key> {
        self.keys
    }
}

impl<'a> IntoIterator for &'a KeyRay {
    type Item = &'a Key;
    type IntoIter = std::slice::Iter<'a, Key>;
    fn into_iter(self) -> Self::IntoIter {
        self.keys.iter()
    }
}

/// How a [`walk_ray_keys_f32`] walk ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RayWalk {
    /// Every key up to (excluding) the end voxel was visited; OctoMap returns `true`.
    Complete,
    /// Origin and end share a voxel: nothing was visited; OctoMap returns `true` and an empty
    /// ray.
    SameVoxel,
    /// The origin or the end is outside the map (or not finite): nothing was visited; OctoMap
    /// returns `false`.
    OutsideMap,
    /// The visitor returned `false`.
    Stopped,
    /// The float arithmetic degenerated (for example the `f32` length underflowed to 0 or
    /// overflowed) and the walk would never end; OctoMap loops until its `KeyRay` assertion
    /// aborts. The walk was cut after more iterations than any regular ray needs; keys
    /// visited so far should be discarded.
    Degenerate,
}

/// `std::min` as C++ defines it (`b < a ? b : a`), so NaN behaves as in OctoMap.
#[inline(always)]
pub(crate) fn cmin(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// OctoMap's `Vector3::norm`: the squared sum in `f32`, the square root in `f64`.
#[inline(always)]
pub(crate) fn norm_f32(v: [f32; 3]) -> f64 {
    let sq: f32 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    (sq as f64).sqrt()
}

/// `a - b` per axis in `f32`, like `point3d` subtraction.
#[inline(always)]
pub(crate) fn sub_f32(a: &Point3<f32>, b: &Point3<f32>) -> [f32; 3] {
    [a.x - b.x, a.y - b.y, a.z - b.z]
}

/// Whether every coordinate of `p` is finite: points with a NaN or infinite one are skipped
/// and counted, never inserted.
#[inline]
pub(crate) fn is_finite(p: &Point3<f32>) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
}

/// The key of an `f32` point, checked like OctoMap's `coordToKeyChecked(point3d)`.
#[inline(always)]
pub(crate) fn key_of(conv: &KeyConverter, p: &Point3<f32>) -> Option<Key> {
    Some(Key([
        conv.coord_to_key_checked(p.x as f64)?,
        conv.coord_to_key_checked(p.y as f64)?,
        conv.coord_to_key_checked(p.z as f64)?,
    ]))
}

/// The axis with the smallest `tMax`; ties go to z over y over x (OctoMap's comparison chain).
#[inline(always)]
pub(crate) fn min_axis(t: &[f64; 3]) -> usize {
    if t[0] < t[1] {
        if t[0] < t[2] {
            0
        } else {
            2
        }
    } else if t[1] < t[2] {
        1
    } else {
        2
    }
}

/// [`min_axis`] as two selections: the same comparisons in the same order, ties and NaN
/// included (`t0 < t1 ? (t0 < t2 ? 0 : 2) : (t1 < t2 ? 1 : 2)`), without the branches a single
/// ray's changing axis mispredicts. For the scalar walk only: the head replay and `castRay`
/// keep the branches (the selections were not timed there).
#[inline(always)]
fn min_axis_select(t: &[f64; 3]) -> usize {
    let m = if t[0] < t[1] { 0 } else { 1 };
    let tm = if m == 0 { t[0] } else { t[1] };
    if tm < t[2] {
        m
    } else {
        2
    }
}

/// The DDA state of one ray after OctoMap's set-up: both keys, per-axis step, `tMax`,
/// `tDelta`, the `f32` length (as `f64`) and the iteration budget.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RaySetup {
    pub(crate) key_origin: Key,
    pub(crate) key_end: Key,
    /// [`Key::morton`] of `key_origin` and of `key_end`, computed once by the caller.
    pub(crate) code_origin: u64,
    pub(crate) code_end: u64,
    pub(crate) step: [i32; 3],
    pub(crate) t_max: [f64; 3],
    pub(crate) t_delta: [f64; 3],
    pub(crate) length: f64,
    pub(crate) budget: u32,
    /// The `f32` length is finite and positive and every direction component finite: the
    /// walk then provably ends within `budget` steps. Each axis `i` is stepped at most
    /// `len·|dᵢ|/res + 1` times before its `tMax` passes the length, which is within two of
    /// the key distance on that axis, so the walk ends long before the budget of the
    /// Manhattan distance plus [`STEP_MARGIN`]; only ill-conditioned rays (a zero, infinite
    /// or NaN length) can degenerate. Such walks need not buffer their keys (tested in
    /// `dda_tests`, every walk against [`walk_ray_codes_f32`]).
    pub(crate) well_conditioned: bool,
}

/// OctoMap's checks and set-up before the loop; `Err` is the outcome when no key is visited.
#[inline(always)]
fn setup(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
) -> Result<RaySetup, RayWalk> {
    setup_from(conv, origin, key_of(conv, origin), end)
}

/// A key with its [`Key::morton`] code, for callers that need both and should compute the
/// code once.
#[inline(always)]
pub(crate) fn coded(key: Key) -> (Key, u64) {
    (key, key.morton())
}

/// [`setup`] with the origin's key already known (`key_of(conv, origin)`), for callers that
/// cast many rays from one origin.
#[inline(always)]
pub(crate) fn setup_from(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    origin_key: Option<Key>,
    end: &Point3<f32>,
) -> Result<RaySetup, RayWalk> {
    setup_with_keys(
        conv,
        origin,
        origin_key.map(coded),
        end,
        key_of(conv, end).map(coded),
    )
}

/// [`setup_from`] with both keys and their Morton codes already known (`key_of(..)` and
/// [`coded`]), for callers that computed them already: a scan's origin once for all its rays,
/// each end point once for its occupied voxel and its ray.
#[inline(always)]
pub(crate) fn setup_with_keys(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    origin_key: Option<(Key, u64)>,
    end: &Point3<f32>,
    end_key: Option<(Key, u64)>,
) -> Result<RaySetup, RayWalk> {
    let (Some((key_origin, code_origin)), Some((key_end, code_end))) = (origin_key, end_key) else {
        return Err(RayWalk::OutsideMap);
    };
    if key_origin == key_end {
        return Err(RayWalk::SameVoxel);
    }
    let mut direction = sub_f32(end, origin);
    let length = norm_f32(direction) as f32;
    for d in direction.iter_mut() {
        *d /= length;
    }
    let well_conditioned =
        length.is_finite() && length > 0.0 && direction.iter().all(|d| d.is_finite());
    let res = conv.resolution();
    let o = [origin.x as f64, origin.y as f64, origin.z as f64];
    let mut step = [0i32; 3];
    let mut t_max = [f64::MAX; 3];
    let mut t_delta = [f64::MAX; 3];
    for i in 0..3 {
        step[i] = if direction[i] > 0.0 {
            1
        } else if direction[i] < 0.0 {
            -1
        } else {
            0
        };
        if step[i] != 0 {
            // the voxel corner in the ray's direction; OctoMap narrows the half-voxel to f32
            let border =
                conv.key_to_coord(key_origin[i]) + ((step[i] as f64 * res * 0.5) as f32) as f64;
            t_max[i] = (border - o[i]) / direction[i] as f64;
            t_delta[i] = res / direction[i].abs() as f64;
        }
    }
    Ok(RaySetup {
        key_origin,
        key_end,
        code_origin,
        code_end,
        step,
        t_max,
        t_delta,
        length: length as f64,
        budget: step_budget(key_origin, key_end),
        well_conditioned,
    })
}

/// The most steps a walk from `from` to `to` may take: their Manhattan key distance plus
/// [`STEP_MARGIN`] (see [`RaySetup::budget`]).
#[inline]
pub(crate) fn step_budget(from: Key, to: Key) -> u32 {
    let manhattan: u32 = (0..3)
        .map(|i| (from[i] as i32 - to[i] as i32).unsigned_abs())
        .sum();
    manhattan + STEP_MARGIN
}

/// Whether a walk's set-up tells the step it stops at: the walk from `t_max` by `t_delta`
/// (OctoMap's chain, one `f64` addition per crossing) whose end key lies `keys[a]` keys from
/// its origin key along axis `a`, and which stops once its key reaches the end key or its
/// smallest `tMax` passes `length`. It does when each axis has exactly `keys[a]` crossings at
/// or before `length`, and each of the nearest crossings on either side of `length` lies
/// farther from it than the roundings of the chain and of this check could move it; the walk
/// then stops at the Manhattan distance `keys[0] + keys[1] + keys[2]`, exactly. `false` for
/// end points within rounding of a voxel face, lengths that are not finite and positive, and
/// `NaN`s.
///
/// Why: each step takes the smallest `tMax`, so the walk takes its axes' crossings in time
/// order; while a crossing at or before `length` is untaken the smallest `tMax` is at most
/// `length` and the walk goes on, unless its key reaches the end key, which takes the
/// Manhattan distance in steps at least. After as many steps as there are crossings at or
/// before `length` (here the Manhattan distance) every one is taken and the smallest `tMax`
/// lies beyond, so the walk stops there. Crossing `j` of an axis is `t_max + j·t_delta`
/// summed by `j` roundings, each at most half an ulp of a value below `length + t_delta`;
/// the tolerance is `(j + 4)` times that size times `f64::EPSILON`, several times the bound.
/// Branch-free and without division, so that the set-ups' loop vectorises.
#[inline(always)]
pub(crate) fn stop_is_told(
    t_max: [f64; 3],
    t_delta: [f64; 3],
    length: f64,
    keys: [u32; 3],
) -> bool {
    let mut told = length.is_finite() & (length > 0.0);
    for a in 0..3 {
        let (t, d) = (t_max[a], t_delta[a]);
        // crossings 0 ..= j at or before the length, crossing j + 1 beyond it; an axis the
        // end key does not move along needs its first crossing beyond (axes that never move
        // have `f64::MAX` there)
        let j = f64::from(keys[a]) - 1.0;
        let tol = (j + 4.0) * (t.abs() + length + d) * f64::EPSILON;
        let below = length - (t + j * d);
        let above = (t + (j + 1.0) * d) - length;
        let crosses = (below > tol) & (above > tol);
        let moves = keys[a] > 0;
        told &= !t.is_nan() & (d > 0.0) & ((moves & crosses) | (!moves & (t > length)));
    }
    told
}

/// The first step at which a walk from the origin key to the end key, `keys[a]` apart on axis
/// `a`, may stop: the Manhattan distance when [`stop_is_told`], else [`untold_watch`]. Until
/// then a SIMD lane needs no end checks for it; with most LiDAR walks told, a lane is checked
/// only on the step it stops at, not on the four before, which most steps of short rays fell
/// in.
#[inline(always)]
pub(crate) fn first_watch(t_max: [f64; 3], t_delta: [f64; 3], length: f64, keys: [u32; 3]) -> u64 {
    let manhattan = u64::from(keys[0]) + u64::from(keys[1]) + u64::from(keys[2]);
    if stop_is_told(t_max, t_delta, length, keys) {
        manhattan
    } else {
        untold_watch(manhattan)
    }
}

/// The first step at which any walk whose end key is `manhattan` keys (Manhattan distance)
/// from its origin key may stop, told nothing else: four steps before that distance.
///
/// A walk's key moves by one on one axis per step, so it reaches its end voxel no earlier than
/// the Manhattan distance. Its smallest `tMax` (where it leaves the current voxel) passes the
/// length only when the end point is within float error of that voxel; four steps or more
/// before that distance the voxel is at least two voxels from the end voxel on some axis, so
/// the ray still has a voxel's width of length ahead (the `f32` direction and length err by
/// at most 2 % of a voxel, at the map's edge). A ray along the diagonal through voxel corners
/// does stop three steps early; one step of margin is kept. Tested in `dda_tests` (every
/// walk) and `lanes` (the diagonals).
#[inline(always)]
pub(crate) fn untold_watch(manhattan: u64) -> u64 {
    manhattan.saturating_sub(4)
}

/// Visit the keys of the voxels the segment `origin -> end` crosses, exactly as OctoMap's
/// `computeRayKeys` lists them: the origin voxel first, the end voxel excluded.
///
/// `visit` returns `true` to continue and `false` to stop the walk. Nothing is visited when an
/// end lies outside the map ([`RayWalk::OutsideMap`]) or both ends share a voxel
/// ([`RayWalk::SameVoxel`]). Consecutive keys differ by one on exactly one axis. Never
/// panics and always terminates: rays whose float arithmetic degenerates (OctoMap would loop
/// until its assertion aborts) end with [`RayWalk::Degenerate`] after at most the Manhattan
/// key distance plus 16 visits.
///
/// An `f32` path only: coordinates as OctoMap's `point3d` (the `f64` door is
/// [`crate::compute_ray_keys`]).
#[inline]
pub fn walk_ray_keys_f32<F>(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    mut visit: F,
) -> RayWalk
where
    F: FnMut(Key) -> bool,
{
    let mut r = match setup(conv, origin, end) {
        Ok(r) => r,
        Err(w) => return w,
    };
    if !visit(r.key_origin) {
        return RayWalk::Stopped;
    }
    // the key packed as x | y << 16 | z << 32, stepped one 16-bit lane at a time with that
    // lane's wrap-around (OctoMap's `unsigned short` arithmetic): one register, where a key
    // array indexed by the axis went through memory at every step
    let pack = |k: Key| u64::from(k[0]) | u64::from(k[1]) << 16 | u64::from(k[2]) << 32;
    let lane = [0xffffu64, 0xffff << 16, 0xffff << 32];
    let add = [0, 1, 2].map(|a| u64::from(r.step[a] as u16) << (16 * a));
    let end = pack(r.key_end);
    let mut current = pack(r.key_origin);
    // tMax per axis in registers, each advanced by a selection (the axis is data)
    let [mut t0, mut t1, mut t2] = r.t_max;
    let [d0, d1, d2] = r.t_delta;
    loop {
        if r.budget == 0 {
            return RayWalk::Degenerate;
        }
        r.budget -= 1;
        let dim = min_axis_select(&[t0, t1, t2]);
        current = (current & !lane[dim]) | (current.wrapping_add(add[dim]) & lane[dim]);
        t0 = if dim == 0 { t0 + d0 } else { t0 };
        t1 = if dim == 1 { t1 + d1 } else { t1 };
        t2 = if dim == 2 { t2 + d2 } else { t2 };
        if current == end {
            return RayWalk::Complete;
        }
        // the border of the current voxel lies beyond the end point: rounding made the walk
        // miss the end voxel, so stop here (without this key)
        if cmin(cmin(t0, t1), t2) > r.length {
            return RayWalk::Complete;
        }
        if !visit(Key::new(
            current as u16,
            (current >> 16) as u16,
            (current >> 32) as u16,
        )) {
            return RayWalk::Stopped;
        }
    }
}

/// Bits of one axis in a [`Key::morton`] code.
pub(crate) const AXIS_MASK: [u64; 3] = [
    0x2492_4924_9249,
    0x2492_4924_9249 << 1,
    0x2492_4924_9249 << 2,
];

/// The Morton bits of the axes marked `down`: a code XOR-ed with it is mirrored on those
/// axes, so that walking them downwards becomes stepping up.
#[inline]
pub(crate) fn mirror_mask(down: [bool; 3]) -> u64 {
    (0..3)
        .filter(|&a| down[a])
        .map(|a| AXIS_MASK[a])
        .fold(0, |m, b| m | b)
}

/// [`walk_ray_keys_f32`] that hands out the keys' [`Key::morton`] codes instead of keys: the
/// same voxels in the same order, but the walk steps the code directly (dilated integer
/// arithmetic), which is what set-building callers want. Never stops early.
///
/// An `f32` path only: coordinates as OctoMap's `point3d` (the `f64` door is
/// [`crate::compute_ray_keys`]).
#[inline]
pub fn walk_ray_codes_f32<F>(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    mut visit: F,
) -> RayWalk
where
    F: FnMut(u64),
{
    let r = match setup(conv, origin, end) {
        Ok(r) => r,
        Err(w) => return w,
    };
    let mut code = r.code_origin;
    let end_code = r.code_end;
    visit(code);
    // The state lives in scalars (not arrays indexed by the axis) so it stays in registers;
    // the comparisons are OctoMap's, in the same order.
    let [mut t0, mut t1, mut t2] = r.t_max;
    let [d0, d1, d2] = r.t_delta;
    let len = r.length;
    let mut budget = r.budget;
    let s0 = AxisStep::new(0, r.step[0] > 0);
    let s1 = AxisStep::new(1, r.step[1] > 0);
    let s2 = AxisStep::new(2, r.step[2] > 0);
    loop {
        if budget == 0 {
            return RayWalk::Degenerate;
        }
        budget -= 1;
        if t0 < t1 {
            if t0 < t2 {
                code = s0.apply(code);
                t0 += d0;
            } else {
                code = s2.apply(code);
                t2 += d2;
            }
        } else if t1 < t2 {
            code = s1.apply(code);
            t1 += d1;
        } else {
            code = s2.apply(code);
            t2 += d2;
        }
        if code == end_code {
            return RayWalk::Complete;
        }
        if cmin(cmin(t0, t1), t2) > len {
            return RayWalk::Complete;
        }
        visit(code);
    }
}

/// One step along one axis of a [`Key::morton`] code, without a branch on the direction:
/// up is `((code | !m) + low) & m`, down is `((code & m) - low) & m` (dilated arithmetic on
/// the axis's bits `m`), written as `(((code & keep) | fill) + add) & m`.
#[derive(Clone, Copy)]
pub(crate) struct AxisStep {
    keep: u64,
    fill: u64,
    add: u64,
    mask: u64,
}

impl AxisStep {
    /// The step by +1 (`up`) or -1 on `axis` (0, 1 or 2).
    #[inline(always)]
    pub(crate) fn new(axis: usize, up: bool) -> Self {
        let mask = AXIS_MASK[axis];
        let low = 1u64 << axis;
        if up {
            AxisStep {
                keep: u64::MAX,
                fill: !mask,
                add: low,
                mask,
            }
        } else {
            AxisStep {
                keep: mask,
                fill: 0,
                add: low.wrapping_neg(),
                mask,
            }
        }
    }

    /// The code of the neighbouring voxel.
    #[inline(always)]
    pub(crate) fn apply(self, code: u64) -> u64 {
        ((((code & self.keep) | self.fill).wrapping_add(self.add)) & self.mask)
            | (code & !self.mask)
    }
}

/// OctoMap's `computeRayKeys(origin, end, ray)`: fill `ray` with the keys of the voxels the
/// segment crosses, origin voxel first, end voxel excluded.
///
/// Returns `false` with an empty ray when an end lies outside the map (or is not finite), and
/// `true` with an empty ray when both ends share a voxel.
///
/// Capacity: OctoMap's `KeyRay` holds 100 000 keys and its assertion aborts the program on a
/// ray of 99 999 keys or more (possible only for rays thousands of metres long). Here the
/// buffer grows instead, so such rays return all their keys (at most 3·65 535 inside the map),
/// continuing exactly the walk OctoMap would have made. Rays whose float arithmetic
/// degenerates ([`RayWalk::Degenerate`], where OctoMap never terminates) return `false` with an
/// empty ray.
///
/// The `f32` fast path: coordinates as OctoMap's `point3d`; [`crate::compute_ray_keys`] takes
/// `f64`.
pub fn compute_ray_keys_f32(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    ray: &mut KeyRay,
) -> bool {
    ray.keys.clear();
    let keys = &mut ray.keys;
    match walk_ray_keys_f32(conv, origin, end, |k| {
        keys.push(k);
        true
    }) {
        RayWalk::Complete | RayWalk::SameVoxel => true,
        RayWalk::OutsideMap | RayWalk::Stopped | RayWalk::Degenerate => {
            ray.keys.clear();
            false
        }
    }
}

#[cfg(test)]
#[path = "dda_tests.rs"]
mod tests;
