//! `octoquant query MAP (--points FILE | --at X Y Z) [--rays FILE] [--json]`: occupancy at
//! points (OctoMap's `search`: class, probability, depth of the node found) and `castRay`
//! results, one line each or one JSON object.
//!
//! Files are text, one query per line, numbers separated by spaces, tabs or commas; empty lines
//! and lines starting with `#` are skipped. Points: `X Y Z`. Rays: `OX OY OZ DX DY DZ` (origin
//! and direction).

use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use nalgebra::{Point3, Vector3};
use octoquant::octree::VoxelClass;
use octoquant::query::occupancy_at;
use octoquant::raycast::{cast_ray, CastOptions, CastStop};
use octoquant::treefile::read_tree_file;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map.
    map: PathBuf,
    /// Points to look up, one `X Y Z` per line.
    #[arg(long, value_name = "FILE", required_unless_present_any = ["at", "rays"])]
    points: Option<PathBuf>,
    /// One point to look up, metres (repeatable).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, action = clap::ArgAction::Append)]
    at: Vec<f64>,
    /// Rays to cast, one `OX OY OZ DX DY DZ` per line (origin, direction).
    #[arg(long, value_name = "FILE")]
    rays: Option<PathBuf>,
    /// Rays walk on through unknown voxels instead of stopping at the first (castRay's
    /// ignoreUnknown).
    #[arg(long)]
    ignore_unknown: bool,
    /// Rays stop at this distance, metres (castRay's maxRange; 0 or less: no limit).
    #[arg(long, allow_negative_numbers = true)]
    max_range: Option<f64>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// The points of `--at X Y Z ...` (triples) followed by those of a `--points` file: what
/// `query` and `distance` look up.
pub(super) fn query_points(at: &[f64], file: Option<&Path>) -> Result<Vec<Point3<f64>>> {
    let mut points: Vec<Point3<f64>> = at
        .chunks_exact(3)
        .map(|c| Point3::new(c[0], c[1], c[2]))
        .collect();
    if let Some(f) = file {
        points.extend(
            read_rows(f, 3)?
                .into_iter()
                .map(|r| Point3::new(r[0], r[1], r[2])),
        );
    }
    Ok(points)
}

/// The numbers of a text file, `width` per line (see `octoquant::rows`); errors name the
/// file and the line.
pub(super) fn read_rows(path: &Path, width: usize) -> Result<Vec<Vec<f64>>> {
    let text = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    octoquant::rows::parse_rows(&text, width).with_context(|| format!("{}", path.display()))
}

fn class_name(c: VoxelClass) -> &'static str {
    match c {
        VoxelClass::Unknown => "unknown",
        VoxelClass::Free => "free",
        VoxelClass::Occupied => "occupied",
    }
}

fn stop_name(s: CastStop) -> &'static str {
    match s {
        CastStop::Occupied => "occupied",
        CastStop::Unknown => "unknown",
        CastStop::MaxRange => "max_range",
        CastStop::MapBoundary => "map_boundary",
        CastStop::OriginOutsideMap => "origin_outside_map",
        CastStop::BadDirection => "bad_direction",
        CastStop::Stalled => "stalled",
    }
}

pub fn run(a: &Args) -> Result<()> {
    if a.at.iter().any(|v| !v.is_finite()) {
        bail!("--at {:?}: every coordinate must be a finite number", a.at);
    }
    if a.max_range.is_some_and(f64::is_nan) {
        bail!("--max-range is NaN");
    }
    let tree = read_tree_file(&a.map)?;
    let points = query_points(&a.at, a.points.as_deref())?;
    let rays: Vec<(Point3<f64>, Vector3<f64>)> = match &a.rays {
        Some(f) => read_rows(f, 6)?
            .into_iter()
            .map(|r| {
                (
                    Point3::new(r[0], r[1], r[2]),
                    Vector3::new(r[3], r[4], r[5]),
                )
            })
            .collect(),
        None => Vec::new(),
    };
    let options = CastOptions {
        ignore_unknown: a.ignore_unknown,
        max_range: a.max_range.filter(|m| *m > 0.0),
    };
    let found: Vec<_> = points.iter().map(|p| (p, occupancy_at(&tree, p))).collect();
    let cast: Vec<_> = rays
        .iter()
        .map(|(o, d)| (o, d, cast_ray(&tree, o, d, &options)))
        .collect();
    if a.json {
        let points: Vec<_> = found
            .iter()
            .map(|(p, q)| {
                serde_json::json!({
                    "point": [p.x, p.y, p.z],
                    "class": class_name(q.class),
                    "probability": q.probability(),
                    "log_odds": q.node.map(|n| n.value),
                    "depth": q.node.map(|n| n.depth),
                })
            })
            .collect();
        let rays: Vec<_> = cast
            .iter()
            .map(|(o, d, r)| {
                serde_json::json!({
                    "origin": [o.x, o.y, o.z],
                    "direction": [d.x, d.y, d.z],
                    "hit": r.hit,
                    "stop": stop_name(r.stop),
                    "end": r.end.map(|e| [e.x, e.y, e.z]),
                })
            })
            .collect();
        print_json(&serde_json::json!({
            "map": json_path(&a.map),
            "resolution": tree.resolution(),
            "points": points,
            "rays": rays,
        }))?;
        return Ok(());
    }
    for (p, q) in &found {
        match q.node {
            Some(n) => outln!(
                "point {} {} {}: {} p={:.6} log-odds={} depth={}",
                p.x,
                p.y,
                p.z,
                class_name(q.class),
                q.probability().unwrap_or(f64::NAN),
                n.value,
                n.depth
            )?,
            None => outln!("point {} {} {}: unknown", p.x, p.y, p.z)?,
        }
    }
    for (o, d, r) in &cast {
        let end = match r.end {
            Some(e) => format!("{} {} {}", e.x, e.y, e.z),
            None => "none".into(),
        };
        outln!(
            "ray {} {} {} -> {} {} {}: {} (stopped: {}) end {end}",
            o.x,
            o.y,
            o.z,
            d.x,
            d.y,
            d.z,
            if r.hit { "hit" } else { "no hit" },
            stop_name(r.stop)
        )?;
    }
    Ok(())
}
