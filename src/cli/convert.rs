//! `octoquant convert IN OUT`: .bt <-> .ot by extension.

use anyhow::Result;
use octoquant::treefile::{read_tree_file, write_tree_file};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Input .bt or .ot file.
    input: PathBuf,
    /// Output file; its extension (.bt or .ot) picks the format. A .bt output holds the
    /// max-likelihood, pruned tree, as OctoMap writes it.
    output: PathBuf,
}

pub fn run(a: &Args) -> Result<()> {
    let mut tree = read_tree_file(&a.input)?;
    write_tree_file(&mut tree, &a.output)?;
    errln!("wrote {} ({} nodes)", a.output.display(), tree.size());
    Ok(())
}
