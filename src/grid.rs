//! 2D occupancy grids for navigation: a height band of the map projected onto the ground
//! plane, written as a ROS map_server / Nav2 map (a PGM image and its YAML description).
//!
//! A grid cell is [`Cell::Occupied`] when an occupied voxel of the band lies over it,
//! [`Cell::Free`] when only free voxels of the band do, and [`Cell::Unknown`] otherwise, as in
//! octomap_server's projected map. A voxel is in the band `[zmin, zmax]` when its extent in z
//! overlaps it (octomap_server's test: `z + size/2 > zmin && z - size/2 < zmax`); pruned
//! nodes count with their whole extent and cover every cell under them. Cells are the nodes
//! of OctoMap's key space at a chosen depth (16 = voxels), so a coarser depth gives cells
//! `2^(16 - depth)` voxels wide, each the union of the voxels under it.
//!
//! ```
//! use octoquant::grid::{project, Cell, GridOptions};
//! use octoquant::{InnerNodes, OcTree, Update};
//! use nalgebra::{Point2, Point3};
//!
//! let mut tree = OcTree::new(0.1).unwrap();
//! let key = tree.converter().point_to_key(&Point3::new(1.0, 2.0, 0.5)).unwrap();
//! tree.update_node(key, Update::Hit, InnerNodes::Refresh);
//! let grid = project(&tree, &GridOptions::default()).unwrap();
//! assert_eq!((grid.width, grid.height), (1, 1));
//! assert_eq!(grid.cell_at(&Point2::new(1.03, 2.04)), Some(Cell::Occupied));
//! ```

use crate::output::{check_extension, check_output, write_atomic, OutputError};
use nalgebra::Point2;
use octoquant_octree::{OcTree, KEY_CENTER, TREE_DEPTH};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The state of one grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Cell {
    /// No known voxel of the band projects into the cell.
    Unknown,
    /// Only free voxels of the band project into the cell.
    Free,
    /// At least one occupied voxel of the band projects into the cell.
    Occupied,
}

impl Cell {
    /// The value in a `nav_msgs/OccupancyGrid`: -1 unknown, 0 free, 100 occupied.
    pub fn occupancy(self) -> i8 {
        match self {
            Cell::Unknown => -1,
            Cell::Free => 0,
            Cell::Occupied => 100,
        }
    }

    /// The grey level map_server's trinary mode reads back as this state (with `negate: 0`):
    /// 0 (black) occupied, 254 free, 205 unknown.
    pub fn pgm_level(self) -> u8 {
        match self {
            Cell::Unknown => 205,
            Cell::Free => 254,
            Cell::Occupied => 0,
        }
    }
}

/// What unknown cells become in the grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum UnknownCells {
    /// They stay unknown (Nav2 plans through them only if told to).
    #[default]
    Unknown,
    /// They are marked free (for planners that need a fully known map).
    Free,
}

/// What to project and how.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridOptions {
    /// Lower end of the height band in metres; `None` for no lower limit.
    pub zmin: Option<f64>,
    /// Upper end of the height band in metres; `None` for no upper limit.
    pub zmax: Option<f64>,
    /// Depth of the cells in OctoMap's key space, 1 to 16 (16: cells are voxels; each level
    /// up doubles the cell size).
    pub depth: u8,
    /// What unknown cells become.
    pub unknown: UnknownCells,
}

impl Default for GridOptions {
    fn default() -> Self {
        GridOptions {
            zmin: None,
            zmax: None,
            depth: TREE_DEPTH,
            unknown: UnknownCells::Unknown,
        }
    }
}

/// The most cells a grid may have (4 Gi cells would be 4 GB of image); a coarser `depth`
/// or a narrower map makes a smaller grid.
pub const MAX_GRID_CELLS: u64 = 1 << 30;

/// Errors from projecting or writing a grid.
#[derive(Debug, thiserror::Error)]
pub enum GridError {
    /// The depth is outside 1..=16.
    #[error("grid depth {0} is outside 1..=16")]
    Depth(u8),
    /// A band limit is NaN or the band is empty.
    #[error("height band [{zmin}, {zmax}] is empty or not a number")]
    Band {
        /// The lower limit given.
        zmin: f64,
        /// The upper limit given.
        zmax: f64,
    },
    /// No known voxel lies in the band, so there is no map to draw.
    #[error("no known voxel lies in the height band [{zmin}, {zmax}]")]
    Empty {
        /// The lower limit used.
        zmin: f64,
        /// The upper limit used.
        zmax: f64,
    },
    /// The grid would have more than [`MAX_GRID_CELLS`] cells.
    #[error("a {width} x {height} grid is too large (at most {MAX_GRID_CELLS} cells): choose a coarser depth")]
    TooLarge {
        /// Cells along x.
        width: u64,
        /// Cells along y.
        height: u64,
    },
    /// The output file name is not usable (no `.yaml`/`.yml` extension, or no file name).
    #[error("{}: the map description must be a .yaml or .yml file", path.display())]
    OutputName {
        /// The name given.
        path: PathBuf,
    },
    /// The output's directory does not exist.
    #[error("{}: no such directory to write into", path.display())]
    MissingDirectory {
        /// The name given.
        path: PathBuf,
    },
    /// Writing a file failed.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// A 2D occupancy grid: cells in rows of increasing y, each row in increasing x (the layout
/// of `nav_msgs/OccupancyGrid`).
#[derive(Debug, Clone, PartialEq)]
pub struct OccupancyGrid {
    /// Cell edge length in metres.
    pub resolution: f64,
    /// The corner of cell (0, 0) with the smallest x and y, in metres (the map's origin).
    pub origin: Point2<f64>,
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// `width * height` cells, row-major from the lowest y.
    pub cells: Vec<Cell>,
}

impl OccupancyGrid {
    /// The cell in column `x`, row `y` (row 0 at the smallest y), if inside the grid.
    pub fn get(&self, x: usize, y: usize) -> Option<Cell> {
        (x < self.width && y < self.height).then(|| self.cells[y * self.width + x])
    }

    /// The cell holding the point `p` (metres), if inside the grid.
    pub fn cell_at(&self, p: &Point2<f64>) -> Option<Cell> {
        let fx = ((p.x - self.origin.x) / self.resolution).floor();
        let fy = ((p.y - self.origin.y) / self.resolution).floor();
        if !(fx >= 0.0 && fy >= 0.0) {
            return None;
        }
        self.get(fx as usize, fy as usize)
    }

    /// Counts of (unknown, free, occupied) cells.
    pub fn counts(&self) -> (usize, usize, usize) {
        self.cells.iter().fold((0, 0, 0), |(u, f, o), c| match c {
            Cell::Unknown => (u + 1, f, o),
            Cell::Free => (u, f + 1, o),
            Cell::Occupied => (u, f, o + 1),
        })
    }
}

/// The band's limits with `None` as infinities, checked.
fn band(options: &GridOptions) -> Result<(f64, f64), GridError> {
    let zmin = options.zmin.unwrap_or(f64::NEG_INFINITY);
    let zmax = options.zmax.unwrap_or(f64::INFINITY);
    if zmin.is_nan() || zmax.is_nan() || zmin >= zmax {
        return Err(GridError::Band { zmin, zmax });
    }
    Ok((zmin, zmax))
}

/// Project the map's height band onto a grid of depth-`options.depth` cells (see the module
/// docs for the rule). The grid spans the cells under the known voxels of the band.
pub fn project(tree: &OcTree, options: &GridOptions) -> Result<OccupancyGrid, GridError> {
    if !(1..=TREE_DEPTH).contains(&options.depth) {
        return Err(GridError::Depth(options.depth));
    }
    let (zmin, zmax) = band(options)?;
    let res = tree.resolution();
    let shift = u32::from(TREE_DEPTH - options.depth);
    let threshold = tree.params().occupancy_threshold;
    // the leaves in the band, as (first cell x, last cell x, first y, last y, occupied)
    let edge = |k: u32| (f64::from(k) - f64::from(KEY_CENTER)) * res;
    let mut spans = Vec::new();
    for leaf in tree.leaves() {
        let min = leaf.min_key();
        let w = leaf.width();
        let (z0, z1) = (edge(u32::from(min.z())), edge(u32::from(min.z()) + w));
        if !(z1 > zmin && z0 < zmax) {
            continue;
        }
        let (x0, y0) = (u32::from(min.x()), u32::from(min.y()));
        spans.push((
            x0 >> shift,
            (x0 + w - 1) >> shift,
            y0 >> shift,
            (y0 + w - 1) >> shift,
            leaf.value >= threshold,
        ));
    }
    let Some(first) = spans.first() else {
        return Err(GridError::Empty { zmin, zmax });
    };
    let init = (first.0, first.1, first.2, first.3);
    let (cx0, cx1, cy0, cy1) = spans.iter().fold(init, |(a, b, c, d), s| {
        (a.min(s.0), b.max(s.1), c.min(s.2), d.max(s.3))
    });
    let (width, height) = (u64::from(cx1 - cx0) + 1, u64::from(cy1 - cy0) + 1);
    if width * height > MAX_GRID_CELLS {
        return Err(GridError::TooLarge { width, height });
    }
    let (width, height) = (width as usize, height as usize);
    let mut cells = vec![Cell::Unknown; width * height];
    for &(x0, x1, y0, y1, occupied) in &spans {
        let state = if occupied { Cell::Occupied } else { Cell::Free };
        for y in y0..=y1 {
            let row = (y - cy0) as usize * width;
            for c in &mut cells[row + (x0 - cx0) as usize..=row + (x1 - cx0) as usize] {
                *c = (*c).max(state);
            }
        }
    }
    if options.unknown == UnknownCells::Free {
        for c in cells.iter_mut().filter(|c| **c == Cell::Unknown) {
            *c = Cell::Free;
        }
    }
    Ok(OccupancyGrid {
        resolution: tree.converter().node_size(options.depth),
        origin: Point2::new(edge(cx0 << shift), edge(cy0 << shift)),
        width,
        height,
        cells,
    })
}

/// Write `grid` as a map_server / Nav2 map: the YAML description at `yaml` and the image
/// beside it with the same stem and `.pgm` (binary P5, rows from the largest y down, as
/// map_server reads them). Both are written atomically; returns the image's path.
pub fn write_nav2(grid: &OccupancyGrid, yaml: &Path) -> Result<PathBuf, GridError> {
    let image = check_output_name(yaml, &[])?;
    let image_name = image
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    write_atomic(&image, |w| write_pgm(grid, w))?;
    write_atomic(yaml, |w| {
        writeln!(w, "image: {}", yaml_string(&image_name))?;
        writeln!(w, "mode: trinary")?;
        writeln!(w, "resolution: {}", grid.resolution)?;
        writeln!(w, "origin: [{}, {}, 0.0]", grid.origin.x, grid.origin.y)?;
        writeln!(w, "negate: 0")?;
        writeln!(w, "occupied_thresh: 0.65")?;
        writeln!(w, "free_thresh: 0.196")
    })?;
    Ok(image)
}

/// Check, before long work, that `yaml` can name a map description: a `.yaml` or `.yml`
/// file name that [`check_output`] accepts (writable directory, none of `inputs`), with the
/// image beside it writable too; returns the image path [`write_nav2`] writes. A wrong
/// extension is [`GridError::OutputName`], a missing directory [`GridError::MissingDirectory`]
/// (value errors in the Python package), other failures [`GridError::Output`].
pub fn check_output_name(yaml: &Path, inputs: &[PathBuf]) -> Result<PathBuf, GridError> {
    let path = || yaml.to_path_buf();
    check_extension(yaml, &["yaml", "yml"]).map_err(|_| GridError::OutputName { path: path() })?;
    check_output(yaml, &["yaml", "yml"], inputs).map_err(|e| {
        let OutputError::Io { source, .. } = &e;
        if source.kind() == std::io::ErrorKind::NotFound {
            GridError::MissingDirectory { path: path() }
        } else {
            GridError::Output(e)
        }
    })?;
    let stem = yaml.file_stem().unwrap_or_default().to_string_lossy();
    let image = yaml.with_file_name(format!("{stem}.pgm"));
    check_output(&image, &["pgm"], inputs)?;
    Ok(image)
}

/// The grid as a binary PGM (P5, maxval 255), top row = largest y.
pub fn write_pgm(grid: &OccupancyGrid, w: &mut dyn Write) -> std::io::Result<()> {
    write!(w, "P5\n{} {}\n255\n", grid.width, grid.height)?;
    let mut row = vec![0u8; grid.width];
    for y in (0..grid.height).rev() {
        let cells = &grid.cells[y * grid.width..(y + 1) * grid.width];
        for (p, c) in row.iter_mut().zip(cells) {
            *p = c.pgm_level();
        }
        w.write_all(&row)?;
    }
    Ok(())
}

/// A YAML scalar for a file name: quoted (with escapes) unless it is plainly safe.
fn yaml_string(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-' | '/'))
        && !s.starts_with('-');
    if plain {
        s.to_string()
    } else {
        serde_json::to_string(s).unwrap_or_else(|_| format!("{s:?}"))
    }
}
