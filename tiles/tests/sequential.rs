//! split + apply + join gives the sequential tree, byte for byte (`.ot` and `.bt`), for any
//! tile depth, batching of frames, order of tile processing and order of tiles in the join.

use nalgebra::Point3;
use octoquant_octree::{io, KeyConverter, OcTree, OccupancyParams};
use octoquant_raycast::{apply_update, compute_update_f32, ApplyOptions, ScanUpdate};
use octoquant_tiles::{apply_tile_updates, join_tiles, Tile, TileSplitter, TileUpdates};
use proptest::prelude::*;
use std::collections::BTreeMap;

mod common;

use common::{frames_strategy, sphere, Frame};

/// The sequential exact pipeline: each frame's sets, applied in order (what `Mapper` does in
/// exact mode without filters).
fn sequential(frames: &[Frame], res: f64, max_range: Option<f64>) -> OcTree {
    let mut tree = OcTree::new(res).unwrap();
    let conv = tree.converter().clone();
    let mut u = ScanUpdate::new();
    for (origin, pts) in frames {
        compute_update_f32(&conv, pts, origin, max_range, &mut u);
        apply_update(&mut tree, &u, &ApplyOptions::default());
    }
    tree
}

/// A deterministic shuffle of `v` by `seed`.
fn shuffle<T>(v: &mut [T], mut seed: u64) {
    for i in (1..v.len()).rev() {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        v.swap(i, (seed % (i as u64 + 1)) as usize);
    }
}

/// The tiled build: frames cast in batches of `batch` (each batch's lists shipped as bytes),
/// tiles applied in a shuffled order, the tile trees joined in another.
fn tiled(
    frames: &[Frame],
    res: f64,
    max_range: Option<f64>,
    depth: u8,
    batch: usize,
    seed: u64,
) -> (OcTree, usize) {
    let conv = KeyConverter::new(res).unwrap();
    let mut shipped: BTreeMap<Tile, Vec<Vec<u8>>> = BTreeMap::new();
    let mut u = ScanUpdate::new();
    for (b, chunk) in frames.chunks(batch.max(1)).enumerate() {
        let mut s = TileSplitter::new(depth).unwrap();
        for (i, (origin, pts)) in chunk.iter().enumerate() {
            compute_update_f32(&conv, pts, origin, max_range, &mut u);
            s.add((b * batch.max(1) + i) as u64, &u).unwrap();
        }
        for l in s.finish() {
            shipped
                .entry(l.tile)
                .or_default()
                .push(l.to_bytes().unwrap());
        }
    }
    let mut order: Vec<(Tile, Vec<Vec<u8>>)> = shipped.into_iter().collect();
    shuffle(&mut order, seed);
    let mut trees = Vec::new();
    for (tile, mut bufs) in order {
        // batches arrive in any order
        shuffle(&mut bufs, seed ^ tile.index());
        let lists: Vec<TileUpdates> = bufs
            .iter()
            .map(|b| TileUpdates::from_bytes(b).unwrap())
            .collect();
        let mut t = OcTree::new(res).unwrap();
        apply_tile_updates(&mut t, tile, &lists).unwrap();
        trees.push(t);
    }
    let n = trees.len();
    shuffle(&mut trees, seed.rotate_left(17));
    let joined = join_tiles(res, OccupancyParams::default(), depth, &trees).unwrap();
    (joined, n)
}

fn bytes(tree: &OcTree) -> (Vec<u8>, Vec<u8>) {
    let mut ot = Vec::new();
    io::write_ot(tree, &mut ot).unwrap();
    let mut bt = Vec::new();
    io::write_bt(&mut tree.clone(), &mut bt).unwrap();
    (ot, bt)
}

fn assert_same(a: &OcTree, b: &OcTree, what: &str) {
    let (aot, abt) = bytes(a);
    let (bot, bbt) = bytes(b);
    assert_eq!(a.size(), b.size(), "{what}: sizes");
    assert!(aot == bot, "{what}: .ot differs");
    assert!(abt == bbt, "{what}: .bt differs");
}

/// Dense, repeated frames clamp whole regions free, so that nodes above the tile depth are
/// pruned; a later frame from elsewhere expands them again. The tiled build still gives the
/// sequential bytes, and the test checks the case it is about did happen.
#[test]
fn pruning_above_the_tile_depth_is_reproduced() {
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let ball = sphere(o, 2.0, 20_000);
    let mut frames: Vec<Frame> = (0..6).map(|_| (o, ball.clone())).collect();
    // a hit inside the pruned region, and rays through it, from another origin
    let o2 = Point3::new(-0.9f32, 0.4, -0.3);
    let mut pts = sphere(o2, 0.7, 300);
    pts.push(Point3::new(0.3, 0.3, 0.3));
    frames.push((o2, pts));
    let res = 0.1;
    let seq = sequential(&frames, res, None);
    let seq_before = sequential(&frames[..6], res, None);
    // the coarsest leaf: nodes down to its depth were pruned whole
    let coarsest = seq_before.leaves().map(|l| l.depth).min().unwrap();
    assert!(
        coarsest <= 13,
        "the dense frames pruned nodes of 0.8 m and more"
    );
    assert!(seq.leaves().map(|l| l.depth).min().unwrap() <= 13);
    for depth in [0u8, 1, 3, 6, 11, 12, 13, 14, 15, 16] {
        let (t, n) = tiled(&frames[..6], res, None, depth, 4, depth as u64);
        assert_same(
            &t,
            &seq_before,
            &format!("before, depth {depth}, {n} tiles"),
        );
        let (t, n) = tiled(&frames, res, None, depth, 3, 99 + depth as u64);
        assert_same(&t, &seq, &format!("after, depth {depth}, {n} tiles"));
    }
}

#[test]
fn no_frames_give_an_empty_tree() {
    let (t, n) = tiled(&[], 0.1, None, 3, 2, 1);
    assert_eq!(n, 0);
    assert!(t.is_empty());
    assert_same(&t, &sequential(&[], 0.1, None), "empty");
}

#[test]
fn join_refuses_what_is_not_a_tile_set() {
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let frames = vec![(o, sphere(o, 1.5, 500))];
    let seq = sequential(&frames, 0.1, None);
    let p = OccupancyParams::default();
    // the whole map is no tile at depth 3: it branches below the root
    let e = join_tiles(0.1, p, 3, [&seq]).unwrap_err().to_string();
    assert!(e.contains("more than one tile"), "{e}");
    // but it is the one tile at depth 0
    assert_same(&join_tiles(0.1, p, 0, [&seq]).unwrap(), &seq, "depth 0");
    let mut u = ScanUpdate::new();
    let conv = KeyConverter::new(0.1).unwrap();
    compute_update_f32(&conv, &frames[0].1, &o, None, &mut u);
    let mut s = TileSplitter::new(5).unwrap();
    s.add(0, &u).unwrap();
    let lists = s.finish();
    let mut t = OcTree::new(0.1).unwrap();
    apply_tile_updates(&mut t, lists[0].tile, &lists[..1]).unwrap();
    let e = join_tiles(0.1, p, 5, [&t, &t]).unwrap_err().to_string();
    assert!(e.contains("twice"), "{e}");
    let e = join_tiles(0.2, p, 5, [&t]).unwrap_err().to_string();
    assert!(e.contains("resolution"), "{e}");
    // a tile tree asked for at a deeper depth than it was built for branches there
    assert!(join_tiles(0.1, p, 16, [&t]).is_err());
    // the joined tree carries the given sensor model
    let q = OccupancyParams::from_probabilities(0.8, 0.3, 0.1, 0.95, 0.5).unwrap();
    assert_eq!(*join_tiles(0.1, q, 5, [&t]).unwrap().params(), q);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn tiled_equals_sequential(
        frames in frames_strategy(),
        max_range in prop_oneof![Just(None), (0.5f64..4.0).prop_map(Some)],
        res in prop_oneof![Just(0.1f64), Just(0.2), Just(0.05)],
        batch in 1usize..5,
        seed in any::<u64>(),
    ) {
        let seq = sequential(&frames, res, max_range);
        for depth in [1u8, 3, 6, 12, 14] {
            let (t, n) = tiled(&frames, res, max_range, depth, batch, seed);
            let (aot, abt) = bytes(&t);
            let (bot, bbt) = bytes(&seq);
            prop_assert!(aot == bot, "depth {}, {} tiles: .ot differs", depth, n);
            prop_assert!(abt == bbt, "depth {}, {} tiles: .bt differs", depth, n);
        }
    }
}
