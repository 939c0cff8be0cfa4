//! Pictures of a map: a height-coloured top view, a depth-coloured front or side view, or a
//! slice, as an RGB image with a colour bar, a scale bar and a legend, written as PNG.
//!
//! [`render`] draws into an [`Image`]; [`write_png`] encodes one; [`render_png_file`] does
//! both and writes the file atomically. The picture frames the occupied voxels (plus a
//! margin); known free space is drawn grey, unknown space dark, so a person sees at once what
//! was observed and what is solid.
//!
//! ```
//! use nalgebra::Point3;
//! use octoquant::render::{render, RenderOptions};
//! use octoquant::{InnerNodes, OcTree, Update};
//!
//! let mut tree = OcTree::new(0.1).unwrap();
//! for i in 0..20 {
//!     let k = tree.converter().point_to_key(&Point3::new(i as f64 * 0.1, 0.0, 0.0)).unwrap();
//!     tree.update_node(k, Update::Hit, InnerNodes::Refresh);
//! }
//! let image = render(&tree, &RenderOptions::default()).unwrap();
//! assert!(image.width > 100 && image.height > 100);
//! ```

use crate::output::{write_atomic, OutputError};
use octoquant_octree::{ColorOcTree, OcTree};
use std::io::Write;
use std::path::Path;

/// Errors from rendering.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The map has no occupied voxel to frame.
    #[error("the map has no occupied voxels to draw")]
    NothingToDraw,
    /// An option is out of range.
    #[error("invalid render option: {0}")]
    InvalidOption(String),
    /// Writing the file failed.
    #[error(transparent)]
    Write(#[from] OutputError),
}

/// The direction the picture looks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum View {
    /// From above: x to the right, y up, colour = height (z) of the highest occupied voxel.
    #[default]
    Top,
    /// From the −y side: x to the right, z up, colour = y of the nearest occupied voxel.
    Front,
    /// From the −x side looking towards +x: y grows to the left, z up, colour = x of the
    /// nearest occupied voxel.
    Side,
}

impl View {
    /// (horizontal axis, vertical axis, depth axis, horizontal axis flipped).
    fn axes(self) -> (usize, usize, usize, bool) {
        match self {
            View::Top => (0, 1, 2, false),
            View::Front => (0, 2, 1, false),
            View::Side => (1, 2, 0, true),
        }
    }

    fn name(self) -> &'static str {
        match self {
            View::Top => "TOP VIEW",
            View::Front => "FRONT VIEW",
            View::Side => "SIDE VIEW",
        }
    }
}

/// What [`render`] draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Viewing direction.
    pub view: View,
    /// Draw only the voxels whose cubes contain this coordinate on the view's depth axis
    /// (z for the top view, y for front, x for side): a cross-section, occupied in colour,
    /// free in grey.
    pub slice: Option<f64>,
    /// Target size in pixels of the longer side of the map area (200 to 4000).
    pub map_pixels: u32,
    /// Draw known free space (grey) as well as occupied space.
    pub show_free: bool,
}

impl Default for RenderOptions {
    /// Top view, no slice, 1000 px, free space shown.
    fn default() -> Self {
        RenderOptions {
            view: View::Top,
            slice: None,
            map_pixels: 1000,
            show_free: true,
        }
    }
}

/// An 8-bit RGB image, rows top to bottom.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` bytes.
    pub rgb: Vec<u8>,
    /// Where the map is drawn: x, y of its top-left pixel, width, height (the rest is the
    /// title, legend and scale bar).
    pub map_area: [u32; 4],
}

impl Image {
    pub(crate) fn new(width: u32, height: u32, colour: [u8; 3]) -> Image {
        let n = width as usize * height as usize;
        let mut rgb = Vec::with_capacity(n * 3);
        for _ in 0..n {
            rgb.extend_from_slice(&colour);
        }
        Image {
            width,
            height,
            rgb,
            map_area: [0, 0, width, height],
        }
    }

    /// The colour at (x, y), `None` outside.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y as usize * self.width as usize + x as usize) * 3;
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 3;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    pub(crate) fn fill(&mut self, x: i64, y: i64, w: i64, h: i64, c: [u8; 3]) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.put(xx, yy, c);
            }
        }
    }
}

/// Background (unknown space).
pub const UNKNOWN_COLOUR: [u8; 3] = [28, 31, 38];
/// Known free space.
pub const FREE_COLOUR: [u8; 3] = [78, 84, 96];
pub(crate) const PANEL: [u8; 3] = [16, 18, 22];
pub(crate) const TEXT: [u8; 3] = [225, 228, 232];

/// The colour of `t` in [0, 1] on the height scale (indigo, blue, teal, yellow, red); values
/// outside are clamped, NaN gives the low end.
pub fn height_colour(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [58.0, 28.0, 140.0],
        [34.0, 118.0, 232.0],
        [36.0, 196.0, 150.0],
        [240.0, 206.0, 48.0],
        [224.0, 58.0, 36.0],
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mut c = [0u8; 3];
    for (k, v) in c.iter_mut().enumerate() {
        *v = (STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f).round() as u8;
    }
    c
}

/// Per-cell state of the projection.
#[derive(Clone, Copy)]
struct Cell {
    /// Depth value of the best occupied voxel (max z for top, min for front/side), NaN if none.
    depth: f64,
    free: bool,
    /// The voxel colour of that voxel, when the map has one for it.
    color: Option<[u8; 3]>,
}

/// Draw the map as described by `options`.
///
/// Errors when the map has no occupied voxel or an option is out of range.
pub fn render(tree: &OcTree, options: &RenderOptions) -> Result<Image, RenderError> {
    render_with(tree, None, options)
}

/// [`render`] of a coloured map: each visible occupied voxel is drawn in its own colour (with
/// the top view's relief shading), those without a colour (white, OctoMap's "unset") by the
/// depth scale as in [`render`].
pub fn render_colored(tree: &ColorOcTree, options: &RenderOptions) -> Result<Image, RenderError> {
    render_with(tree.occupancy(), Some(tree), options)
}

fn render_with(
    tree: &OcTree,
    colors: Option<&ColorOcTree>,
    options: &RenderOptions,
) -> Result<Image, RenderError> {
    if !(200..=4000).contains(&options.map_pixels) {
        return Err(RenderError::InvalidOption(format!(
            "map size {} px is outside 200..4000",
            options.map_pixels
        )));
    }
    if options.slice.is_some_and(|s| !s.is_finite()) {
        return Err(RenderError::InvalidOption(
            "the slice coordinate is not finite".into(),
        ));
    }
    let (ua, va, da, flip) = options.view.axes();
    let conv = tree.converter();
    let params = tree.params();

    // Frame: bounds of occupied leaves.
    let mut lo = [f64::MAX; 3];
    let mut hi = [f64::MIN; 3];
    let mut any = false;
    for leaf in tree.leaves().filter(|l| params.is_occupied(l.value)) {
        any = true;
        let c = conv.key_to_point_at_depth(&leaf.key, leaf.depth);
        let h = conv.node_size(leaf.depth) / 2.0;
        for a in 0..3 {
            lo[a] = lo[a].min(c[a] - h);
            hi[a] = hi[a].max(c[a] + h);
        }
    }
    if !any {
        return Err(RenderError::NothingToDraw);
    }
    let margin = 0.04 * (hi[ua] - lo[ua]).max(hi[va] - lo[va]) + conv.resolution();
    let (u0, u1) = (lo[ua] - margin, hi[ua] + margin);
    let (v0, v1) = (lo[va] - margin, hi[va] + margin);

    // Cell size: the resolution, doubled until the grid fits the pixel budget. Voxel faces
    // lie on multiples of the resolution, so a grid aligned to multiples of the cell size
    // maps each voxel onto whole cells.
    let mut cell = conv.resolution();
    while ((u1 - u0) / cell).max((v1 - v0) / cell) > options.map_pixels as f64 {
        cell *= 2.0;
    }
    let snap = |x: f64| (x / cell + 1e-6).floor() * cell;
    let (u0, v0) = (snap(u0), snap(v0));
    let nu = ((u1 - u0) / cell - 1e-6).ceil().max(1.0) as usize;
    let nv = ((v1 - v0) / cell - 1e-6).ceil().max(1.0) as usize;
    let mut grid = vec![
        Cell {
            depth: f64::NAN,
            free: false,
            color: None,
        };
        nu * nv
    ];
    let top = options.view == View::Top;
    let better = |new: f64, old: f64| old.is_nan() || if top { new > old } else { new < old };

    for leaf in tree.leaves() {
        let occupied = params.is_occupied(leaf.value);
        if !occupied && !options.show_free {
            continue;
        }
        let c = conv.key_to_point_at_depth(&leaf.key, leaf.depth);
        let h = conv.node_size(leaf.depth) / 2.0;
        if let Some(s) = options.slice {
            if s < c[da] - h || s >= c[da] + h {
                continue;
            }
        }
        let range = |lo_m: f64, hi_m: f64, origin: f64, n: usize| -> Option<(usize, usize)> {
            let a = ((lo_m - origin) / cell + 1e-6).floor().max(0.0);
            let b = ((hi_m - origin) / cell - 1e-6).ceil().min(n as f64);
            (b > a).then_some((a as usize, b as usize))
        };
        let Some((iu0, iu1)) = range(c[ua] - h, c[ua] + h, u0, nu) else {
            continue;
        };
        let Some((iv0, iv1)) = range(c[va] - h, c[va] + h, v0, nv) else {
            continue;
        };
        let d = if top { c[da] + h } else { c[da] - h };
        let voxel_color = if occupied {
            colors
                .and_then(|t| t.search(leaf.key, leaf.depth))
                .map(|n| n.color)
                .filter(|c| c.is_set())
                .map(|c| c.to_array())
        } else {
            None
        };
        for iv in iv0..iv1 {
            for iu in iu0..iu1 {
                let g = &mut grid[iv * nu + iu];
                if occupied {
                    if better(d, g.depth) {
                        g.depth = d;
                        g.color = voxel_color;
                    }
                } else {
                    g.free = true;
                }
            }
        }
    }

    // Colour scale over the depth axis of the occupied voxels.
    let (dlo, dhi) = if options.slice.is_some() {
        (lo[da], hi[da])
    } else {
        let mut a = f64::MAX;
        let mut b = f64::MIN;
        for g in grid.iter().filter(|g| !g.depth.is_nan()) {
            a = a.min(g.depth);
            b = b.max(g.depth);
        }
        (a, b)
    };
    let span = (dhi - dlo).max(1e-9);
    let colour_of = |d: f64| {
        height_colour(if top {
            (d - dlo) / span
        } else {
            1.0 - (d - dlo) / span
        })
    };

    // Layout: title above, map at left, colour bar and legend at right, scale bar below.
    let scale = ((options.map_pixels as usize) / nu.max(nv)).max(1);
    let text_scale: i64 = if options.map_pixels >= 600 { 2 } else { 1 };
    let glyph_h = 7 * text_scale;
    let pad = 8 * text_scale + 8;
    let map_w = (nu * scale) as i64;
    let map_h = (nv * scale) as i64;
    let legend_w = 150 * text_scale;
    let width = pad + map_w + pad + legend_w;
    // Legend column: label, colour bar, gap, two swatches.
    let swatch_h = glyph_h + 6 * text_scale;
    let legend_extra = glyph_h + 6 * text_scale + 10 * text_scale + 2 * swatch_h;
    let bar_h = (map_h - legend_extra).clamp(100 * text_scale, 400 * text_scale);
    let content_h = map_h.max(bar_h + legend_extra);
    let height = pad + glyph_h + pad + content_h + pad + glyph_h * 2 + pad;
    let mut img = Image::new(width as u32, height as u32, PANEL);
    let mx = pad;
    let my = pad + glyph_h + pad;
    img.fill(mx, my, map_w, map_h, UNKNOWN_COLOUR);
    img.map_area = [mx as u32, my as u32, map_w as u32, map_h as u32];
    for iv in 0..nv {
        // Image rows run downwards, the vertical axis upwards.
        let py = my + ((nv - 1 - iv) * scale) as i64;
        for iu in 0..nu {
            let g = grid[iv * nu + iu];
            let col = if !g.depth.is_nan() {
                let mut c = g.color.unwrap_or_else(|| colour_of(g.depth));
                // Relief: darken where the neighbour towards the light (up-left) is higher.
                if top && options.slice.is_none() {
                    let up = if iv + 1 < nv {
                        grid[(iv + 1) * nu + iu].depth
                    } else {
                        f64::NAN
                    };
                    let left = if iu > 0 {
                        grid[iv * nu + iu - 1].depth
                    } else {
                        f64::NAN
                    };
                    let shade = [up, left]
                        .iter()
                        .filter(|n| !n.is_nan() && **n > g.depth + cell * 1.5)
                        .count();
                    let k = [1.0, 0.78, 0.62][shade];
                    c = c.map(|v| (v as f64 * k) as u8);
                }
                c
            } else if g.free {
                FREE_COLOUR
            } else {
                continue;
            };
            let col_u = if flip { nu - 1 - iu } else { iu };
            img.fill(
                mx + (col_u * scale) as i64,
                py,
                scale as i64,
                scale as i64,
                col,
            );
        }
    }

    // Title.
    let axis = ["X", "Y", "Z"];
    let title = match options.slice {
        Some(s) => format!(
            "{} SLICE {}={:.2} M   RES {} M",
            options.view.name(),
            axis[da],
            s,
            conv.resolution()
        ),
        None => format!("{}   RES {} M", options.view.name(), conv.resolution()),
    };
    let title = if colors.is_some() {
        format!("{title}   VOXEL COLOURS")
    } else {
        title
    };
    draw_text(&mut img, pad, pad, &title, text_scale, TEXT);

    // Colour bar with five labelled ticks.
    let lx = mx + map_w + pad;
    let bar_w = 14 * text_scale;
    draw_text(
        &mut img,
        lx,
        my,
        &format!("{} (M)", axis[da]),
        text_scale,
        TEXT,
    );
    let by = my + glyph_h + 6 * text_scale;
    for y in 0..bar_h {
        let t = 1.0 - y as f64 / (bar_h - 1) as f64;
        // In the top view high is red; front/side: near (low depth) is red.
        let d = if top { dlo + t * span } else { dhi - t * span };
        img.fill(lx, by + y, bar_w, 1, colour_of(d));
    }
    let prec = if span < 2.0 { 2 } else { 1 };
    for i in 0..5 {
        let t = i as f64 / 4.0;
        let y = by + ((1.0 - t) * (bar_h - 1) as f64) as i64;
        let d = if top { dlo + t * span } else { dhi - t * span };
        img.fill(lx + bar_w, y, 4 * text_scale, text_scale.max(1), TEXT);
        draw_text(
            &mut img,
            lx + bar_w + 9 * text_scale,
            (y - glyph_h / 2).max(by - glyph_h / 2),
            &format!("{d:.prec$}"),
            text_scale,
            TEXT,
        );
    }
    // Swatches.
    let mut sy = by + bar_h + 10 * text_scale;
    let mut swatch = |img: &mut Image, colour: [u8; 3], label: &str| {
        img.fill(lx, sy, bar_w, glyph_h, colour);
        draw_text(
            img,
            lx + bar_w + 6 * text_scale,
            sy,
            label,
            text_scale,
            TEXT,
        );
        sy += swatch_h;
    };
    if options.show_free {
        swatch(&mut img, FREE_COLOUR, "FREE");
    }
    swatch(&mut img, UNKNOWN_COLOUR, "UNKNOWN");

    // Scale bar: a round length near a fifth of the map width.
    let px_per_m = scale as f64 / cell;
    let target = (map_w as f64 / 5.0) / px_per_m;
    let nice = [
        0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0, 1000.0,
    ]
    .into_iter()
    .rev()
    .find(|&n| n <= target)
    .unwrap_or(0.1);
    let bar_px = (nice * px_per_m).round() as i64;
    let sby = my + content_h + pad;
    img.fill(mx, sby, bar_px, 3 * text_scale, TEXT);
    img.fill(mx, sby - 2 * text_scale, text_scale, 7 * text_scale, TEXT);
    img.fill(
        mx + bar_px - text_scale,
        sby - 2 * text_scale,
        text_scale,
        7 * text_scale,
        TEXT,
    );
    draw_text(
        &mut img,
        mx + bar_px + 8 * text_scale,
        sby - 2 * text_scale,
        &format!("{nice} M"),
        text_scale,
        TEXT,
    );
    Ok(img)
}

/// Encode `image` as an 8-bit RGB PNG into `w`.
pub fn write_png(image: &Image, w: &mut dyn Write) -> std::io::Result<()> {
    let mut enc = png::Encoder::new(w, image.width, image.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(std::io::Error::other)?;
    writer
        .write_image_data(&image.rgb)
        .map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

/// Render `tree` and write the picture to `path` as PNG (atomically).
pub fn render_png_file(
    tree: &OcTree,
    path: &Path,
    options: &RenderOptions,
) -> Result<Image, RenderError> {
    let image = render(tree, options)?;
    write_atomic(path, |w| write_png(&image, w))?;
    Ok(image)
}

/// [`render_colored`] written to `path` as PNG (atomically).
pub fn render_colored_png_file(
    tree: &ColorOcTree,
    path: &Path,
    options: &RenderOptions,
) -> Result<Image, RenderError> {
    let image = render_colored(tree, options)?;
    write_atomic(path, |w| write_png(&image, w))?;
    Ok(image)
}

/// 5×7 glyphs, one string of 7 rows × 5 columns per character ('#' = ink).
fn glyph(c: char) -> Option<&'static [&'static str; 7]> {
    #[rustfmt::skip]
    const G: &[(char, [&str; 7])] = &[
        ('0', [" ### ", "#   #", "#  ##", "# # #", "##  #", "#   #", " ### "]),
        ('1', ["  #  ", " ##  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "]),
        ('2', [" ### ", "#   #", "    #", "   # ", "  #  ", " #   ", "#####"]),
        ('3', ["#####", "   # ", "  #  ", "   # ", "    #", "#   #", " ### "]),
        ('4', ["   # ", "  ## ", " # # ", "#  # ", "#####", "   # ", "   # "]),
        ('5', ["#####", "#    ", "#### ", "    #", "    #", "#   #", " ### "]),
        ('6', ["  ## ", " #   ", "#    ", "#### ", "#   #", "#   #", " ### "]),
        ('7', ["#####", "    #", "   # ", "  #  ", " #   ", " #   ", " #   "]),
        ('8', [" ### ", "#   #", "#   #", " ### ", "#   #", "#   #", " ### "]),
        ('9', [" ### ", "#   #", "#   #", " ####", "    #", "   # ", " ##  "]),
        ('A', [" ### ", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"]),
        ('B', ["#### ", "#   #", "#   #", "#### ", "#   #", "#   #", "#### "]),
        ('C', [" ### ", "#   #", "#    ", "#    ", "#    ", "#   #", " ### "]),
        ('D', ["#### ", "#   #", "#   #", "#   #", "#   #", "#   #", "#### "]),
        ('E', ["#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#####"]),
        ('F', ["#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#    "]),
        ('G', [" ### ", "#   #", "#    ", "# ###", "#   #", "#   #", " ####"]),
        ('H', ["#   #", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"]),
        ('I', [" ### ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", " ### "]),
        ('J', ["  ###", "   # ", "   # ", "   # ", "   # ", "#  # ", " ##  "]),
        ('K', ["#   #", "#  # ", "# #  ", "##   ", "# #  ", "#  # ", "#   #"]),
        ('L', ["#    ", "#    ", "#    ", "#    ", "#    ", "#    ", "#####"]),
        ('M', ["#   #", "## ##", "# # #", "# # #", "#   #", "#   #", "#   #"]),
        ('N', ["#   #", "#   #", "##  #", "# # #", "#  ##", "#   #", "#   #"]),
        ('O', [" ### ", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "]),
        ('P', ["#### ", "#   #", "#   #", "#### ", "#    ", "#    ", "#    "]),
        ('Q', [" ### ", "#   #", "#   #", "#   #", "# # #", "#  # ", " ## #"]),
        ('R', ["#### ", "#   #", "#   #", "#### ", "# #  ", "#  # ", "#   #"]),
        ('S', [" ####", "#    ", "#    ", " ### ", "    #", "    #", "#### "]),
        ('T', ["#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  "]),
        ('U', ["#   #", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "]),
        ('V', ["#   #", "#   #", "#   #", "#   #", "#   #", " # # ", "  #  "]),
        ('W', ["#   #", "#   #", "#   #", "# # #", "# # #", "# # #", " # # "]),
        ('X', ["#   #", "#   #", " # # ", "  #  ", " # # ", "#   #", "#   #"]),
        ('Y', ["#   #", "#   #", " # # ", "  #  ", "  #  ", "  #  ", "  #  "]),
        ('Z', ["#####", "    #", "   # ", "  #  ", " #   ", "#    ", "#####"]),
        ('.', ["     ", "     ", "     ", "     ", "     ", " ##  ", " ##  "]),
        ('-', ["     ", "     ", "     ", "#####", "     ", "     ", "     "]),
        ('=', ["     ", "     ", "#####", "     ", "#####", "     ", "     "]),
        ('(', ["   # ", "  #  ", " #   ", " #   ", " #   ", "  #  ", "   # "]),
        (')', [" #   ", "  #  ", "   # ", "   # ", "   # ", "  #  ", " #   "]),
        (':', ["     ", " ##  ", " ##  ", "     ", " ##  ", " ##  ", "     "]),
        ('/', ["    #", "    #", "   # ", "  #  ", " #   ", "#    ", "#    "]),
    ];
    let c = c.to_ascii_uppercase();
    G.iter().find(|(g, _)| *g == c).map(|(_, rows)| rows)
}

/// Draw `text` (upper-cased; unknown characters are blanks) with its top-left at (x, y).
pub(crate) fn draw_text(img: &mut Image, x: i64, y: i64, text: &str, scale: i64, colour: [u8; 3]) {
    let mut cx = x;
    for ch in text.chars() {
        if let Some(rows) = glyph(ch) {
            for (ry, row) in rows.iter().enumerate() {
                for (rx, b) in row.bytes().enumerate() {
                    if b == b'#' {
                        img.fill(
                            cx + rx as i64 * scale,
                            y + ry as i64 * scale,
                            scale,
                            scale,
                            colour,
                        );
                    }
                }
            }
        }
        cx += 6 * scale;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_ends() {
        assert_eq!(height_colour(0.0), [58, 28, 140]);
        assert_eq!(height_colour(1.0), [224, 58, 36]);
        assert_eq!(height_colour(f64::NAN), height_colour(0.0));
        assert_eq!(height_colour(7.0), height_colour(1.0));
    }

    #[test]
    fn every_glyph_is_5_by_7() {
        for c in "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.-=():/".chars() {
            let g = glyph(c).unwrap_or_else(|| panic!("no glyph for {c}"));
            assert!(g.iter().all(|r| r.len() == 5), "glyph {c}");
        }
    }
}
