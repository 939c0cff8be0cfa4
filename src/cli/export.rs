//! `octoquant export MAP -o OUT.ply [--free] [--cubes] [--ascii]`.

use anyhow::Result;
use octoquant::export::{export_ply_file, ExportOptions};
use octoquant::treefile::read_tree_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map.
    map: PathBuf,
    /// Output PLY.
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
}

pub fn run(a: &Args) -> Result<()> {
    let tree = read_tree_file(&a.map)?;
    let options = ExportOptions {
        free: a.free,
        cubes: a.cubes,
        ascii: a.ascii,
    };
    let s = export_ply_file(&tree, &a.output, &options)?;
    errln!(
        "wrote {}: {} occupied, {} free leaves, {} vertices, {} faces",
        a.output.display(),
        s.occupied,
        s.free,
        s.vertices,
        s.faces
    );
    Ok(())
}
