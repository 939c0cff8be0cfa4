//! The checked keys and Morton codes of a block of end points at once.
//!
//! A scan's per-point work before its ray is queued starts with the point's key, OctoMap's
//! `coordToKeyChecked(point3d)`: per axis a widening to `f64`, a scaling, a floor, a range
//! check and the key centre, then the key's Morton code. One point at a time that was about
//! half of [`crate::update`]'s per-point loop on depth images and short-range LiDAR (a sixth
//! of an `exact` TUM or Ouster frame); here [`CHUNK`] points go through a loop of fixed length
//! without branches, which the compiler turns into vector code (built for AVX-512 or AVX2
//! where the CPU has them, as [`crate::setups`] is).
//!
//! The keys are OctoMap's, bit for bit: with `v = factor · (c as f64)`, the key exists exactly
//! when `-32768 <= v < 32768` (NaN fails), and it is `floor(v) + 32768` (the floor exact in
//! that range), as [`KeyConverter`]'s scalar conversion computes it.

use nalgebra::Point3;
use octoquant_octree::{Key, KeyConverter};

/// Points per block.
pub(crate) const CHUNK: usize = 64;

/// The keys of a block of up to [`CHUNK`] points: which are finite, which lie in the map, and
/// their keys and Morton codes.
#[derive(Debug, Clone)]
pub(crate) struct ChunkKeys {
    /// Per axis, each point's key coordinate (meaningless where the point is not in the map).
    keys: [[u16; CHUNK]; 3],
    /// Each point's [`Key::morton`] code (likewise).
    codes: [u64; CHUNK],
    /// Whether every coordinate of point `j` is finite.
    finite: [bool; CHUNK],
    /// Whether point `j` has a key (it is finite and inside the map).
    inside: [bool; CHUNK],
}

impl Default for ChunkKeys {
    fn default() -> Self {
        ChunkKeys {
            keys: [[0; CHUNK]; 3],
            codes: [0; CHUNK],
            finite: [false; CHUNK],
            inside: [false; CHUNK],
        }
    }
}

impl ChunkKeys {
    /// The keys of `points` (at most [`CHUNK`]; the rest are ignored) under `conv`.
    pub(crate) fn fill(&mut self, conv: &KeyConverter, points: &[Point3<f32>]) {
        // the coordinates by axis, padded with zeros (whose keys are never read)
        let mut coords = [[0f32; CHUNK]; 3];
        for (j, p) in points.iter().take(CHUNK).enumerate() {
            for (a, c) in coords.iter_mut().enumerate() {
                c[j] = p[a];
            }
        }
        let factor = conv.resolution_factor();
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx512() {
            // SAFETY: `fill_avx512` needs AVX-512 Foundation, found just above; it is the
            // safe `fill_lanes` compiled for it.
            #[allow(unsafe_code)]
            unsafe {
                fill_avx512(self, factor, &coords)
            };
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::has_avx2() {
            // SAFETY: `fill_avx2` needs AVX2, found just above; it is the safe `fill_lanes`
            // compiled for it.
            #[allow(unsafe_code)]
            unsafe {
                fill_avx2(self, factor, &coords)
            };
            return;
        }
        fill_lanes(self, factor, &coords);
    }

    /// Whether every coordinate of point `j` is finite.
    #[inline(always)]
    pub(crate) fn finite(&self, j: usize) -> bool {
        self.finite[j % CHUNK]
    }

    /// Point `j`'s key and Morton code (`key_of` and `coded`), `None` outside the map or for a
    /// non-finite point.
    #[inline(always)]
    pub(crate) fn hit(&self, j: usize) -> Option<(Key, u64)> {
        let j = j % CHUNK;
        self.inside[j].then(|| {
            let k = Key([self.keys[0][j], self.keys[1][j], self.keys[2][j]]);
            (k, self.codes[j])
        })
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn fill_avx512(out: &mut ChunkKeys, factor: f64, coords: &[[f32; CHUNK]; 3]) {
    fill_lanes(out, factor, coords);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn fill_avx2(out: &mut ChunkKeys, factor: f64, coords: &[[f32; CHUNK]; 3]) {
    fill_lanes(out, factor, coords);
}

/// [`ChunkKeys::fill`] for every lane (the padding too: a fixed length and no branches, so it
/// vectorises).
#[inline(always)]
fn fill_lanes(out: &mut ChunkKeys, factor: f64, coords: &[[f32; CHUNK]; 3]) {
    let mut finite = [true; CHUNK];
    let mut inside = [true; CHUNK];
    let mut codes = [0u64; CHUNK];
    for (a, axis) in coords.iter().enumerate() {
        for j in 0..CHUNK {
            let c = axis[j];
            finite[j] &= c.is_finite();
            let v = factor * c as f64;
            let ok = (-32768.0..32768.0).contains(&v);
            inside[j] &= ok;
            // in range, adding and taking off 1.5·2^52 rounds to an integer, exactly, and
            // the correction makes that the floor; the key's bits are then read off the
            // mantissa of the sum (no float-to-integer conversion, which would not vectorise
            // with Rust's saturating `as`)
            let vc = if ok { v } else { 0.0 };
            let r = (vc + ROUNDER) - ROUNDER;
            let floor = r - if r > vc { 1.0 } else { 0.0 };
            let key = ((floor + 32768.0) + ROUNDER).to_bits() as u16;
            out.keys[a][j] = key;
            codes[j] |= spread(key) << a;
        }
    }
    out.codes = codes;
    out.finite = finite;
    out.inside = inside;
}

/// 1.5·2^52: an `f64` below 2^51 in magnitude plus this lies where the spacing of doubles is 1,
/// so the sum is the value rounded to an integer, and its low mantissa bits are that integer.
const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// Bit `i` of a 16-bit value moved to bit `3i` (as [`Key::morton`]'s table does).
#[inline(always)]
fn spread(v: u16) -> u64 {
    let mut x = u64::from(v);
    x = (x | x << 16) & 0x0000_ff00_00ff;
    x = (x | x << 8) & 0x00f0_0f00_f00f;
    x = (x | x << 4) & 0x0c30_c30c_30c3;
    x = (x | x << 2) & 0x2492_4924_9249;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dda::key_of;
    use proptest::prelude::*;

    /// Coordinates that test the key's edges: voxel borders, the map's border, and the
    /// non-finite values, besides ordinary ones.
    fn coordinate(res: f64) -> impl Strategy<Value = f32> {
        let edge = 32768.0 * res;
        prop_oneof![
            4 => -50.0f32..50.0,
            2 => (-300i32..300).prop_map(move |k| (k as f64 * res) as f32),
            2 => (-3i32..3).prop_map(move |d| (edge as f32) + d as f32 * f32::EPSILON * edge as f32),
            2 => (-3i32..3).prop_map(move |d| -(edge as f32) + d as f32 * f32::EPSILON * edge as f32),
            1 => prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)],
            1 => any::<f32>(),
        ]
    }

    fn check(conv: &KeyConverter, points: &[Point3<f32>], ck: &ChunkKeys) {
        for (j, p) in points.iter().enumerate() {
            let finite = p.x.is_finite() && p.y.is_finite() && p.z.is_finite();
            assert_eq!(ck.finite(j), finite, "point {j}: {p:?}");
            let naive = key_of(conv, p).map(|k| (k, k.morton()));
            if finite {
                assert_eq!(ck.hit(j), naive, "point {j}: {p:?}");
            }
        }
    }

    fn case() -> impl Strategy<Value = (f64, Vec<Point3<f32>>)> {
        let res = prop_oneof![
            Just(0.1),
            Just(0.05),
            Just(0.123456789),
            Just(1e-5),
            Just(3.0)
        ];
        res.prop_flat_map(|res| {
            let c = move || coordinate(res);
            let point = (c(), c(), c()).prop_map(|(x, y, z)| Point3::new(x, y, z));
            (Just(res), prop::collection::vec(point, 0..=CHUNK))
        })
    }

    proptest! {
        /// Every lane path gives the scalar `key_of` and `Key::morton` (and finiteness).
        #[test]
        fn chunk_keys_match_the_scalar_keys((res, points) in case()) {
            let conv = KeyConverter::new(res).unwrap();
            let mut ck = ChunkKeys::default();
            ck.fill(&conv, &points);
            check(&conv, &points, &ck);
            // the portable loop, whatever the CPU
            let mut coords = [[0f32; CHUNK]; 3];
            for (j, p) in points.iter().enumerate() {
                for (a, c) in coords.iter_mut().enumerate() {
                    c[j] = p[a];
                }
            }
            let mut plain = ChunkKeys::default();
            fill_lanes(&mut plain, conv.resolution_factor(), &coords);
            check(&conv, &points, &plain);
        }
    }

    #[test]
    fn spread_matches_the_morton_table() {
        for v in [
            0u16, 1, 2, 3, 0x00ff, 0xff00, 0x8000, 0xffff, 0x5555, 0xaaaa, 12345,
        ] {
            assert_eq!(spread(v), Key([v, 0, 0]).morton());
            assert_eq!(spread(v) << 1, Key([0, v, 0]).morton());
            assert_eq!(spread(v) << 2, Key([0, 0, v]).morton());
        }
    }
}
