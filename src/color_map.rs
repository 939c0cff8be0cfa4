//! Coloured maps: scans with per-point colours into a [`ColorOcTree`], as octomap_server's
//! colour server (`octomap_color_server`, `OctomapServer::insertScan` built with
//! `COLOR_OCTOMAP_SERVER`) builds them.
//!
//! For each scan, in this order (octomap_server's, read from its source):
//!
//! 1. every end point, in scan order, merges its colour into the node that holds its voxel
//!    *now*, before this scan's occupancy updates (octomap_server calls `averageNodeColor`
//!    inside its loop over the points, which only collects the key sets). A node that does not
//!    exist yet (unknown space) takes no colour: an end point is coloured from its second
//!    observation on. [`ColorMerge::Average`] is octomap_server's `averageNodeColor`;
//!    [`ColorMerge::Integrate`] uses OctoMap's occupancy-weighted `integrateNodeColor` instead.
//!    Points with a NaN or infinite coordinate are skipped (PCL's filters drop them before
//!    octomap_server sees the cloud), as are points outside the map;
//! 2. one miss per free voxel (the rays' voxels that are not end-point voxels), then one hit
//!    per end-point voxel, eager (`updateNode(key, occupied)`, pruning on the way), with the
//!    colour bookkeeping of every expansion and pruning ([`ColorOcTree::update_keys`]: the
//!    same result as [`ColorOcTree::update_node`] on each key in turn, through the plain
//!    tree's batched walk except below the few nodes a prune could undo within the pass);
//! 3. `prune()` (octomap_server's default `compress_map`).
//!
//! The free and occupied voxel sets are those of OctoMap's `computeUpdate`, built as
//! octomap_server builds them (each ray's keys with OctoMap's DDA, point by point) and walked
//! in the order of octomap_server's `KeySet`s ([`crate::keyset_order`]): occupancy does not
//! depend on that order, but colours do (a node pruned by one update and expanded by a later
//! one of the same scan hands the children's average colour to all of them). The rays are
//! walked many at a time in the SIMD lanes and their keys handed on ray by ray, in order, as
//! bricks ([`octoquant_raycast::walk_rays_in_order_f32`]), which the key set takes a brick at a
//! time ([`octoquant_octree::PartRange::bricks`]).
//!
//! With a maximum range (octomap_server's `sensor_model/max_range`), a point farther than it
//! from the origin gives no occupied voxel and no colour: its ray is cut at the range (the cut
//! end computed in `f32` as OctoMap's `computeUpdate` computes it) and its voxels, *and the cut
//! end's voxel*, are free (octomap_server's rule; OctoMap's `insertPointCloud` leaves the cut
//! end's voxel out).
//!
//! octoquant's point filters ([`crate::filters`], `map --zmin`, `--crop-world`, ...) drop
//! points, with their colours, before the insertion, as they do before `insertPointCloud`
//! (octomap_server's own ground filter, which inserts ground points as free, is not
//! reproduced; see docs/filters.md). Reduction, quantization and lazy updates are not
//! octomap_server's insertion; [`ColorMapper::new`] refuses them.

use crate::filters::PointFilters;
use crate::keyset_order::KeySetOrder;
use crate::pipeline::{sensor_frame_to_world, FrameStats, InsertMode, MapperOptions};
use nalgebra::{Isometry3, Point3, UnitQuaternion};
use octoquant_formats::Frame;
use octoquant_octree::{
    Color, ColorOcTree, InnerNodes, Key, KeyConverter, KeySetPart, OctreeError, Update,
};
use octoquant_raycast::{max_range_end_f32, walk_rays_in_order_f32, RayKeys, RayOrderScratch};
use std::time::Instant;

/// How an end point's colour merges into its node's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColorMerge {
    /// OctoMap's `averageNodeColor`: the integer mean of the old and new colour
    /// (octomap_server's rule).
    #[default]
    Average,
    /// OctoMap's `integrateNodeColor`: the old colour weighted by the node's occupancy
    /// probability `p`, the new one by `0.99 − p`.
    Integrate,
}

impl ColorMerge {
    /// The name used on the command line (`average`, `integrate`).
    pub fn name(self) -> &'static str {
        match self {
            ColorMerge::Average => "average",
            ColorMerge::Integrate => "integrate",
        }
    }
}

/// Why a coloured map cannot be built as asked.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ColorMapError {
    /// An option octomap_server's colour insertion does not have.
    #[error("coloured mapping follows octomap_server's insertion, which has no {0}")]
    Unsupported(&'static str),
    /// A frame without colours.
    #[error(
        "frame {frame} has no colours (coloured inputs: PCD rgb/rgba, PLY red/green/blue, a TUM association with its RGB images, PointCloud2 rgb/rgba)"
    )]
    NoColors {
        /// The frame's index among those inserted.
        frame: usize,
    },
    /// A frame whose colour count differs from its point count.
    #[error("frame {frame} has {colors} colours for {points} points")]
    ColorCount {
        /// The frame's index among those inserted.
        frame: usize,
        /// Its colours.
        colors: usize,
        /// Its points.
        points: usize,
    },
    /// A frame with more points than the filters' index channel holds (2^32).
    #[error("frame {frame} has {points} points, more than filters take (2^32)")]
    TooManyPoints {
        /// The frame's index among those inserted.
        frame: usize,
        /// Its points.
        points: usize,
    },
    /// The point filters are invalid.
    #[error(transparent)]
    Filter(#[from] crate::filters::FilterError),
    /// The tree cannot be made (an invalid resolution or sensor model).
    #[error(transparent)]
    Octree(#[from] OctreeError),
}

/// Builds a [`ColorOcTree`] from coloured frames, scan by scan as octomap_server's colour
/// server does (see the module docs).
pub struct ColorMapper {
    tree: ColorOcTree,
    rules: ScanRules,
    merge: ColorMerge,
    frames: usize,
}

/// What turns a coloured frame into its key sets and colours, the tree aside.
struct ScanRules {
    conv: KeyConverter,
    /// octomap_server's `m_maxRange`: negative for none.
    max_range: f64,
    /// octoquant's point filters, applied first.
    filters: PointFilters,
}

/// A coloured scan made ready for the tree: octomap_server's key sets in the order it walks
/// them and the end points' colours in scan order.
struct ColorScan {
    /// Free keys that are not occupied, in `KeySet` order.
    free: Vec<Key>,
    /// Occupied keys, in `KeySet` order.
    occupied: Vec<Key>,
    /// Each end point's voxel and colour, in scan order.
    colors: Vec<(Key, Color)>,
    st: FrameStats,
}

impl std::fmt::Debug for ColorMapper {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ColorMapper")
            .field("merge", &self.merge)
            .field("frames", &self.frames)
            .field("tree", &self.tree)
            .finish_non_exhaustive()
    }
}

impl ColorMapper {
    /// A mapper into a new tree of `options.resolution` and `options.params`, with
    /// `options.max_range` as octomap_server applies it and `options.filters` before the
    /// insertion (see the module docs). Only exact mode without reduction or lazy updates is
    /// octomap_server's insertion; anything else is [`ColorMapError::Unsupported`] (as are
    /// filters that fail [`crate::filters::PointFilters::validate`]).
    pub fn new(options: MapperOptions, merge: ColorMerge) -> Result<Self, ColorMapError> {
        let unsupported = if options.mode != InsertMode::Exact {
            Some("insertion mode but exact")
        } else if options.lazy {
            Some("lazy insertion")
        } else if options.reduce.is_some() {
            Some("density reduction")
        } else {
            None
        };
        if let Some(what) = unsupported {
            return Err(ColorMapError::Unsupported(what));
        }
        options.filters.validate()?;
        let tree = ColorOcTree::with_params(options.resolution, options.params)?;
        Ok(ColorMapper {
            rules: ScanRules {
                conv: KeyConverter::new(options.resolution)?,
                max_range: options.max_range.unwrap_or(-1.0),
                filters: options.filters,
            },
            tree,
            merge,
            frames: 0,
        })
    }

    /// Insert one coloured frame (world coordinates); errors, changing nothing, when the frame
    /// has no colours or not one per point.
    pub fn insert(&mut self, frame: &Frame) -> Result<FrameStats, ColorMapError> {
        self.insert_oriented(frame, &UnitQuaternion::identity())
    }

    /// [`ColorMapper::insert`] for a coloured frame measured in the sensor frame: `frame`'s
    /// points, with their colours, are moved into the world by the sensor `pose` (sensor to
    /// world) exactly as [`crate::Mapper::insert_sensor_frame_f32`] moves them (`pose * p` in
    /// `f64`, narrowed once to `f32`; the origin is the pose's translation, `frame.origin` is
    /// not used), and the [`crate::filters::PointFilters::crop_sensor`] box is taken in the
    /// pose's axes, so that a robot's scans and poses go in as they come. Errors as `insert`.
    pub fn insert_sensor_frame_f32(
        &mut self,
        frame: &Frame,
        pose: &Isometry3<f64>,
    ) -> Result<FrameStats, ColorMapError> {
        self.insert_oriented(&sensor_frame_to_world(frame, pose), &pose.rotation)
    }

    /// Whether [`ColorMapper::insert`] takes `frame`: `Ok` when it has one colour per point
    /// (and, with filters, no more points than their index channel holds), the error `insert`
    /// would give otherwise, naming the frame `index`. Lets a caller check a batch of frames
    /// before inserting any.
    pub fn check(&self, frame: &Frame, index: usize) -> Result<(), ColorMapError> {
        self.rules.checked_colors(frame, index).map(|_| ())
    }

    /// Insert coloured world-coordinate frames in order, calling `after` with the mapper and
    /// each frame's statistics once it is in the tree: the same map as one
    /// [`ColorMapper::insert`] per frame. With two or more rayon threads it is pipelined: a
    /// frame's rays are walked while the frame before goes into the tree (which is the only
    /// part that depends on the frames before). The first error, of the source, of a frame or
    /// of `after`, ends the run after the frames before it are in.
    pub fn insert_stream<F, E>(
        &mut self,
        frames: impl Iterator<Item = Result<F, E>>,
        mut after: impl FnMut(&ColorMapper, &FrameStats) -> Result<(), E>,
    ) -> Result<(), E>
    where
        F: std::borrow::Borrow<Frame> + Sync,
        E: From<ColorMapError>,
    {
        let identity = UnitQuaternion::identity();
        let mut frames = frames;
        if rayon::current_num_threads() < 2 {
            for f in frames {
                let st = self.insert_oriented(f?.borrow(), &identity)?;
                after(self, &st)?;
            }
            return Ok(());
        }
        let Some(first) = frames.next() else {
            return Ok(());
        };
        let mut mark = Instant::now();
        let mut scan = self
            .rules
            .prepare(first?.borrow(), &identity, self.frames)?;
        loop {
            let upcoming = frames.next();
            let ColorMapper {
                tree,
                rules,
                merge,
                frames: done,
            } = self;
            let index = *done + 1;
            let (mut st, next) = match &upcoming {
                Some(Ok(f)) => {
                    let (st, next) = rayon::join(
                        || apply(tree, *merge, scan),
                        || rules.prepare(f.borrow(), &identity, index),
                    );
                    (st, Some(next))
                }
                _ => (apply(tree, *merge, scan), None),
            };
            *done += 1;
            st.seconds = mark.elapsed().as_secs_f64();
            mark = Instant::now();
            after(self, &st)?;
            match (upcoming, next) {
                (Some(Err(e)), _) => return Err(e),
                (_, Some(next)) => scan = next?,
                _ => return Ok(()),
            }
        }
    }

    /// Insert a coloured world-coordinate frame whose sensor has the orientation `rotation`
    /// (sensor to world; the crop box's axes).
    fn insert_oriented(
        &mut self,
        frame: &Frame,
        rotation: &UnitQuaternion<f64>,
    ) -> Result<FrameStats, ColorMapError> {
        let start = Instant::now();
        let scan = self.rules.prepare(frame, rotation, self.frames)?;
        let mut st = apply(&mut self.tree, self.merge, scan);
        st.seconds = start.elapsed().as_secs_f64();
        self.frames += 1;
        Ok(st)
    }

    /// Frames inserted so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The tree built so far.
    pub fn tree(&self) -> &ColorOcTree {
        &self.tree
    }

    /// The tree, consuming the mapper.
    pub fn into_tree(self) -> ColorOcTree {
        self.tree
    }
}

/// Points per stretch of rays walked apart, at least: fewer make more parts to append than
/// threads gain.
const MIN_STRETCH: usize = 4096;

/// Stretches of rays per thread: more than one, so that a thread whose rays are long does not
/// leave the others waiting.
const STRETCHES_PER_THREAD: usize = 4;

/// What a scan's rays need to find their free keys: octomap_server's rules for one origin.
struct RayStretch<'a> {
    conv: &'a KeyConverter,
    origin: &'a Point3<f32>,
    /// octomap_server's `m_maxRange`: negative for none.
    max_range: f64,
    /// The box the scan's keys lie in ([`ScanRules::key_box`]).
    window: Option<(Key, Key)>,
    /// A ray cut at the maximum range frees its cut end's voxel too (octomap_server's rule;
    /// OctoMap's `computeUpdate` leaves it out).
    cut_end_free: bool,
}

/// The free keys of a stretch of rays, and its ends outside the map.
struct FreePart {
    keys: KeySetPart,
    outside_map: usize,
}

impl RayStretch<'_> {
    /// The free-key parts of the ground rays, then of the points' rays, in order, walked in
    /// stretches on the rayon threads.
    fn walk_all(&self, ground: &[Point3<f32>], points: &[Point3<f32>]) -> Vec<FreePart> {
        use rayon::prelude::*;
        let stretches = rayon::current_num_threads() * STRETCHES_PER_THREAD;
        let per = (ground.len() + points.len())
            .div_ceil(stretches)
            .max(MIN_STRETCH);
        let jobs: Vec<(bool, &[Point3<f32>])> = ground
            .chunks(per)
            .map(|g| (true, g))
            .chain(points.chunks(per).map(|p| (false, p)))
            .collect();
        jobs.par_iter()
            .map(|&(is_ground, pts)| self.walk(is_ground, pts))
            .collect()
    }

    /// The free keys of the rays to `points` (ground points' when `ground`), in order.
    fn walk(&self, ground: bool, points: &[Point3<f32>]) -> FreePart {
        let mut part = FreePart {
            keys: match self.window {
                Some((lo, hi)) => KeySetPart::with_window(lo, hi),
                None => KeySetPart::new(),
            },
            outside_map: 0,
        };
        let (conv, origin) = (self.conv, self.origin);
        let outside = |e: &Point3<f32>| conv.point_to_key(&e.cast::<f64>()).is_none();
        // the rays' ends, and for each whether its voxel joins the free keys after the ray
        // (octomap_server's "ray longer than maxrange": free up to and including the cut end's
        // voxel, when the ray's keys could be computed)
        let mut ends = Vec::with_capacity(points.len());
        let mut cut = Vec::with_capacity(points.len());
        for p in points {
            if ground {
                let end = max_range_end_f32(origin, p, self.max_range).unwrap_or(*p);
                part.outside_map += usize::from(outside(&end));
                ends.push(end);
                cut.push(false);
                continue;
            }
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                continue;
            }
            match max_range_end_f32(origin, p, self.max_range) {
                None => {
                    ends.push(*p);
                    cut.push(false);
                }
                Some(end) => {
                    ends.push(end);
                    cut.push(true);
                }
            }
        }
        let mut scratch = RayOrderScratch::default();
        let keys = &mut part.keys;
        let mut outside_map = 0;
        walk_rays_in_order_f32(conv, origin, &ends, &mut scratch, |i, ray| {
            // a ray whose keys cannot be computed adds nothing
            let Ok(ray) = ray else {
                return;
            };
            let mut range = keys.range();
            match ray {
                RayKeys::Bricks { bricks, step } => range.bricks(bricks, step),
                RayKeys::Keys(ks) => ks.iter().for_each(|&k| range.key(k)),
            }
            range.finish();
            if cut[i] && self.cut_end_free {
                match conv.point_to_key(&ends[i].cast::<f64>()) {
                    Some(k) => {
                        keys.insert(k);
                    }
                    None => outside_map += 1,
                }
            }
        });
        part.outside_map += outside_map;
        part
    }
}

impl ScanRules {
    /// The frame's colours, checked as [`ColorMapper::check`] does.
    fn checked_colors<'f>(
        &self,
        frame: &'f Frame,
        index: usize,
    ) -> Result<&'f [Color], ColorMapError> {
        let colors = frame
            .colors
            .as_deref()
            .ok_or(ColorMapError::NoColors { frame: index })?;
        if colors.len() != frame.points.len() {
            return Err(ColorMapError::ColorCount {
                frame: index,
                colors: colors.len(),
                points: frame.points.len(),
            });
        }
        if self.filters.is_active() {
            point_index_count(frame, index)?;
        }
        Ok(colors)
    }

    /// The frame's key sets in octomap_server's order and its end points' colours, all that
    /// does not depend on the tree; `index` names the frame in errors.
    fn prepare(
        &self,
        frame: &Frame,
        rotation: &UnitQuaternion<f64>,
        index: usize,
    ) -> Result<ColorScan, ColorMapError> {
        let colors = self.checked_colors(frame, index)?;
        let start = Instant::now();
        let mut st = FrameStats {
            points: frame.points.len(),
            reduced: frame.points.len(),
            ..FrameStats::default()
        };
        let origin = frame.origin;
        // the filters keep points with their colours: each kept point's index rides along
        // in the filters' pixel channel
        let filtered;
        let (points, colors) = if self.filters.is_active() {
            let n = point_index_count(frame, index)?;
            let (mut kept, mut kept_index) = (Vec::new(), Vec::new());
            let index: Vec<u32> = (0..n).collect();
            let c = self.filters.apply(
                &origin,
                rotation,
                &frame.points,
                Some(&index),
                &mut kept,
                &mut kept_index,
            );
            st.non_finite = c.non_finite;
            st.zero = c.zero;
            st.dropped = c.dropped;
            st.clearing = c.clearing;
            let kept_colors: Vec<Color> = kept_index.iter().map(|&i| colors[i as usize]).collect();
            filtered = (kept, kept_colors);
            (&filtered.0[..], &filtered.1[..])
        } else {
            (&frame.points[..], colors)
        };
        // octomap_server's loop over the points: the rays' keys into the free set, first
        // those of the ground points kept to clear space (the filters put them last), whose
        // rays only clear (cut at the maximum range); the rays are walked in stretches on the
        // rayon threads and the stretches appended in order, which gives the set of one walk
        // after another ([`octoquant_octree::KeySetPart`])
        let window = self.key_box(&origin, points);
        let (points, ground) = points.split_at(points.len() - st.clearing);
        let rays = RayStretch {
            conv: &self.conv,
            origin: &origin,
            max_range: self.max_range,
            window,
            cut_end_free: true,
        };
        let (mut free, mut occupied) = (key_set(window), key_set(window));
        for part in rays.walk_all(ground, points) {
            free.append(&part.keys);
            st.outside_map += part.outside_map;
        }
        st.rays += ground.len();
        // the same loop's end points, in order: occupied keys, and each one's colour, which
        // goes into its node as the tree is before this scan's updates
        let mut merges = Vec::with_capacity(points.len());
        for (p, &c) in points.iter().zip(colors) {
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                st.non_finite += 1;
                continue;
            }
            if *p == origin && !self.filters.is_active() {
                st.zero += 1; // (the filters counted them)
            }
            st.rays += 1;
            if max_range_end_f32(&origin, p, self.max_range).is_some() {
                // a cut ray: free space only (counted in its stretch)
                continue;
            }
            let Some(key) = self.conv.point_to_key(&p.cast::<f64>()) else {
                st.outside_map += 1;
                continue;
            };
            occupied.insert(key);
            merges.push((key, c));
        }
        let free = free
            .order()
            .into_iter()
            .filter(|k| !occupied.contains(k))
            .collect();
        st.ray_seconds = start.elapsed().as_secs_f64();
        Ok(ColorScan {
            free,
            occupied: occupied.order(),
            colors: merges,
            st,
        })
    }

    /// The box of voxels the scan's keys lie in: those of the origin and of every ray's end
    /// (cut at the maximum range), one voxel wider on each side (a ray's keys lie between its
    /// two ends' keys; the margin covers an end whose `f32` key differs from its `f64` one).
    /// `None` when the origin is outside the map (no ray has keys). The key sets only go
    /// faster inside it.
    fn key_box(&self, origin: &Point3<f32>, points: &[Point3<f32>]) -> Option<(Key, Key)> {
        let o = self.conv.point_to_key(&origin.cast::<f64>())?;
        let (mut lo, mut hi) = (o.0, o.0);
        for p in points {
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                continue;
            }
            let end = max_range_end_f32(origin, p, self.max_range).unwrap_or(*p);
            if let Some(k) = self.conv.point_to_key(&end.cast::<f64>()) {
                for i in 0..3 {
                    lo[i] = lo[i].min(k[i]);
                    hi[i] = hi[i].max(k[i]);
                }
            }
        }
        Some((
            Key(lo.map(|c| c.saturating_sub(1))),
            Key(hi.map(|c| c.saturating_add(1))),
        ))
    }
}

/// octomap_server's insertion of a prepared scan: each end point's colour into its node as
/// the tree is now, one miss per free voxel and one hit per occupied one in `KeySet` order,
/// eager, then `prune()`. Returns the scan's statistics with the tree's time.
fn apply(tree: &mut ColorOcTree, merge: ColorMerge, scan: ColorScan) -> FrameStats {
    let start = Instant::now();
    let ColorScan {
        free,
        occupied,
        colors,
        mut st,
    } = scan;
    // neighbouring end points often share a voxel: each run of them merges with one search
    for run in colors.chunk_by(|a, b| a.0 == b.0) {
        let (key, run) = (run[0].0, run.iter().map(|&(_, c)| c));
        match merge {
            ColorMerge::Average => tree.average_node_colors(key, run),
            ColorMerge::Integrate => tree.integrate_node_colors(key, run),
        };
    }
    tree.update_keys(&free, Update::Miss, InnerNodes::Refresh);
    tree.update_keys(&occupied, Update::Hit, InnerNodes::Refresh);
    tree.prune();
    st.free = free.len();
    st.occupied = occupied.len();
    st.tree_seconds = start.elapsed().as_secs_f64();
    st
}

/// OctoMap's `insertPointCloud(scan, origin, maxrange, lazy_eval, discretize)` on a
/// [`ColorOcTree`] (what octomap-python's `ColorOcTree.insertPointCloud` calls): the key sets
/// of `computeUpdate` (with `discretize`, of `computeDiscreteUpdate`: one ray per end-point
/// voxel, to its centre), then one miss per free key and one hit per occupied key, in the
/// order of OctoMap's `KeySet`s, `inner` as `lazy_eval` asks, and no `prune()`. Colours change
/// only through the structure (expansions copy a node's colour down, prunes average the
/// children's), which is why the order is OctoMap's: a node pruned by one update and expanded
/// by a later one hands its children the average colour. The updates go through
/// [`ColorOcTree::update_key_set`], which builds the `KeySet`s' order only when some node
/// could be pruned and expanded again within the pass (never on an empty tree).
///
/// `max_range` as OctoMap's `maxrange` (`None` for its -1): a farther point frees its ray cut
/// there, without the cut end's voxel and without an occupied voxel. Points with a NaN or
/// infinite coordinate are skipped; points outside the map give no keys. Returns the counts
/// of free and occupied voxels updated.
pub fn insert_point_cloud(
    tree: &mut ColorOcTree,
    points: &[Point3<f32>],
    origin: &Point3<f32>,
    max_range: Option<f64>,
    inner: InnerNodes,
    discretize: bool,
) -> (usize, usize) {
    let conv = tree.converter().clone();
    let mut centres = Vec::new();
    let points = if discretize {
        octoquant_raycast::discretize_f32(&conv, points, &mut centres);
        &centres[..]
    } else {
        points
    };
    let rules = ScanRules {
        conv,
        max_range: max_range.unwrap_or(-1.0),
        filters: PointFilters::default(),
    };
    let window = rules.key_box(origin, points);
    let rays = RayStretch {
        conv: &rules.conv,
        origin,
        max_range: rules.max_range,
        window,
        cut_end_free: false,
    };
    let (mut free, mut occupied) = (key_set(window), key_set(window));
    for part in rays.walk_all(&[], points) {
        free.append(&part.keys);
    }
    for p in points {
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
            || max_range_end_f32(origin, p, rules.max_range).is_some()
        {
            continue;
        }
        if let Some(key) = rules.conv.point_to_key(&p.cast::<f64>()) {
            occupied.insert(key);
        }
    }
    update_key_sets(tree, &free, &occupied, inner)
}

/// `insertPointCloud`'s updates of a scan's `KeySet`s on a [`ColorOcTree`]: one miss per key of
/// `free` that `occupied` does not hold, then one hit per key of `occupied`, each set in the
/// order OctoMap's `KeySet` iterates it, which is built only if a colour can depend on it
/// ([`ColorOcTree::update_key_set`]). Returns the counts of free and occupied voxels updated.
pub fn update_key_sets(
    tree: &mut ColorOcTree,
    free: &KeySetOrder,
    occupied: &KeySetOrder,
    inner: InnerNodes,
) -> (usize, usize) {
    let only_free = |keys: Vec<Key>| -> Vec<Key> {
        keys.into_iter().filter(|k| !occupied.contains(k)).collect()
    };
    let free_keys = only_free(free.keys().to_vec());
    tree.update_key_set(&free_keys, || only_free(free.order()), Update::Miss, inner);
    tree.update_key_set(occupied.keys(), || occupied.order(), Update::Hit, inner);
    (free_keys.len(), occupied.len())
}

/// An empty key set, with a membership window over the scan's key box when it has one
/// ([`ScanRules::key_box`]).
fn key_set(window: Option<(Key, Key)>) -> KeySetOrder {
    match window {
        Some((lo, hi)) => KeySetOrder::with_window(lo, hi),
        None => KeySetOrder::new(),
    }
}

/// The frame's point count as the filters' `u32` index channel holds it
/// ([`ColorMapError::TooManyPoints`] beyond).
fn point_index_count(frame: &Frame, index: usize) -> Result<u32, ColorMapError> {
    u32::try_from(frame.points.len()).map_err(|_| ColorMapError::TooManyPoints {
        frame: index,
        points: frame.points.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use octoquant_octree::Color;

    fn frame(points: &[[f32; 3]], colors: Option<Vec<Color>>) -> Frame {
        Frame {
            colors,
            ..Frame::new_f32(
                Point3::origin(),
                points.iter().map(|p| Point3::from(*p)).collect(),
            )
        }
    }

    /// The first sighting of a voxel gives it no colour (its node does not exist yet when the
    /// colours merge); the second averages into it; the occupancy is the plain mapper's.
    #[test]
    fn colour_merges_before_the_scan_updates() {
        let mut m = ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
        let p = [[1.05f32, 0.05, 0.05]];
        m.insert(&frame(&p, Some(vec![Color::new(100, 0, 0)])))
            .unwrap();
        let key = m
            .rules
            .conv
            .point_to_key(&Point3::new(1.05, 0.05, 0.05))
            .unwrap();
        assert_eq!(m.tree().node_color(key), Some(Color::WHITE));
        m.insert(&frame(&p, Some(vec![Color::new(100, 0, 0)])))
            .unwrap();
        assert_eq!(m.tree().node_color(key), Some(Color::new(100, 0, 0)));
        m.insert(&frame(&p, Some(vec![Color::new(0, 50, 0)])))
            .unwrap();
        assert_eq!(m.tree().node_color(key), Some(Color::new(50, 25, 0)));
        let mut plain = crate::Mapper::new(MapperOptions::default()).unwrap();
        for _ in 0..3 {
            plain.insert(&frame(&p, None));
        }
        let mut a = Vec::new();
        let mut b = Vec::new();
        octoquant_octree::io::write_ot(m.tree().occupancy(), &mut a).unwrap();
        octoquant_octree::io::write_ot(plain.tree(), &mut b).unwrap();
        assert_eq!(a, b);
    }

    /// Pipelined on two threads, `insert_stream` gives each frame's colours the tree of the
    /// frames before (the merges of frame `i + 1` wait for frame `i`'s updates) and the map of
    /// one `insert` per frame; a frame without colours ends the run after the frames before
    /// it, with `after` called once for each of them and the frame named in the error.
    #[test]
    fn insert_stream_is_insert_frame_by_frame_and_stops_at_a_bad_frame() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let p = [
            [1.05f32, 0.05, 0.05],
            [0.55, -0.35, 0.25],
            [-0.8, 0.45, 0.05],
        ];
        let rgb = |r, g| Some(vec![Color::new(r, g, 0); 3]);
        let good = [
            frame(&p, rgb(100, 0)),
            frame(&p, rgb(100, 0)),
            frame(&p, rgb(0, 50)),
        ];
        let ot = |m: &ColorMapper| {
            let mut b = Vec::new();
            octoquant_octree::io::write_color_ot(m.tree(), &mut b).unwrap();
            b
        };
        let mut one_by_one =
            ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
        for f in &good {
            one_by_one.insert(f).unwrap();
        }
        let key = one_by_one
            .rules
            .conv
            .point_to_key(&Point3::new(1.05, 0.05, 0.05))
            .unwrap();
        assert_eq!(
            one_by_one.tree().node_color(key),
            Some(Color::new(50, 25, 0))
        );
        pool.install(|| {
            let mut m = ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
            let mut seen = Vec::new();
            m.insert_stream(good.iter().map(Ok::<_, ColorMapError>), |m, st| {
                seen.push((m.frames(), st.occupied));
                Ok(())
            })
            .unwrap();
            assert_eq!(seen, vec![(1, 3), (2, 3), (3, 3)]);
            assert_eq!(ot(&m), ot(&one_by_one));

            let mut bad = good.to_vec();
            bad.insert(2, frame(&p, None));
            let mut m = ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
            let mut calls = 0;
            let e = m
                .insert_stream(bad.iter().map(Ok::<_, ColorMapError>), |_, _| {
                    calls += 1;
                    Ok(())
                })
                .unwrap_err();
            assert!(matches!(e, ColorMapError::NoColors { frame: 2 }), "{e}");
            assert_eq!((calls, m.frames()), (2, 2));
            let mut two = ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
            for f in &good[..2] {
                two.insert(f).unwrap();
            }
            assert_eq!(ot(&m), ot(&two));
        });
    }

    #[test]
    fn frames_without_colours_and_unsupported_options_are_refused() {
        let mut m = ColorMapper::new(MapperOptions::default(), ColorMerge::Average).unwrap();
        let e = m.insert(&frame(&[[1.0, 0.0, 0.0]], None)).unwrap_err();
        assert!(matches!(e, ColorMapError::NoColors { frame: 0 }), "{e}");
        let e = m
            .insert(&frame(&[[1.0, 0.0, 0.0]], Some(Vec::new())))
            .unwrap_err();
        assert!(matches!(e, ColorMapError::ColorCount { .. }), "{e}");
        assert!(m.tree().is_empty());
        for options in [
            MapperOptions {
                lazy: true,
                ..MapperOptions::default()
            },
            MapperOptions {
                mode: InsertMode::Discretize,
                ..MapperOptions::default()
            },
        ] {
            let e = ColorMapper::new(options, ColorMerge::Average).unwrap_err();
            assert!(matches!(e, ColorMapError::Unsupported(_)), "{e}");
        }
    }
}
