//! Dense voxel-key quantization of a frame's end points, before the octree update
//! (Kwon & Yoon, "Point-Cloud Data Quantization for OctoMap Update in Real-Time").
//!
//! Per frame: the key bounding box of the end points, a dense bit grid over it, one bit set per
//! end-point voxel, then each set voxel's centre emitted once. Casting rays to those centres
//! gives exactly OctoMap's `insertPointCloud(.., discretize = true)`: OctoMap also reduces the
//! cloud to one centre per end-point key (with its unchecked, wrapping key) and the tree does
//! not depend on the order of the rays within a frame.
//!
//! The grid is used when it is small enough: at most [`QuantizeOptions::max_grid_bits`] bits and
//! at most [`QuantizeOptions::bits_per_point`] bits per point (a sparse far-reaching LiDAR frame
//! would spend more time clearing and scanning a huge grid than sorting its keys). Otherwise the
//! same set is computed by sorting the keys' Morton codes; both paths give the same centres in
//! the same order (z-major, then y, then x). Marking runs on all rayon threads for large frames.

use bitvec::prelude::*;
use nalgebra::Point3;
use octoquant_octree::{Key, KeyConverter};
use rayon::prelude::*;
use std::sync::atomic::AtomicU64;

/// Limits that decide between the dense bit grid and the sorted-keys fallback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QuantizeOptions {
    /// Largest grid, in bits, ever allocated (default 2^30 bits = 128 MiB).
    pub max_grid_bits: u64,
    /// Largest grid per end point, in bits (default 4096): beyond it the box is mostly empty
    /// and sorting is cheaper.
    pub bits_per_point: u64,
    /// Frames with at least this many points mark and emit in parallel (default 32 768).
    pub parallel_threshold: usize,
}

impl Default for QuantizeOptions {
    fn default() -> Self {
        QuantizeOptions {
            max_grid_bits: 1 << 30,
            bits_per_point: 4096,
            parallel_threshold: 1 << 15,
        }
    }
}

/// What [`quantize_endpoints`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct QuantizeStats {
    /// Points given.
    pub points: usize,
    /// Points with a NaN or infinite coordinate, skipped.
    pub non_finite: usize,
    /// Distinct end-point voxels, i.e. centres emitted.
    pub voxels: usize,
    /// Bits in the dense grid, or 0 when the sorted fallback ran.
    pub grid_bits: u64,
}

/// The end points of one frame reduced to one voxel centre per end-point key.
///
/// Keys are OctoMap's unchecked `coordToKey` (points outside the map wrap into it, as with
/// OctoMap's `discretize`); centres are `keyToCoord` as `f32`. Non-finite points are skipped
/// and counted (OctoMap's result for them is undefined). `out` is cleared first.
pub fn quantize_endpoints(
    conv: &KeyConverter,
    points: &[Point3<f32>],
    options: &QuantizeOptions,
    out: &mut Vec<Point3<f32>>,
) -> QuantizeStats {
    out.clear();
    let mut stats = QuantizeStats {
        points: points.len(),
        ..QuantizeStats::default()
    };
    // one pass converts every point to its key, packed as `zyx_code` (NO_KEY when not
    // finite), and gathers the key box; marking then reads the packed keys
    let par = points.len() >= options.parallel_threshold;
    let mut codes = vec![0u64; points.len()];
    let b = if par {
        points
            .par_chunks(CHUNK)
            .zip(codes.par_chunks_mut(CHUNK))
            .map(|(pts, out)| KeyBounds::pack(conv, pts, out))
            .reduce(|| KeyBounds::EMPTY, KeyBounds::union)
    } else {
        KeyBounds::pack(conv, points, &mut codes)
    };
    let (lo, hi) = (b.lo, b.hi);
    stats.non_finite = b.non_finite;
    let valid = points.len() - stats.non_finite;
    if valid == 0 {
        return stats;
    }
    let dims = [0, 1, 2].map(|a| (hi[a] - lo[a]) as u64 + 1);
    let bits = dims[0] * dims[1] * dims[2];
    let centre = |k: Key| conv.key_to_point_f32(&k);
    if bits <= options.max_grid_bits && bits <= options.bits_per_point.saturating_mul(valid as u64)
    {
        stats.grid_bits = bits;
        // the grid index of a packed key: x fastest, then y, then z, like `zyx_code`
        let (row, plane) = (dims[0] as usize, (dims[0] * dims[1]) as usize);
        let base = (lo[2] as usize * dims[1] as usize + lo[1] as usize) * row + lo[0] as usize;
        let index = |c: u64| -> usize {
            let (x, y, z) = (
                c as u16 as usize,
                (c >> 16) as u16 as usize,
                (c >> 32) as usize,
            );
            // wrapping: `base` folds the box's corner into one subtraction
            (z * plane + y * row + x).wrapping_sub(base)
        };
        let key_at = |i: usize| -> Key {
            let i = i as u64;
            let x = i % dims[0];
            let y = (i / dims[0]) % dims[1];
            let z = i / (dims[0] * dims[1]);
            Key::new(lo[0] + x as u16, lo[1] + y as u16, lo[2] + z as u16)
        };
        if par {
            let grid: BitVec<AtomicU64, Lsb0> = BitVec::repeat(false, bits as usize);
            let words = grid.as_raw_slice();
            codes.par_chunks(CHUNK).for_each(|chunk| {
                for &c in chunk {
                    if c != NO_KEY {
                        // most end points share a voxel with an earlier one: a plain load
                        // finds the bit set and skips the locked read-modify-write
                        let i = index(c);
                        let (w, bit) = (&words[i / 64], 1u64 << (i % 64));
                        if w.load(std::sync::atomic::Ordering::Relaxed) & bit == 0 {
                            w.fetch_or(bit, std::sync::atomic::Ordering::Relaxed);
                        }
                    }
                }
            });
            // emit in index order: each thread scans whole words of its own range
            let per = words
                .len()
                .div_ceil(rayon::current_num_threads().max(1) * 4)
                .max(1);
            let parts: Vec<Vec<Point3<f32>>> = words
                .par_chunks(per)
                .enumerate()
                .map(|(ci, ws)| {
                    let mut v = Vec::new();
                    for (wi, w) in ws.iter().enumerate() {
                        let mut word = w.load(std::sync::atomic::Ordering::Relaxed);
                        while word != 0 {
                            let b = word.trailing_zeros() as usize;
                            word &= word - 1;
                            v.push(centre(key_at((ci * per + wi) * 64 + b)));
                        }
                    }
                    v
                })
                .collect();
            for p in parts {
                out.extend(p);
            }
        } else {
            let mut grid: BitVec<u64, Lsb0> = BitVec::repeat(false, bits as usize);
            let words = grid.as_raw_mut_slice();
            for &c in &codes {
                if c != NO_KEY {
                    let i = index(c);
                    words[i / 64] |= 1u64 << (i % 64);
                }
            }
            out.extend(grid.iter_ones().map(|i| centre(key_at(i))));
        }
    } else {
        // sparse fallback: sort the (z, y, x)-ordered codes so the order matches the grid's
        // (a radix sort: the codes share their high bits; a comparison sort of a LiDAR
        // frame's 41 000 codes took 2 % of its insertion)
        codes.retain(|&c| c != NO_KEY);
        let mut scratch = vec![0u64; codes.len()];
        octoquant_radix::sort_by_key(&mut codes, &mut scratch, |&c| c);
        codes.dedup();
        out.extend(codes.into_iter().map(|c| centre(zyx_key(c))));
    }
    stats.voxels = out.len();
    stats
}

/// Points per parallel share of the key pass and of the marking.
const CHUNK: usize = 8192;

/// The packed code of a point without a key (a non-finite coordinate); no `zyx_code` has
/// bits above 48.
const NO_KEY: u64 = u64::MAX;

/// Key bounding box of a share of the points, and how many of them were not finite.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KeyBounds {
    lo: [u16; 3],
    hi: [u16; 3],
    non_finite: usize,
}

impl KeyBounds {
    const EMPTY: KeyBounds = KeyBounds {
        lo: [u16::MAX; 3],
        hi: [0; 3],
        non_finite: 0,
    };

    /// Write each point's packed key (`zyx_code`, or [`NO_KEY`]) to `out` and return the
    /// share's key box and non-finite count: four points at a time where the CPU has AVX2.
    fn pack(conv: &KeyConverter, points: &[Point3<f32>], out: &mut [u64]) -> KeyBounds {
        #[cfg(target_arch = "x86_64")]
        if let Some(b) = avx2::pack(conv, points, out) {
            return b;
        }
        KeyBounds::pack_scalar(conv, points, out)
    }

    /// [`KeyBounds::pack`] one point after another.
    fn pack_scalar(conv: &KeyConverter, points: &[Point3<f32>], out: &mut [u64]) -> KeyBounds {
        let mut b = KeyBounds::EMPTY;
        for (p, o) in points.iter().zip(out.iter_mut()) {
            if p.x.is_finite() && p.y.is_finite() && p.z.is_finite() {
                let k = conv.point_to_key_unchecked(&p.cast::<f64>());
                b.add(k);
                *o = zyx_code(k);
            } else {
                b.non_finite += 1;
                *o = NO_KEY;
            }
        }
        b
    }

    #[inline]
    fn add(&mut self, k: Key) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(k[a]);
            self.hi[a] = self.hi[a].max(k[a]);
        }
    }

    fn union(a: KeyBounds, b: KeyBounds) -> KeyBounds {
        KeyBounds {
            lo: [0, 1, 2].map(|i| a.lo[i].min(b.lo[i])),
            hi: [0, 1, 2].map(|i| a.hi[i].max(b.hi[i])),
            non_finite: a.non_finite + b.non_finite,
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[path = "voxel_keys_avx2.rs"]
mod avx2;

#[inline]
fn zyx_code(k: Key) -> u64 {
    ((k[2] as u64) << 32) | ((k[1] as u64) << 16) | k[0] as u64
}

/// The key of a [`zyx_code`].
#[inline]
fn zyx_key(c: u64) -> Key {
    Key::new(c as u16, (c >> 16) as u16, (c >> 32) as u16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::BTreeSet;

    /// Coordinates that exercise the key pass: ordinary values, voxel borders, the edges of
    /// the map and of `i32`, and the non-finite values.
    fn coordinate() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -50.0f32..50.0,
            2 => (-2000i32..2000).prop_map(|i| i as f32 * 0.05),
            1 => prop::sample::select(vec![
                0.0, -0.0, 1638.4, -1638.4, 1638.35, -1638.45, 3276.8, -3276.8,
                1.0e9, -1.0e9, 1.1e8, -1.1e8, f32::MAX, f32::MIN, f32::MIN_POSITIVE,
                -f32::MIN_POSITIVE, f32::INFINITY, f32::NEG_INFINITY, f32::NAN,
            ]),
            1 => any::<f32>(),
        ]
    }

    proptest! {
        /// The key pass (four at a time where the CPU has AVX2) writes the scalar pass's codes
        /// and returns its box and count, for any length (the tail is scalar).
        #[test]
        fn key_pass_matches_the_scalar_pass(
            pts in prop::collection::vec(prop::array::uniform3(coordinate()), 0..70),
            res in prop::sample::select(vec![0.05, 0.1, 0.2, 1.0]),
        ) {
            let conv = KeyConverter::new(res).unwrap();
            let pts: Vec<Point3<f32>> = pts.into_iter().map(Point3::from).collect();
            let (mut a, mut b) = (vec![0; pts.len()], vec![1; pts.len()]);
            let got = KeyBounds::pack(&conv, &pts, &mut a);
            let want = KeyBounds::pack_scalar(&conv, &pts, &mut b);
            prop_assert_eq!(a, b);
            prop_assert_eq!(got, want);
        }
    }

    fn naive(conv: &KeyConverter, points: &[Point3<f32>]) -> Vec<Point3<f32>> {
        let keys: BTreeSet<u64> = points
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .map(|p| zyx_code(conv.point_to_key_unchecked(&p.cast())))
            .collect();
        keys.into_iter()
            .map(|c| conv.key_to_point_f32(&zyx_key(c)))
            .collect()
    }

    fn cloud(n: usize, spread: f32, seed: u64) -> Vec<Point3<f32>> {
        let mut s = seed | 1;
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 2.0 * spread
        };
        let mut v: Vec<_> = (0..n).map(|_| Point3::new(r(), r(), r() * 0.3)).collect();
        v.push(Point3::new(f32::NAN, 0.0, 0.0));
        v.push(Point3::new(1.0, f32::INFINITY, 0.0));
        v
    }

    #[test]
    fn dense_sparse_and_parallel_paths_agree_with_a_set() {
        let conv = KeyConverter::new(0.1).unwrap();
        for (n, spread, far) in [
            (10, 1.0, false),
            (5000, 3.0, false),
            (50_000, 8.0, false),
            (40_000, 400.0, false),
            (5000, 3.0, true),
            (50_000, 8.0, true),
        ] {
            let mut pts = cloud(n, spread, n as u64);
            if far {
                // outside the map (+-3276.8 m at 0.1 m): their unchecked keys wrap around
                pts.push(Point3::new(1.0, -5000.0, 0.5));
                pts.push(Point3::new(3276.8, 0.0, 0.0));
            }
            let want = naive(&conv, &pts);
            for opts in [
                QuantizeOptions::default(),
                QuantizeOptions {
                    bits_per_point: 0,
                    ..QuantizeOptions::default()
                },
                QuantizeOptions {
                    parallel_threshold: 0,
                    ..QuantizeOptions::default()
                },
                QuantizeOptions {
                    parallel_threshold: usize::MAX,
                    ..QuantizeOptions::default()
                },
            ] {
                let mut out = Vec::new();
                let st = quantize_endpoints(&conv, &pts, &opts, &mut out);
                assert_eq!(out, want, "n={n} spread={spread} far={far} {opts:?}");
                assert_eq!(st.non_finite, 2);
                assert_eq!(st.voxels, want.len());
            }
        }
    }

    #[test]
    fn empty_and_all_bad_frames() {
        let conv = KeyConverter::new(0.05).unwrap();
        let mut out = vec![Point3::origin()];
        let st = quantize_endpoints(&conv, &[], &QuantizeOptions::default(), &mut out);
        assert!(out.is_empty());
        assert_eq!(st.voxels, 0);
        let bad = [Point3::new(f32::NAN, 1.0, 1.0)];
        let st = quantize_endpoints(&conv, &bad, &QuantizeOptions::default(), &mut out);
        assert_eq!((st.non_finite, st.voxels), (1, 0));
    }
}
