//! `octoquant compare A B [--json]`: OctoMap's `compare_octrees`, and more: how two maps of
//! the same resolution agree voxel by voxel (occupancy class), the volume that changed class,
//! and the Kullback-Leibler divergence exactly as `compare_octrees` sums it.

use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::octree::{compare_classes, kl_divergence, Divergence, VoxelClass};
use octoquant::treefile::read_tree_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The first map (.bt or .ot): the divergence is taken over its voxels.
    first: PathBuf,
    /// The second map, of the same resolution.
    second: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    let ta = read_tree_file(&a.first)?;
    let tb = read_tree_file(&a.second)?;
    if (ta.resolution() - tb.resolution()).abs() > 1e-6 {
        bail!(
            "the maps' resolutions differ ({:?} m in {}, {:?} m in {}): their voxels do not line up",
            ta.resolution(),
            a.first.display(),
            tb.resolution(),
            a.second.display()
        );
    }
    let classes = compare_classes(&ta, &tb)?;
    let divergence = kl_divergence(&ta, &tb)?;
    let res = ta.resolution();
    let changed = classes.known_in_either() - classes.agreeing();
    let changed_m3 = changed as f64 * res * res * res;
    let names = ["unknown", "free", "occupied"];
    if a.json {
        let mut matrix = serde_json::Map::new();
        for ca in VoxelClass::ALL {
            let mut row = serde_json::Map::new();
            for cb in VoxelClass::ALL {
                row.insert(names[cb as usize].into(), classes.count(ca, cb).into());
            }
            matrix.insert(names[ca as usize].into(), row.into());
        }
        let (kld, kld_note) = match divergence {
            Divergence::Sum { kld, octomap_order } => (
                serde_json::json!(kld),
                if octomap_order {
                    "compare_octrees' sum, in its order"
                } else {
                    "summed cube by cube (too many voxels to add one at a time)"
                },
            ),
            Divergence::DifferentVoxels => (
                serde_json::Value::Null,
                "not defined: the maps know different voxels",
            ),
            Divergence::NotANumber => (serde_json::Value::Null, "not a number"),
        };
        print_json(&serde_json::json!({
            "first": json_path(&a.first),
            "second": json_path(&a.second),
            "resolution": res,
            "known_in_either": classes.known_in_either(),
            "agreeing": classes.agreeing(),
            "agreement": classes.agreement(),
            "classes": matrix,
            "changed_voxels": changed,
            "changed_volume_m3": changed_m3,
            "kld": kld,
            "kld_note": kld_note,
        }))?;
        return Ok(());
    }
    outln!("first:            {}", a.first.display())?;
    outln!("second:           {}", a.second.display())?;
    outln!("resolution:       {res:?} m")?;
    outln!(
        "known voxels:     {} (known to either map)",
        classes.known_in_either()
    )?;
    outln!(
        "class agreement:  {:.6} ({} voxels in the same class)",
        classes.agreement(),
        classes.agreeing()
    )?;
    outln!("voxels by class (rows: first map, columns: second map):")?;
    outln!(
        "  {:>10} {:>14} {:>14} {:>14}",
        "",
        names[0],
        names[1],
        names[2]
    )?;
    for ca in VoxelClass::ALL {
        let c = |cb| classes.count(ca, cb);
        outln!(
            "  {:>10} {:>14} {:>14} {:>14}",
            names[ca as usize],
            if ca == VoxelClass::Unknown {
                "-".to_string()
            } else {
                c(VoxelClass::Unknown).to_string()
            },
            c(VoxelClass::Free),
            c(VoxelClass::Occupied)
        )?;
    }
    outln!("changed volume:   {changed_m3:.6} m3 ({changed} voxels in another class)")?;
    match divergence {
        Divergence::Sum {
            kld,
            octomap_order: true,
        } => outln!("KLD:              {kld:?} (compare_octrees' sum, in its order)")?,
        Divergence::Sum {
            kld,
            octomap_order: false,
        } => outln!("KLD:              {kld:?} (summed cube by cube: too many voxels to add one at a time)")?,
        Divergence::DifferentVoxels => outln!(
            "KLD:              not defined: the maps know different voxels (compare_octrees refuses them)"
        )?,
        Divergence::NotANumber => outln!("KLD:              not a number (a NaN log-odds in a map)")?,
    }
    Ok(())
}
