//! `octoquant simulate --scene city --frames N --seed S -o OUT.frames`: scan a built-in scene
//! with its simulated sensors and write the frames, as input for `map`, `bench` or a
//! distributed build. `--scene builtin --carve-misses` gives the frames `map` maps without
//! inputs (the terrestrial scanner and the LiDAR in the small building); `--scene city` a seeded city
//! (blocks of buildings, streets, trees, parked cars) driven by a car-mounted spinning LiDAR,
//! one frame per metre of route. The `.frames` file keeps each frame's scan time, so
//! `map --stamped` of it stamps the scans as the simulation timed them.

use super::vocab::SceneArg;
use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::formats::frames::write_frames_file;
use octoquant::output::check_output;
use octoquant::scene::{
    scan_lidar, scan_terrestrial, City, CityOptions, MissPolicy, ScanOptions, ScanStats, Scene,
    SceneError, SpinningLidar, TerrestrialScanner,
};
use octoquant::Frame;
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// The scene: `builtin` (the small building of `demo` and `map` without inputs) or `city`.
    #[arg(long, value_enum, default_value = "city")]
    scene: SceneArg,
    /// City: the number of LiDAR frames (one per metre of route).
    #[arg(long, default_value_t = 1000)]
    frames: usize,
    /// Seed of the city's layout and route, and of the sensor noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// City: blocks along x and y.
    #[arg(long, num_args = 2, value_names = ["NX", "NY"])]
    blocks: Option<Vec<u32>>,
    /// City: LiDAR rings (default 16, from −15° to 15°).
    #[arg(long)]
    rings: Option<u32>,
    /// City: LiDAR firings per revolution (default 1024).
    #[arg(long)]
    columns: Option<u32>,
    /// Range noise (standard deviation), metres.
    #[arg(long, default_value_t = 0.01)]
    noise: f64,
    /// Return beams that hit nothing as readings just beyond the sensor's range (80 m in the
    /// city, 30 m in the built-in scene), to carve free space when mapped with that
    /// --max-range; without it they are dropped.
    #[arg(long)]
    carve_misses: bool,
    /// Output .frames file.
    #[arg(short, long)]
    output: PathBuf,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

/// A scene error, with a scanner or city option named as the command-line option that set
/// it (`--rings`, not the field `rings`).
fn option_error(e: SceneError) -> anyhow::Error {
    if let SceneError::InvalidOption { name, message } = &e {
        let option = match *name {
            "rings" => Some("--rings"),
            "columns" => Some("--columns"),
            "frames" => Some("--frames"),
            "blocks_x" | "blocks_y" => Some("--blocks"),
            "range_noise" => Some("--noise"),
            _ => None,
        };
        if let Some(option) = option {
            return anyhow::anyhow!("{option}: {message}");
        }
    }
    e.into()
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &["frames"], &[])?;
    let options = ScanOptions {
        seed: a.seed,
        range_noise: a.noise,
        misses: if a.carve_misses {
            MissPolicy::MaxRange
        } else {
            MissPolicy::Drop
        },
    };
    let t = Instant::now();
    let (frames, stats, shapes, extent): (Vec<Frame>, Vec<ScanStats>, usize, _) = match a.scene {
        SceneArg::Builtin => {
            if a.blocks.is_some() || a.rings.is_some() || a.columns.is_some() {
                bail!("--blocks, --rings and --columns are options of --scene city");
            }
            let scene = Scene::builtin();
            let (mut f, mut s) =
                scan_terrestrial(&scene, &TerrestrialScanner::builtin(&scene), &options)
                    .map_err(option_error)?;
            let (lf, ls) = scan_lidar(&scene, &SpinningLidar::builtin_path(), &options)
                .map_err(option_error)?;
            f.extend(lf);
            s.extend(ls);
            (f, s, scene.len(), scene.bounds())
        }
        SceneArg::City => {
            let mut city_options = CityOptions {
                seed: a.seed,
                ..CityOptions::default()
            };
            if let Some([nx, ny]) = a.blocks.as_deref() {
                city_options.blocks_x = *nx;
                city_options.blocks_y = *ny;
            }
            let city = City::generate(&city_options).map_err(option_error)?;
            let scene = city.scene();
            let mut lidar = city.lidar(a.frames).map_err(option_error)?;
            if let Some(r) = a.rings {
                lidar.rings = r;
            }
            if let Some(c) = a.columns {
                lidar.columns = c;
            }
            let (f, s) = scan_lidar(&scene, &lidar, &options).map_err(option_error)?;
            (f, s, scene.len(), scene.bounds())
        }
    };
    let scan_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    write_frames_file(&a.output, &frames)?;
    let write_s = t.elapsed().as_secs_f64();
    let points: usize = frames.iter().map(|f| f.points.len()).sum();
    let rays: usize = stats.iter().map(|s| s.rays).sum();
    let hits: usize = stats.iter().map(|s| s.hits).sum();
    let misses: usize = stats.iter().map(|s| s.misses).sum();
    let (lo, hi) = extent;
    if a.json {
        print_json(&serde_json::json!({
            "output": json_path(&a.output),
            "scene": match a.scene { SceneArg::Builtin => "builtin", SceneArg::City => "city" },
            "seed": a.seed,
            "shapes": shapes,
            "bounds": [[lo.x, lo.y, lo.z], [hi.x, hi.y, hi.z]],
            "frames": frames.len(),
            "points": points,
            "rays": rays,
            "hits": hits,
            "misses": misses,
            "scan_seconds": scan_s,
            "write_seconds": write_s,
        }))?;
        return Ok(());
    }
    outln!(
        "scene: {shapes} shapes over {:.0} m × {:.0} m × {:.0} m",
        hi.x - lo.x,
        hi.y - lo.y,
        hi.z - lo.z
    )?;
    outln!(
        "{} frames, {rays} rays, {hits} hits, {misses} misses ({}), {points} points; scanned in {scan_s:.1} s",
        frames.len(),
        if a.carve_misses { "returned beyond the range" } else { "dropped" }
    )?;
    outln!("wrote {} ({write_s:.1} s)", a.output.display())?;
    Ok(())
}
