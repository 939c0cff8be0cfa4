//! The tiled build (split by tile, apply per tile, join) on real data gives the `.ot` and
//! `.bt` bytes of the sequential `Mapper`, for several tile depths and batch sizes.

use crate::common::{self, first_diff};
use octoquant::formats::{read_frames, ReadOptions, TumOptions};
use octoquant::octree::io::{write_bt, write_ot};
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::tiled::{build_tiled, default_tile_depth, TiledError};
use octoquant::Frame;

fn bytes(tree: &octoquant::OcTree) -> (Vec<u8>, Vec<u8>) {
    let (mut ot, mut bt) = (Vec::new(), Vec::new());
    write_ot(tree, &mut ot).unwrap();
    write_bt(&mut tree.clone(), &mut bt).unwrap();
    (ot, bt)
}

fn check(what: &str, frames: &[Frame], options: &MapperOptions, depths: &[u8]) {
    let mut m = Mapper::new(options.clone()).unwrap();
    m.insert_frames(frames);
    let want_stats = *m.stats();
    let (wot, wbt) = bytes(m.tree());
    for &depth in depths {
        for batch in [1, 2] {
            let (tree, stats) = build_tiled(options, depth, frames, batch).unwrap();
            let (ot, bt) = bytes(&tree);
            let at = format!("{what}, tile depth {depth}, {batch} frames per batch");
            assert!(ot == wot, "{at}: .ot {}", first_diff(&ot, &wot));
            assert!(bt == wbt, "{at}: .bt {}", first_diff(&bt, &wbt));
            assert_eq!(stats.frames, frames.len(), "{at}");
            assert_eq!(
                (stats.total.rays, stats.total.free, stats.total.occupied),
                (
                    want_stats.total.rays,
                    want_stats.total.free,
                    want_stats.total.occupied
                ),
                "{at}"
            );
        }
    }
}

#[test]
fn norlab_frames_tiled_match_the_mapper() {
    let Some(dir) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames = read_frames(&dir, &ReadOptions::default()).unwrap();
    // 3 frames, every 3rd point: up to 195 m rays
    let frames: Vec<Frame> = frames
        .into_iter()
        .take(3)
        .map(|f| Frame {
            points: f.points.into_iter().step_by(3).collect(),
            ..f
        })
        .collect();
    for max_range in [None, Some(20.0)] {
        let options = MapperOptions {
            resolution: 0.2,
            max_range,
            ..MapperOptions::default()
        };
        let depths = [1, 3, 6, default_tile_depth(0.2), 12];
        check(
            &format!("norlab, max range {max_range:?}"),
            &frames,
            &options,
            &depths,
        );
    }
}

#[test]
fn tum_frames_tiled_match_the_mapper() {
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let opts = ReadOptions {
        tum: TumOptions {
            pixel_step: 4,
            ..TumOptions::default()
        },
        ..ReadOptions::default()
    };
    let frames: Vec<Frame> = read_frames(&assoc, &opts)
        .unwrap()
        .into_iter()
        .take(4)
        .collect();
    let options = MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    };
    check("tum", &frames, &options, &[1, 3, 6, 10, 14]);
    // quantized mode's voxel sets travel the same way
    let options = MapperOptions {
        resolution: 0.05,
        mode: InsertMode::Quantized,
        max_range: Some(3.0),
        ..MapperOptions::default()
    };
    check("tum quantized", &frames, &options, &[3, 9]);
}

#[test]
fn tiled_builds_refuse_what_they_cannot_reproduce() {
    let options = MapperOptions {
        mode: InsertMode::Simple,
        ..MapperOptions::default()
    };
    let e = build_tiled(&options, 3, &[], 1).unwrap_err();
    assert!(matches!(e, TiledError::Caster(_)), "{e}");
    let options = MapperOptions {
        lazy: true,
        ..MapperOptions::default()
    };
    assert!(matches!(
        build_tiled(&options, 3, &[], 1),
        Err(TiledError::Lazy)
    ));
    let e = build_tiled(&MapperOptions::default(), 17, &[], 1).unwrap_err();
    assert!(e.to_string().contains("tile depth 17"), "{e}");
}

/// Out of core: the tiles written to a directory (one .ot per tile plus the index), then
/// assembled by `join_dir` and by `octoquant join`, give the sequential map's bytes.
#[test]
fn norlab_tiles_spilled_to_a_directory_join_to_the_mapper_map() {
    let Some(src) = common::data_file("lidar3d/norlab_icp_mapper_example") else {
        return;
    };
    let frames: Vec<Frame> = read_frames(&src, &ReadOptions::default())
        .unwrap()
        .into_iter()
        .take(4)
        .map(|f| Frame {
            points: f.points.into_iter().step_by(3).collect(),
            ..f
        })
        .collect();
    let options = MapperOptions {
        resolution: 0.2,
        max_range: Some(30.0),
        ..MapperOptions::default()
    };
    let mut m = Mapper::new(options.clone()).unwrap();
    m.insert_frames(&frames);
    let (wot, wbt) = bytes(m.tree());
    for depth in [4, default_tile_depth(0.2)] {
        let dir = common::scratch(&format!("tiled_spill_{depth}"));
        let tiles = dir.join("tiles");
        std::fs::create_dir(&tiles).unwrap();
        let (index, _) =
            octoquant::tiled::build_tiled_to_dir(&options, depth, &frames, 2, &tiles).unwrap();
        assert!(index.tiles.len() > 1, "several tiles at depth {depth}");
        let files = std::fs::read_dir(&tiles).unwrap().count();
        assert_eq!(
            files,
            index.tiles.len() + 1,
            "one file per tile plus the index"
        );
        let back = octoquant::tiles::read_index(&tiles).unwrap();
        assert_eq!(back, index);
        let (ot, bt) = bytes(&octoquant::tiles::join_dir(&tiles).unwrap());
        assert!(ot == wot, "depth {depth}: .ot {}", first_diff(&ot, &wot));
        assert!(bt == wbt, "depth {depth}: .bt {}", first_diff(&bt, &wbt));
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("join")
            .arg(&tiles)
            .arg("-o")
            .arg(dir.join("map.ot"))
            .arg("-o")
            .arg(dir.join("map.bt"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(std::fs::read(dir.join("map.ot")).unwrap() == wot);
        assert!(std::fs::read(dir.join("map.bt")).unwrap() == wbt);
        // a tile file swapped for another tile's is named in the error
        if let [(_, a), (_, b), ..] = &index.tiles[..] {
            std::fs::copy(tiles.join(a), tiles.join(b)).unwrap();
            let e = octoquant::tiles::join_dir(&tiles).unwrap_err().to_string();
            assert!(
                e.contains(b.as_str()) && e.contains("where the index names"),
                "{e}"
            );
        }
        std::fs::remove_file(tiles.join(octoquant::tiles::INDEX_FILE)).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_octoquant"))
            .arg("join")
            .arg(&tiles)
            .arg("-o")
            .arg(dir.join("again.bt"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        assert!(String::from_utf8_lossy(&out.stderr).contains("tiles.index"));
        assert!(!dir.join("again.bt").exists());
    }
}
