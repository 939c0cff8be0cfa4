//! `octoquant merge A B... -o OUT [-o OUT2] [--json]`: fuse maps built separately into the
//! first one.
//!
//! Each later map's leaves are applied to the first map as log-odds updates (OctoMap's
//! `updateNode` with the leaf's log-odds, clamped to the first map's sensor model, pruned
//! leaves applied whole): [`octoquant::OcTree::merge`], in the order given. The files carry no
//! sensor model, so the clamping is OctoMap's default (as any tree read from a file has).
//! A `.bt` input holds only the clamping bounds as values (OctoMap's `readBinary`), so its
//! leaves add `+3.5` or `-2.0`; `.ot` inputs carry the full log-odds.

use super::{json_path, print_json};
use anyhow::{Context, Result};
use octoquant::output::check_output;
use octoquant::treefile::{read_tree_file, save_tree_file, TREE_EXTENSIONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The maps (.bt or .ot): the first is the base, the others are merged into it in order.
    #[arg(required = true, num_args = 2..)]
    inputs: Vec<PathBuf>,
    /// Output file(s); each one's extension (.bt or .ot) picks its format. A .bt output holds
    /// the max-likelihood, pruned tree, as OctoMap writes it. Repeat for both formats.
    #[arg(short, long = "output", required = true)]
    output: Vec<PathBuf>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

/// A map given twice (the same file, by any path) adds its evidence twice: allowed, since
/// weighting a map is a use, but said on stderr, since it is more often a slip.
fn warn_repeated_inputs(inputs: &[PathBuf]) {
    let mut seen: Vec<(PathBuf, &PathBuf)> = Vec::new();
    for input in inputs {
        let Ok(real) = std::fs::canonicalize(input) else {
            continue; // the read reports it
        };
        if let Some((_, first)) = seen.iter().find(|(r, _)| *r == real) {
            errln!(
                "warning: {} is the same file as {}: its evidence is merged once more",
                input.display(),
                first.display()
            );
        } else {
            seen.push((real, input));
        }
    }
}

pub fn run(a: &Args) -> Result<()> {
    for o in &a.output {
        check_output(o, &TREE_EXTENSIONS, &a.inputs)?;
    }
    warn_repeated_inputs(&a.inputs);
    let mut tree = read_tree_file(&a.inputs[0])?;
    let (mut leaves, mut pruned, mut voxels) = (0usize, 0usize, 0u64);
    for input in &a.inputs[1..] {
        let other = read_tree_file(input)?;
        let s = tree.merge(&other).with_context(|| {
            format!("merging {} into {}", input.display(), a.inputs[0].display())
        })?;
        leaves += s.leaves;
        pruned += s.pruned_leaves;
        voxels += s.voxels;
    }
    for o in &a.output {
        save_tree_file(&tree, o)?;
    }
    if a.json {
        print_json(&serde_json::json!({
            "inputs": a.inputs.iter().map(|p| json_path(p)).collect::<Vec<_>>(),
            "outputs": a.output.iter().map(|p| json_path(p)).collect::<Vec<_>>(),
            "leaves_merged": leaves,
            "pruned_leaves_merged": pruned,
            "voxels_merged": voxels,
            "nodes": tree.size(),
        }))?;
    } else {
        for o in &a.output {
            errln!(
                "wrote {} ({} nodes; {} leaves merged, {} of them pruned, {} voxels)",
                o.display(),
                tree.size(),
                leaves,
                pruned,
                voxels
            );
        }
    }
    Ok(())
}
