//! `octoquant join TILES_DIR -o OUT [-o OUT2] [--json]`: assemble a tile directory (one `.ot`
//! per tile plus its index, from a tiled build with a spill directory) into one map.
//!
//! The result is the map the in-memory tiled build gives, and so the map `octoquant map`
//! builds from the same frames (see `octoquant_tiles`). The tiles are read one at a time;
//! the joined map is held in memory while it is written.

use super::{json_path, print_json};
use anyhow::Result;
use octoquant::output::check_output;
use octoquant::tiles::{join_dir, INDEX_FILE};
use octoquant::treefile::{save_tree_file, TREE_EXTENSIONS};
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
    let tree = join_dir(&a.dir)?;
    for o in &a.output {
        save_tree_file(&tree, o)?;
    }
    if a.json {
        print_json(&serde_json::json!({
            "dir": json_path(&a.dir),
            "outputs": a.output.iter().map(|p| json_path(p)).collect::<Vec<_>>(),
            "nodes": tree.size(),
        }))?;
    } else {
        for o in &a.output {
            errln!("wrote {} ({} nodes)", o.display(), tree.size());
        }
    }
    Ok(())
}
