//! `octoquant export MAP -o OUT.ply [--free] [--cubes] [--ascii] [--json]`, or `-o OUT.pcd`:
//! the occupied voxel centres as ASCII PCD (OctoMap's octree2pointcloud).

use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::export::{
    export_colored_pcd_file, export_colored_ply_file, export_pcd_file, export_ply_file,
    ExportOptions,
};
use octoquant::output::check_output;
use octoquant::treefile::read_any_tree_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map (a ColorOcTree's voxels keep their colours: PLY red/green/blue,
    /// PCD rgb).
    map: PathBuf,
    /// Output .ply, or .pcd for the occupied voxel centres (every voxel of a pruned block).
    #[arg(short, long)]
    output: PathBuf,
    /// Also export free leaves (pale blue).
    #[arg(long)]
    free: bool,
    /// Export each leaf as a cube (8 vertices, 6 quads) instead of its centre.
    #[arg(long)]
    cubes: bool,
    /// Write ASCII PLY instead of binary little-endian.
    #[arg(long)]
    ascii: bool,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &["ply", "pcd"], std::slice::from_ref(&a.map))?;
    let pcd = a
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pcd"));
    if pcd && (a.free || a.cubes) {
        bail!(
            "{}: a PCD export holds occupied voxel centres only (--free and --cubes are for PLY)",
            a.output.display()
        );
    }
    let any = read_any_tree_file(&a.map)?;
    let colored = any.colors().is_some();
    if pcd {
        let n = match any.colors() {
            Some(t) => export_colored_pcd_file(t, &a.output)?,
            None => export_pcd_file(any.occupancy(), &a.output)?,
        };
        if a.json {
            print_json(&serde_json::json!({
                "map": json_path(&a.map),
                "output": json_path(&a.output),
                "points": n,
                "voxel_colors": colored,
            }))?;
        } else {
            errln!("wrote {}: {n} occupied voxel centres", a.output.display());
        }
        return Ok(());
    }
    let options = ExportOptions {
        free: a.free,
        cubes: a.cubes,
        ascii: a.ascii,
    };
    let s = match any.colors() {
        Some(t) => export_colored_ply_file(t, &a.output, &options)?,
        None => export_ply_file(any.occupancy(), &a.output, &options)?,
    };
    if a.json {
        print_json(&serde_json::json!({
            "map": json_path(&a.map),
            "output": json_path(&a.output),
            "occupied": s.occupied,
            "free": s.free,
            "vertices": s.vertices,
            "faces": s.faces,
            "voxel_colors": colored,
        }))?;
    } else {
        errln!(
            "wrote {}: {} occupied, {} free leaves, {} vertices, {} faces",
            a.output.display(),
            s.occupied,
            s.free,
            s.vertices,
            s.faces
        );
    }
    Ok(())
}
