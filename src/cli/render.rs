//! `octoquant render MAP -o OUT.png [--view top|front|side] [--slice C] [--json]`.

use super::vocab::ViewArg;
use super::{json_path, print_json};
use anyhow::Result;
use octoquant::output::check_output;
use octoquant::render::{render_colored_png_file, render_png_file, RenderOptions};
use octoquant::treefile::read_any_tree_file;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The .bt or .ot map (a ColorOcTree is drawn in its voxel colours).
    map: PathBuf,
    /// Output PNG.
    #[arg(short, long)]
    output: PathBuf,
    /// Viewing direction: top (colour = height), front (from −y) or side (from −x).
    #[arg(long, value_enum, default_value = "top")]
    view: ViewArg,
    /// Draw a slice through this coordinate of the view's depth axis (z for top).
    #[arg(long, allow_negative_numbers = true)]
    slice: Option<f64>,
    /// Size of the longer side of the map area, in pixels.
    #[arg(long, default_value_t = 1000)]
    size: u32,
    /// Do not draw free space.
    #[arg(long)]
    no_free: bool,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(a: &Args) -> Result<()> {
    check_output(&a.output, &["png"], std::slice::from_ref(&a.map))?;
    let any = read_any_tree_file(&a.map)?;
    let options = RenderOptions {
        view: a.view.into(),
        slice: a.slice,
        map_pixels: a.size,
        show_free: !a.no_free,
    };
    let image = match any.colors() {
        Some(t) => render_colored_png_file(t, &a.output, &options)?,
        None => render_png_file(any.occupancy(), &a.output, &options)?,
    };
    if a.json {
        print_json(&serde_json::json!({
            "map": json_path(&a.map),
            "output": json_path(&a.output),
            "width": image.width,
            "height": image.height,
            "voxel_colors": any.colors().is_some(),
        }))?;
    } else {
        errln!(
            "wrote {} ({} × {} px)",
            a.output.display(),
            image.width,
            image.height
        );
    }
    Ok(())
}
