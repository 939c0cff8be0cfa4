//! `octoquant convert IN OUT [--json]`: .bt <-> .ot by extension, from any OctoMap tree type
//! octoquant reads (OcTree, ColorOcTree, OcTreeStamped).

use super::{json_path, print_json};
use anyhow::Result;
use octoquant::octree::io::{write_bt_typed, write_color_ot, write_stamped_ot, TreeFormat};
use octoquant::output::check_output;
use octoquant::output::write_atomic;
use octoquant::treefile::{read_any_tree_file, write_tree_file, AnyTree, TREE_EXTENSIONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Input .bt or .ot file (an OcTree, ColorOcTree or OcTreeStamped).
    input: PathBuf,
    /// Output file; its extension (.bt or .ot) picks the format. A .bt output holds the
    /// max-likelihood, pruned occupancy, as OctoMap's writeBinary writes it from any of the
    /// three types; an .ot output keeps the input's type (and colours).
    output: PathBuf,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &TREE_EXTENSIONS, std::slice::from_ref(&a.input))?;
    let any = read_any_tree_file(&a.input)?;
    let kind = any.type_name();
    let to_ot = TreeFormat::from_path(&a.output) == Some(TreeFormat::Ot);
    let nodes = match any {
        AnyTree::Color(t) if to_ot => {
            write_atomic(&a.output, |w| write_color_ot(&t, w))?;
            t.size()
        }
        AnyTree::Stamped(t) if to_ot => {
            write_atomic(&a.output, |w| write_stamped_ot(&t, w))?;
            t.size()
        }
        AnyTree::Plain(mut tree) => {
            write_tree_file(&mut tree, &a.output)?;
            tree.size()
        }
        // OctoMap's writeBinary on a ColorOcTree or OcTreeStamped: max-likelihood and prune
        // decide on occupancy alone (colours are ignored by the collapse test, and stamps read
        // from an .ot are all 0), under the header id of the tree's type
        any => {
            let mut tree = any.into_occupancy();
            write_atomic(&a.output, |w| write_bt_typed(&mut tree, kind, w))?;
            tree.size()
        }
    };
    if a.json {
        print_json(&serde_json::json!({
            "input": json_path(&a.input),
            "type": kind,
            "output": json_path(&a.output),
            "nodes": nodes,
        }))?;
    } else {
        errln!("wrote {} ({kind}, {nodes} nodes)", a.output.display());
    }
    Ok(())
}
