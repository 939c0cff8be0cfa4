//! `StreamJoin` (a tile directory written one tile at a time) gives the bytes of the tile
//! directory joined in memory and written by `write_ot` / `write_bt`, which are the
//! sequential tree's: for random frame sequences at every tile depth, for dense frames that
//! prune above the tile depth, and for a tree where OctoMap's `prune()` stopping at the first
//! level that prunes nothing, counted over the whole tree, decides the `.bt`.

use nalgebra::Point3;
use octoquant_octree::io::{self, TreeFormat};
use octoquant_octree::{InnerNodes, Key, KeyConverter, OcTree, OccupancyParams};
use octoquant_raycast::{apply_update, compute_update_f32, ApplyOptions, ScanUpdate};
use octoquant_tiles::{
    apply_tile_updates, join_dir, write_index, write_tile, StreamJoin, TileIndex, TileSplitter,
};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

mod common;

use common::{frames_strategy, sphere, Frame};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "octoquant-stream-join-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The sequential exact pipeline (what `Mapper` does in exact mode without filters).
fn sequential(frames: &[Frame], res: f64) -> OcTree {
    let mut tree = OcTree::new(res).unwrap();
    let conv = tree.converter().clone();
    let mut u = ScanUpdate::new();
    for (origin, pts) in frames {
        compute_update_f32(&conv, pts, origin, None, &mut u);
        apply_update(&mut tree, &u, &ApplyOptions::default());
    }
    tree
}

/// The frames built tile by tile into `dir` (one `.ot` per tile plus the index).
fn spill(frames: &[Frame], res: f64, depth: u8, dir: &Path) {
    let conv = KeyConverter::new(res).unwrap();
    let mut s = TileSplitter::new(depth).unwrap();
    let mut u = ScanUpdate::new();
    for (i, (origin, pts)) in frames.iter().enumerate() {
        compute_update_f32(&conv, pts, origin, None, &mut u);
        s.add(i as u64, &u).unwrap();
    }
    let mut tiles = Vec::new();
    for l in s.finish() {
        let mut t = OcTree::new(res).unwrap();
        apply_tile_updates(&mut t, l.tile, std::slice::from_ref(&l)).unwrap();
        tiles.extend(write_tile(dir, &t, depth).unwrap());
    }
    index(dir, res, depth, tiles);
}

fn index(dir: &Path, res: f64, depth: u8, tiles: Vec<(octoquant_tiles::Tile, String)>) {
    let index = TileIndex {
        resolution: res,
        params: OccupancyParams::default(),
        tile_depth: depth,
        tiles,
    };
    write_index(dir, &index).unwrap();
}

fn streamed(dir: &Path, format: TreeFormat) -> Vec<u8> {
    let plan = StreamJoin::plan(dir, format).unwrap();
    let mut out = Vec::new();
    plan.write(&mut out).unwrap();
    out
}

fn written(tree: &OcTree) -> (Vec<u8>, Vec<u8>) {
    let mut ot = Vec::new();
    io::write_ot(tree, &mut ot).unwrap();
    let mut bt = Vec::new();
    io::write_bt(&mut tree.clone(), &mut bt).unwrap();
    (ot, bt)
}

/// The streamed files equal the in-memory join's and `want`'s, and announce their node count.
fn check_dir(dir: &Path, want: &OcTree, what: &str) -> Result<(), TestCaseError> {
    let (wot, wbt) = written(want);
    let (mot, mbt) = written(&join_dir(dir).unwrap());
    prop_assert!(
        mot == wot && mbt == wbt,
        "{}: the in-memory join differs",
        what
    );
    let ot = streamed(dir, TreeFormat::Ot);
    let bt = streamed(dir, TreeFormat::Bt);
    prop_assert!(ot == wot, "{}: streamed .ot differs", what);
    prop_assert!(bt == wbt, "{}: streamed .bt differs", what);
    prop_assert_eq!(
        StreamJoin::plan(dir, TreeFormat::Ot).unwrap().nodes(),
        want.size()
    );
    Ok(())
}

#[test]
fn dense_frames_pruned_above_the_tile_depth() {
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let ball = sphere(o, 2.0, 20_000);
    let mut frames: Vec<Frame> = (0..6).map(|_| (o, ball.clone())).collect();
    let o2 = Point3::new(-0.9f32, 0.4, -0.3);
    frames.push((o2, sphere(o2, 0.7, 300)));
    let want = sequential(&frames, 0.1);
    // (deeper tiles mean tens of thousands of tile files, each written with an fsync)
    for depth in [0u8, 1, 3, 6, 11, 12, 13] {
        let dir = scratch(&format!("dense-{depth}"));
        spill(&frames, 0.1, depth, &dir);
        check_dir(&dir, &want, &format!("depth {depth}")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn an_empty_directory_is_an_empty_map() {
    let dir = scratch("empty");
    index(&dir, 0.1, 5, Vec::new());
    check_dir(&dir, &OcTree::new(0.1).unwrap(), "empty").unwrap();
}

/// Tile A prunes a node at depth 15 after the max-likelihood conversion; tile B prunes
/// nothing at depth 15 but would at depth 14. OctoMap's `prune()` on the whole tree goes on
/// to depth 14 because A pruned at 15, so B's node collapses in the `.bt`; B's tile pruned
/// alone would stop at 15 and keep it. The streamed `.bt` must follow the whole tree.
#[test]
fn prune_stops_where_the_whole_tree_stops() {
    let depth = 8u8;
    let a = Key::new(32768, 32768, 32768);
    let b = Key::new(32768 + 4096, 32768, 32768);
    let mut full = OcTree::new(0.1).unwrap();
    let mut ta = OcTree::new(0.1).unwrap();
    let mut tb = OcTree::new(0.1).unwrap();
    let set = |t: &mut OcTree, k: Key, v: f32| {
        t.set_node_value(k, v, InnerNodes::Refresh).unwrap();
    };
    // A: eight voxels of one depth-15 node, occupied but all different
    for i in 0..8u16 {
        let k = Key::new(a.x() + (i & 1), a.y() + ((i >> 1) & 1), a.z() + (i >> 2));
        for t in [&mut full, &mut ta] {
            set(t, k, 0.5 + 0.1 * f32::from(i));
        }
    }
    // B: eight depth-15 leaves (each eight equal voxels, pruned on the way) under one
    // depth-14 node, occupied but different from each other
    for j in 0..8u16 {
        let base = Key::new(
            b.x() + 2 * (j & 1),
            b.y() + 2 * ((j >> 1) & 1),
            b.z() + 2 * (j >> 2),
        );
        for i in 0..8u16 {
            let k = Key::new(
                base.x() + (i & 1),
                base.y() + ((i >> 1) & 1),
                base.z() + (i >> 2),
            );
            for t in [&mut full, &mut tb] {
                set(t, k, 1.0 + 0.1 * f32::from(j));
            }
        }
    }
    // the case is the one described: B alone keeps its depth-14 node inner, the whole tree
    // collapses it
    let min_depth = |t: &OcTree| t.leaves().map(|l| l.depth).min().unwrap();
    let mut b_alone = tb.clone();
    b_alone.to_max_likelihood();
    b_alone.prune();
    assert_eq!(min_depth(&b_alone), 15, "B alone stops at depth 15");
    let mut whole = full.clone();
    whole.to_max_likelihood();
    whole.prune();
    assert_eq!(
        min_depth(&whole),
        14,
        "the whole tree prunes B's node at 14"
    );

    let dir = scratch("prune-stop");
    let tiles = [&ta, &tb]
        .into_iter()
        .map(|t| write_tile(&dir, t, depth).unwrap().unwrap())
        .collect();
    index(&dir, 0.1, depth, tiles);
    check_dir(&dir, &full, "prune stop").unwrap();
}

#[test]
fn a_tile_file_changed_between_the_passes_is_an_error() {
    let o = Point3::new(0.05f32, 0.05, 0.05);
    let frames: Vec<Frame> = vec![(o, sphere(o, 6.0, 2000))];
    let dir = scratch("changed");
    spill(&frames, 0.1, 6, &dir);
    let plan = StreamJoin::plan(&dir, TreeFormat::Ot).unwrap();
    let names: Vec<_> = octoquant_tiles::read_index(&dir).unwrap().tiles;
    let (_, victim) = &names[0];
    let mut t = io::read_ot(std::fs::File::open(dir.join(victim)).unwrap()).unwrap();
    let k = t.leaves().next().unwrap().key;
    t.set_node_value(k, 3.5, InnerNodes::Refresh).unwrap();
    io::write_ot(&t, std::fs::File::create(dir.join(victim)).unwrap()).unwrap();
    let e = plan.write(&mut Vec::new()).unwrap_err().to_string();
    assert!(e.contains(victim.as_str()) && e.contains("changed"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]
    #[test]
    fn streamed_equals_sequential(
        frames in frames_strategy(),
        res in prop_oneof![Just(0.1f64), Just(0.2), Just(0.05)],
    ) {
        let want = sequential(&frames, res);
        for depth in [0u8, 1, 3, 6, 9, 12] {
            let dir = scratch(&format!("prop-{depth}"));
            spill(&frames, res, depth, &dir);
            check_dir(&dir, &want, &format!("depth {depth}"))?;
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
}
