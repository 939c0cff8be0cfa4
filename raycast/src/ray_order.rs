//! The keys of many rays from one origin, handed on ray by ray in the rays' order: for callers
//! whose result depends on the order in which keys come, as octomap_server's colour scan does
//! (it fills a `KeySet` ray by ray, and that set's iteration order follows the first
//! insertions).
//!
//! The rays are walked many at once in the SIMD lanes, as a scan's free set is. Each ray's
//! Morton codes carry its place in the batch in their bits above the 48th: the lanes' steps
//! change only an axis's bits and their end test compares whole codes, so the mark rides
//! along, and the bricks the lanes leave, in whatever order they come, are put back ray by ray
//! by a stable counting sort on it (a lane leaves a ray's bricks in walk order). A ray's
//! voxels in one brick are those of consecutive steps, and every step moves one axis by one in
//! the ray's direction, so their walk order is that of `Σ step[a]·key[a]`: the bricks and the
//! ray's step signs give the keys in OctoMap's order. Rays the lanes do not take (not
//! well-conditioned) are walked one at a time and handed on as keys.

use crate::brickset::BrickSink;
use crate::dda::{key_of, setup_from, walk_ray_keys_f32, RaySetup, RayWalk};
use crate::lanes::{walk_all, LaneScratch};
use nalgebra::Point3;
use octoquant_octree::{Brick, Key, KeyConverter};

/// One ray's keys, as OctoMap's `computeRayKeys` lists them: the origin's voxel first, the end
/// point's voxel left out.
#[derive(Debug, Clone, Copy)]
pub enum RayKeys<'a> {
    /// The bricks the walk entered, in walk order, each with the ray's voxels in it; inside a
    /// brick the voxels come in increasing order of `Σ step[a]·key[a]`.
    Bricks {
        /// The bricks (codes below 2⁴²).
        bricks: &'a [Brick],
        /// The walk's direction on each axis: -1, 0 or 1.
        step: [i32; 3],
    },
    /// The keys in walk order.
    Keys(&'a [Key]),
}

/// The buffers of [`walk_rays_in_order_f32`], kept from call to call.
#[derive(Debug, Default)]
pub struct RayOrderScratch {
    /// Per ray of the batch: what it is.
    rays: Vec<Ray>,
    /// The set-ups of the batch's well-conditioned rays, their codes marked.
    lanes_rays: Vec<RaySetup>,
    lanes: LaneScratch,
    /// The bricks the lanes left, marked, in the order they came.
    left: Vec<Brick>,
    /// The same bricks ray by ray: lane ray `n` (mark `n + 1`) holds
    /// `sorted[starts[n]..starts[n + 1]]`.
    sorted: Vec<Brick>,
    starts: Vec<usize>,
    /// The keys of a ray walked alone.
    keys: Vec<Key>,
}

/// What one ray of a batch is.
#[derive(Debug, Clone, Copy)]
enum Ray {
    /// Walked in the lanes, as the `n`-th of them (its mark is `n + 1`), with these steps.
    Lanes(usize, [i32; 3]),
    /// Walked alone (not well-conditioned).
    Alone,
    /// Both ends in one voxel: no keys.
    Empty,
    /// No keys could be computed.
    Failed(RayWalk),
}

/// Rays per batch: their marks (1 to `BATCH`) must fit the 16 bits above a Morton code's 48.
const BATCH: usize = 256;
/// Where a ray's mark sits in its codes (and, shifted by 6, in its bricks').
const MARK_SHIFT: u32 = 48;

/// Collects the lanes' bricks as they come.
struct Collect<'a>(&'a mut Vec<Brick>);

impl BrickSink for Collect<'_> {
    #[inline]
    fn put(&mut self, brick: Brick) {
        self.0.push(brick);
    }

    #[inline]
    fn put_all(&mut self, bricks: &[u64], bits: &[u64]) {
        self.0.extend(
            bricks
                .iter()
                .zip(bits)
                .map(|(&code, &voxels)| Brick { code, voxels }),
        );
    }
}

/// Walk the rays `origin -> ends[i]` (OctoMap's `computeRayKeys`, in `f32` as
/// [`walk_ray_keys_f32`]) and call `each(i, keys)` for every ray in order: `Ok` with its keys
/// when they could be computed (none when both ends share a voxel), `Err` with the walk's
/// outcome when not (an end outside the map, a degenerate walk), exactly as
/// [`walk_ray_keys_f32`] would have it.
pub fn walk_rays_in_order_f32<F>(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    ends: &[Point3<f32>],
    scratch: &mut RayOrderScratch,
    mut each: F,
) where
    F: FnMut(usize, Result<RayKeys<'_>, RayWalk>),
{
    let origin_key = key_of(conv, origin);
    for (b, batch) in ends.chunks(BATCH).enumerate() {
        walk_batch(conv, origin, origin_key, batch, scratch);
        let RayOrderScratch {
            rays,
            sorted,
            starts,
            keys,
            ..
        } = &mut *scratch;
        for (i, (ray, end)) in rays.iter().zip(batch).enumerate() {
            let at = b * BATCH + i;
            match *ray {
                Ray::Lanes(n, step) => {
                    let bricks = &sorted[starts[n]..starts[n + 1]];
                    each(at, Ok(RayKeys::Bricks { bricks, step }));
                }
                Ray::Alone => {
                    keys.clear();
                    let walk = walk_ray_keys_f32(conv, origin, end, |k| {
                        keys.push(k);
                        true
                    });
                    match walk {
                        RayWalk::Complete | RayWalk::SameVoxel => each(at, Ok(RayKeys::Keys(keys))),
                        w => each(at, Err(w)),
                    }
                }
                Ray::Empty => each(at, Ok(RayKeys::Keys(&[]))),
                Ray::Failed(w) => each(at, Err(w)),
            }
        }
    }
}

/// Set up the rays of `batch`, walk the well-conditioned ones in the lanes and sort their
/// bricks ray by ray into `scratch`.
fn walk_batch(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    origin_key: Option<Key>,
    batch: &[Point3<f32>],
    scratch: &mut RayOrderScratch,
) {
    scratch.rays.clear();
    scratch.lanes_rays.clear();
    for end in batch {
        let ray = match setup_from(conv, origin, origin_key, end) {
            Ok(mut r) if r.well_conditioned => {
                let n = scratch.lanes_rays.len();
                let mark = (n as u64 + 1) << MARK_SHIFT;
                r.code_origin |= mark;
                r.code_end |= mark;
                let step = r.step;
                scratch.lanes_rays.push(r);
                Ray::Lanes(n, step)
            }
            Ok(_) => Ray::Alone,
            Err(RayWalk::SameVoxel) => Ray::Empty,
            Err(w) => Ray::Failed(w),
        };
        scratch.rays.push(ray);
    }
    scratch.left.clear();
    let degenerate = walk_all(
        &scratch.lanes_rays,
        &mut scratch.lanes,
        &mut Collect(&mut scratch.left),
    );
    if degenerate > 0 {
        // cannot happen (see `RaySetup::well_conditioned`); were it to, each ray is walked
        // alone, which decides its outcome as OctoMap does
        for r in &mut scratch.rays {
            if let Ray::Lanes(..) = r {
                *r = Ray::Alone;
            }
        }
        return;
    }
    // a stable counting sort of the bricks by mark; mark 0 is the idle lanes' (dropped)
    let n = scratch.lanes_rays.len();
    let starts = &mut scratch.starts;
    starts.clear();
    starts.resize(n + 2, 0);
    let mark_of = |b: &Brick| (b.code >> (MARK_SHIFT - 6)) as usize;
    for b in &scratch.left {
        if let Some(c) = starts.get_mut(mark_of(b) + 1) {
            *c += 1;
        }
    }
    // starts[m]: where mark m's bricks begin (marks 1..=n hold rays 0..n)
    for m in 1..starts.len() {
        starts[m] += starts[m - 1];
    }
    scratch.sorted.clear();
    scratch.sorted.resize(starts[n + 1], Brick::default());
    let mut next = starts.clone();
    for b in &scratch.left {
        let m = mark_of(b);
        if let Some(at) = next.get_mut(m) {
            if let Some(slot) = scratch.sorted.get_mut(*at) {
                *slot = Brick {
                    code: b.code & ((1 << (MARK_SHIFT - 6)) - 1),
                    voxels: b.voxels,
                };
            }
            *at += 1;
        }
    }
    // ray `r` (mark r + 1) spans starts[r + 1]..starts[r + 2]: drop the idle lanes' span
    starts.remove(0);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The keys of `keys` in OctoMap's order: [`RayKeys::Bricks`] expanded brick by brick,
    /// each brick's voxels sorted by `Σ step[a]·key[a]` as its docs say.
    fn expand(keys: RayKeys<'_>) -> Vec<Key> {
        match keys {
            RayKeys::Keys(ks) => ks.to_vec(),
            RayKeys::Bricks { bricks, step } => {
                let mut out = Vec::new();
                for b in bricks {
                    assert!(b.code < 1 << 42, "a mark left in {:#x}", b.code);
                    let mut voxels: Vec<Key> = (0..64)
                        .filter(|i| b.voxels >> i & 1 == 1)
                        .map(|i| Key::from_morton(b.code << 6 | i))
                        .collect();
                    voxels.sort_by_key(|k| (0..3).map(|a| step[a] * i32::from(k[a])).sum::<i32>());
                    out.extend(voxels);
                }
                out
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Every ray is handed on once, in order, with the keys and outcome of
        /// [`walk_ray_keys_f32`]: across batches, with ends in the origin's voxel, outside the
        /// map and not finite.
        #[test]
        fn each_ray_gets_the_reference_walks_keys_in_order(
            o in prop::array::uniform3(-2.0f32..2.0),
            ends in prop::collection::vec(
                prop_oneof![
                    8 => prop::array::uniform3(-9.0f32..9.0),
                    1 => prop::array::uniform3(-0.04f32..0.04),
                    1 => prop::sample::select(vec![
                        [f32::NAN, 0.0, 1.0],
                        [f32::INFINITY, 2.0, 0.0],
                        [1.0e6, 0.5, 0.5],
                    ]),
                ],
                0..700,
            ),
            res in prop::sample::select(vec![0.05, 0.1, 0.3]),
        ) {
            let conv = KeyConverter::new(res).unwrap();
            let o = Point3::from(o);
            let ends: Vec<Point3<f32>> = ends.into_iter().map(Point3::from).collect();
            let mut scratch = RayOrderScratch::default();
            let mut seen = 0;
            walk_rays_in_order_f32(&conv, &o, &ends, &mut scratch, |i, got| {
                assert_eq!(i, seen, "rays out of order");
                seen += 1;
                let mut want = Vec::new();
                let walk = walk_ray_keys_f32(&conv, &o, &ends[i], |k| {
                    want.push(k);
                    true
                });
                match got {
                    Ok(keys) => {
                        assert!(matches!(walk, RayWalk::Complete | RayWalk::SameVoxel), "ray {i}: {walk:?}");
                        assert_eq!(expand(keys), want, "ray {i}");
                    }
                    Err(w) => assert_eq!(w, walk, "ray {i}"),
                }
            });
            prop_assert_eq!(seen, ends.len());
        }
    }
}
