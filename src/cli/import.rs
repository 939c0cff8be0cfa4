//! `octoquant import IN.binvox... [-o OUT.bt] [--mark-free] [--rotate] [--bb ...] [--offset
//! X Y Z] [--json]`: OctoMap's `binvox2bt` (see `octoquant::import`). Unlike binvox2bt, where
//! an option applies to the files after it, the options apply to every input.

use super::{json_path, print_json};
use anyhow::{bail, Result};
use nalgebra::{Point3, Vector3};
use octoquant::formats::binvox::read_binvox;
use octoquant::import::{finish_import, import_binvox, tree_for_binvox, BinvoxImport};
use octoquant::output::check_output;
use octoquant::treefile::{write_tree_file, TREE_EXTENSIONS};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// binvox files; several are composed into one map at the first one's resolution.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Output .bt (or .ot) file; default: the first input's name + ".bt", as binvox2bt.
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Mark the cells that are not voxels free (otherwise they stay unknown).
    #[arg(long)]
    mark_free: bool,
    /// Turn the model a quarter turn about x (for files exported from Webots).
    #[arg(long)]
    rotate: bool,
    /// Keep only the cells whose point lies in this box, bounds included.
    #[arg(long, num_args = 6, value_names = ["MINX", "MINY", "MINZ", "MAXX", "MAXY", "MAXZ"], allow_negative_numbers = true)]
    bb: Option<Vec<f64>>,
    /// Add this offset (metres) to every point.
    #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
    offset: Option<Vec<f64>>,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    let output = a.output.clone().unwrap_or_else(|| {
        let mut name = a.inputs[0].clone().into_os_string();
        name.push(".bt");
        PathBuf::from(name)
    });
    check_output(&output, &TREE_EXTENSIONS, &a.inputs)?;
    let finite = |v: &[f64], name: &str| -> Result<()> {
        if v.iter().any(|c| !c.is_finite()) {
            bail!("--{name} {v:?}: every value must be a finite number");
        }
        Ok(())
    };
    let mut options = BinvoxImport {
        mark_free: a.mark_free,
        rotate: a.rotate,
        ..BinvoxImport::default()
    };
    if let Some(b) = &a.bb {
        finite(b, "bb")?;
        options.bbx = Some((Point3::new(b[0], b[1], b[2]), Point3::new(b[3], b[4], b[5])));
    }
    if let Some(o) = &a.offset {
        finite(o, "offset")?;
        // binvox2bt reads the offset into a float point3d
        options.offset = Some(Vector3::new(o[0] as f32, o[1] as f32, o[2] as f32));
    }
    let mut tree = None;
    let mut files = Vec::new();
    let (mut updated, mut outside_map) = (0u64, 0u64);
    for input in &a.inputs {
        let grid = read_binvox(input)?;
        let t = match &mut tree {
            Some(t) => t,
            None => tree.insert(tree_for_binvox(&grid).map_err(|e| {
                anyhow::anyhow!(
                    "{}: scale {} over {} cells is not a usable leaf size: {e}",
                    input.display(),
                    grid.scale,
                    grid.max_side()
                )
            })?),
        };
        let st = import_binvox(t, &grid, &options);
        updated += st.hits + st.misses;
        outside_map += st.outside_map;
        if !a.json {
            errln!(
                "{}: {} x {} x {} cells, {} voxels, {} outside the box, {} hits, {} misses{}",
                input.display(),
                grid.dims[0],
                grid.dims[1],
                grid.dims[2],
                st.voxels,
                st.outside_box,
                st.hits,
                st.misses,
                if st.outside_map > 0 {
                    format!(", {} outside the map", st.outside_map)
                } else {
                    String::new()
                }
            );
        }
        files.push(serde_json::json!({
            "input": json_path(input),
            "dims": grid.dims,
            "voxels": st.voxels,
            "outside_box": st.outside_box,
            "hits": st.hits,
            "misses": st.misses,
            "outside_map": st.outside_map,
        }));
    }
    let Some(mut tree) = tree else {
        bail!("no input files");
    };
    if updated == 0 && outside_map > 0 {
        bail!(
            "every voxel to mark ({outside_map}) lies outside the map's addressable cube \
             (±{} m at {} m resolution){}; nothing written",
            tree.resolution() * 32768.0,
            tree.resolution(),
            if a.offset.is_some() {
                ": check --offset"
            } else {
                ""
            }
        );
    }
    finish_import(&mut tree);
    write_tree_file(&mut tree, &output)?;
    if a.json {
        print_json(&serde_json::json!({
            "output": json_path(&output),
            "resolution": tree.resolution(),
            "leaves": tree.num_leaves(),
            "nodes": tree.size(),
            "inputs": files,
        }))?;
    } else {
        errln!(
            "wrote {} ({:?} m, {} leaves, {} nodes)",
            output.display(),
            tree.resolution(),
            tree.num_leaves(),
            tree.size()
        );
    }
    Ok(())
}
