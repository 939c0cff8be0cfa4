//! `octoquant convert IN OUT [--json]`: .bt <-> .ot by extension.

use super::{json_path, print_json};
use anyhow::Result;
use octoquant::output::check_output;
use octoquant::treefile::{read_tree_file, write_tree_file, TREE_EXTENSIONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Input .bt or .ot file.
    input: PathBuf,
    /// Output file; its extension (.bt or .ot) picks the format. A .bt output holds the
    /// max-likelihood, pruned tree, as OctoMap writes it.
    output: PathBuf,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &TREE_EXTENSIONS, std::slice::from_ref(&a.input))?;
    let mut tree = read_tree_file(&a.input)?;
    write_tree_file(&mut tree, &a.output)?;
    if a.json {
        print_json(&serde_json::json!({
            "input": json_path(&a.input),
            "output": json_path(&a.output),
            "nodes": tree.size(),
        }))?;
    } else {
        errln!("wrote {} ({} nodes)", a.output.display(), tree.size());
    }
    Ok(())
}
