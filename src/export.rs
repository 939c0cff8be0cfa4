//! Voxels as PLY for MeshLab or CloudCompare: occupied (and optionally free) leaves as
//! coloured points at their centres, or as cubes (8 vertices and 6 quads each).
//!
//! [`write_ply`] writes to any `Write`; [`export_ply_file`] writes a file atomically. Binary
//! little-endian by default, ASCII on request. Vertices carry `x y z` (`float`) and `red green
//! blue` (`uchar`): occupied leaves coloured by height (the scale of [`crate::render`]), free
//! leaves pale blue. A pruned leaf (a block of many voxels) is one point at its centre, or
//! one cube of its size. A coloured map ([`write_colored_ply`]) gives each occupied leaf its
//! own colour when it has one (not white, OctoMap's "unset"), and [`write_colored_pcd`] adds
//! PCL's packed `rgb` field to the PCD export.

use crate::output::{write_atomic, OutputError};
use crate::render::height_colour;
use octoquant_octree::{ColorOcTree, OcTree};
use std::io::Write;
use std::path::Path;

/// Errors from exporting.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// Writing the file failed (nothing is left under its name).
    #[error(transparent)]
    Write(#[from] OutputError),
}

/// What [`write_ply`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ExportOptions {
    /// Also write free leaves.
    pub free: bool,
    /// Write each leaf as a cube (8 vertices, 6 quad faces) instead of its centre point.
    pub cubes: bool,
    /// Write `format ascii 1.0` instead of `binary_little_endian 1.0`.
    pub ascii: bool,
}

/// What [`write_ply`] wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ExportStats {
    /// Occupied leaves written.
    pub occupied: usize,
    /// Free leaves written.
    pub free: usize,
    /// PLY vertices.
    pub vertices: usize,
    /// PLY faces (quads; 0 for points).
    pub faces: usize,
}

/// Colour of free leaves.
pub const FREE_PLY_COLOUR: [u8; 3] = [150, 196, 255];

/// Corner offsets of a unit cube (±1) and its faces as outward-facing quads.
const CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];
const FACES: [[u32; 4]; 6] = [
    [0, 3, 2, 1],
    [4, 5, 6, 7],
    [0, 1, 5, 4],
    [2, 3, 7, 6],
    [1, 2, 6, 5],
    [0, 4, 7, 3],
];

/// Write the tree's leaves as PLY into `w`.
///
/// Leaves are written in the tree's pre-order; the header counts are exact (the tree is
/// walked once to count, once to write).
pub fn write_ply(
    tree: &OcTree,
    w: &mut dyn Write,
    options: &ExportOptions,
) -> std::io::Result<ExportStats> {
    write_ply_with(tree, None, w, options)
}

/// [`write_ply`] of a coloured map: occupied leaves that have a colour carry it, the others
/// the height colour.
pub fn write_colored_ply(
    tree: &ColorOcTree,
    w: &mut dyn Write,
    options: &ExportOptions,
) -> std::io::Result<ExportStats> {
    write_ply_with(tree.occupancy(), Some(tree), w, options)
}

/// The set colour of the leaf at `key`/`depth` of `colors`, if any.
fn leaf_color(
    colors: Option<&ColorOcTree>,
    key: octoquant_octree::Key,
    depth: u8,
) -> Option<[u8; 3]> {
    colors
        .and_then(|t| t.search(key, depth))
        .map(|n| n.color)
        .filter(|c| c.is_set())
        .map(|c| c.to_array())
}

fn write_ply_with(
    tree: &OcTree,
    colors: Option<&ColorOcTree>,
    w: &mut dyn Write,
    options: &ExportOptions,
) -> std::io::Result<ExportStats> {
    let conv = tree.converter();
    let params = tree.params();
    let mut stats = ExportStats::default();
    let (mut zlo, mut zhi) = (f64::MAX, f64::MIN);
    for leaf in tree.leaves() {
        if params.is_occupied(leaf.value) {
            stats.occupied += 1;
            let z = conv.key_to_coord_at_depth(leaf.key[2], leaf.depth);
            zlo = zlo.min(z);
            zhi = zhi.max(z);
        } else if options.free {
            stats.free += 1;
        }
    }
    let leaves = stats.occupied + stats.free;
    let (per_v, per_f) = if options.cubes { (8, 6) } else { (1, 0) };
    stats.vertices = leaves * per_v;
    stats.faces = leaves * per_f;
    if options.cubes && stats.vertices > i32::MAX as usize {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{} cube vertices exceed PLY's int indices; export centres instead",
                stats.vertices
            ),
        ));
    }

    let format = if options.ascii {
        "ascii"
    } else {
        "binary_little_endian"
    };
    write!(
        w,
        "ply\nformat {format} 1.0\ncomment octoquant export: {} occupied, {} free leaves, resolution {} m\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n",
        stats.occupied,
        stats.free,
        tree.resolution(),
        stats.vertices
    )?;
    if options.cubes {
        write!(
            w,
            "element face {}\nproperty list uchar int vertex_indices\n",
            stats.faces
        )?;
    }
    w.write_all(b"end_header\n")?;

    let span = (zhi - zlo).max(1e-9);
    let vertex = |w: &mut dyn Write, p: [f64; 3], c: [u8; 3]| -> std::io::Result<()> {
        if options.ascii {
            writeln!(
                w,
                "{} {} {} {} {} {}",
                p[0] as f32, p[1] as f32, p[2] as f32, c[0], c[1], c[2]
            )
        } else {
            for v in p {
                w.write_all(&(v as f32).to_le_bytes())?;
            }
            w.write_all(&c)
        }
    };
    for leaf in tree.leaves() {
        let occupied = params.is_occupied(leaf.value);
        if !occupied && !options.free {
            continue;
        }
        let c = conv.key_to_point_at_depth(&leaf.key, leaf.depth);
        let colour = if occupied {
            leaf_color(colors, leaf.key, leaf.depth)
                .unwrap_or_else(|| height_colour((c.z - zlo) / span))
        } else {
            FREE_PLY_COLOUR
        };
        if options.cubes {
            let h = conv.node_size(leaf.depth) / 2.0;
            for k in CORNERS {
                vertex(w, [c.x + k[0] * h, c.y + k[1] * h, c.z + k[2] * h], colour)?;
            }
        } else {
            vertex(w, [c.x, c.y, c.z], colour)?;
        }
    }
    if options.cubes {
        for i in 0..leaves as u64 {
            let base = i * 8;
            for f in FACES {
                let idx = f.map(|v| (base + v as u64) as i32);
                if options.ascii {
                    writeln!(w, "4 {} {} {} {}", idx[0], idx[1], idx[2], idx[3])?;
                } else {
                    w.write_all(&[4u8])?;
                    for v in idx {
                        w.write_all(&v.to_le_bytes())?;
                    }
                }
            }
        }
    }
    Ok(stats)
}

/// Write the tree's leaves as a PLY file at `path` (atomically).
pub fn export_ply_file(
    tree: &OcTree,
    path: &Path,
    options: &ExportOptions,
) -> Result<ExportStats, ExportError> {
    let mut stats = ExportStats::default();
    write_atomic(path, |w| {
        stats = write_ply(tree, w, options)?;
        Ok(())
    })?;
    Ok(stats)
}

/// [`write_colored_ply`] as a file at `path` (atomically).
pub fn export_colored_ply_file(
    tree: &ColorOcTree,
    path: &Path,
    options: &ExportOptions,
) -> Result<ExportStats, ExportError> {
    let mut stats = ExportStats::default();
    write_atomic(path, |w| {
        stats = write_colored_ply(tree, w, options)?;
        Ok(())
    })?;
    Ok(stats)
}

/// The most points [`write_pcd`] writes (2^32 - 1, the most a PCD `WIDTH` holds in practice):
/// a map whose occupied leaves hold more voxels (a pruned block of 2^48 voxels, say) is refused.
pub const MAX_PCD_POINTS: u64 = u32::MAX as u64;

/// Write the tree's occupied voxels as an ASCII PCD v0.7 cloud into `w`: OctoMap's
/// `octree2pointcloud`. Every occupied leaf is expanded to voxel level (a pruned block becomes
/// its voxels, in the tree's child order, as the tool's `expandNode` loop leaves them) and
/// each voxel's centre is one point, in the tree's pre-order.
///
/// The header is the tool's, line for line (`FIELDS x y z`, `TYPE F F F`, `VIEWPOINT 0 0 0 0
/// 0 0 1`...). The tool prints coordinates with six significant digits, which can name the
/// wrong voxel for fine resolutions far from the origin; here each coordinate is the centre as
/// an `f32` (the tool's `point3d`) in the shortest form that reads back to the same `f32`.
/// Returns the number of points; an `InvalidInput` error, before anything is written, when
/// that would exceed [`MAX_PCD_POINTS`].
pub fn write_pcd(tree: &OcTree, w: &mut dyn Write) -> std::io::Result<u64> {
    write_pcd_with(tree, None, w)
}

/// [`write_pcd`] of a coloured map, with a fourth field `rgb` (`U 4`, PCL's packed
/// `0x00RRGGBB`, written as the integer as PCL's ASCII writer does): each voxel takes the
/// colour of its leaf, white where none was set (OctoMap's default colour).
pub fn write_colored_pcd(tree: &ColorOcTree, w: &mut dyn Write) -> std::io::Result<u64> {
    write_pcd_with(tree.occupancy(), Some(tree), w)
}

fn write_pcd_with(
    tree: &OcTree,
    colors: Option<&ColorOcTree>,
    w: &mut dyn Write,
) -> std::io::Result<u64> {
    let params = tree.params();
    let conv = tree.converter();
    let count: u64 = tree
        .leaves()
        .filter(|l| params.is_occupied(l.value))
        .map(|l| u64::from(l.width()).pow(3))
        .sum();
    // a pruned block near the root holds up to 2^48 voxels: refuse before writing any
    if count > MAX_PCD_POINTS {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "the map's occupied leaves hold {count} voxels, more than the {MAX_PCD_POINTS} \
                 points a PCD export may have"
            ),
        ));
    }
    let (fields, sizes, types, counts) = if colors.is_some() {
        ("x y z rgb", "4 4 4 4", "F F F U", "1 1 1 1")
    } else {
        ("x y z", "4 4 4", "F F F", "1 1 1")
    };
    write!(
        w,
        "# .PCD v0.7\nVERSION 0.7\nFIELDS {fields}\nSIZE {sizes}\nTYPE {types}\nCOUNT {counts}\n\
         WIDTH {count}\nHEIGHT 1\nVIEWPOINT 0 0 0 0 0 0 1\nPOINTS {count}\nDATA ascii\n"
    )?;
    for leaf in tree.leaves().filter(|l| params.is_occupied(l.value)) {
        let rgb = colors.map(|t| {
            let [r, g, b] = leaf_color(Some(t), leaf.key, leaf.depth).unwrap_or([255; 3]);
            u32::from_be_bytes([0, r, g, b])
        });
        let min = leaf.min_key();
        let levels = octoquant_octree::TREE_DEPTH - leaf.depth;
        // the voxels of the block in child order: the Morton order of their offsets
        for i in 0u64..u64::from(leaf.width()).pow(3) {
            let mut off = [0u16; 3];
            for level in 0..levels {
                for (a, o) in off.iter_mut().enumerate() {
                    *o |= (((i >> (3 * u64::from(level) + a as u64)) & 1) as u16) << level;
                }
            }
            let key = octoquant_octree::Key([0, 1, 2].map(|a| min[a] + off[a]));
            let c = conv.key_to_point_f32(&key);
            match rgb {
                Some(rgb) => writeln!(w, "{} {} {} {rgb}", c.x, c.y, c.z)?,
                None => writeln!(w, "{} {} {}", c.x, c.y, c.z)?,
            }
        }
    }
    Ok(count)
}

/// Write the tree's occupied voxels as a PCD file at `path` (atomically); see [`write_pcd`].
pub fn export_pcd_file(tree: &OcTree, path: &Path) -> Result<u64, ExportError> {
    let mut n = 0;
    write_atomic(path, |w| {
        n = write_pcd(tree, w)?;
        Ok(())
    })?;
    Ok(n)
}

/// [`write_colored_pcd`] as a file at `path` (atomically).
pub fn export_colored_pcd_file(tree: &ColorOcTree, path: &Path) -> Result<u64, ExportError> {
    let mut n = 0;
    write_atomic(path, |w| {
        n = write_colored_pcd(tree, w)?;
        Ok(())
    })?;
    Ok(n)
}
