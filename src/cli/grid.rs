//! `octoquant grid MAP -o map.yaml [--zmin Z] [--zmax Z] [--depth D] [--unknown free|unknown]`.

use super::vocab::UnknownArg;
use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::grid::{project, write_nav2, GridOptions};
use octoquant::treefile::read_tree_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map.
    map: PathBuf,
    /// Output map description (.yaml); the image is written beside it as .pgm.
    #[arg(short, long)]
    output: PathBuf,
    /// Lowest height of the band projected, metres (default: no limit).
    #[arg(long, allow_negative_numbers = true)]
    zmin: Option<f64>,
    /// Highest height of the band projected, metres (default: no limit).
    #[arg(long, allow_negative_numbers = true)]
    zmax: Option<f64>,
    /// Cell depth in the octree, 1-16: 16 gives cells of the map's resolution, each level
    /// less doubles the cell size.
    #[arg(long, default_value_t = 16)]
    depth: u8,
    /// What unknown cells become.
    #[arg(long, value_enum, default_value = "unknown")]
    unknown: UnknownArg,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    // the band's ends named as options, before any work (the library's error cannot name them)
    for (name, v) in [("--zmin", a.zmin), ("--zmax", a.zmax)] {
        if let Some(z) = v.filter(|z| !z.is_finite()) {
            bail!("{name} {z}: give a finite height in metres (leave it out for no limit)");
        }
    }
    if let (Some(lo), Some(hi)) = (a.zmin, a.zmax) {
        if lo > hi {
            bail!("--zmin {lo} lies above --zmax {hi}: the height band is empty");
        }
    }
    // the output name is checked before reading the map
    let options = GridOptions {
        zmin: a.zmin,
        zmax: a.zmax,
        depth: a.depth,
        unknown: a.unknown.into(),
    };
    octoquant::grid::check_output_name(&a.output, std::slice::from_ref(&a.map))?;
    let tree = read_tree_file(&a.map)?;
    let grid = project(&tree, &options)?;
    let image = write_nav2(&grid, &a.output)?;
    let (unknown, free, occupied) = grid.counts();
    if a.json {
        let summary = serde_json::json!({
            "map": json_path(&a.map),
            "yaml": json_path(&a.output),
            "image": json_path(&image),
            "resolution": grid.resolution,
            "origin": [grid.origin.x, grid.origin.y, 0.0],
            "width": grid.width,
            "height": grid.height,
            "cells": {"occupied": occupied, "free": free, "unknown": unknown},
        });
        print_json(&summary)?;
    } else {
        outln!(
            "wrote {} and {} ({} x {} cells of {} m; {} occupied, {} free, {} unknown)",
            a.output.display(),
            image.display(),
            grid.width,
            grid.height,
            grid.resolution,
            occupied,
            free,
            unknown
        )?;
    }
    Ok(())
}
