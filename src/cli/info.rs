//! `octoquant info FILE [--json]`.

use super::{json_path, per_node, print_json};
use anyhow::Result;
use octoquant::treefile::{read_any_tree_file, AnyTree};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot file (an OctoMap OcTree, ColorOcTree or OcTreeStamped).
    file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    let any = read_any_tree_file(&a.file)?;
    let kind = any.type_name();
    let colored = any.colors().map(|t| t.num_colored_nodes());
    let stamps = match &any {
        AnyTree::Stamped(t) => Some(t.last_update_time()),
        _ => None,
    };
    let mut tree = any.into_occupancy();
    tree.shrink_to_fit();
    let c = tree.counts();
    let bounds = tree.metric_bounds();
    let mem = tree.memory_usage();
    let bpn = per_node(mem, c.nodes);
    let octomap_mem = tree.octomap_memory_usage();
    let octomap_bpn = per_node(octomap_mem, c.nodes);
    if a.json {
        let b = bounds.map(|(lo, hi)| {
            serde_json::json!({
                "min": [lo.x, lo.y, lo.z],
                "max": [hi.x, hi.y, hi.z],
            })
        });
        print_json(&serde_json::json!({
            "file": json_path(&a.file),
            "type": kind,
            "colored_nodes": colored,
            "resolution": tree.resolution(),
            "nodes": c.nodes,
            "inner": c.inner,
            "leaves": c.leaves,
            "occupied_leaves": c.occupied_leaves,
            "free_leaves": c.free_leaves,
            "bounds": b,
            "memory_bytes": mem,
            "bytes_per_node": bpn,
            "octomap_memory_bytes": octomap_mem,
            "octomap_bytes_per_node": octomap_bpn,
        }))?;
    } else {
        outln!("file:            {}", a.file.display())?;
        outln!("type:            {kind}")?;
        if let Some(n) = colored {
            outln!("colours:         {n} nodes with a colour")?;
        }
        if let Some(t) = stamps {
            outln!("last update:     {t} (OctoMap's .ot keeps no time stamps)")?;
        }
        outln!("resolution:      {:?} m", tree.resolution())?;
        outln!("nodes:           {} ({} inner)", c.nodes, c.inner)?;
        outln!(
            "leaves:          {} ({} occupied, {} free)",
            c.leaves,
            c.occupied_leaves,
            c.free_leaves
        )?;
        match bounds {
            Some((lo, hi)) => outln!(
                "bounds:          ({:.3}, {:.3}, {:.3}) .. ({:.3}, {:.3}, {:.3}) m",
                lo.x,
                lo.y,
                lo.z,
                hi.x,
                hi.y,
                hi.z
            )?,
            None => outln!("bounds:          (empty tree)")?,
        }
        outln!("memory:          {mem} bytes, {bpn:.2} bytes/node")?;
        outln!("OctoMap formula: {octomap_mem} bytes, {octomap_bpn:.2} bytes/node")?;
    }
    Ok(())
}
