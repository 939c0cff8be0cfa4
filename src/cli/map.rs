//! `octoquant map INPUT... --res R ... -o OUT.bt`: build a map from sensor files.

use super::args::{InputArgs, TreeArgs};
use super::vocab::{ModeArg, RayArg};
use anyhow::{bail, Context, Result};
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::scene::{
    scan_lidar, scan_terrestrial, ScanOptions, Scene, SpinningLidar, TerrestrialScanner,
};
use octoquant::treefile::write_tree_file;
use octoquant::{Frame, OccupancyParams};
use octoquant_raycast::RayModel;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    tree: TreeArgs,
    /// OctoMap's discretize: one ray per end-point voxel, to its centre.
    #[arg(long)]
    discretize: bool,
    /// Insertion mode; `quantized` gives the same tree as --discretize via the dense bit grid,
    /// `quantized+bresenham` is `quantized` with --ray bresenham, `simple` is graph2tree's
    /// -simple (no deduplication, max range ignored).
    #[arg(long, value_enum)]
    mode: Option<ModeArg>,
    /// Ray model: `dda` (OctoMap's, exact) or `bresenham` (integer lines between voxel keys,
    /// implies the quantization pre-pass; faster, slightly less free space).
    #[arg(long, value_enum, default_value = "dda")]
    ray: RayArg,
    /// Lazy insertion: inner nodes are updated once at the end.
    #[arg(long)]
    lazy: bool,
    /// Clamping probabilities (OctoMap defaults 0.1192 0.971).
    #[arg(long, num_args = 2, value_names = ["PMIN", "PMAX"])]
    clamping: Option<Vec<f64>>,
    /// Sensor model, miss first as in graph2tree (defaults 0.4 0.7).
    #[arg(long, num_args = 2, value_names = ["PMISS", "PHIT"])]
    sensor: Option<Vec<f64>>,
    /// Thin each frame with the online density reducer first (cell size, metres).
    #[arg(long)]
    reduce: Option<f64>,
    #[command(flatten)]
    input: InputArgs,
    /// Output .bt (max-likelihood, pruned, as OctoMap writes it).
    #[arg(short, long, default_value = "map.bt")]
    output: PathBuf,
    /// Also write the full tree as .ot (before the .bt's max-likelihood conversion).
    #[arg(long)]
    ot: Option<PathBuf>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

fn builtin_frames() -> Result<Vec<Frame>> {
    let scene = Scene::builtin();
    let opts = ScanOptions::default();
    let (mut frames, _) = scan_terrestrial(&scene, &TerrestrialScanner::builtin(&scene), &opts)?;
    frames.extend(scan_lidar(&scene, &SpinningLidar::builtin_path(), &opts)?.0);
    Ok(frames)
}

/// The insertion mode that --mode, --discretize and --ray ask for together.
fn insert_mode(a: &Args) -> Result<InsertMode> {
    let mode = match a.mode {
        None if a.discretize => InsertMode::Discretize,
        None => InsertMode::Exact,
        Some(ModeArg::Exact) if a.discretize => bail!("--discretize contradicts --mode exact"),
        Some(m) => m.into(),
    };
    match (RayModel::from(a.ray), mode) {
        (RayModel::Dda, m) => Ok(m),
        (RayModel::Bresenham, InsertMode::Simple) => {
            bail!("--ray bresenham does not apply to --mode {}", mode.name())
        }
        (RayModel::Bresenham, _) => Ok(InsertMode::QuantizedBresenham),
    }
}

/// The mapper settings the arguments ask for, checked.
fn mapper_options(a: &Args) -> Result<MapperOptions> {
    let mode = insert_mode(a)?;
    let (pmin, pmax) = match &a.clamping {
        Some(v) => (v[0], v[1]),
        None => (0.1192, 0.971),
    };
    let (pmiss, phit) = match &a.sensor {
        Some(v) => (v[0], v[1]),
        None => (0.4, 0.7),
    };
    let params = OccupancyParams::from_probabilities(phit, pmiss, pmin, pmax, 0.5)
        .context("invalid --clamping/--sensor")?;
    if let Some(c) = a.reduce {
        if !(c.is_finite() && c > 0.0) {
            bail!("--reduce needs a positive cell size, got {c}");
        }
    }
    Ok(MapperOptions {
        resolution: a.tree.res,
        params,
        max_range: a.tree.max_range()?,
        mode,
        lazy: a.lazy,
        reduce: a.reduce.map(|c| [c; 3]),
        ..MapperOptions::default()
    })
}

pub fn run(a: &Args) -> Result<()> {
    let options = mapper_options(a)?;
    let mut mapper = Mapper::new(options).context("invalid --res")?;

    let t_load = Instant::now();
    let frames = if a.input.inputs.is_empty() {
        errln!("no input given: mapping the built-in scene (pass files to map your own data)");
        builtin_frames()?
    } else {
        a.input.read_frames()?
    };
    let load_s = t_load.elapsed().as_secs_f64();
    let progress = std::io::stderr().is_terminal() && !a.json;
    // pipelined in chunks, so that progress can still be shown
    let mut done = 0;
    for chunk in frames.chunks(16) {
        mapper.insert_frames(chunk);
        done += chunk.len();
        if progress {
            err!("\rinserting frame {}/{}", done, frames.len());
        }
    }
    if progress {
        errln!();
    }
    mapper.finish();
    let stats = *mapper.stats();
    let mut tree = mapper.into_tree();
    // blocks freed by pruning are kept for reuse while mapping; measure (and write) the tree
    // as it stands, as `bench` and `info` do
    tree.shrink_to_fit();
    let full_nodes = tree.size();
    let bytes_per_node = if full_nodes > 0 {
        tree.memory_usage() as f64 / full_nodes as f64
    } else {
        0.0
    };
    if let Some(ot) = &a.ot {
        write_tree_file(&mut tree, ot)?;
    }
    write_tree_file(&mut tree, &a.output)?;
    let t = &stats.total;
    let pps = if t.seconds > 0.0 {
        t.points as f64 / t.seconds
    } else {
        0.0
    };
    if a.json {
        outln!(
            "{{\"frames\":{},\"points\":{},\"non_finite\":{},\"outside_map\":{},\"rays\":{},\"heads_skipped\":{},\"free_updates\":{},\"occupied_updates\":{},\"load_seconds\":{:.6},\"insert_seconds\":{:.6},\"points_per_second\":{:.1},\"nodes\":{},\"bytes_per_node\":{:.3},\"bt_nodes\":{},\"output\":{:?}}}",
            stats.frames, t.points, t.non_finite, t.outside_map, t.rays, t.heads_skipped, t.free, t.occupied,
            load_s, t.seconds, pps, full_nodes, bytes_per_node, tree.size(),
            a.output.display().to_string()
        )?;
    } else {
        outln!("frames:          {}", stats.frames)?;
        outln!(
            "points:          {} ({} non-finite and {} outside the map skipped)",
            t.points,
            t.non_finite,
            t.outside_map
        )?;
        outln!(
            "rays:            {} ({} walked from where their neighbours stop covering them)",
            t.rays,
            t.heads_skipped
        )?;
        outln!("loading:         {load_s:.3} s")?;
        outln!(
            "insertion:       {:.3} s, {:.0} points/s (rays {:.3} s, tree {:.3} s)",
            t.seconds,
            pps,
            t.ray_seconds,
            t.tree_seconds
        )?;
        outln!(
            "tree:            {} nodes, {:.2} bytes/node ({} nodes in the .bt after ML + prune)",
            full_nodes,
            bytes_per_node,
            tree.size()
        )?;
        outln!("wrote:           {}", a.output.display())?;
    }
    Ok(())
}
