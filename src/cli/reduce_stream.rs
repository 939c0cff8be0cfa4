//! `octoquant reduce --stream`: the density reducer as the paper runs it, input and output
//! stages on two threads over one store.
//!
//! This thread reads the input frame by frame ([`frame_stream`]) and inserts each frame in
//! pieces of `--chunk` points; after each piece it tells the output thread, which then runs a
//! read cycle over whatever has arrived (pieces that arrive during a cycle wait for the next
//! one) and, with `--every-cycle DIR`, writes that cycle's points to `DIR/cycle-NNNNNN.ply`
//! (a directory that already holds such files is refused).
//! When the input ends, the points of `--delete FILE` are deleted, and a last read cycle over
//! the complete store gives the output (also written to `DIR` as the last cycle). That last
//! cycle does not depend on the pieces or the threads' timing: it equals the batch reduction
//! of the input without the deleted points. The intermediate cycles do depend on timing.

use super::args::read_points;
use super::vocab::StorageArg;
use anyhow::{bail, Context, Result};
use nalgebra::Point3;
use octoquant::formats::ply::{write_ply_file, PlyEncoding};
use octoquant::formats::{frame_stream, ReadOptions};
use octoquant_density::{
    CycleCounts, DensityGrid, GridCounts, GridSpec, Selection, SharedDensityGrid, Storage,
};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread;
use std::time::Instant;

/// Cells a read cycle visits per lock of the store, so that input goes on between steps.
const CYCLE_STEP: usize = 4096;

/// What `--stream` was asked to do.
pub struct StreamJob<'a> {
    pub input: &'a Path,
    pub read: ReadOptions,
    pub spec: GridSpec<3>,
    pub chunk: usize,
    pub every_cycle: Option<&'a Path>,
    pub delete: Option<&'a Path>,
    pub storage: Option<StorageArg>,
    pub encoding: PlyEncoding,
}

/// What a streamed reduction did.
pub struct StreamResult {
    /// The last read cycle's points, in output order.
    pub output: Vec<Point3<f32>>,
    /// Its counts.
    pub last_cycle: CycleCounts,
    /// The store's input counts.
    pub counts: GridCounts,
    /// Non-empty cells at the end (the grid stage's output).
    pub cells: usize,
    /// Read cycles run, the last one included.
    pub cycles: u64,
    /// The storage used.
    pub storage: Storage,
    /// Points of `--delete` found and deleted, and those not stored.
    pub deleted: u64,
    pub not_deleted: u64,
    /// Input points with a NaN or infinite coordinate (rejected by the grid).
    pub non_finite: u64,
    /// Seconds reading and inserting the input (including deletions), and the last cycle.
    pub input_seconds: f64,
    pub output_seconds: f64,
}

/// The storage: one node per cell unless points are to be deleted (which needs all members).
fn storage(job: &StreamJob<'_>) -> Result<Storage> {
    Ok(match (job.storage, job.delete) {
        (Some(StorageArg::OneNode), Some(_)) => bail!(
            "--delete needs --storage all-members: one node per cell keeps only each cell's \
             best point, so the others could not be deleted"
        ),
        (Some(StorageArg::OneNode), None) | (None, None) => Storage::OneNode,
        (Some(StorageArg::AllMembers), _) | (None, Some(_)) => Storage::AllMembers,
    })
}

/// `true` when every coordinate is a finite number (the grid rejects the others).
pub(super) fn finite(p: &Point3<f32>) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
}

fn f32s(p: &[f64; 3]) -> Point3<f32> {
    // Every stored point came from an f32 file: f64 -> f32 is exact.
    Point3::new(p[0] as f32, p[1] as f32, p[2] as f32)
}

fn cycle_file(dir: &Path, n: u64) -> PathBuf {
    dir.join(format!("cycle-{n:06}.ply"))
}

/// Run a streamed reduction; writes the `--every-cycle` files, not the final output.
pub fn run_stream(job: &StreamJob<'_>) -> Result<StreamResult> {
    if job.chunk == 0 {
        bail!("--chunk must be at least 1");
    }
    let storage = storage(job)?;
    if let Some(dir) = job.every_cycle {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the cycle directory {}", dir.display()))?;
        // An earlier run's numbered files would mix with this run's.
        let entries = std::fs::read_dir(dir)
            .with_context(|| format!("cannot read the cycle directory {}", dir.display()))?;
        for e in entries {
            let name = e?.file_name();
            let name = name.to_string_lossy();
            if name.starts_with("cycle-") && name.ends_with(".ply") {
                bail!(
                    "{} already holds cycle files ({name}); give an empty or new directory",
                    dir.display()
                );
            }
        }
    }
    // The points to delete are read first: a bad file fails before any work.
    let delete = match job.delete {
        Some(path) => Some(read_points(path, &ReadOptions::default())?),
        None => None,
    };
    let grid = DensityGrid::with_storage(job.spec.clone(), Selection::CentreClosest, storage)?;
    let shared = SharedDensityGrid::new(grid);
    let (tx, rx) = mpsc::channel::<()>();
    let output = {
        let shared = shared.clone();
        let dir = job.every_cycle.map(Path::to_path_buf);
        let encoding = job.encoding;
        thread::Builder::new()
            .name("reduce-output".into())
            .spawn(move || output_stage(&shared, &rx, dir.as_deref(), encoding))
            .context("cannot start the output thread")?
    };

    let t0 = Instant::now();
    let input = input_stage(job, &shared, &tx, delete.as_deref());
    drop(tx);
    let cycles = match output.join() {
        Ok(r) => r,
        Err(_) => bail!("the output thread panicked"),
    };
    let (deleted, not_deleted, non_finite) = input?;
    let mut cycles = cycles?;
    let input_seconds = t0.elapsed().as_secs_f64();

    let Ok(mut grid) = shared.try_into_inner() else {
        bail!("the output thread still holds the store");
    };
    let t1 = Instant::now();
    let (out, last_cycle) = grid.output_cycle();
    let output_seconds = t1.elapsed().as_secs_f64();
    cycles += 1;
    let output: Vec<Point3<f32>> = out.iter().map(f32s).collect();
    if let Some(dir) = job.every_cycle {
        write_ply_file(&cycle_file(dir, cycles), &output, job.encoding)?;
    }
    Ok(StreamResult {
        output,
        last_cycle,
        counts: grid.counts(),
        cells: grid.len(),
        cycles,
        storage,
        deleted,
        not_deleted,
        non_finite,
        input_seconds,
        output_seconds,
    })
}

/// This thread's part: read, insert in pieces (telling the output thread after each), then
/// delete. Returns the points deleted and not found, and the input points with a NaN or
/// infinite coordinate. Stops early, without error, when the output thread has ended (its
/// error is reported instead).
fn input_stage(
    job: &StreamJob<'_>,
    shared: &SharedDensityGrid<3>,
    tx: &mpsc::Sender<()>,
    delete: Option<&[Point3<f32>]>,
) -> Result<(u64, u64, u64)> {
    let mut non_finite = 0;
    let mut piece: Vec<[f64; 3]> = Vec::with_capacity(job.chunk.min(1 << 20));
    for frame in frame_stream(job.input, &job.read)? {
        let frame = frame?;
        for part in frame.points.chunks(job.chunk) {
            non_finite += part.iter().filter(|p| !finite(p)).count() as u64;
            piece.clear();
            piece.extend(
                part.iter()
                    .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)]),
            );
            shared.insert_batch(&piece);
            if tx.send(()).is_err() {
                return Ok((0, 0, non_finite));
            }
        }
    }
    let (mut deleted, mut missing) = (0, 0);
    if let Some(points) = delete {
        for part in points.chunks(job.chunk) {
            let mut grid = shared.lock();
            for p in part {
                if grid.remove(&[f64::from(p.x), f64::from(p.y), f64::from(p.z)]) {
                    deleted += 1;
                } else {
                    missing += 1;
                }
            }
            drop(grid);
            if tx.send(()).is_err() {
                break;
            }
        }
    }
    Ok((deleted, missing, non_finite))
}

/// The output thread: a read cycle each time new input has arrived, until the input ends;
/// returns the number of cycles run.
fn output_stage(
    shared: &SharedDensityGrid<3>,
    rx: &mpsc::Receiver<()>,
    dir: Option<&Path>,
    encoding: PlyEncoding,
) -> Result<u64> {
    let mut cycles = 0;
    while rx.recv().is_ok() {
        // Everything that arrived while the last cycle ran goes into this one.
        while rx.try_recv().is_ok() {}
        let (out, _) = shared.run_cycle(CYCLE_STEP)?;
        cycles += 1;
        if let Some(dir) = dir {
            let points: Vec<Point3<f32>> = out.iter().map(f32s).collect();
            write_ply_file(&cycle_file(dir, cycles), &points, encoding)?;
        }
    }
    Ok(cycles)
}
