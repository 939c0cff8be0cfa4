//! `octoquant eval [MAP] SCANS... [--json]`: OctoMap's `eval_octree_accuracy`, how well a map
//! predicts scans (see `octoquant::eval`).
//!
//! With a map (the first input, when it is a .bt or .ot file) every scan is evaluated against
//! it. Without one, the tool's own protocol: every 5th scan is held out, the others build the
//! map at `--res`, and the held-out scans are evaluated.

use super::args::{InputArgs, TreeArgs};
use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::eval::{cross_validate, evaluate_scan, Accuracy, CrossValidation};
use octoquant::octree::io::TreeFormat;
use octoquant::pipeline::MapperOptions;
use octoquant::raycast::ScanUpdate;
use octoquant::treefile::read_tree_file;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    #[command(flatten)]
    tree: TreeArgs,
    /// Without a map: hold out the scans whose 1-based number is a multiple of N (the tool's
    /// 5); 0 holds out none.
    #[arg(long, default_value_t = 5, value_name = "N")]
    every: usize,
    /// Use only the first N scans (the tool's -n).
    #[arg(long, value_name = "N")]
    max_scans: Option<usize>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// What one run found, however the map came about.
struct Report {
    map: Option<std::path::PathBuf>,
    resolution: f64,
    scans_inserted: usize,
    scans_evaluated: usize,
    points_considered: u64,
    accuracy: Accuracy,
}

pub fn run(a: &Args) -> Result<()> {
    let inputs = &a.input.inputs;
    let Some(first) = inputs.first() else {
        bail!("no scans given: eval [MAP.bt|MAP.ot] SCANS...");
    };
    let max_range = a.tree.max_range()?;
    let report = if TreeFormat::from_path(first).is_some() {
        if inputs.len() < 2 {
            bail!(
                "{}: a map needs scans to evaluate: eval MAP SCANS...",
                first.display()
            );
        }
        let tree = read_tree_file(first)?;
        let scans = InputArgs {
            inputs: inputs[1..].to_vec(),
            read: a.input.read.clone(),
        };
        let mut frames = scans.read_frames()?;
        if let Some(n) = a.max_scans {
            frames.truncate(n);
        }
        let mut acc = Accuracy::default();
        let mut scratch = ScanUpdate::new();
        for f in &frames {
            evaluate_scan(&tree, f, max_range, &mut scratch, &mut acc);
        }
        Report {
            map: Some(first.clone()),
            resolution: tree.resolution(),
            scans_inserted: 0,
            scans_evaluated: frames.len(),
            points_considered: acc.points,
            accuracy: acc,
        }
    } else {
        let frames = a.input.read_frames()?;
        let options = CrossValidation {
            mapper: MapperOptions {
                resolution: a.tree.resolution()?,
                max_range,
                ..MapperOptions::default()
            },
            every: a.every,
            max_scans: a.max_scans,
        };
        let run = cross_validate(&frames, &options)?;
        Report {
            map: None,
            resolution: run.tree.resolution(),
            scans_inserted: run.scans_inserted,
            scans_evaluated: run.scans_evaluated,
            points_considered: run.points_considered,
            accuracy: run.accuracy,
        }
    };
    let acc = &report.accuracy;
    let share = acc.share_correct();
    if a.json {
        print_json(&serde_json::json!({
            "map": report.map.as_deref().map(json_path),
            "resolution": report.resolution,
            "scans_inserted": report.scans_inserted,
            "scans_evaluated": report.scans_evaluated,
            "points_evaluated": acc.points,
            "points_considered": report.points_considered,
            "correct": acc.correct,
            "wrong": acc.wrong,
            "unknown": acc.unknown,
            "share_correct": share,
        }))?;
        return Ok(());
    }
    match &report.map {
        Some(m) => outln!("map:              {}", m.display())?,
        None => outln!(
            "map:              built from {} scans at {:?} m (every {}th scan held out)",
            report.scans_inserted,
            report.resolution,
            a.every
        )?,
    }
    outln!("scans evaluated:  {}", report.scans_evaluated)?;
    outln!(
        "points:           {} of {} evaluated",
        acc.points,
        report.points_considered
    )?;
    outln!(
        "voxels:           {} correct, {} wrong, {} unknown",
        acc.correct,
        acc.wrong,
        acc.unknown
    )?;
    if share.is_nan() {
        outln!("share correct:    undefined (no known voxel was checked)")?;
    } else {
        outln!("share correct:    {share:.6} (correct / (correct + wrong))")?;
    }
    Ok(())
}
