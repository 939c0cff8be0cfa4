//! `octoquant demo --out DIR`: scan the built-in scene, build the map in each insertion mode,
//! write `map.bt` and `map.png`, print a timing table. Without `--out` (and so `octoquant`
//! alone) it writes into a new directory, `octoquant-demo/` or `octoquant-demo-N/`, and says
//! which: trying the tool never overwrites a file.

use super::args::TreeArgs;
use super::fresh_dir::{create_fresh_dir, DEMO_DIR};
use super::{json_path, print_json};
use anyhow::{Context, Result};
use clap::Parser;
use octoquant::output::check_writable;
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::render::{render_png_file, RenderOptions};
use octoquant::scene::{
    scan_depth, scan_lidar, scan_terrestrial, DepthCamera, MissPolicy, ScanOptions, ScanStats,
    Scene, SpinningLidar, TerrestrialScanner,
};
use octoquant::treefile::write_tree_file;
use octoquant::{Frame, OcTree};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Output directory for map.bt and map.png (created if missing). Default: a new directory
    /// `octoquant-demo/` (or `octoquant-demo-2/`, ... when it exists) in the current one.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    tree: TreeArgs,
    /// Range noise (standard deviation), metres.
    #[arg(long, default_value_t = 0.01)]
    noise: f64,
    /// LiDAR rings.
    #[arg(long, default_value_t = 16)]
    rings: u32,
    /// LiDAR firings per revolution.
    #[arg(long, default_value_t = 1024)]
    columns: u32,
    /// Metres of path between LiDAR frames.
    #[arg(long, default_value_t = 0.5)]
    spacing: f64,
    /// Angular step of the terrestrial scanner, degrees.
    #[arg(long, default_value_t = 0.5)]
    step: f64,
    /// Skip the terrestrial scanner.
    #[arg(long)]
    no_terrestrial: bool,
    /// Skip the LiDAR.
    #[arg(long)]
    no_lidar: bool,
    /// Skip the depth camera (320 x 240 images, whose rays exact insertion walks only where
    /// neighbouring pixels do not cover them).
    #[arg(long)]
    no_depth: bool,
    /// Return beams that hit nothing as max-range readings so they carve free space (as
    /// OctoMap users do). The scene has no roof, so this clears the sky to 30 m around every
    /// pose: tens of millions of free voxels at 0.1 m, and a much slower demo.
    #[arg(long)]
    carve_misses: bool,
    /// Print the summary as one JSON object on stdout instead of the tables.
    #[arg(long)]
    json: bool,
}

/// Parses the defaults of [`Args`], for `octoquant` with no subcommand.
#[derive(Parser)]
struct Defaults {
    #[command(flatten)]
    args: Args,
}

/// The demo with every option at its default, writing into a new directory.
pub fn run_default() -> Result<()> {
    run(&Defaults::parse_from(["octoquant"]).args)
}

struct Row {
    label: String,
    seconds: f64,
    tree: OcTree,
}

pub fn run(a: &Args) -> Result<()> {
    // the options are checked before a directory is made
    let resolution = a.tree.resolution()?;
    let max_range = a.tree.max_range()?;
    let scene = Scene::builtin();
    let options = ScanOptions {
        seed: a.seed,
        range_noise: a.noise,
        misses: if a.carve_misses {
            MissPolicy::MaxRange
        } else {
            MissPolicy::Drop
        },
    };
    let mut lidar = SpinningLidar::builtin_path();
    lidar.rings = a.rings;
    lidar.columns = a.columns;
    lidar.frame_spacing = a.spacing;
    let mut tls = TerrestrialScanner::builtin(&scene);
    tls.angular_step_deg = a.step;
    // the scanners return their misses beyond this range; insertion clears space up to it
    // unless --max-range says otherwise
    let scan_range = lidar.max_range.max(tls.max_range);
    let max_range = max_range.unwrap_or(scan_range);

    // the scanners' settings too: an error names the options and leaves no directory behind
    options.validate().context("invalid --noise")?;
    if !a.no_lidar {
        lidar
            .validate()
            .context("invalid --rings/--columns/--spacing")?;
    }
    if !a.no_terrestrial {
        tls.validate().context("invalid --step")?;
    }
    let out = match &a.out {
        Some(dir) => {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create {}", dir.display()))?;
            dir.clone()
        }
        None => {
            let dir = create_fresh_dir(Path::new("."), DEMO_DIR)?;
            errln!(
                "writing into {}/ (a new directory; --out DIR to choose)",
                dir.display()
            );
            dir
        }
    };
    let bt = out.join("map.bt");
    let png = out.join("map.png");
    check_writable(&bt)?;
    let mut frames: Vec<Frame> = Vec::new();
    let mut stats: Vec<ScanStats> = Vec::new();
    let mut scan_rows = Vec::new();
    if !a.no_terrestrial {
        let t = Instant::now();
        let (f, s) = scan_terrestrial(&scene, &tls, &options)?;
        scan_rows.push(("terrestrial", f.len(), t.elapsed().as_secs_f64()));
        frames.extend(f);
        stats.extend(s);
    }
    if !a.no_lidar {
        let t = Instant::now();
        let (f, s) = scan_lidar(&scene, &lidar, &options)?;
        scan_rows.push(("lidar", f.len(), t.elapsed().as_secs_f64()));
        frames.extend(f);
        stats.extend(s);
    }
    if !a.no_depth {
        let t = Instant::now();
        let (f, s) = scan_depth(&scene, &DepthCamera::builtin(&scene), &options)?;
        scan_rows.push(("depth camera", f.len(), t.elapsed().as_secs_f64()));
        frames.extend(f);
        stats.extend(s);
    }
    let points: usize = frames.iter().map(|f| f.points.len()).sum();
    let rays: usize = stats.iter().map(|s| s.rays).sum();
    let hits: usize = stats.iter().map(|s| s.hits).sum();
    let misses: usize = stats.iter().map(|s| s.misses).sum();
    if !a.json {
        outln!(
            "scene: {} shapes; {} frames, {} rays, {} hits, {} misses ({})",
            scene.len(),
            frames.len(),
            rays,
            hits,
            misses,
            if a.carve_misses {
                format!("returned beyond {scan_range} m to carve free space")
            } else {
                "dropped; --carve-misses to carve free space with them".to_string()
            }
        )?;
        for (name, n, s) in &scan_rows {
            outln!("  simulated {name:<12} {n:>4} frames in {s:>7.3} s")?;
        }
    }

    // (mode, lazy insertion)
    let modes = [
        (InsertMode::Exact, false),
        (InsertMode::Exact, true),
        (InsertMode::Discretize, false),
        (InsertMode::Quantized, false),
        (InsertMode::QuantizedBresenham, false),
    ];
    let mut rows = Vec::new();
    for (mode, lazy) in modes {
        let mut mapper = Mapper::new(MapperOptions {
            resolution,
            max_range: Some(max_range),
            mode,
            lazy,
            ..MapperOptions::default()
        })?;
        let t = Instant::now();
        for f in &frames {
            mapper.insert(f);
        }
        let tree = mapper.into_tree();
        rows.push(Row {
            label: if lazy {
                format!("{} --lazy", mode.name())
            } else {
                mode.name().to_string()
            },
            seconds: t.elapsed().as_secs_f64(),
            tree,
        });
    }

    let exact_s = rows[0].seconds;
    if !a.json {
        outln!()?;
        outln!(
            "{:<20} {:>9} {:>12} {:>9} {:>11} {:>10} {:>10}",
            "mode",
            "seconds",
            "points/s",
            "vs exact",
            "nodes",
            "leaves",
            "occupied"
        )?;
        for r in &rows {
            let c = r.tree.counts();
            outln!(
                "{:<20} {:>9.3} {:>12.0} {:>8.2}x {:>11} {:>10} {:>10}",
                r.label,
                r.seconds,
                points as f64 / r.seconds.max(1e-9),
                exact_s / r.seconds.max(1e-9),
                c.nodes,
                c.leaves,
                c.occupied_leaves
            )?;
        }
    }
    let rows_summary: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let c = r.tree.counts();
            serde_json::json!({
                "mode": r.label,
                "seconds": r.seconds,
                "points_per_second": points as f64 / r.seconds.max(1e-9),
                "speedup_vs_exact": exact_s / r.seconds.max(1e-9),
                "nodes": c.nodes,
                "leaves": c.leaves,
                "occupied_leaves": c.occupied_leaves,
            })
        })
        .collect();
    let mut tree = rows.swap_remove(0).tree;
    let t = Instant::now();
    write_tree_file(&mut tree, &bt)?;
    let t_bt = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let image = render_png_file(&tree, &png, &RenderOptions::default())?;
    let t_png = t.elapsed().as_secs_f64();
    if a.json {
        let runs: Vec<serde_json::Value> = rows_summary;
        print_json(&serde_json::json!({
            "directory": json_path(&out),
            "bt": json_path(&bt),
            "png": json_path(&png),
            "shapes": scene.len(),
            "frames": frames.len(),
            "points": points,
            "rays": rays,
            "hits": hits,
            "misses": misses,
            "max_range": max_range,
            "runs": runs,
            "bt_seconds": t_bt,
            "png_seconds": t_png,
            "png_size": [image.width, image.height],
        }))?;
        return Ok(());
    }
    outln!()?;
    outln!("wrote {} ({t_bt:.3} s, exact mode)", bt.display())?;
    outln!(
        "wrote {} ({} × {} px, {t_png:.3} s)",
        png.display(),
        image.width,
        image.height
    )?;
    Ok(())
}
