//! `octoquant join TILES_DIR -o OUT [-o OUT2] [--json]`: assemble a tile directory (one `.ot`
//! per tile plus its index, from a tiled build with a spill directory) into one map.
//!
//! The result is the map the in-memory tiled build gives, and so the map `octoquant map`
//! builds from the same frames (see `octoquant_tiles`). Each output is streamed
//! (`StreamJoin`): the tiles are read one at a time, twice (a summary pass, then the
//! writing pass), so memory is bounded by the largest tile, not by the map.

use super::{json_path, print_json};
use anyhow::Result;
use octoquant::octree::io::TreeFormat;
use octoquant::output::{check_output, write_atomic};
use octoquant::tiles::{StreamJoin, INDEX_FILE};
use octoquant::treefile::TREE_EXTENSIONS;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The tile directory (with its tiles.index).
    dir: PathBuf,
    /// Output file(s); each one's extension (.bt or .ot) picks its format. A .bt output holds
    /// the max-likelihood, pruned tree, as OctoMap writes it. Repeat for both formats.
    #[arg(short, long = "output", required = true)]
    output: Vec<PathBuf>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    let index = a.dir.join(INDEX_FILE);
    for o in &a.output {
        check_output(o, &TREE_EXTENSIONS, std::slice::from_ref(&index))?;
    }
    let mut nodes = Vec::with_capacity(a.output.len());
    for o in &a.output {
        let format = TreeFormat::from_path(o)
            .ok_or_else(|| anyhow::anyhow!("{}: not a .bt or .ot file", o.display()))?;
        let plan = StreamJoin::plan(&a.dir, format)?;
        write_atomic(o, |w| plan.write(w).map_err(std::io::Error::other))?;
        nodes.push(plan.nodes());
    }
    if a.json {
        print_json(&serde_json::json!({
            "dir": json_path(&a.dir),
            "outputs": a.output.iter().map(|p| json_path(p)).collect::<Vec<_>>(),
            "nodes": nodes,
        }))?;
    } else {
        for (o, n) in a.output.iter().zip(&nodes) {
            errln!("wrote {} ({n} nodes)", o.display());
        }
    }
    Ok(())
}
