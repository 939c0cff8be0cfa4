//! `octoquant crop MAP --min X Y Z --max X Y Z -o OUT [--json]`: keep the voxels of a box.

use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use nalgebra::Point3;
use octoquant::output::check_output;
use octoquant::treefile::{read_tree_file, write_tree_file, TREE_EXTENSIONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Input .bt or .ot map.
    input: PathBuf,
    /// One corner of the box, metres.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, required = true)]
    min: Vec<f64>,
    /// The opposite corner, metres. The box holds every voxel whose key lies between the
    /// corners' keys, inclusive (OctoMap's bounding-box convention).
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true, required = true)]
    max: Vec<f64>,
    /// Output .bt or .ot file (by extension).
    #[arg(short, long)]
    output: PathBuf,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &TREE_EXTENSIONS, std::slice::from_ref(&a.input))?;
    let corner = |v: &[f64], name: &str| -> Result<Point3<f64>> {
        if v.iter().any(|c| !c.is_finite()) {
            bail!("--{name} {v:?}: every coordinate must be a finite number");
        }
        Ok(Point3::new(v[0], v[1], v[2]))
    };
    let (lo, hi) = (corner(&a.min, "min")?, corner(&a.max, "max")?);
    let mut tree = read_tree_file(&a.input)?;
    let before = tree.num_leaves();
    let key = |p: &Point3<f64>, name: &str| {
        tree.converter()
            .point_to_key_checked(p)
            .with_context(|| format!("--{name} ({}, {}, {}) is outside the map", p.x, p.y, p.z))
    };
    let (kmin, kmax) = (key(&lo, "min")?, key(&hi, "max")?);
    tree.crop(kmin, kmax);
    let after = tree.num_leaves();
    write_tree_file(&mut tree, &a.output)?;
    if a.json {
        print_json(&serde_json::json!({
            "input": json_path(&a.input),
            "output": json_path(&a.output),
            "leaves_before": before,
            "leaves": after,
            "nodes": tree.size(),
        }))?;
    } else {
        errln!(
            "wrote {} ({after} leaves of {before}, {} nodes)",
            a.output.display(),
            tree.size()
        );
    }
    Ok(())
}
