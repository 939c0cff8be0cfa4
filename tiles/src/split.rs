//! One frame's update split by tile: sorted Morton codes per tile, tagged with the frame.

use crate::error::TileError;
use crate::tile::Tile;
use crate::tile_check::check_depth;
use octoquant_octree::Brick;
use octoquant_raycast::ScanUpdate;
use std::collections::BTreeMap;

/// One frame's update of one tile: the voxels it clears and the voxels it hits, each as
/// sorted, distinct Morton codes ([`octoquant_octree::Key::morton`]) inside the tile, the two
/// lists disjoint (occupied wins, as in OctoMap's `computeUpdate`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TileFrame {
    /// The frame's index in the run (0 = first frame): the order the tile applies frames in.
    pub frame: u64,
    /// Voxels updated as misses.
    pub free: Vec<u64>,
    /// Voxels updated as hits.
    pub occupied: Vec<u64>,
}

/// A tile's update lists from one or more frames, in increasing frame order: what a ray
/// task hands to the tile's task.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TileUpdates {
    /// The tile every code lies in.
    pub tile: Tile,
    /// The frames that touch the tile, strictly increasing by index.
    pub frames: Vec<TileFrame>,
}

impl TileUpdates {
    /// No updates yet for `tile`.
    pub fn new(tile: Tile) -> Self {
        TileUpdates {
            tile,
            frames: Vec::new(),
        }
    }

    /// Voxel updates held (free and occupied, all frames).
    pub fn voxel_updates(&self) -> usize {
        self.frames
            .iter()
            .map(|f| f.free.len() + f.occupied.len())
            .sum()
    }

    /// Checks what the lists promise: frames strictly increasing; per frame, codes strictly
    /// increasing, inside the tile, free and occupied disjoint.
    pub fn check(&self) -> Result<(), TileError> {
        let bad = |message: String| TileError::BadList {
            tile: self.tile,
            message,
        };
        for (i, f) in self.frames.iter().enumerate() {
            if i > 0 && self.frames[i - 1].frame >= f.frame {
                return Err(bad(format!(
                    "frame {} follows frame {}: frames must increase",
                    f.frame,
                    self.frames[i - 1].frame
                )));
            }
            for (name, codes) in [("free", &f.free), ("occupied", &f.occupied)] {
                if let Some(w) = codes.windows(2).find(|w| w[0] >= w[1]) {
                    return Err(bad(format!(
                        "frame {}: {name} codes not strictly increasing ({} then {})",
                        f.frame, w[0], w[1]
                    )));
                }
                if let Some(c) = codes.iter().find(|&&c| !self.tile.contains_code(c)) {
                    return Err(bad(format!(
                        "frame {}: {name} code {c} lies outside the tile",
                        f.frame
                    )));
                }
            }
            if let Some(c) = first_common(&f.free, &f.occupied) {
                return Err(bad(format!(
                    "frame {}: voxel {c} is both free and occupied",
                    f.frame
                )));
            }
        }
        Ok(())
    }
}

/// The first value in both sorted lists.
fn first_common(a: &[u64], b: &[u64]) -> Option<u64> {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
            std::cmp::Ordering::Equal => return Some(a[i]),
        }
    }
    None
}

/// The voxel codes of sorted bricks, grouped by tile at `depth`, in order.
fn group_by_tile(bricks: &[Brick], depth: u8) -> Vec<(Tile, Vec<u64>)> {
    let mut out: Vec<(Tile, Vec<u64>)> = Vec::new();
    for b in bricks {
        let mut bits = b.voxels;
        while bits != 0 {
            let code = (b.code << 6) | bits.trailing_zeros() as u64;
            bits &= bits - 1;
            let tile = Tile::of_code(code, depth);
            match out.last_mut() {
                Some((t, codes)) if *t == tile => codes.push(code),
                _ => out.push((tile, vec![code])),
            }
        }
    }
    out
}

/// Split one frame's update (free and occupied voxel sets, as the exact pipeline computes
/// them: sorted, disjoint, each voxel once) by tile at `depth`: one [`TileFrame`] per tile
/// the frame touches, tagged `frame`, in tile order. Errors for a depth above 16.
pub fn split_update(
    depth: u8,
    frame: u64,
    update: &ScanUpdate,
) -> Result<Vec<(Tile, TileFrame)>, TileError> {
    check_depth(depth)?;
    let free = group_by_tile(update.free_bricks(), depth);
    let occupied = group_by_tile(update.occupied_bricks(), depth);
    // both are in tile order: merge them
    let mut out = Vec::with_capacity(free.len().max(occupied.len()));
    let (mut f, mut o) = (free.into_iter().peekable(), occupied.into_iter().peekable());
    loop {
        let take_free = match (f.peek(), o.peek()) {
            (None, None) => break,
            (Some(_), None) => Some(true),
            (None, Some(_)) => Some(false),
            (Some((a, _)), Some((b, _))) => match a.cmp(b) {
                std::cmp::Ordering::Less => Some(true),
                std::cmp::Ordering::Greater => Some(false),
                std::cmp::Ordering::Equal => None,
            },
        };
        let (tile, free, occupied) = match take_free {
            Some(true) => {
                let (t, c) = f.next().expect("peeked");
                (t, c, Vec::new())
            }
            Some(false) => {
                let (t, c) = o.next().expect("peeked");
                (t, Vec::new(), c)
            }
            None => {
                let (t, a) = f.next().expect("peeked");
                let (_, b) = o.next().expect("peeked");
                (t, a, b)
            }
        };
        out.push((
            tile,
            TileFrame {
                frame,
                free,
                occupied,
            },
        ));
    }
    Ok(out)
}

/// Collects the per-tile lists of a batch of frames: [`TileSplitter::add`] each frame's
/// update in increasing frame order, then [`TileSplitter::finish`].
#[derive(Debug, Clone)]
pub struct TileSplitter {
    depth: u8,
    tiles: BTreeMap<Tile, TileUpdates>,
    last: Option<u64>,
}

impl TileSplitter {
    /// A splitter for tiles at `depth` (0..=16).
    pub fn new(depth: u8) -> Result<Self, TileError> {
        check_depth(depth)?;
        Ok(TileSplitter {
            depth,
            tiles: BTreeMap::new(),
            last: None,
        })
    }

    /// The tile depth.
    pub fn depth(&self) -> u8 {
        self.depth
    }

    /// Add frame `frame`'s update; frames must come in strictly increasing order (else an
    /// error and nothing is added).
    pub fn add(&mut self, frame: u64, update: &ScanUpdate) -> Result<(), TileError> {
        if let Some(last) = self.last {
            if frame <= last {
                return Err(TileError::Mismatch(format!(
                    "frame {frame} added after frame {last}: frames must increase"
                )));
            }
        }
        self.last = Some(frame);
        for (tile, tf) in split_update(self.depth, frame, update)? {
            self.tiles
                .entry(tile)
                .or_insert_with(|| TileUpdates::new(tile))
                .frames
                .push(tf);
        }
        Ok(())
    }

    /// The lists of every tile touched, in tile order.
    pub fn finish(self) -> Vec<TileUpdates> {
        self.tiles.into_values().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use octoquant_octree::{Key, KeyConverter};
    use octoquant_raycast::compute_update_f32;

    fn scan_update(conv: &KeyConverter, origin: Point3<f32>, n: usize) -> ScanUpdate {
        let pts: Vec<Point3<f32>> = (0..n)
            .map(|i| {
                let a = i as f32 * 0.37;
                Point3::new(3.0 * a.cos(), 2.5 * a.sin(), (i % 7) as f32 * 0.3 - 1.0)
            })
            .collect();
        let mut u = ScanUpdate::new();
        compute_update_f32(conv, &pts, &origin, Some(2.8), &mut u);
        u
    }

    #[test]
    fn split_lists_partition_the_frame() {
        let conv = KeyConverter::new(0.1).unwrap();
        let u = scan_update(&conv, Point3::new(0.05, -0.02, 0.1), 300);
        let free: Vec<u64> = u.free().iter().map(Key::morton).collect();
        let occ: Vec<u64> = u.occupied().iter().map(Key::morton).collect();
        for depth in [0, 1, 3, 6, 14, 15, 16] {
            let parts = split_update(depth, 7, &u).unwrap();
            assert!(parts.windows(2).all(|w| w[0].0 < w[1].0), "tile order");
            let mut all_free = Vec::new();
            let mut all_occ = Vec::new();
            for (tile, tf) in &parts {
                assert_eq!(tf.frame, 7);
                assert!(!(tf.free.is_empty() && tf.occupied.is_empty()));
                let list = TileUpdates {
                    tile: *tile,
                    frames: vec![tf.clone()],
                };
                list.check().unwrap();
                all_free.extend_from_slice(&tf.free);
                all_occ.extend_from_slice(&tf.occupied);
            }
            // tiles in order and codes sorted in each: the concatenation is the sorted set
            assert_eq!(all_free, free, "depth {depth}");
            assert_eq!(all_occ, occ, "depth {depth}");
            if depth == 0 {
                assert_eq!(parts.len(), 1);
            }
            if depth >= 14 {
                assert!(parts.len() > 8, "depth {depth}: {} tiles", parts.len());
            }
        }
        assert!(split_update(17, 0, &u).is_err());
    }

    #[test]
    fn splitter_keeps_frames_in_order_per_tile() {
        let conv = KeyConverter::new(0.1).unwrap();
        let mut s = TileSplitter::new(3).unwrap();
        let a = scan_update(&conv, Point3::new(0.05, 0.05, 0.05), 100);
        let b = scan_update(&conv, Point3::new(0.5, 0.2, 0.05), 120);
        s.add(4, &a).unwrap();
        s.add(9, &b).unwrap();
        assert!(s.add(9, &b).is_err());
        let lists = s.finish();
        assert!(lists.len() > 1);
        let mut total = 0;
        for l in &lists {
            l.check().unwrap();
            assert!(l.frames.iter().all(|f| f.frame == 4 || f.frame == 9));
            total += l.voxel_updates();
        }
        assert_eq!(
            total,
            a.free().len() + a.occupied().len() + b.free().len() + b.occupied().len()
        );
    }

    #[test]
    fn check_catches_broken_lists() {
        let tile = Tile::new(1, 0).unwrap();
        let ok = TileFrame {
            frame: 1,
            free: vec![1, 5],
            occupied: vec![2],
        };
        let good = TileUpdates {
            tile,
            frames: vec![ok.clone()],
        };
        good.check().unwrap();
        let cases = [
            vec![ok.clone(), ok.clone()],
            vec![TileFrame {
                free: vec![5, 1],
                ..ok.clone()
            }],
            vec![TileFrame {
                occupied: vec![5],
                ..ok.clone()
            }],
            vec![TileFrame {
                free: vec![1 << 45],
                ..ok.clone()
            }],
        ];
        for frames in cases {
            let l = TileUpdates { tile, frames };
            assert!(l.check().is_err(), "{l:?}");
        }
    }
}
