//! A picture of where two maps differ: a top view (x to the right, y up) of the space known to
//! either map, each pixel a column of voxels coloured by the most telling class pair in it.
//!
//! | colour | in the column |
//! |---|---|
//! | [`BOTH_CHANGES`] yellow | voxels occupied only in the first map and others only in the second |
//! | [`ONLY_FIRST`] red | a voxel occupied in the first map, not in the second (free or unknown) |
//! | [`ONLY_SECOND`] green | a voxel occupied in the second map, not in the first |
//! | [`BOTH_OCCUPIED`] light grey | no change; a voxel occupied in both |
//! | [`ONE_KNOWS`] blue | no occupied voxel; space free in one map, unknown in the other |
//! | [`BOTH_FREE`] dark grey | only space free in both |
//! | [`crate::render::UNKNOWN_COLOUR`] | nothing known |
//!
//! A pixel is one voxel column while the map's longer side fits in the requested size;
//! beyond, each pixel covers `k × k` columns (k a power of two), so any map gives a picture of
//! bounded size. The maps are walked together ([`for_each_class_cube`]), never expanded.
//! [`with_legend`] frames the picture with a title and a legend of these colours
//! ([`LEGEND`]), as `octoquant compare --png` writes it.

use crate::render::{draw_text, Image, PANEL, TEXT, UNKNOWN_COLOUR};
use octoquant_octree::{for_each_class_cube, ClassCube, OcTree, OctreeError, VoxelClass};

/// Occupied only in the first map and, elsewhere in the column, only in the second.
pub const BOTH_CHANGES: [u8; 3] = [240, 200, 40];
/// Occupied in the first map, not in the second.
pub const ONLY_FIRST: [u8; 3] = [220, 50, 47];
/// Occupied in the second map, not in the first.
pub const ONLY_SECOND: [u8; 3] = [60, 180, 75];
/// Occupied in both.
pub const BOTH_OCCUPIED: [u8; 3] = [200, 200, 205];
/// Free in one map, unknown in the other.
pub const ONE_KNOWS: [u8; 3] = [70, 110, 200];
/// Free in both.
pub const BOTH_FREE: [u8; 3] = [78, 84, 96];

/// The legend's rows: each colour of the picture and what it means, in the order of
/// [`DifferenceImage::pixels`].
pub const LEGEND: [([u8; 3], &str); 7] = [
    (BOTH_CHANGES, "CHANGED BOTH WAYS"),
    (ONLY_FIRST, "OCCUPIED ONLY IN A"),
    (ONLY_SECOND, "OCCUPIED ONLY IN B"),
    (BOTH_OCCUPIED, "OCCUPIED IN BOTH"),
    (ONE_KNOWS, "FREE IN ONE ONLY"),
    (BOTH_FREE, "FREE IN BOTH"),
    (UNKNOWN_COLOUR, "UNKNOWN IN BOTH"),
];

/// Layout of [`with_legend`]: margin, swatch size and legend row height in pixels (text is
/// 5×7 glyphs at scale 1).
const PAD: u32 = 8;
const SWATCH: u32 = 9;
const ROW: u32 = 14;
const LEGEND_W: u32 = SWATCH + 6 + 18 * 6;

/// Where [`with_legend`] puts legend row `i`'s swatch (a square of 9 pixels): its top-left
/// pixel, right of the map area `[x, y, width, height]` (so readers of the picture can find it).
pub fn legend_swatch([mx, my, mw, _]: [u32; 4], i: usize) -> (u32, u32) {
    (mx + mw + PAD, my + i as u32 * ROW)
}

/// `d` framed for reading: a title line (`title`, e.g. the two file names), the map below it,
/// and to its right the legend ([`LEGEND`]: a swatch and its meaning per colour). The map's
/// pixels are unchanged, moved to `image.map_area`.
pub fn with_legend(d: DifferenceImage, title: &str) -> DifferenceImage {
    let (w, h) = (d.image.width, d.image.height);
    let top = PAD + 7 + PAD;
    let width = PAD + w + PAD + LEGEND_W + PAD;
    let height = top + h.max(LEGEND.len() as u32 * ROW) + PAD;
    let mut img = Image::new(width, height, PANEL);
    for y in 0..h {
        for x in 0..w {
            if let Some(c) = d.image.pixel(x, y) {
                img.fill(i64::from(PAD + x), i64::from(top + y), 1, 1, c);
            }
        }
    }
    img.map_area = [PAD, top, w, h];
    draw_text(&mut img, i64::from(PAD), i64::from(PAD), title, 1, TEXT);
    for (i, (colour, label)) in LEGEND.iter().enumerate() {
        let (sx, sy) = legend_swatch(img.map_area, i);
        let (x, y) = (i64::from(sx), i64::from(sy));
        img.fill(x, y, SWATCH.into(), SWATCH.into(), *colour);
        draw_text(&mut img, x + i64::from(SWATCH) + 6, y + 1, label, 1, TEXT);
    }
    DifferenceImage { image: img, ..d }
}

/// A column's state, most telling last (a pixel keeps the highest it sees).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Shade {
    Unknown = 0,
    BothFree,
    OneKnows,
    BothOccupied,
    OnlySecond,
    OnlyFirst,
}

fn shade(c: &ClassCube) -> Shade {
    use VoxelClass::*;
    match (c.first, c.second) {
        (Occupied, Occupied) => Shade::BothOccupied,
        (Occupied, _) => Shade::OnlyFirst,
        (_, Occupied) => Shade::OnlySecond,
        (Free, Free) => Shade::BothFree,
        _ => Shade::OneKnows,
    }
}

/// What [`difference_image`] drew.
#[derive(Debug, Clone)]
pub struct DifferenceImage {
    /// The picture (no margins: `map_area` is the whole image).
    pub image: Image,
    /// Voxel columns per pixel side (1, 2, 4, ...).
    pub columns_per_pixel: u32,
    /// Metric x and y of the lower-left corner of the drawn area.
    pub origin: [f64; 2],
    /// Pixels per colour: changes in both directions, only first, only second, both
    /// occupied, one knows, both free, unknown.
    pub pixels: [u64; 7],
}

/// The largest `max_pixels` [`difference_image`] honours: a map spanning the whole key range
/// at one voxel column per pixel would need 2^32 pixels (gigabytes); larger values draw at
/// this size.
pub const MAX_DIFFERENCE_PIXELS: u32 = 8192;

/// Draw where `a` and `b` differ (see the [module docs](self)), the longer side at most
/// `max_pixels` (taken as at least 16 and at most [`MAX_DIFFERENCE_PIXELS`]). Errors when the
/// resolutions differ; two empty maps give a 1×1 picture of unknown space.
pub fn difference_image(
    a: &OcTree,
    b: &OcTree,
    max_pixels: u32,
) -> Result<DifferenceImage, OctreeError> {
    let max_pixels = max_pixels.clamp(16, MAX_DIFFERENCE_PIXELS);
    // the key box of the known space
    let (mut lo, mut hi) = ([u32::MAX; 2], [0u32; 2]);
    for_each_class_cube(a, b, |c| {
        for ax in 0..2 {
            lo[ax] = lo[ax].min(u32::from(c.min_key[ax]));
            hi[ax] = hi[ax].max(u32::from(c.min_key[ax]) + c.width());
        }
    })?;
    if lo[0] > hi[0] {
        lo = [0; 2];
        hi = [1; 2];
    }
    // pixels of `per` columns, the box aligned to whole pixels
    let side = |per: u32, ax: usize| (hi[ax] - lo[ax] / per * per).div_ceil(per);
    let mut per = 1u32;
    while side(per, 0).max(side(per, 1)) > max_pixels {
        per *= 2;
    }
    let lo = lo.map(|v| v / per * per);
    let (w, h) = ((hi[0] - lo[0]).div_ceil(per), (hi[1] - lo[1]).div_ceil(per));
    let mut shades = vec![Shade::Unknown; w as usize * h as usize];
    let mut changes = vec![[false; 2]; w as usize * h as usize];
    for_each_class_cube(a, b, |c| {
        let s = shade(&c);
        let px = |ax: usize, v: u32| (v - lo[ax]) / per;
        let (x0, x1) = (
            px(0, u32::from(c.min_key[0])),
            px(0, u32::from(c.min_key[0]) + c.width() - 1),
        );
        let (y0, y1) = (
            px(1, u32::from(c.min_key[1])),
            px(1, u32::from(c.min_key[1]) + c.width() - 1),
        );
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = y as usize * w as usize + x as usize;
                shades[i] = shades[i].max(s);
                match s {
                    Shade::OnlyFirst => changes[i][0] = true,
                    Shade::OnlySecond => changes[i][1] = true,
                    _ => {}
                }
            }
        }
    })?;
    let mut rgb = Vec::with_capacity(shades.len() * 3);
    let mut pixels = [0u64; 7];
    // rows top to bottom: the highest y first
    for row in (0..h).rev() {
        for x in 0..w {
            let i = row as usize * w as usize + x as usize;
            let (colour, slot) = if changes[i] == [true, true] {
                (BOTH_CHANGES, 0)
            } else {
                match shades[i] {
                    Shade::OnlyFirst => (ONLY_FIRST, 1),
                    Shade::OnlySecond => (ONLY_SECOND, 2),
                    Shade::BothOccupied => (BOTH_OCCUPIED, 3),
                    Shade::OneKnows => (ONE_KNOWS, 4),
                    Shade::BothFree => (BOTH_FREE, 5),
                    Shade::Unknown => (UNKNOWN_COLOUR, 6),
                }
            };
            pixels[slot] += 1;
            rgb.extend_from_slice(&colour);
        }
    }
    let conv = a.converter();
    let half = conv.resolution() / 2.0;
    let corner = |ax: usize| conv.key_to_coord(lo[ax] as u16) - half;
    Ok(DifferenceImage {
        image: Image {
            width: w,
            height: h,
            rgb,
            map_area: [0, 0, w, h],
        },
        columns_per_pixel: per,
        origin: [corner(0), corner(1)],
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use octoquant_octree::{InnerNodes, Key, Update};

    #[test]
    fn columns_take_the_most_telling_class_pair() {
        let base = 32768u16;
        let mut a = OcTree::new(0.1).unwrap();
        let mut b = OcTree::new(0.1).unwrap();
        let set = |t: &mut OcTree, x: u16, y: u16, z: u16, u: Update| {
            t.update_node(
                Key::new(base + x, base + y, base + z),
                u,
                InnerNodes::Refresh,
            );
        };
        // column (0,0): free in both; (1,0): occupied only in a above free in both;
        // (2,0): occupied in both; (0,1): free only in b; (1,1): a-only and b-only voxels
        for t in [&mut a, &mut b] {
            set(t, 0, 0, 0, Update::Miss);
            set(t, 1, 0, 0, Update::Miss);
            set(t, 2, 0, 3, Update::Hit);
        }
        set(&mut a, 1, 0, 5, Update::Hit);
        set(&mut b, 0, 1, 0, Update::Miss);
        set(&mut a, 1, 1, 0, Update::Hit);
        set(&mut b, 1, 1, 2, Update::Hit);
        let d = difference_image(&a, &b, 100).unwrap();
        assert_eq!(d.columns_per_pixel, 1);
        assert_eq!((d.image.width, d.image.height), (3, 2));
        // row 0 is y = 1
        let at = |x: u32, y: u32| d.image.pixel(x, 1 - y).unwrap();
        assert_eq!(at(0, 0), BOTH_FREE);
        assert_eq!(at(1, 0), ONLY_FIRST);
        assert_eq!(at(2, 0), BOTH_OCCUPIED);
        assert_eq!(at(0, 1), ONE_KNOWS);
        assert_eq!(at(1, 1), BOTH_CHANGES);
        assert_eq!(at(2, 1), UNKNOWN_COLOUR);
        assert_eq!(d.pixels, [1, 1, 0, 1, 1, 1, 1]);
        assert!((d.origin[0] - 0.0).abs() < 1e-12 && (d.origin[1] - 0.0).abs() < 1e-12);
        // swapped maps: the one-sided change changes side
        let d = difference_image(&b, &a, 100).unwrap();
        assert_eq!(d.image.pixel(1, 1).unwrap(), ONLY_SECOND);
        // a small size bound halves the picture until it fits
        let mut big = OcTree::new(0.1).unwrap();
        set(&mut big, 0, 0, 0, Update::Hit);
        set(&mut big, 99, 40, 0, Update::Hit);
        let d = difference_image(&big, &big, 16).unwrap();
        assert_eq!(d.columns_per_pixel, 8);
        assert!(d.image.width <= 16 && d.image.height <= 16);
        assert_eq!(d.pixels[3], 2);
    }
}
