//! `octoquant reduce INPUT --cell SIZE[,SIZE...] -o OUTPUT [--json]`: the online grid density
//! reducer over a whole cloud, written as PLY; with `--stream`, input and output stages on two
//! threads (`reduce_stream.rs`).

use super::args::{read_points, ReadArgs};
use super::reduce_stream::{finite, run_stream, StreamJob};
use super::vocab::StorageArg;
use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use nalgebra::Point3;
use octoquant::formats::ply::{write_ply_file, PlyEncoding};
use octoquant::output::check_output;
use octoquant_density::{CentreDistance, DensityGrid, GridSpec, Storage};
use std::path::PathBuf;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// Input cloud: PLY, PCD, VTK, text (`x y z`), ... (all frames are merged, in world
    /// coordinates); `.gz`/`.bz2` allowed.
    input: PathBuf,
    /// Cell size in metres: one value for all axes, or three for x,y,z.
    #[arg(long, value_delimiter = ',', num_args = 1.., required = true)]
    cell: Vec<f64>,
    /// Grid offset: one value for all axes, or three.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    offset: Vec<f64>,
    /// How a cell picks its point: the one nearest the cell centre in metres (`euclidean`, the
    /// paper's criterion) or with each axis in cell units (`cell-units`; differs only when the
    /// cell sizes differ).
    #[arg(long, value_enum, default_value = "euclidean")]
    distance: DistanceArg,
    #[command(flatten)]
    read: ReadArgs,
    /// Output PLY file (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Write an ASCII PLY instead of binary little-endian.
    #[arg(long)]
    ascii: bool,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Stream the input: read it frame by frame, in pieces of `--chunk` points, while the
    /// output stage runs read cycles on its own thread (the paper's two threads); the output
    /// is the last cycle, over everything read (the same points as without `--stream`).
    #[arg(long)]
    stream: bool,
    /// With `--stream`: points per input piece.
    #[arg(long, default_value_t = 65_536, requires = "stream")]
    chunk: usize,
    /// With `--stream`: also write every read cycle's points, as they were when it ran, to
    /// DIR/cycle-000001.ply, ... (each written atomically; the last is the final output; a
    /// DIR that already holds cycle files is refused).
    #[arg(long, value_name = "DIR", requires = "stream")]
    every_cycle: Option<PathBuf>,
    /// With `--stream`: delete these points (a point file in any readable format; equal bit
    /// for bit to input points) after the input, before the last cycle. Needs the
    /// all-members storage, which it selects.
    #[arg(long, value_name = "FILE", requires = "stream")]
    delete: Option<PathBuf>,
    /// With `--stream`: what a cell stores: `one-node` (the paper's: only its best point;
    /// memory grows with cells, not points; the default) or `all-members` (every point, so
    /// that any can be deleted; the default with `--delete`).
    #[arg(long, value_enum, requires = "stream")]
    storage: Option<StorageArg>,
}

/// `--distance`: the grid's centre distance.
#[derive(clap::ValueEnum, Clone, Copy)]
enum DistanceArg {
    Euclidean,
    CellUnits,
}

fn per_axis(v: &[f64], what: &str, default: f64) -> Result<[f64; 3]> {
    match v {
        [] => Ok([default; 3]),
        [s] => Ok([*s; 3]),
        [x, y, z] => Ok([*x, *y, *z]),
        _ => bail!("--{what} takes one value or three (x,y,z), got {}", v.len()),
    }
}

/// The points the grid refused for their cell index (beyond the grid's index range) rather
/// than for a NaN or infinite coordinate; an error, before anything is written, when that is
/// every finite point of a non-empty input: the cell size or offset cannot suit the cloud.
fn check_range(a: &Args, points: u64, non_finite: u64, rejected: u64) -> Result<u64> {
    let out_of_range = rejected.saturating_sub(non_finite);
    if points > non_finite && out_of_range == points - non_finite {
        bail!(
            "{}: every finite point ({out_of_range}) lies beyond the grid's index range \
             (cell indices up to 2^53) with --cell {} and --offset {}; nothing written",
            a.input.display(),
            list(&a.cell),
            if a.offset.is_empty() {
                "0".to_string()
            } else {
                list(&a.offset)
            }
        );
    }
    Ok(out_of_range)
}

fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:?}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// The rejected count split by cause.
fn rejected_line(non_finite: u64, out_of_range: u64) -> String {
    format!(
        "{} ({non_finite} NaN/inf, {out_of_range} beyond the grid's index range)",
        non_finite + out_of_range
    )
}

pub fn run(a: &Args) -> Result<()> {
    let cell = per_axis(&a.cell, "cell", 0.0)?;
    let offset = per_axis(&a.offset, "offset", 0.0)?;
    let spec = GridSpec::new(cell, offset)
        .context("invalid grid")?
        .with_centre_distance(match a.distance {
            DistanceArg::Euclidean => CentreDistance::Euclidean,
            DistanceArg::CellUnits => CentreDistance::CellUnits,
        });
    check_output(&a.output, &["ply"], std::slice::from_ref(&a.input))?;
    if a.stream {
        return run_streamed(a, spec, cell);
    }

    let t0 = Instant::now();
    let points = read_points(&a.input, &a.read.options())?;
    let t_read = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    let mut grid = DensityGrid::new(spec);
    grid.extend_rewalk(
        points
            .iter()
            .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)]),
    );
    let t_grid = t1.elapsed().as_secs_f64();
    let counts = grid.counts();
    let cells = grid.len();
    let non_finite = points.iter().filter(|p| !finite(p)).count() as u64;
    let out_of_range = check_range(a, points.len() as u64, non_finite, counts.rejected)?;

    let t2 = Instant::now();
    let (out, cycle) = grid.output_cycle();
    let t_output = t2.elapsed().as_secs_f64();
    let out: Vec<Point3<f32>> = out
        .iter()
        .map(|p| Point3::new(p[0] as f32, p[1] as f32, p[2] as f32))
        .collect();

    let encoding = if a.ascii {
        PlyEncoding::Ascii
    } else {
        PlyEncoding::BinaryLittleEndian
    };
    write_ply_file(&a.output, &out, encoding)?;

    if a.json {
        print_json(&serde_json::json!({
            "input": json_path(&a.input),
            "output": json_path(&a.output),
            "cell": cell,
            "points": points.len(),
            "rejected": counts.rejected,
            "non_finite": non_finite,
            "out_of_range": out_of_range,
            "grid": cells,
            "eliminated": cycle.eliminated,
            "reduced": out.len(),
            "seconds": {"read": t_read, "grid": t_grid, "output": t_output},
        }))?;
    } else {
        let rate = |n: usize, t: f64| if t > 0.0 { n as f64 / t / 1e6 } else { 0.0 };
        outln!(
            "input:       {} points from {}",
            points.len(),
            a.input.display()
        )?;
        outln!("rejected:    {}", rejected_line(non_finite, out_of_range))?;
        outln!(
            "grid stage:  {cells} points ({} cells), {:.1} ms, {:.1} M pts/s",
            cells,
            t_grid * 1e3,
            rate(points.len(), t_grid)
        )?;
        outln!(
            "elimination: {} points ({} eliminated), {:.1} ms",
            out.len(),
            cycle.eliminated,
            t_output * 1e3
        )?;
        outln!("output:      {}", a.output.display())?;
    }
    Ok(())
}

/// `--stream`: the two-thread reduction, then the same report as a batch run plus the
/// stream's own figures.
fn run_streamed(a: &Args, spec: GridSpec<3>, cell: [f64; 3]) -> Result<()> {
    let encoding = if a.ascii {
        PlyEncoding::Ascii
    } else {
        PlyEncoding::BinaryLittleEndian
    };
    let job = StreamJob {
        input: &a.input,
        read: a.read.options(),
        spec,
        chunk: a.chunk,
        every_cycle: a.every_cycle.as_deref(),
        delete: a.delete.as_deref(),
        storage: a.storage,
        encoding,
    };
    let r = run_stream(&job)?;
    let storage = match r.storage {
        Storage::OneNode => "one-node",
        _ => "all-members",
    };
    let points = r.counts.inserted + r.counts.rejected;
    let out_of_range = check_range(a, points, r.non_finite, r.counts.rejected)?;
    write_ply_file(&a.output, &r.output, encoding)?;
    if a.json {
        print_json(&serde_json::json!({
            "input": json_path(&a.input),
            "output": json_path(&a.output),
            "cell": cell,
            "stream": true,
            "storage": storage,
            "points": points,
            "rejected": r.counts.rejected,
            "non_finite": r.non_finite,
            "out_of_range": out_of_range,
            "stored": r.counts.inserted - r.counts.removed - r.counts.discarded,
            "deleted": r.deleted,
            "not_deleted": r.not_deleted,
            "grid": r.cells,
            "eliminated": r.last_cycle.eliminated,
            "reduced": r.output.len(),
            "cycles": r.cycles,
            "seconds": {"input": r.input_seconds, "output": r.output_seconds},
        }))?;
    } else {
        outln!(
            "input:       {points} points from {} (streamed, {storage} storage)",
            a.input.display()
        )?;
        outln!("rejected:    {}", rejected_line(r.non_finite, out_of_range))?;
        if a.delete.is_some() {
            outln!("deleted:     {} ({} not stored)", r.deleted, r.not_deleted)?;
        }
        outln!("grid stage:  {} points ({} cells)", r.cells, r.cells)?;
        outln!(
            "elimination: {} points ({} eliminated), last of {} read cycles, {:.1} ms",
            r.output.len(),
            r.last_cycle.eliminated,
            r.cycles,
            r.output_seconds * 1e3
        )?;
        outln!("output:      {}", a.output.display())?;
    }
    Ok(())
}
