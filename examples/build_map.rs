//! Frames -> map -> .bt: scan the built-in scene with the simulated LiDAR, insert every frame
//! into an occupancy octree and write it as an OctoMap `.bt` file.
//!
//! `cargo run --release --example build_map -- [OUT.bt]` (default `scene.bt`).

use octoquant::pipeline::{Mapper, MapperOptions};
use octoquant::scene::{scan_lidar, ScanOptions, Scene, SpinningLidar};
use octoquant::treefile::write_tree_file;
use std::path::PathBuf;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "scene.bt".into()));

    // Frames: any source works (formats::read_frames, formats::mcap, ...); here the
    // simulated LiDAR, one frame per revolution, misses returned beyond max range.
    let scene = Scene::builtin();
    let lidar = SpinningLidar::builtin_path();
    let (frames, _stats) = scan_lidar(&scene, &lidar, &ScanOptions::default())?;

    // Map: OctoMap's insertPointCloud per frame; max_range turns misses into free space.
    let mut mapper = Mapper::new(MapperOptions {
        resolution: 0.1,
        max_range: Some(lidar.max_range),
        ..MapperOptions::default()
    })?;
    for frame in &frames {
        mapper.insert(frame);
    }
    let mut tree = mapper.into_tree();

    // .bt: max-likelihood and pruned, byte-identical to what OctoMap would write.
    write_tree_file(&mut tree, &out)?;
    let c = tree.counts();
    println!(
        "{} frames -> {} ({} leaves, {} occupied)",
        frames.len(),
        out.display(),
        c.leaves,
        c.occupied_leaves
    );
    Ok(())
}
