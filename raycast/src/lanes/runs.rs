//! Runs of one brick among the bricks the SIMD lanes leave: neighbouring lanes walk
//! neighbouring rays, so consecutive entries often repeat a brick; each run is merged into one
//! entry before the entries reach the brick set.

use crate::brickset::BrickSink;

/// Hand the bricks `(bricks[i], bits[i])` left by lanes to `flush`, each run of one brick
/// merged into one call. Neighbouring lanes walk neighbouring rays, so about three brick
/// entries in five repeat the one before; merged first (without a branch), they no longer
/// queue behind each other's update of one table slot.
#[inline]
pub(crate) fn hand_on_runs<F: BrickSink>(bricks: &mut [u64], bits: &mut [u64], flush: &mut F) {
    let k = merge_runs(bricks, bits);
    flush.put_all(&bricks[..k], &bits[..k]);
}

/// Merge each run of one brick in `(bricks[i], bits[i])` into one entry (the union of its
/// bits), in place at the front, and return how many entries there are then.
#[inline]
pub(crate) fn merge_runs(bricks: &mut [u64], bits: &mut [u64]) -> usize {
    let n = bricks.len().min(bits.len());
    let (bricks, bits) = (&mut bricks[..n], &mut bits[..n]);
    let (Some(&b0), Some(&m0)) = (bricks.first(), bits.first()) else {
        return 0;
    };
    merge_runs_from(bricks, bits, 1, 0, b0, m0)
}

/// [`merge_runs`] from entry `from` on, with `k` entries merged before it and the run of
/// brick `cb` (bits `cm`) still open.
#[inline]
pub(crate) fn merge_runs_from(
    bricks: &mut [u64],
    bits: &mut [u64],
    from: usize,
    mut k: usize,
    mut cb: u64,
    mut cm: u64,
) -> usize {
    let n = bricks.len().min(bits.len());
    for i in from..n {
        let (b, m) = (bricks[i], bits[i]);
        let same = b == cb;
        // the open run is written at `k` every time and kept once the next entry differs
        bricks[k] = cb;
        bits[k] = cm;
        k += !same as usize;
        cm = (cm & (same as u64).wrapping_neg()) | m;
        cb = b;
    }
    bricks[k] = cb;
    bits[k] = cm;
    k + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoquant_octree::Brick;
    use proptest::prelude::*;

    proptest! {
        /// Merging runs keeps every brick's voxels and leaves no run of one brick.
        #[test]
        fn merged_runs_keep_every_voxel(
            entries in prop::collection::vec((0u64..4, any::<u64>()), 0..60),
        ) {
            let (mut bricks, mut bits): (Vec<u64>, Vec<u64>) = entries.iter().copied().unzip();
            let mut got = Vec::new();
            hand_on_runs(&mut bricks, &mut bits, &mut |b: Brick| got.push((b.code, b.voxels)));
            prop_assert!(got.windows(2).all(|w| w[0].0 != w[1].0));
            let union = |v: &[(u64, u64)]| {
                let mut u = std::collections::BTreeMap::new();
                for &(b, m) in v {
                    *u.entry(b).or_insert(0u64) |= m;
                }
                u
            };
            prop_assert_eq!(union(&got), union(&entries));
            let runs = 1 + entries.windows(2).filter(|w| w[0].0 != w[1].0).count();
            prop_assert_eq!(got.len(), if entries.is_empty() { 0 } else { runs });
        }
    }
}
