//! Pictures and PLY exports of maps: PNGs decode to the drawn image and show the occupied
//! voxels in their height colours; PLY files hold one vertex (or cube) per leaf.

use crate::common;
use nalgebra::Point3;
use octoquant::export::{write_ply, ExportOptions};
use octoquant::render::{
    height_colour, render, render_png_file, RenderOptions, View, FREE_COLOUR, UNKNOWN_COLOUR,
};
use octoquant::{InnerNodes, OcTree, Update};

/// A 2 m × 2 m floor at z = 0.05 with a 1 m column at (0.55, 0.55), all at 0.1 m, and free
/// space above the floor's far half.
fn floor_and_column() -> OcTree {
    let mut tree = OcTree::new(0.1).unwrap();
    let mut set = |x: f64, y: f64, z: f64, u: Update| {
        let k = tree
            .converter()
            .point_to_key(&Point3::new(x, y, z))
            .unwrap();
        tree.update_node(k, u, InnerNodes::Refresh);
    };
    for i in 0..20 {
        for j in 0..20 {
            let (x, y) = (i as f64 * 0.1 + 0.05, j as f64 * 0.1 + 0.05);
            set(x, y, 0.05, Update::Hit);
            if i >= 10 {
                set(x, y, 0.15, Update::Miss);
            }
        }
    }
    for k in 0..10 {
        set(0.55, 0.55, k as f64 * 0.1 + 0.05, Update::Hit);
    }
    tree
}

/// Pixels of `colour` inside the map area (not the legend).
fn count(image: &octoquant::render::Image, colour: [u8; 3]) -> usize {
    let [x0, y0, w, h] = image.map_area;
    (y0..y0 + h)
        .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
        .filter(|&(x, y)| image.pixel(x, y) == Some(colour))
        .count()
}

fn decode(path: &std::path::Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn top_view_png_decodes_and_shows_heights() {
    let dir = common::scratch("render_top");
    let tree = floor_and_column();
    let path = dir.join("top.png");
    let image = render_png_file(&tree, &path, &RenderOptions::default()).unwrap();
    let (w, h, rgb) = decode(&path);
    assert_eq!((w, h), (image.width, image.height));
    assert_eq!(rgb, image.rgb);
    // the floor is the lowest height colour, the column's top the highest
    let low = count(&image, height_colour(0.0));
    let high = count(&image, height_colour(1.0));
    // 399 floor cells (2 of them shaded by the column's relief) and 1 column cell, each
    // voxel drawn as one square of the same size
    assert!(high > 0);
    let cell = high;
    assert_eq!(low, 397 * cell, "cell {cell}");
    // the far half of the floor is free above but occupied on top: no free pixels there
    assert_eq!(count(&image, FREE_COLOUR), 0);
    assert!(count(&image, UNKNOWN_COLOUR) > 0);
}

#[test]
fn front_side_and_slice_views() {
    let tree = floor_and_column();
    let front = render(
        &tree,
        &RenderOptions {
            view: View::Front,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    // the column rises 10 cells above the 1-cell floor: nearest depth (y) coloured
    let near = count(&front, height_colour(1.0));
    assert!(near > 0);
    let side = render(
        &tree,
        &RenderOptions {
            view: View::Side,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    assert_eq!((side.width, side.height), (front.width, front.height));

    // a slice at z = 0.15 cuts the column (occupied) and the free layer over the far half
    let slice = render(
        &tree,
        &RenderOptions {
            slice: Some(0.15),
            ..RenderOptions::default()
        },
    )
    .unwrap();
    let free = count(&slice, FREE_COLOUR);
    assert!(free > 0);
    let no_free = render(
        &tree,
        &RenderOptions {
            slice: Some(0.15),
            show_free: false,
            ..RenderOptions::default()
        },
    )
    .unwrap();
    assert_eq!(count(&no_free, FREE_COLOUR), 0);
    // an empty tree has nothing to draw; bad options are errors
    assert!(render(&OcTree::new(0.1).unwrap(), &RenderOptions::default()).is_err());
    let bad = RenderOptions {
        map_pixels: 5,
        ..RenderOptions::default()
    };
    assert!(render(&tree, &bad).is_err());
}

/// `element NAME N` from a PLY header, and the header's length in bytes.
fn ply_header(bytes: &[u8]) -> (BTreeMap<String, usize>, usize) {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let text = std::str::from_utf8(&bytes[..end]).unwrap();
    let mut elements = BTreeMap::new();
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("element ") {
            let mut it = rest.split_whitespace();
            let name = it.next().unwrap().to_string();
            elements.insert(name, it.next().unwrap().parse().unwrap());
        }
    }
    (elements, end)
}

use std::collections::BTreeMap;

#[test]
fn ply_has_one_vertex_per_occupied_leaf() {
    let mut tree = floor_and_column();
    tree.prune();
    let c = tree.counts();
    assert!(c.occupied_leaves > 0 && c.free_leaves > 0);

    let mut bytes = Vec::new();
    let s = write_ply(&tree, &mut bytes, &ExportOptions::default()).unwrap();
    let (el, header) = ply_header(&bytes);
    assert_eq!(el["vertex"], c.occupied_leaves);
    assert_eq!(s.vertices, c.occupied_leaves);
    assert_eq!(bytes.len() - header, c.occupied_leaves * 15);

    let mut bytes = Vec::new();
    let opts = ExportOptions {
        free: true,
        cubes: true,
        ascii: false,
    };
    write_ply(&tree, &mut bytes, &opts).unwrap();
    let (el, header) = ply_header(&bytes);
    let leaves = c.occupied_leaves + c.free_leaves;
    assert_eq!(el["vertex"], 8 * leaves);
    assert_eq!(el["face"], 6 * leaves);
    assert_eq!(bytes.len() - header, 8 * leaves * 15 + 6 * leaves * 17);

    let mut bytes = Vec::new();
    let opts = ExportOptions {
        ascii: true,
        ..ExportOptions::default()
    };
    write_ply(&tree, &mut bytes, &opts).unwrap();
    let (el, header) = ply_header(&bytes);
    let body = std::str::from_utf8(&bytes[header..]).unwrap();
    assert_eq!(body.lines().count(), el["vertex"]);
    // the first vertex is a real voxel centre of the map
    let first: Vec<f64> = body
        .lines()
        .next()
        .unwrap()
        .split_whitespace()
        .take(3)
        .map(|v| v.parse().unwrap())
        .collect();
    let k = tree
        .converter()
        .point_to_key(&Point3::new(first[0], first[1], first[2]))
        .unwrap();
    assert_eq!(tree.is_occupied(k), Some(true));
}
