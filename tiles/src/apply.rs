//! A tile's update lists applied, in frame order, to the tile's own tree.

use crate::error::TileError;
use crate::split::{TileFrame, TileUpdates};
use crate::tile::Tile;
use octoquant_octree::{Brick, InnerNodes, OcTree, Update};

/// What [`apply_tile_updates`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ApplyStats {
    /// Frames applied (those that touch the tile).
    pub frames: usize,
    /// Miss updates applied.
    pub free: usize,
    /// Hit updates applied.
    pub occupied: usize,
}

/// Apply the update lists of `tile` (from any number of ray batches, given in any order) to
/// `tree`, the tile's own tree (empty at first, or holding earlier frames of this tile only):
/// merged by frame index and applied in increasing frame order, each frame's misses then its
/// hits, with OctoMap's `updateNode` semantics (clamping, early exit at the clamps, pruning
/// and inner nodes refreshed on the way up), through [`OcTree::update_bricks`] as the
/// sequential pipeline applies a frame.
///
/// Errors, before the tree is touched, for lists of another tile, lists that break their
/// invariants ([`TileUpdates::check`]) and a frame given twice.
pub fn apply_tile_updates(
    tree: &mut OcTree,
    tile: Tile,
    lists: &[TileUpdates],
) -> Result<ApplyStats, TileError> {
    let mut frames: Vec<&TileFrame> = Vec::new();
    for l in lists {
        if l.tile != tile {
            return Err(TileError::WrongTile {
                expected: tile,
                found: l.tile,
            });
        }
        l.check()?;
        frames.extend(&l.frames);
    }
    frames.sort_by_key(|f| f.frame);
    if let Some(w) = frames.windows(2).find(|w| w[0].frame == w[1].frame) {
        return Err(TileError::DuplicateFrame {
            tile,
            frame: w[0].frame,
        });
    }
    let mut stats = ApplyStats::default();
    let mut bricks = Vec::new();
    for f in frames {
        for (codes, update) in [(&f.free, Update::Miss), (&f.occupied, Update::Hit)] {
            to_bricks(codes, &mut bricks);
            tree.update_bricks(&bricks, update, InnerNodes::Refresh);
        }
        stats.frames += 1;
        stats.free += f.free.len();
        stats.occupied += f.occupied.len();
    }
    Ok(stats)
}

/// Sorted voxel codes as sorted bricks.
fn to_bricks(codes: &[u64], out: &mut Vec<Brick>) {
    out.clear();
    for &c in codes {
        let b = Brick::of_voxel(c);
        match out.last_mut() {
            Some(last) if last.code == b.code => last.voxels |= b.voxels,
            _ => out.push(b),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoquant_octree::Key;

    #[test]
    fn frames_apply_in_index_order_whatever_the_list_order() {
        let k = Key::new(32768, 32768, 32768);
        let tile = Tile::of_key(k, 4).unwrap();
        let c = k.morton();
        let list = |frame: u64, hit: bool| TileUpdates {
            tile,
            frames: vec![TileFrame {
                frame,
                free: if hit { vec![] } else { vec![c] },
                occupied: if hit { vec![c] } else { vec![] },
            }],
        };
        // four misses reach -1.62; a hit then gives -0.77. Hit first, then the misses, clamps
        // differently: the order decides the value
        let lists = [
            list(4, true),
            list(0, false),
            list(2, false),
            list(1, false),
            list(3, false),
        ];
        let mut t = OcTree::new(0.1).unwrap();
        let s = apply_tile_updates(&mut t, tile, &lists).unwrap();
        assert_eq!((s.frames, s.free, s.occupied), (5, 4, 1));
        let mut want = OcTree::new(0.1).unwrap();
        for u in [
            Update::Miss,
            Update::Miss,
            Update::Miss,
            Update::Miss,
            Update::Hit,
        ] {
            want.update_node(k, u, InnerNodes::Refresh);
        }
        assert_eq!(t.search(k, 16), want.search(k, 16));
        assert_eq!(t.size(), want.size());
    }

    #[test]
    fn wrong_lists_are_refused_untouched() {
        let k = Key::new(32768, 32768, 32768);
        let tile = Tile::of_key(k, 2).unwrap();
        let other = Tile::of_key(Key::new(0, 0, 0), 2).unwrap();
        let mut t = OcTree::new(0.1).unwrap();
        let f = TileFrame {
            frame: 1,
            free: vec![k.morton()],
            occupied: vec![],
        };
        let l = TileUpdates {
            tile,
            frames: vec![f.clone()],
        };
        let e = apply_tile_updates(&mut t, other, std::slice::from_ref(&l)).unwrap_err();
        assert!(matches!(e, TileError::WrongTile { .. }), "{e}");
        let e = apply_tile_updates(&mut t, tile, &[l.clone(), l.clone()]).unwrap_err();
        assert!(
            matches!(e, TileError::DuplicateFrame { frame: 1, .. }),
            "{e}"
        );
        assert!(t.is_empty());
    }
}
