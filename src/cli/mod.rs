//! Command-line parsing (clap) and dispatch; one file per subcommand.

/// `println!` that returns the write's `io::Result` instead of panicking: a reader that
/// closes the pipe early (`octoquant info map.bt | head -2`) must not make the program panic.
/// See [`main`], which then ends quietly with status 141.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
    }};
}

/// A status line on stderr. Unlike `eprintln!` it never panics: when stderr is closed or its
/// reader has gone, the message is lost and the work goes on (the output files are what
/// counts).
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod args;
mod bench;
mod compare;
mod convert;
mod crop;
mod demo;
mod distance;
mod eval;
mod export;
mod fresh_dir;
mod grid;
mod import;
mod info;
mod join;
mod map;
mod merge;
mod progress;
mod query;
mod reduce;
mod reduce_stream;
mod render;
mod segment;
mod simulate;
mod vocab;

use clap::{Parser, Subcommand};

/// OctoMap-compatible occupancy mapping, fast.
#[derive(Parser)]
#[command(name = "octoquant", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Scan the built-in scene, build the map, write map.bt and map.png (into a new directory
    /// unless --out names one), print timings.
    Demo(demo::Args),
    /// Draw a map as PNG: height-coloured top view, front/side view, or a slice.
    Render(render::Args),
    /// Export occupied (and free) voxels as PLY points or cubes.
    Export(export::Args),
    /// Build a map from sensor files (or the built-in scene): OctoMap's insertPointCloud.
    Map(map::Args),
    /// Time the insertion modes on the same frames, optionally against OctoMap, as ratios.
    Bench(bench::Args),
    /// Summarise a .bt or .ot map: resolution, nodes, leaves, bounds, bytes per node.
    Info(info::Args),
    /// Convert between .bt and .ot (by extension).
    Convert(convert::Args),
    /// Compare two maps voxel by voxel: class agreement, changed volume, and the KLD of
    /// OctoMap's compare_octrees.
    Compare(compare::Args),
    /// Keep the voxels of a box (inclusive in keys, as OctoMap's bounding boxes), delete the
    /// rest.
    Crop(crop::Args),
    /// Thin a point cloud with the online grid density reducer; writes PLY.
    Reduce(reduce::Args),
    /// Project a height band of a map onto a 2D occupancy grid (ROS map_server / Nav2 YAML + PGM).
    Grid(grid::Args),
    /// Fuse maps built separately: each later map's leaves applied to the first as log-odds
    /// updates (OctoMap's updateNode, the first map's clamping).
    Merge(merge::Args),
    /// Assemble a tile directory (one .ot per tile plus tiles.index, from a tiled build's
    /// spill directory) into one map.
    Join(join::Args),
    /// Scan a built-in scene (the small building or a seeded city driven by a car-mounted
    /// LiDAR) with its simulated sensors and write the frames as .frames.
    Simulate(simulate::Args),
    /// Segment 2D laser scans of a CARMEN log into lines (one scan, or --all with timing).
    Segment(segment::Args),
    /// How well a map predicts scans (OctoMap's eval_octree_accuracy): the share of the
    /// scans' free and end-point voxels the map holds in the same class.
    Eval(eval::Args),
    /// Turn binvox voxel grids into a map (OctoMap's binvox2bt).
    Import(import::Args),
    /// Look up points (class, probability, depth of the node found) and cast rays (castRay)
    /// in a map.
    Query(query::Args),
    /// Distances to the nearest obstacle (OctoMap's dynamicEDT3D) at points, or a picture of
    /// a horizontal slice.
    Distance(distance::Args),
}

pub fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Demo(a)) => demo::run(&a),
        Some(Command::Render(a)) => render::run(&a),
        Some(Command::Export(a)) => export::run(&a),
        Some(Command::Map(a)) => map::run(&a),
        Some(Command::Bench(a)) => bench::run(&a),
        Some(Command::Info(a)) => info::run(&a),
        Some(Command::Convert(a)) => convert::run(&a),
        Some(Command::Compare(a)) => compare::run(&a),
        Some(Command::Crop(a)) => crop::run(&a),
        Some(Command::Reduce(a)) => reduce::run(&a),
        Some(Command::Segment(a)) => segment::run(&a),
        Some(Command::Grid(a)) => grid::run(&a),
        Some(Command::Eval(a)) => eval::run(&a),
        Some(Command::Import(a)) => import::run(&a),
        Some(Command::Query(a)) => query::run(&a),
        Some(Command::Distance(a)) => distance::run(&a),
        Some(Command::Merge(a)) => merge::run(&a),
        Some(Command::Join(a)) => join::run(&a),
        Some(Command::Simulate(a)) => simulate::run(&a),
        None => demo::run_default(),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // the reader of the output went away (a pipe into `head`): stop quietly with the
        // status of a C tool that SIGPIPE ended (128 + 13), since the work may be unfinished
        Err(e) if closed_pipe(&e) => std::process::ExitCode::from(141),
        Err(e) => {
            errln!("octoquant: error: {}", describe(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// A file name as a JSON string: names that are not UTF-8 are printed lossily (each invalid
/// sequence as U+FFFD), the same as in the text output; `serde_json` escapes quotes,
/// backslashes and control characters, so the JSON stays valid for any name.
/// Bytes per node of a tree holding `bytes` for `nodes` nodes (0 for an empty tree): the
/// summaries' `bytes/node` (`map`, `info`).
fn per_node(bytes: usize, nodes: usize) -> f64 {
    if nodes == 0 {
        0.0
    } else {
        bytes as f64 / nodes as f64
    }
}

fn json_path(path: &std::path::Path) -> serde_json::Value {
    serde_json::Value::String(path.to_string_lossy().into_owned())
}

/// Print `value` as one line of JSON on stdout (non-finite numbers are `null`, as
/// `serde_json` writes them).
fn print_json(value: &serde_json::Value) -> std::io::Result<()> {
    outln!("{value}")
}

/// An error and its causes on one line, each cause once: the library errors already name
/// their source in their own message (so that they read well alone), and repeating it after
/// a colon, as `{:#}` does, would print it twice.
fn describe(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Whether `e` comes from writing to a pipe whose reader has closed it.
fn closed_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
