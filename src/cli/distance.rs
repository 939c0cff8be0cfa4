//! `octoquant distance MAP --max-dist D [--bbx-min X Y Z --bbx-max X Y Z]
//! [--unknown-occupied] (--at X Y Z ... | --points FILE | --slice Z -o OUT.png) [--json]`:
//! distances to the nearest obstacle with OctoMap's dynamicEDT3D numbers (see
//! `docs/distance.md`), at points and as a grayscale picture of a horizontal slice.
//!
//! The slice picture has one pixel per voxel of the box at the slice's height: x to the
//! right, y upwards (row 0 is the box's largest y). A pixel's gray level is
//! `round(255 · distance / max)`, `max` being the map's distance clamp, so obstacles are black
//! and voxels at the clamp white.

use super::query::query_points;
use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use nalgebra::Point3;
use octoquant::distance::{DistanceMap, DistanceOptions, DISTANCE_OUTSIDE};
use octoquant::output::{check_output, write_atomic};
use octoquant::treefile::read_tree_file;
use octoquant::Key;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map.
    map: PathBuf,
    /// Distances are clamped at this many metres (dynamicEDT3D's maxdist).
    #[arg(long, allow_negative_numbers = true)]
    max_dist: f64,
    /// Smallest corner of the box, metres (default: the centre of the map's lowest voxel).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, requires = "bbx_max")]
    bbx_min: Option<Vec<f64>>,
    /// Largest corner of the box, metres (default: the centre of the map's highest voxel).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, requires = "bbx_min")]
    bbx_max: Option<Vec<f64>>,
    /// Count unknown voxels as obstacles (default: as free space).
    #[arg(long)]
    unknown_occupied: bool,
    /// A point to look up, metres (repeatable).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, action = clap::ArgAction::Append)]
    at: Vec<f64>,
    /// Points to look up, one `X Y Z` per line.
    #[arg(long, value_name = "FILE")]
    points: Option<PathBuf>,
    /// Draw the horizontal slice of the box through this height (metres) as a PNG.
    #[arg(long, allow_negative_numbers = true, requires = "output")]
    slice: Option<f64>,
    /// Output PNG of --slice.
    #[arg(short, long, requires = "slice")]
    output: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

fn corner(v: &[f64], name: &str) -> Result<Point3<f64>> {
    if v.iter().any(|c| !c.is_finite()) {
        bail!("--{name} {v:?}: every coordinate must be a finite number");
    }
    Ok(Point3::new(v[0], v[1], v[2]))
}

/// The slice's pixels, row 0 at the largest y, and its width and height.
fn slice_pixels(map: &DistanceMap, z_key: u16) -> (u32, u32, Vec<u8>) {
    let (lo, size) = (map.min_key(), map.size());
    let max = map.max_dist();
    let (w, h) = (size.x, size.y);
    let mut gray = Vec::with_capacity(w * h);
    for row in 0..h {
        let y = lo[1] as usize + h - 1 - row;
        for col in 0..w {
            let key = Key::new((lo[0] as usize + col) as u16, y as u16, z_key);
            let d = map.distance_at_key(key);
            gray.push(
                (255.0 * f64::from(d) / f64::from(max))
                    .round()
                    .clamp(0.0, 255.0) as u8,
            );
        }
    }
    (w as u32, h as u32, gray)
}

pub fn run(a: &Args) -> Result<()> {
    if a.at.iter().any(|v| !v.is_finite()) {
        bail!("--at {:?}: every coordinate must be a finite number", a.at);
    }
    // the distance map keeps it as an f32: a larger value would become infinite there
    if !(a.max_dist.is_finite() && (a.max_dist as f32).is_finite()) {
        bail!(
            "--max-dist {}: must be a finite number of metres",
            a.max_dist
        );
    }
    if a.max_dist < 0.0 {
        bail!("--max-dist {}: must not be negative", a.max_dist);
    }
    if a.at.is_empty() && a.points.is_none() && a.slice.is_none() {
        bail!("nothing to do: give --at, --points or --slice with -o");
    }
    if a.slice.is_some_and(|z| !z.is_finite()) {
        bail!("--slice must be a finite number");
    }
    if let Some(out) = &a.output {
        check_output(out, &["png"], std::slice::from_ref(&a.map))?;
    }
    let tree = read_tree_file(&a.map)?;
    let res = tree.resolution();
    let (bbx_min, bbx_max) = match (&a.bbx_min, &a.bbx_max) {
        (Some(lo), Some(hi)) => (corner(lo, "bbx-min")?, corner(hi, "bbx-max")?),
        _ => {
            let (lo, hi) = tree.metric_bounds().with_context(|| {
                format!(
                    "{}: the map is empty; give --bbx-min and --bbx-max",
                    a.map.display()
                )
            })?;
            (lo.map(|v| v + res / 2.0), hi.map(|v| v - res / 2.0))
        }
    };
    let points = query_points(&a.at, a.points.as_deref())?;
    let options = DistanceOptions {
        max_dist: a.max_dist as f32,
        bbx_min,
        bbx_max,
        unknown_occupied: a.unknown_occupied,
    };
    let map = DistanceMap::new(&tree, &options)
        .with_context(|| format!("{}: distance map", a.map.display()))?;
    let found = points
        .iter()
        .map(|p| Ok((p, map.distance_and_closest_obstacle(p)?)))
        .collect::<Result<Vec<_>>>()?;
    let mut slice_info = None;
    if let (Some(z), Some(out)) = (a.slice, &a.output) {
        let z_key = tree
            .converter()
            .coord_to_key_checked(f64::from(z as f32))
            .filter(|k| *k >= map.min_key()[2] && *k <= map.max_key()[2])
            .with_context(|| format!("--slice {z}: outside the box's heights"))?;
        let (w, h, gray) = slice_pixels(&map, z_key);
        write_atomic(out, |wr: &mut dyn Write| {
            let mut enc = png::Encoder::new(wr, w, h);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Eight);
            let mut writer = enc.write_header().map_err(std::io::Error::other)?;
            writer
                .write_image_data(&gray)
                .map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        })?;
        slice_info = Some((z, out, w, h));
    }
    if a.json {
        let pts: Vec<_> = found
            .iter()
            .map(|(p, (d, o))| {
                serde_json::json!({
                    "point": [p.x, p.y, p.z],
                    "distance": d,
                    "inside": *d != DISTANCE_OUTSIDE,
                    "closest_obstacle": o.map(|o| [o.x, o.y, o.z]),
                })
            })
            .collect();
        let (lo, hi) = (map.min_key(), map.max_key());
        let conv = tree.converter();
        print_json(&serde_json::json!({
            "map": json_path(&a.map),
            "resolution": res,
            "max_dist": map.max_dist(),
            "unknown_occupied": a.unknown_occupied,
            "bbx_min": [conv.key_to_coord(lo[0]), conv.key_to_coord(lo[1]), conv.key_to_coord(lo[2])],
            "bbx_max": [conv.key_to_coord(hi[0]), conv.key_to_coord(hi[1]), conv.key_to_coord(hi[2])],
            "size": [map.size().x, map.size().y, map.size().z],
            "points": pts,
            "slice": slice_info.map(|(z, out, w, h)| serde_json::json!({
                "z": z, "output": json_path(out), "width": w, "height": h,
            })),
        }))?;
        return Ok(());
    }
    for (p, (d, o)) in &found {
        if *d == DISTANCE_OUTSIDE {
            outln!("point {} {} {}: outside the box", p.x, p.y, p.z)?;
            continue;
        }
        match o {
            Some(o) => outln!(
                "point {} {} {}: distance {} obstacle {} {} {}",
                p.x,
                p.y,
                p.z,
                d,
                o.x,
                o.y,
                o.z
            )?,
            None => outln!(
                "point {} {} {}: distance {} (no obstacle within)",
                p.x,
                p.y,
                p.z,
                d
            )?,
        }
    }
    if let Some((_, out, w, h)) = slice_info {
        errln!("wrote {} ({} × {} px)", out.display(), w, h);
    }
    Ok(())
}
