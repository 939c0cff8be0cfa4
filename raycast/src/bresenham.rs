//! Integer 3D Bresenham rays between voxel keys: the opt-in fast ray model (`--ray bresenham`).
//!
//! The ray runs from the origin's voxel to the end point's voxel, the origin voxel included and
//! the end voxel excluded (as OctoMap's DDA), stepping the axis with the largest key distance
//! every time and the others when their error term says so. It visits `max(|dx|, |dy|, |dz|)`
//! voxels where the DDA visits every voxel the segment crosses (up to `|dx| + |dy| + |dz|`):
//! consecutive voxels may share only an edge or a corner, so thin diagonal strips next to the
//! DDA's path are not cleared, and voxels are chosen by the line between voxel *centres*, not
//! by the exact segment. Maps differ from OctoMap's only in those free voxels.

use crate::brickset::BrickSink;
use crate::dda::AxisStep;
use octoquant_octree::{Brick, Key};

/// The axis a line steps every time: the one with the largest key distance `ad`, ties to x,
/// then y.
#[inline]
pub(crate) fn main_axis<T: PartialOrd>(ad: [T; 3]) -> usize {
    if ad[0] >= ad[1] && ad[0] >= ad[2] {
        0
    } else if ad[1] >= ad[2] {
        1
    } else {
        2
    }
}

/// Visit the keys of the Bresenham line from `start` to `end`, `start` included, `end`
/// excluded (nothing when they are equal). Returns the number of keys visited.
#[inline]
pub fn walk_bresenham_keys(start: Key, end: Key, mut visit: impl FnMut(Key)) -> u32 {
    let d = [0, 1, 2].map(|a| end[a] as i32 - start[a] as i32);
    let ad = d.map(i32::abs);
    let s = d.map(i32::signum);
    let main = main_axis(ad);
    let (a1, a2) = ((main + 1) % 3, (main + 2) % 3);
    let n = ad[main];
    let mut cur = [start[0] as i32, start[1] as i32, start[2] as i32];
    let mut e1 = 2 * ad[a1] - n;
    let mut e2 = 2 * ad[a2] - n;
    for _ in 0..n {
        visit(Key::new(cur[0] as u16, cur[1] as u16, cur[2] as u16));
        if e1 > 0 {
            cur[a1] += s[a1];
            e1 -= 2 * n;
        }
        if e2 > 0 {
            cur[a2] += s[a2];
            e2 -= 2 * n;
        }
        e1 += 2 * ad[a1];
        e2 += 2 * ad[a2];
        cur[main] += s[main];
    }
    n as u32
}

/// [`walk_bresenham_keys`] for set builders: the same voxels, stepped as Morton codes and
/// handed out per 4x4x4 brick (`code >> 6`) with the mask of the brick's visited voxels (bit
/// `code & 63`), one `flush.put` per brick the line enters. Returns the number of voxels.
#[inline]
pub(crate) fn walk_bresenham_bricks(start: Key, end: Key, flush: &mut impl BrickSink) -> u32 {
    let d = [0, 1, 2].map(|a| end[a] as i32 - start[a] as i32);
    let ad = d.map(i32::abs);
    let main = main_axis(ad);
    let (a1, a2) = ((main + 1) % 3, (main + 2) % 3);
    let n = ad[main];
    let sm = AxisStep::new(main, d[main] > 0);
    let s1 = AxisStep::new(a1, d[a1] > 0);
    let s2 = AxisStep::new(a2, d[a2] > 0);
    let mut code = start.morton();
    let (mut e1, mut e2) = (2 * ad[a1] - n, 2 * ad[a2] - n);
    let mut brick = code >> 6;
    let mut bits = 0u64;
    for _ in 0..n {
        if code >> 6 != brick {
            flush.put(Brick {
                code: brick,
                voxels: bits,
            });
            brick = code >> 6;
            bits = 0;
        }
        bits |= 1u64 << (code & 63);
        if e1 > 0 {
            code = s1.apply(code);
            e1 -= 2 * n;
        }
        if e2 > 0 {
            code = s2.apply(code);
            e2 -= 2 * n;
        }
        e1 += 2 * ad[a1];
        e2 += 2 * ad[a2];
        code = sm.apply(code);
    }
    if bits != 0 {
        flush.put(Brick {
            code: brick,
            voxels: bits,
        });
    }
    n as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn line(a: Key, b: Key) -> Vec<Key> {
        let mut v = Vec::new();
        walk_bresenham_keys(a, b, |k| v.push(k));
        v
    }

    #[test]
    fn simple_lines() {
        let o = Key::new(100, 100, 100);
        assert!(line(o, o).is_empty());
        assert_eq!(
            line(o, Key::new(103, 100, 100)),
            vec![o, Key::new(101, 100, 100), Key::new(102, 100, 100)]
        );
        assert_eq!(
            line(o, Key::new(97, 97, 97)),
            vec![o, Key::new(99, 99, 99), Key::new(98, 98, 98)]
        );
    }

    proptest! {
        /// The brick walk hands out exactly the key walk's voxels, brick by brick in order.
        #[test]
        fn brick_walk_matches_key_walk(a in any::<[u16; 3]>(), d in any::<[i16; 3]>()) {
            let start = Key(a);
            let end = Key([0, 1, 2].map(|i| (a[i] as i32 + d[i] as i32 / 64).clamp(0, 65535) as u16));
            let keys = line(start, end);
            let mut want: Vec<Brick> = Vec::new();
            for k in &keys {
                let b = Brick::of_voxel(k.morton());
                match want.last_mut() {
                    Some(last) if last.code == b.code => last.voxels |= b.voxels,
                    _ => want.push(b),
                }
            }
            let mut got = Vec::new();
            let n = walk_bresenham_bricks(start, end, &mut |b| got.push(b));
            prop_assert_eq!(n as usize, keys.len());
            prop_assert_eq!(got, want);
        }

        /// The line has max(|d|) keys, starts at `start`, moves by at most one per axis per
        /// step, advances monotonically towards `end`, and its next step would be `end`.
        #[test]
        fn lines_are_monotone_26_connected(a in any::<[u16; 3]>(), d in any::<[i8; 3]>()) {
            let start = Key(a);
            let end = Key([0, 1, 2].map(|i| (a[i] as i32 + d[i] as i32).clamp(0, 65535) as u16));
            let v = line(start, end);
            let n = (0..3).map(|i| (end[i] as i32 - start[i] as i32).abs()).max().unwrap();
            prop_assert_eq!(v.len() as i32, n);
            if n > 0 {
                prop_assert_eq!(v[0], start);
                let mut all = v.clone();
                all.push(end);
                for w in all.windows(2) {
                    for i in 0..3 {
                        let step = w[1][i] as i32 - w[0][i] as i32;
                        let dir = (end[i] as i32 - start[i] as i32).signum();
                        prop_assert!(step == 0 || step == dir);
                    }
                }
            }
        }
    }
}
