//! `octoquant compare A B [--json]`: OctoMap's `compare_octrees`, and more: how two maps of
//! the same resolution agree voxel by voxel (occupancy class), the volume that changed class,
//! and the Kullback-Leibler divergence exactly as `compare_octrees` sums it; with `--png`, a
//! top view coloured by where they differ (`octoquant::compare_image`).

use super::{json_path, print_json};
use anyhow::{bail, Result};
use octoquant::compare_image::{difference_image, with_legend, MAX_DIFFERENCE_PIXELS};
use octoquant::octree::{compare_classes, kl_divergence, Divergence, VoxelClass};
use octoquant::output::{check_output, write_atomic};
use octoquant::render::write_png;
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
    /// Also draw where the maps differ, seen from above: red occupied only in the first map,
    /// green only in the second, yellow both kinds in one column, light grey occupied in both,
    /// blue free in one map and unknown in the other, dark grey free in both; titled with the
    /// two file names (A, B), with a legend of the colours at its right.
    #[arg(long, value_name = "OUT.png")]
    png: Option<PathBuf>,
    /// The map's longer side in the picture at most, in pixels, 16 to 8192 (a pixel covers
    /// more voxel columns when the map is larger; title and legend come on top).
    #[arg(long, default_value_t = 1000, value_name = "N",
          value_parser = clap::value_parser!(u32).range(16..=i64::from(MAX_DIFFERENCE_PIXELS)))]
    max_pixels: u32,
}

pub fn run(a: &Args) -> Result<()> {
    if let Some(png) = &a.png {
        check_output(png, &["png"], &[a.first.clone(), a.second.clone()])?;
    }
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
    let picture = match &a.png {
        Some(png) => {
            let title = format!("A {}   B {}", file_label(&a.first), file_label(&a.second));
            let d = with_legend(difference_image(&ta, &tb, a.max_pixels)?, &title);
            write_atomic(png, |w| write_png(&d.image, w))?;
            Some((png, d))
        }
        None => None,
    };
    let picture_json = picture.as_ref().map(|(png, d)| {
        let keys = [
            "both_changes",
            "only_first",
            "only_second",
            "both_occupied",
            "one_knows",
            "both_free",
            "unknown",
        ];
        let pixels: serde_json::Map<String, serde_json::Value> = keys
            .iter()
            .zip(d.pixels)
            .map(|(k, n)| (k.to_string(), n.into()))
            .collect();
        serde_json::json!({
            "output": json_path(png),
            "width": d.image.width,
            "height": d.image.height,
            "map_area": d.image.map_area,
            "columns_per_pixel": d.columns_per_pixel,
            "origin": d.origin,
            "pixels": pixels,
        })
    });
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
            "png": picture_json,
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
    if let Some((png, d)) = &picture {
        errln!(
            "wrote {} ({} x {} pixels, {} voxel columns per pixel side; {} pixels with changes)",
            png.display(),
            d.image.width,
            d.image.height,
            d.columns_per_pixel,
            d.pixels[0] + d.pixels[1] + d.pixels[2]
        );
    }
    Ok(())
}

/// A file's name for the picture's title (its glyphs: letters, digits and `.-=')':/`).
fn file_label(p: &std::path::Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
