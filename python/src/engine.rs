//! The one place that names the octoquant Rust library's paths and free functions.
//!
//! The other files of the bindings deal in Python objects, in the types re-exported here and
//! their methods, and in these functions; when a path or a signature of the library changes
//! (a crate split, an options struct instead of trailing arguments), the fix is here, one
//! line per call. Nothing here touches Python.

use nalgebra::Point3;
use octoquant::octree::io;
use octoquant::raycast::{self, InsertOptions};
use std::path::Path;

pub use octoquant::color_map::{ColorMapError, ColorMapper, ColorMerge};
pub use octoquant::filters::{CropBox, FilterError, GroundFilter, PointFilters};
pub use octoquant::grid::{GridError, GridOptions, OccupancyGrid, UnknownCells};
pub use octoquant::octree::{
    logodds, now_seconds, probability, Color, ColorOcTree, InnerNodes, Key, KeyConverter, NodeInfo,
    NodeItem, OcTree, OccupancyParams, OctreeError, StampedOcTree, Update, TREE_DEPTH,
};
pub use octoquant::pipeline::{FrameCaster, FrameStats, InsertMode, Mapper, MapperOptions};
pub use octoquant::stamped_map::{StampedMapError, StampedMapper};
pub use octoquant::tiled::{cast_frames, default_tile_depth};
pub use octoquant::tiles::{
    apply_tile_updates, join_dir, write_index, write_tile, Tile, TileError, TileIndex, TileUpdates,
};
pub use octoquant::Frame;

pub use octoquant::formats::carmen::LaserScan;
pub use octoquant::formats::pcd::ViewpointUse;
pub use octoquant::formats::tum::CameraIntrinsics;
pub use octoquant::formats::{InputFormat, ReadOptions};
pub use octoquant_density::{
    CentreDistance, CycleCounts, DensityError, DensityGrid, GridSpec, OutputCycle, Selection,
};
pub use octoquant_distance::{DistanceError, DistanceMap, DistanceOptions};
pub use octoquant_segment::{
    BorderPolicy, Clustering, Dbscan1dParams, Line, LineParams, SegmentError, Segmentation, NOISE,
};

/// Join tile trees built at `depth` into one tree of `resolution` with OctoMap's default
/// sensor model (the tiles crate's `join_tiles`).
pub fn join_tiles(resolution: f64, depth: u8, trees: &[OcTree]) -> Result<OcTree, TileError> {
    octoquant::tiles::join_tiles(resolution, OccupancyParams::default(), depth, trees)
}

/// The input format with this CLI short name, or a message listing them.
pub fn input_format(name: &str) -> Result<InputFormat, String> {
    InputFormat::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = InputFormat::ALL.iter().map(|f| f.name()).collect();
        format!(
            "unknown format {name:?}; expected one of {}",
            names.join(", ")
        )
    })
}

/// Read a sensor file (or scan directory) as frames in world coordinates, with the reader
/// options of the CLI's `map`. Errors are messages naming the file.
pub fn read_frames(path: &Path, options: &ReadOptions) -> Result<Vec<Frame>, String> {
    octoquant::formats::read_frames(path, options).map_err(|e| e.to_string())
}

/// Frames `first .. first + count` of a sensor file (all from `first` when `count` is `None`),
/// read one at a time and only as far as needed (the slice a distributed task reads). The
/// frames before `first` are passed over as cheaply as the input allows (`FrameStream::
/// skip_frames`: a `.frames` file seeks over their points, VTK sequences and TUM associations
/// do not open their files), so a slice costs about what its own frames cost; an input that
/// ends before `first`, or before `first + count` when a count is given, is an error naming
/// the file and the frame counts.
pub fn read_frame_range(
    path: &Path,
    options: &ReadOptions,
    first: usize,
    count: Option<usize>,
) -> Result<Vec<Frame>, String> {
    let mut stream = octoquant::formats::frame_stream(path, options).map_err(|e| e.to_string())?;
    let short = |got: usize| {
        format!(
            "{}: frames {first}..{} asked, the input has only {got}",
            path.display(),
            count.map_or_else(|| "end".to_string(), |c| (first + c).to_string())
        )
    };
    let passed = stream.skip_frames(first).map_err(|e| e.to_string())?;
    if passed < first {
        return Err(short(passed));
    }
    let mut frames = Vec::new();
    while count.is_none_or(|c| frames.len() < c) {
        match stream.next() {
            Some(f) => frames.push(f.map_err(|e| e.to_string())?),
            None if count.is_some() => return Err(short(first + frames.len())),
            None => break,
        }
    }
    Ok(frames)
}

/// Write frames as a `.frames` file, atomically (the formats crate's `write_frames_file`):
/// version 1 when no frame has colours or a stamp, else version 2. Errors name the file.
pub fn write_frames_file(path: &Path, frames: &[Frame]) -> Result<(), String> {
    octoquant::formats::frames::write_frames_file(path, frames).map_err(|e| e.to_string())
}

/// How many frames a sensor file announces without reading its points (the formats crate's
/// `count_frames`): `None` for text logs and MCAP files without statistics.
pub fn count_frames(path: &Path, options: &ReadOptions) -> Option<usize> {
    octoquant::formats::count_frames(path, options)
}

/// Every laser scan of a CARMEN log (`FLASER`/`ROBOTLASER1` lines; `.gz`/`.bz2` allowed), in
/// file order. Errors name the file and line.
pub fn read_laser_scans(path: &Path) -> Result<Vec<LaserScan>, String> {
    octoquant::formats::carmen::read_carmen_file(path).map_err(|e| e.to_string())
}

/// Cluster sorted values with DBSCAN in O(N) (the segment crate's `dbscan1d`).
pub fn dbscan1d(
    x: &[f64],
    params: &Dbscan1dParams,
    out: &mut Clustering,
) -> Result<(), SegmentError> {
    octoquant_segment::dbscan1d(x, params, out)
}

/// Line segments of one 2D laser scan (the segment crate's `segment_scan`).
pub fn segment_scan(
    points: &[[f64; 2]],
    params: &LineParams,
    out: &mut Segmentation,
) -> Result<(), SegmentError> {
    octoquant_segment::segment_scan(points, params, out)
}

/// Every insertion mode, for looking one up by its name.
pub const INSERT_MODES: [InsertMode; 5] = [
    InsertMode::Exact,
    InsertMode::Discretize,
    InsertMode::Quantized,
    InsertMode::QuantizedBresenham,
    InsertMode::Simple,
];

/// Where a ray cast stopped: `hit` is OctoMap's return value, `end` what it writes into its
/// `end` argument (`None`: OctoMap leaves `end` untouched).
pub struct Cast {
    /// An occupied voxel was reached.
    pub hit: bool,
    /// Centre of the voxel where the cast stopped.
    pub end: Option<Point3<f32>>,
}

/// OctoMap's `castRay(origin, direction, end, ignoreUnknownCells, maxRange)`.
pub fn cast_ray(
    tree: &OcTree,
    origin: &Point3<f32>,
    direction: &Point3<f32>,
    ignore_unknown: bool,
    max_range: f64,
) -> Cast {
    // OctoMap's maxRange <= 0 (its -1 default) means no limit
    let options = raycast::CastOptions {
        ignore_unknown,
        max_range: (max_range > 0.0).then_some(max_range),
    };
    let r = raycast::cast_ray_f32(tree, origin, direction, &options);
    Cast {
        hit: r.hit,
        end: r.end_f32(),
    }
}

/// OctoMap's `insertPointCloud(scan, origin, maxrange, lazy_eval, discretize)`; `max_range`
/// `None` (or negative) is OctoMap's -1. Non-finite points are skipped.
pub fn insert_point_cloud(
    tree: &mut OcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    lazy: bool,
    discretize: bool,
) {
    let options = InsertOptions {
        max_range,
        discretize,
        lazy,
    };
    raycast::insert_point_cloud_f32(tree, points, origin, &options);
}

/// OctoMap's `insertPointCloud(scan, origin, maxrange, lazy_eval, discretize)` on an
/// `OcTreeStamped` whose clock reads `now`: the scan's sets as [`insert_point_cloud`] computes
/// them, every update stamped `now`. Non-finite points are skipped.
pub fn insert_stamped_point_cloud(
    tree: &mut StampedOcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    lazy: bool,
    discretize: bool,
    now: u32,
) {
    let options = InsertOptions {
        max_range,
        discretize,
        lazy,
    };
    let mut update = raycast::ScanUpdate::new();
    raycast::compute_scan_update_f32(tree.converter(), points, origin, &options, &mut update);
    tree.insert_bricks_at(
        update.free_bricks(),
        update.occupied_bricks(),
        InnerNodes::from_lazy(lazy),
        now,
    );
}

/// OctoMap's `insertPointCloud(scan, origin, maxrange, lazy_eval, discretize)` on a
/// `ColorOcTree`: the updates in the order of OctoMap's `KeySet`s, which the colours depend
/// on. Non-finite points are skipped.
pub fn insert_color_point_cloud(
    tree: &mut ColorOcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    lazy: bool,
    discretize: bool,
) {
    octoquant::color_map::insert_point_cloud(
        tree,
        points,
        origin,
        max_range,
        InnerNodes::from_lazy(lazy),
        discretize,
    );
}

/// One miss per key of `free`, then one hit per key of `occupied`, on a `ColorOcTree`, in the
/// iteration order of OctoMap's `KeySet`s filled by one `insert` per key of each sequence in
/// turn (repeats change nothing); the free keys that are occupied are left out.
pub fn update_color_key_sets(tree: &mut ColorOcTree, free: &[Key], occupied: &[Key], lazy: bool) {
    use octoquant::keyset_order::KeySetOrder;
    let (mut f, mut o) = (KeySetOrder::new(), KeySetOrder::new());
    for &k in free {
        f.insert(k);
    }
    for &k in occupied {
        o.insert(k);
    }
    octoquant::color_map::update_key_sets(tree, &f, &o, InnerNodes::from_lazy(lazy));
}

/// The voxels a segment crosses by OctoMap's DDA (`computeRayKeys`), end voxel excluded;
/// `false` when an end is outside the map.
pub fn ray_keys(
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
    out: &mut Vec<Key>,
) -> bool {
    let mut ray = raycast::KeyRay::new();
    let ok = raycast::compute_ray_keys_f32(conv, origin, end, &mut ray);
    out.clear();
    out.extend_from_slice(ray.keys());
    ok
}

/// OctoMap's `discretize` pre-pass: one voxel centre per end-point voxel, first-seen order.
pub fn discretize(conv: &KeyConverter, points: &[Point3<f32>]) -> Vec<Point3<f32>> {
    let mut centres = Vec::new();
    raycast::discretize_f32(conv, points, &mut centres);
    centres
}

/// A tree from `.bt` or `.ot` bytes (told apart by the header line).
pub fn read_tree(bytes: &[u8]) -> Result<OcTree, OctreeError> {
    io::read_tree(bytes)
}

/// A tree from `.bt` bytes only (OctoMap's `readBinary`).
pub fn read_bt(bytes: &[u8]) -> Result<OcTree, OctreeError> {
    io::read_bt(bytes)
}

/// `.bt` bytes; converts the tree to max-likelihood and prunes it first, as OctoMap's
/// `writeBinary` does.
pub fn write_bt(tree: &mut OcTree) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    io::write_bt(tree, &mut out)?;
    Ok(out)
}

/// `.ot` bytes (OctoMap's `write`): the full tree with every node's log-odds.
pub fn write_ot(tree: &OcTree) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    io::write_ot(tree, &mut out)?;
    Ok(out)
}

/// A `ColorOcTree` from `.ot` bytes of that tree type.
pub fn read_color_ot(bytes: &[u8]) -> Result<ColorOcTree, OctreeError> {
    io::read_color_ot(bytes)
}

/// `.ot` bytes of a `ColorOcTree` (OctoMap's `write`): every node's log-odds and colour.
pub fn write_color_ot(tree: &ColorOcTree) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    io::write_color_ot(tree, &mut out)?;
    Ok(out)
}

/// `.bt` bytes of a `ColorOcTree` (OctoMap's `writeBinary` on one): the tree is converted to
/// max-likelihood and pruned by the colour rules first, then its occupancy written under
/// `id ColorOcTree` (a `.bt` holds no colours).
pub fn write_color_bt(tree: &mut ColorOcTree) -> std::io::Result<Vec<u8>> {
    tree.to_max_likelihood();
    tree.prune();
    let mut out = Vec::new();
    io::write_bt_const_typed(tree.occupancy(), "ColorOcTree", &mut out)?;
    Ok(out)
}

/// A `StampedOcTree` from `.ot` bytes of type `OcTreeStamped` (every stamp 0: OctoMap does
/// not save stamps).
pub fn read_stamped_ot(bytes: &[u8]) -> Result<StampedOcTree, OctreeError> {
    io::read_stamped_ot(bytes)
}

/// `.ot` bytes of a `StampedOcTree` (OctoMap's `OcTreeStamped::write`): every node's log-odds
/// under `id OcTreeStamped`, no stamps.
pub fn write_stamped_ot(tree: &StampedOcTree) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    io::write_stamped_ot(tree, &mut out)?;
    Ok(out)
}

/// Write bytes to `path` through a temporary file and a rename, so a failed write leaves no
/// half-written file.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), String> {
    octoquant::output::write_atomic(path, |w| w.write_all(bytes)).map_err(|e| e.to_string())
}

/// The leaves of `tree` down to `max_depth` (16 = all), in OctoMap's iteration order.
pub fn leaves(tree: &OcTree, max_depth: u8) -> Vec<NodeItem> {
    tree.leaves_to_depth(max_depth).collect()
}

/// Every node (inner ones too) down to `max_depth`, in OctoMap's `tree_iterator` order.
pub fn nodes(tree: &OcTree, max_depth: u8) -> Vec<NodeItem> {
    tree.nodes().filter(|n| n.depth <= max_depth).collect()
}

/// A height band of the tree projected onto a 2D occupancy grid (see `octoquant::grid`).
pub fn grid(tree: &OcTree, options: &GridOptions) -> Result<OccupancyGrid, GridError> {
    octoquant::grid::project(tree, options)
}

/// Write a grid as a Nav2 / map_server map (YAML + PGM beside it); returns the image path.
pub fn write_grid(grid: &OccupancyGrid, yaml: &Path) -> Result<std::path::PathBuf, GridError> {
    octoquant::grid::write_nav2(grid, yaml)
}
