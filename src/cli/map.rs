//! `octoquant map INPUT... --res R ... -o OUT.bt`: build a map from sensor files.

use super::args::{InputArgs, ReadArgs, SensorArgs, TreeArgs};
use super::fresh_dir::{create_fresh_dir, DEMO_DIR};
use super::per_node;
use super::progress::Progress;
use super::vocab::{ModeArg, RayArg};
use anyhow::{bail, Context, Result};
use octoquant::checkpoint::{Checkpoint, InputFile, RunIdentity, MANIFEST};
use octoquant::color_map::{ColorMapError, ColorMapper, ColorMerge};
use octoquant::filters::{CropBox, GroundFilter, PointFilters, MAX_GROUND_ITERATIONS};
use octoquant::formats::{count_frames, frame_stream, FormatError, FrameStream, ReadOptions};
use octoquant::octree::io::TreeFormat;
use octoquant::output::{check_output, check_writable, remove_stale_temporaries, same_file};
use octoquant::pipeline::{
    CheckpointOptions, FrameStats, InsertMode, MapStats, Mapper, MapperOptions,
};
use octoquant::scene::{
    scan_lidar, scan_terrestrial, ScanOptions, Scene, SpinningLidar, TerrestrialScanner,
};
use octoquant::stamped_map::StampedMapper;
use octoquant::treefile::{save_color_tree_file, write_tree_file, TREE_EXTENSIONS};
use octoquant::Frame;
use octoquant_raycast::RayModel;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    tree: TreeArgs,
    /// OctoMap's discretize: one ray per end-point voxel, to its centre.
    #[arg(long)]
    discretize: bool,
    /// Insertion mode; `quantized` gives the same tree as --discretize via the dense bit grid,
    /// `quantized+bresenham` is `quantized` with --ray bresenham, `simple` is graph2tree's
    /// -simple (no deduplication, max range ignored).
    #[arg(long, value_enum)]
    mode: Option<ModeArg>,
    /// Ray model: `dda` (OctoMap's, exact) or `bresenham` (integer lines between voxel keys,
    /// implies the quantization pre-pass; faster, slightly less free space).
    #[arg(long, value_enum, default_value = "dda")]
    ray: RayArg,
    /// Lazy insertion: inner nodes are updated once at the end.
    #[arg(long)]
    lazy: bool,
    #[command(flatten)]
    sensor: SensorArgs,
    /// Thin each frame with the online density reducer first (cell size, metres).
    #[arg(long)]
    reduce: Option<f64>,
    #[command(flatten)]
    input: InputArgs,
    /// Output .bt (max-likelihood, pruned, as OctoMap writes it). Default: map.bt, or, without
    /// inputs (the built-in scene), map.bt in a new directory `octoquant-demo/` (or
    /// `octoquant-demo-2/`, ...).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Also write the full tree as .ot (before the .bt's max-likelihood conversion).
    #[arg(long)]
    ot: Option<PathBuf>,
    /// Build a coloured map (OctoMap's ColorOcTree, written as .ot) from inputs that carry
    /// colour (PCD rgb/rgba, PLY red/green/blue, a TUM association with its RGB images,
    /// PointCloud2 rgb/rgba), as octomap_server's colour server inserts scans: each end
    /// point's colour merges into its voxel before the scan's updates (so a voxel takes colour
    /// from its second sighting on), then the scan, then prune. Exact mode only, without
    /// --max-range, filters, --reduce, --lazy or checkpoints.
    #[arg(long, conflicts_with_all = ["checkpoint", "ot", "discretize", "mode", "lazy", "reduce"])]
    color: bool,
    /// How an end point's colour merges into its voxel: `average` (octomap_server's
    /// averageNodeColor) or `integrate` (OctoMap's occupancy-weighted integrateNodeColor).
    #[arg(long, value_enum, default_value = "average", requires = "color")]
    color_merge: ColorMergeArg,
    /// Build a time-stamped map (OctoMap's OcTreeStamped, written as .ot): every voxel and
    /// inner node a frame updates is stamped with the frame's time in whole seconds (the
    /// system clock for inputs without time stamps). OctoMap's .ot keeps no stamps, so they
    /// matter through pruning (equal leaves of different stamps stay apart) and
    /// --degrade-older-than.
    #[arg(long, conflicts_with_all = ["color", "checkpoint", "ot", "lazy"])]
    stamped: bool,
    /// With --stamped: after each frame, give every occupied voxel last updated more than S
    /// seconds before the frame one miss (OctoMap's degradeOutdatedNodes), so obstacles that
    /// are no longer seen fade away.
    #[arg(long, value_name = "S", requires = "stamped")]
    degrade_older_than: Option<u32>,
    /// Print the summary as one JSON object.
    #[arg(long)]
    json: bool,
    /// Threads for the insertion, 1 to 256 (default: all cores). The map is the same, byte for byte,
    /// whatever the count: frames go into the tree in order, and each frame's key sets are
    /// unions that do not depend on how its rays were shared out.
    #[arg(long, value_name = "N", value_parser = super::args::parse_threads)]
    threads: Option<u16>,
    /// No progress on stderr (neither the bar nor the plain lines).
    #[arg(short, long)]
    quiet: bool,
    /// When stderr is not a terminal, a plain progress line every N frames (0: none); on a
    /// terminal a bar shows frames, points/s and, when the frame count is known, the ETA.
    #[arg(long, value_name = "N", default_value_t = 100)]
    progress_every: usize,
    /// Save a checkpoint (the tree and the input position) into DIR every --every frames and
    /// after the last; a killed run continues with `--resume DIR`, with the same result.
    #[arg(long, value_name = "DIR")]
    checkpoint: Option<PathBuf>,
    /// Frames between two checkpoints.
    #[arg(long, value_name = "N", default_value_t = 100, requires = "checkpoint")]
    every: usize,
    /// Continue the run checkpointed in DIR. Its options, inputs, outputs and checkpoint
    /// interval come from the checkpoint, so no other option may be given (but --json,
    /// --threads and the progress options); the inputs must be unchanged. The outputs are byte-identical to an uninterrupted run's.
    #[arg(
        long,
        value_name = "DIR",
        conflicts_with_all = [
            "checkpoint", "every", "inputs", "format", "global", "topic", "fixed_frame",
            "pixel_step", "max_expansion", "intrinsics", "depth_scale", "trajectory",
            "identity_poses", "pcd_viewpoint", "res", "max_range", "discretize", "mode", "ray",
            "lazy", "sensor_model", "clamping", "sensor", "reduce", "output", "ot", "drop_zero", "min_range",
            "crop_sensor", "crop_world", "zmin", "zmax", "ground", "ground_angle",
            "ground_iterations", "ground_seed", "ground_clears", "color", "color_merge", "stamped",
            "degrade_older_than",
        ]
    )]
    resume: Option<PathBuf>,
    // last: its help heading applies to the options after it; boxed: inline, it would make
    // `map::Args` the largest command by far
    #[command(flatten)]
    filters: Box<FilterArgs>,
}

/// octoquant's point filters (octomap_server's and more), applied to each frame before
/// insertion, in the order listed; each dropped point is counted under the first that drops
/// it. Without them the map is OctoMap's, byte for byte.
#[derive(clap::Args)]
#[command(next_help_heading = "Point filters")]
struct FilterArgs {
    /// Drop points exactly at the sensor origin (drivers' (0, 0, 0) "no return" points).
    /// They are counted either way; OctoMap inserts them, so this changes the map.
    #[arg(long)]
    drop_zero: bool,
    /// Drop readings closer than M metres to the sensor origin (sensor housing, robot body).
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    min_range: Option<f64>,
    /// Drop points inside this box of the sensor frame: centred on the sensor origin, with the
    /// world's axes (frames record the sensor's position, not its orientation).
    #[arg(long, num_args = 6, allow_negative_numbers = true,
          value_names = ["XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"])]
    crop_sensor: Option<Vec<f64>>,
    /// Keep only points inside this world box.
    #[arg(long, num_args = 6, allow_negative_numbers = true,
          value_names = ["XMIN", "YMIN", "ZMIN", "XMAX", "YMAX", "ZMAX"])]
    crop_world: Option<Vec<f64>>,
    /// Drop points below this world height (octomap_server's pointcloud_min_z).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    zmin: Option<f64>,
    /// Drop points above this world height (octomap_server's pointcloud_max_z).
    #[arg(long, value_name = "Z", allow_negative_numbers = true)]
    zmax: Option<f64>,
    /// Drop each frame's dominant ground plane (points within D metres of it), found by a
    /// seeded RANSAC among near-horizontal planes below the sensor (octomap_server's
    /// filter_ground, whose ground_filter/distance is 0.04). Ground rays do not clear space
    /// unless --ground-clears.
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    ground: Option<f64>,
    /// Insert the ground points as octomap_server does, as free space: their rays clear (cut
    /// at --max-range as any other), their end voxels are not marked occupied.
    #[arg(long, requires = "ground")]
    ground_clears: bool,
    /// Largest angle between the ground's normal and the z axis, radians.
    #[arg(
        long,
        value_name = "RAD",
        default_value_t = 0.15,
        requires = "ground",
        allow_negative_numbers = true
    )]
    ground_angle: f64,
    /// RANSAC iterations per frame.
    #[arg(long, value_name = "N", default_value_t = 200, requires = "ground")]
    ground_iterations: u32,
    /// Seed of the RANSAC sampler (the same seed gives the same map on every run).
    #[arg(long, value_name = "N", default_value_t = 0, requires = "ground")]
    ground_seed: u64,
}

impl FilterArgs {
    /// The filters asked for, checked; errors name the option.
    fn filters(&self) -> Result<PointFilters> {
        let crop = |name: &str, v: &Option<Vec<f64>>| -> Result<Option<CropBox>> {
            v.as_ref()
                .map(|v| CropBox::from_slice(name, v))
                .transpose()
                .map_err(Into::into)
        };
        if let Some(m) = self.min_range {
            if !(m.is_finite() && m >= 0.0) {
                bail!("--min-range needs a finite distance >= 0, got {m}");
            }
        }
        for (name, z) in [("--zmin", self.zmin), ("--zmax", self.zmax)] {
            if let Some(z) = z {
                if !z.is_finite() {
                    bail!("{name} needs a finite height, got {z}");
                }
            }
        }
        if let (Some(lo), Some(hi)) = (self.zmin, self.zmax) {
            if lo > hi {
                bail!("--zmin {lo} is above --zmax {hi}: no point would be kept");
            }
        }
        let ground = match self.ground {
            None => None,
            Some(d) => {
                let g = GroundFilter {
                    distance: d,
                    angle: self.ground_angle,
                    iterations: self.ground_iterations,
                    seed: self.ground_seed,
                    clear: self.ground_clears,
                };
                if !(1..=MAX_GROUND_ITERATIONS).contains(&g.iterations) {
                    bail!(
                        "--ground-iterations {}: must be 1 to {MAX_GROUND_ITERATIONS} per frame",
                        g.iterations
                    );
                }
                g.validate("--ground")?;
                Some(g)
            }
        };
        Ok(PointFilters {
            drop_zero: self.drop_zero,
            min_range: self.min_range.filter(|m| *m > 0.0),
            crop_sensor: crop("--crop-sensor", &self.crop_sensor)?,
            crop_world: crop("--crop-world", &self.crop_world)?,
            z_min: self.zmin,
            z_max: self.zmax,
            ground,
        })
    }
}

fn builtin_frames() -> Result<Vec<Frame>> {
    let scene = Scene::builtin();
    let opts = ScanOptions::default();
    let (mut frames, _) = scan_terrestrial(&scene, &TerrestrialScanner::builtin(&scene), &opts)?;
    frames.extend(scan_lidar(&scene, &SpinningLidar::builtin_path(), &opts)?.0);
    Ok(frames)
}

/// The insertion mode that --mode, --discretize and --ray ask for together.
fn insert_mode(a: &Args) -> Result<InsertMode> {
    let mode = match a.mode {
        None if a.discretize => InsertMode::Discretize,
        None => InsertMode::Exact,
        Some(ModeArg::Exact) if a.discretize => bail!("--discretize contradicts --mode exact"),
        Some(m) => m.into(),
    };
    match (RayModel::from(a.ray), mode) {
        (RayModel::Dda, m) => Ok(m),
        (RayModel::Bresenham, InsertMode::Simple) => {
            bail!("--ray bresenham does not apply to --mode {}", mode.name())
        }
        (RayModel::Bresenham, _) => Ok(InsertMode::QuantizedBresenham),
    }
}

/// The mapper settings the arguments ask for, checked.
fn mapper_options(a: &Args) -> Result<MapperOptions> {
    let mode = insert_mode(a)?;
    let params = a.sensor.params()?;
    if let Some(c) = a.reduce {
        if !(c.is_finite() && c > 0.0) {
            bail!("--reduce needs a positive cell size, got {c}");
        }
    }
    Ok(MapperOptions {
        resolution: a.tree.resolution()?,
        params,
        max_range: a.tree.max_range()?,
        mode,
        lazy: a.lazy,
        reduce: a.reduce.map(|c| [c; 3]),
        filters: a.filters.filters()?,
        ..MapperOptions::default()
    })
}

/// Everything a run needs: from the arguments, or from a checkpoint for `--resume`.
struct Plan {
    options: MapperOptions,
    inputs: Vec<PathBuf>,
    read: ReadArgs,
    output: PathBuf,
    ot: Option<PathBuf>,
    checkpoint: Option<CheckpointOptions>,
}

/// `path` made absolute (against the current directory), as a checkpoint records it, so that
/// a resume from another directory finds the same files.
fn absolute(path: &std::path::Path) -> Result<PathBuf> {
    std::path::absolute(path).with_context(|| format!("cannot resolve {}", path.display()))
}

/// The output the arguments name; without one, `map.bt`, or for the built-in scene (no
/// inputs) `map.bt` in a new directory, which is said.
fn output_path(a: &Args) -> Result<PathBuf> {
    if let Some(o) = &a.output {
        return Ok(o.clone());
    }
    if !a.input.inputs.is_empty() {
        return Ok(PathBuf::from("map.bt"));
    }
    let dir = create_fresh_dir(std::path::Path::new("."), DEMO_DIR)?;
    errln!(
        "writing into {}/ (a new directory; -o to choose the output)",
        dir.display()
    );
    Ok(dir.join("map.bt"))
}

impl Plan {
    fn from_args(a: &Args) -> Result<Plan> {
        let options = mapper_options(a)?;
        Ok(Plan {
            options,
            inputs: a.input.inputs.clone(),
            read: a.input.read.clone(),
            output: output_path(a)?,
            ot: a.ot.clone(),
            checkpoint: a.checkpoint.as_ref().map(|dir| CheckpointOptions {
                dir: dir.clone(),
                every: a.every,
            }),
        })
    }

    /// The run a checkpoint records, with the settings [`Plan::settings`] stored.
    fn from_checkpoint(dir: &std::path::Path, c: &Checkpoint) -> Result<Plan> {
        let id = &c.identity;
        let get = |k: &str| id.setting(k);
        let output = get("output").context("the checkpoint records no output")?;
        let every = get("every").unwrap_or("0");
        Ok(Plan {
            options: id.options.clone(),
            inputs: id.inputs.iter().map(|i| i.path.clone()).collect(),
            read: ReadArgs::from_settings(get)?,
            output: PathBuf::from(output),
            ot: get("ot").map(PathBuf::from),
            checkpoint: Some(CheckpointOptions {
                dir: dir.to_path_buf(),
                every: every
                    .parse()
                    .with_context(|| format!("checkpoint interval {every:?}"))?,
            }),
        })
    }

    /// What the checkpoint records besides the mapper options and inputs: absolute output
    /// paths, the interval and the reader options.
    fn settings(&self) -> Result<Vec<(String, String)>> {
        let mut s = vec![(
            "output".to_string(),
            absolute(&self.output)?.to_string_lossy().into_owned(),
        )];
        if let Some(ot) = &self.ot {
            s.push(("ot".into(), absolute(ot)?.to_string_lossy().into_owned()));
        }
        if let Some(c) = &self.checkpoint {
            s.push(("every".into(), c.every.to_string()));
        }
        s.extend(self.read.to_settings());
        Ok(s)
    }

    /// This run's identity: options, inputs (absolute), settings (the frames are streamed:
    /// a resume checks those it skips against the checkpoint).
    fn identity(&self) -> Result<RunIdentity> {
        let mut inputs = Vec::new();
        for p in &self.inputs {
            let abs = absolute(p)?;
            inputs.push(
                InputFile::stat(&abs).with_context(|| format!("cannot read {}", p.display()))?,
            );
        }
        let mut id = RunIdentity::streamed(&self.options, inputs);
        for (k, v) in self.settings()? {
            id = id.with_setting(&k, v);
        }
        Ok(id)
    }

    /// Every failure that can be known before reading the inputs: an unknown output format,
    /// a missing or unwritable output directory, an output that is an input, `-o` and `--ot`
    /// the same file, an unwritable checkpoint directory. Stale temporaries of killed runs
    /// are removed (and said).
    fn preflight(&self) -> Result<()> {
        for out in std::iter::once(&self.output).chain(&self.ot) {
            check_output(out, &TREE_EXTENSIONS, &self.inputs)?;
            for p in remove_stale_temporaries(out).unwrap_or_default() {
                errln!("removed {} (left by an interrupted run)", p.display());
            }
        }
        if let Some(ot) = &self.ot {
            if same_file(ot, &self.output) {
                bail!(
                    "--ot {} and -o {} are the same file",
                    ot.display(),
                    self.output.display()
                );
            }
        }
        if let Some(c) = &self.checkpoint {
            std::fs::create_dir_all(&c.dir).with_context(|| {
                format!("cannot create checkpoint directory {}", c.dir.display())
            })?;
            check_writable(&c.dir.join(MANIFEST))?;
        }
        Ok(())
    }

    /// The run's frames as they are read (every input in turn, each opened when the one
    /// before is done), the number of frames when known up front (one input that knows
    /// it, several that all announce theirs, or the built-in scene), and the seconds spent
    /// reading so far (`load`, in ns).
    fn frame_source(&self, load: Arc<AtomicU64>) -> Result<(Frames, Option<usize>)> {
        if self.inputs.is_empty() {
            errln!("no input given: mapping the built-in scene (pass files to map your own data)");
            let frames = builtin_frames()?;
            let n = frames.len();
            return Ok((Box::new(frames.into_iter().map(Ok)), Some(n)));
        }
        let mut inputs = InputFrames {
            paths: self.inputs.clone().into(),
            read: self.read.options(),
            current: None,
            load,
        };
        // the first input is opened now: its header errors come before any work
        inputs.open_next()?;
        let total = match (&inputs.current, self.inputs.len()) {
            // (a .frames file's bound counts a possible error after its frames)
            (Some(s), 1) => match s.size_hint() {
                (lo, Some(hi)) if hi <= lo + 1 => Some(lo),
                _ => None,
            },
            // several inputs: the counts their headers, indexes or summaries announce, when
            // every one does
            _ => self
                .inputs
                .iter()
                .map(|p| count_frames(p, &inputs.read))
                .sum::<Option<usize>>(),
        };
        Ok((Box::new(inputs), total))
    }
}

/// A run's frames, read while they are inserted.
type Frames = Box<dyn Iterator<Item = Result<Frame, FormatError>> + Send>;

/// Every input's frames in order, one input open at a time, timing the reads.
struct InputFrames {
    paths: std::collections::VecDeque<PathBuf>,
    read: ReadOptions,
    current: Option<FrameStream>,
    load: Arc<AtomicU64>,
}

impl InputFrames {
    /// Open the next input; false when there is none.
    fn open_next(&mut self) -> Result<bool, FormatError> {
        let Some(p) = self.paths.pop_front() else {
            self.current = None;
            return Ok(false);
        };
        let t = Instant::now();
        let s = frame_stream(&p, &self.read);
        self.load
            .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
        self.current = Some(s?);
        Ok(true)
    }
}

impl Iterator for InputFrames {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(s) = &mut self.current {
                let t = Instant::now();
                let r = s.next();
                self.load
                    .fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                if r.is_some() {
                    return r;
                }
            }
            match self.open_next() {
                Ok(true) => {}
                Ok(false) => return None,
                Err(e) => {
                    self.paths.clear();
                    return Some(Err(e));
                }
            }
        }
    }
}

/// `--color-merge` values.
#[derive(Clone, Copy, clap::ValueEnum)]
enum ColorMergeArg {
    /// octomap_server's averageNodeColor.
    Average,
    /// OctoMap's integrateNodeColor.
    Integrate,
}

impl From<ColorMergeArg> for ColorMerge {
    fn from(m: ColorMergeArg) -> Self {
        match m {
            ColorMergeArg::Average => ColorMerge::Average,
            ColorMergeArg::Integrate => ColorMerge::Integrate,
        }
    }
}

/// The plan of a `--color` or `--stamped` run (`flag`, writing OctoMap tree type `kind`):
/// inputs needed, an .ot output.
fn typed_plan(a: &Args, flag: &str, kind: &str) -> Result<Plan> {
    if a.input.inputs.is_empty() && flag == "--color" {
        bail!("--color needs inputs that carry colour (the built-in scene has none)");
    }
    // checked before the plan, which may make a directory for a default output
    let ot = a
        .output
        .as_deref()
        .is_some_and(|o| TreeFormat::from_path(o) == Some(TreeFormat::Ot));
    if !ot {
        let named = a.output.as_deref().map_or_else(
            || "no output was named".to_string(),
            |o| format!("not {}", o.display()),
        );
        bail!(
            "{flag} writes a {kind}, which only the .ot format holds (a .bt keeps occupancy only): name an .ot output with -o ({named})"
        );
    }
    Plan::from_args(a)
}

/// The frames of `plan`'s inputs (colours read when `colors`), the built-in scene without
/// inputs.
fn typed_frames(plan: &Plan, colors: bool, load: Arc<AtomicU64>) -> Result<Frames> {
    if plan.inputs.is_empty() {
        return plan.frame_source(load).map(|(f, _)| f);
    }
    let mut read = plan.read.options();
    read.colors = colors;
    let mut inputs = InputFrames {
        paths: plan.inputs.clone().into(),
        read,
        current: None,
        load,
    };
    inputs.open_next()?;
    Ok(Box::new(inputs))
}

/// `map --stamped`: an OcTreeStamped, written as .ot.
fn run_stamped(a: &Args) -> Result<()> {
    let plan = typed_plan(a, "--stamped", "OcTreeStamped")?;
    let mut mapper = StampedMapper::new(plan.options.clone(), a.degrade_older_than)?;
    plan.preflight()?;
    let load_ns = Arc::new(AtomicU64::new(0));
    let frames = typed_frames(&plan, false, load_ns.clone())?;
    let mut progress = Progress::new(a.quiet, a.progress_every, None);
    let mut stats = MapStats::default();
    // pipelined: a frame's rays are cast while the one before goes into the tree
    let frames = frames.map(|f| f.map_err(anyhow::Error::from));
    mapper.insert_stream(frames, |_, st, _| -> Result<()> {
        stats.add(st);
        progress.update(&stats, stats.total.points, 0);
        Ok(())
    })?;
    progress.finish();
    let tree = mapper.into_tree();
    octoquant::output::write_atomic(&plan.output, |w| {
        octoquant::octree::io::write_stamped_ot(&tree, w)
    })?;
    let bytes_per_node = per_node(tree.memory_usage(), tree.size());
    let extra = serde_json::json!({
        "last_update": tree.last_update_time(),
        "degrade_older_than": a.degrade_older_than,
        "bytes_per_node": bytes_per_node,
    });
    let line = format!(
        "{} nodes, {bytes_per_node:.2} bytes/node with the stamps, last update at {} s",
        tree.size(),
        tree.last_update_time()
    );
    let load_s = load_ns.load(Ordering::Relaxed) as f64 * 1e-9;
    let tree_figures = (tree.resolution(), tree.size());
    typed_summary(a, &stats, load_s, tree_figures, extra, &line, &plan.output)
}

/// `map --color`: a ColorOcTree from coloured inputs, written as .ot.
fn run_color(a: &Args) -> Result<()> {
    let plan = typed_plan(a, "--color", "ColorOcTree")?;
    let mut mapper = ColorMapper::new(plan.options.clone(), a.color_merge.into())?;
    plan.preflight()?;
    let load_ns = Arc::new(AtomicU64::new(0));
    let inputs = typed_frames(&plan, true, load_ns.clone())?;
    let mut progress = Progress::new(a.quiet, a.progress_every, None);
    let mut stats = MapStats::default();
    // pipelined: a frame's rays are walked while the one before goes into the tree
    let frames = inputs.map(|f| f.map_err(anyhow::Error::from));
    mapper
        .insert_stream(frames, |_, st| -> Result<()> {
            stats.add(st);
            progress.update(&stats, stats.total.points, 0);
            Ok(())
        })
        .map_err(|e| {
            // a read error names its file and place already; the mapper's own (a frame without
            // colours, ...) get the inputs
            if !e.is::<ColorMapError>() {
                return e;
            }
            let names: Vec<String> = plan
                .inputs
                .iter()
                .map(|p| p.display().to_string())
                .collect();
            e.context(format!("mapping {} in colour", names.join(", ")))
        })?;
    progress.finish();
    let tree = mapper.into_tree();
    save_color_tree_file(&tree, &plan.output)?;
    let merge = ColorMerge::from(a.color_merge).name();
    let bytes_per_node = per_node(tree.memory_usage(), tree.size());
    let extra = serde_json::json!({
        "colored_nodes": tree.num_colored_nodes(),
        "color_merge": merge,
        "bytes_per_node": bytes_per_node,
    });
    let line = format!(
        "{} nodes, {} with a colour ({merge} merge), {bytes_per_node:.2} bytes/node with the \
         colours",
        tree.size(),
        tree.num_colored_nodes()
    );
    let load_s = load_ns.load(Ordering::Relaxed) as f64 * 1e-9;
    let tree_figures = (tree.resolution(), tree.size());
    typed_summary(a, &stats, load_s, tree_figures, extra, &line, &plan.output)
}

/// The points a run dropped, by reason, as the summaries' JSON `dropped` object.
fn dropped_json(t: &FrameStats) -> serde_json::Map<String, serde_json::Value> {
    let mut dropped = serde_json::Map::new();
    dropped.insert("non_finite".into(), t.non_finite.into());
    dropped.insert("outside_map".into(), t.outside_map.into());
    for (name, n) in t.dropped.named() {
        dropped.insert(name.into(), n.into());
    }
    dropped
}

/// The text summaries' "filtered out" line: each filter's dropped count, and the ground
/// points kept to clear space only; `None` when no filter dropped or set aside anything.
fn filtered_out(t: &FrameStats) -> Option<String> {
    let mut filtered: Vec<String> = t
        .dropped
        .named()
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(name, n)| format!("{n} {name}"))
        .collect();
    if t.clearing > 0 {
        filtered.push(format!("{} ground points only cleared space", t.clearing));
    }
    (!filtered.is_empty()).then(|| filtered.join(", "))
}

/// The summary of `map --color` and `map --stamped`: the common counts, then the tree type's
/// own figures (`extra` in JSON, `tree_line` in text).
fn typed_summary(
    a: &Args,
    stats: &MapStats,
    load_s: f64,
    (resolution, nodes): (f64, usize),
    extra: serde_json::Value,
    tree_line: &str,
    output: &std::path::Path,
) -> Result<()> {
    let t = &stats.total;
    if a.json {
        let mut json = serde_json::json!({
            "frames": stats.frames,
            "points": t.points,
            "non_finite": t.non_finite,
            "outside_map": t.outside_map,
            "zero_points": t.zero,
            "dropped": dropped_json(t),
            "dropped_total": t.non_finite + t.outside_map + t.dropped.total(),
            "ground_clearing": t.clearing,
            "free_updates": t.free,
            "occupied_updates": t.occupied,
            "load_seconds": load_s,
            "insert_seconds": t.seconds,
            "resolution": resolution,
            "nodes": nodes,
        });
        if let (Some(all), serde_json::Value::Object(more)) = (json.as_object_mut(), extra) {
            all.extend(more);
        }
        json["output"] = serde_json::Value::from(output.to_string_lossy());
        outln!("{json}")?;
    } else {
        outln!("frames:          {}", stats.frames)?;
        outln!(
            "points:          {} ({} non-finite and {} outside the map skipped)",
            t.points,
            t.non_finite,
            t.outside_map
        )?;
        if let Some(line) = filtered_out(t) {
            outln!("filtered out:    {line}")?;
        }
        outln!("loading:         {load_s:.3} s")?;
        outln!("insertion:       {:.3} s", t.seconds)?;
        outln!("tree:            {tree_line}")?;
        outln!("wrote:           {}", output.display())?;
    }
    Ok(())
}

pub fn run(a: &Args) -> Result<()> {
    match a.threads {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(usize::from(n))
            .build()
            .context("cannot start the insertion threads")?
            .install(|| run_on_threads(a)),
        None => run_on_threads(a),
    }
}

/// [`run`] inside the thread pool the run was given.
fn run_on_threads(a: &Args) -> Result<()> {
    if a.color {
        return run_color(a);
    }
    if a.stamped {
        return run_stamped(a);
    }
    let resumed = match &a.resume {
        Some(dir) => Some(Checkpoint::load(dir)?),
        None => None,
    };
    let plan = match (&resumed, &a.resume) {
        (Some(c), Some(dir)) => Plan::from_checkpoint(dir, c)?,
        _ => Plan::from_args(a)?,
    };
    if resumed.is_none() {
        if let Some(c) = &plan.checkpoint {
            if Checkpoint::exists(&c.dir) {
                let done = Checkpoint::load(&c.dir)
                    .map(|k| format!(" ({} frames done)", k.frames_done))
                    .unwrap_or_default();
                bail!(
                    "{} already holds a checkpoint{done}: continue it with `octoquant map --resume {}`, or remove it to start over",
                    c.dir.display(),
                    c.dir.display()
                );
            }
        }
    }
    let fresh = match &resumed {
        None => {
            let m = Mapper::new(plan.options.clone()).context("invalid --res")?;
            // without --checkpoint no frame needs its fingerprint
            Some(match plan.checkpoint {
                Some(_) => m,
                None => m.without_checkpoints(),
            })
        }
        Some(_) => None,
    };
    plan.preflight()?;
    if let Some(c) = &resumed {
        c.identity.check_inputs_on_disk(&c.dir)?;
    }

    let identity = plan.identity()?;
    let mut mapper = match (fresh, &resumed) {
        (Some(m), _) => m,
        (None, Some(c)) => {
            identity.check_same(&c.identity, &c.dir)?;
            if !a.quiet {
                errln!(
                    "resuming from {}: {} frames done",
                    c.dir.display(),
                    c.frames_done
                );
            }
            Mapper::from_checkpoint(c)?
        }
        (None, None) => unreachable!("a run is fresh or resumed"),
    };
    let load_ns = Arc::new(AtomicU64::new(0));
    let (frames, total) = plan.frame_source(load_ns.clone())?;
    let mut progress = Progress::new(a.quiet, a.progress_every, total);
    if let Some(n) = total {
        progress.set_total(n);
    }
    let skipped = mapper.stats().frames;
    let points_before = mapper.stats().total.points;
    mapper.insert_stream(
        frames,
        plan.checkpoint.as_ref().map(|c| (c, &identity)),
        |s| progress.update(s, s.total.points - points_before, skipped),
    )?;
    progress.finish();
    let load_s = load_ns.load(Ordering::Relaxed) as f64 * 1e-9;
    mapper.finish();
    let stats = *mapper.stats();
    let all = &stats.total;
    if all.outside_map > 0 && all.outside_map + all.non_finite == all.points {
        // the key range is 2^16 voxels around the origin
        let half = plan.options.resolution * 32768.0;
        bail!(
            "all {} points lie outside the map: at --res {:?} it spans only ±{half:?} m around the origin; choose a coarser resolution",
            all.points,
            plan.options.resolution
        );
    }
    let mut tree = mapper.into_tree();
    // blocks freed by pruning are kept for reuse while mapping: the bytes in use leave them
    // out, as `bench` and `info` do by shrinking first; not shrinking here keeps the copy
    // that shrinking makes (the tree twice, briefly) out of the run's peak memory
    let full_nodes = tree.size();
    let bytes_per_node = per_node(tree.memory_breakdown().in_use(), full_nodes);
    if let Some(ot) = &plan.ot {
        write_tree_file(&mut tree, ot)?;
    }
    write_tree_file(&mut tree, &plan.output)?;
    let t = &stats.total;
    let pps = if t.seconds > 0.0 {
        t.points as f64 / t.seconds
    } else {
        0.0
    };
    if a.json {
        let path = |p: &std::path::Path| p.to_string_lossy().into_owned();
        let bounds = match tree.metric_bounds() {
            Some((lo, hi)) => serde_json::json!({
                "min": [lo.x, lo.y, lo.z],
                "max": [hi.x, hi.y, hi.z],
            }),
            None => serde_json::Value::Null,
        };
        let json = serde_json::json!({
            "frames": stats.frames,
            "points": t.points,
            "non_finite": t.non_finite,
            "outside_map": t.outside_map,
            "zero_points": t.zero,
            "dropped": dropped_json(t),
            "dropped_total": t.non_finite + t.outside_map + t.dropped.total(),
            "ground_clearing": t.clearing,
            "rays": t.rays,
            "heads_skipped": t.heads_skipped,
            "free_updates": t.free,
            "occupied_updates": t.occupied,
            "load_seconds": load_s,
            "insert_seconds": t.seconds,
            "threads": rayon::current_num_threads(),
            "points_per_second": pps,
            "resolution": tree.resolution(),
            "bounds": bounds,
            "nodes": full_nodes,
            "bytes_per_node": bytes_per_node,
            "bt_nodes": tree.size(),
            "output": path(&plan.output),
            "outputs": {
                "bt": path(&plan.output),
                "ot": plan.ot.as_deref().map(path),
            },
        });
        outln!("{json}")?;
    } else {
        outln!("frames:          {}", stats.frames)?;
        outln!(
            "points:          {} ({} non-finite and {} outside the map skipped)",
            t.points,
            t.non_finite,
            t.outside_map
        )?;
        if let Some(line) = filtered_out(t) {
            outln!("filtered out:    {line}")?;
        }
        if t.zero > 0 {
            outln!(
                "zero points:     {} at the sensor origin ({})",
                t.zero,
                if plan.options.filters.drop_zero {
                    "dropped"
                } else {
                    "inserted as OctoMap does; --drop-zero drops them"
                }
            )?;
        }
        outln!(
            "rays:            {} ({} walked from where their neighbours stop covering them)",
            t.rays,
            t.heads_skipped
        )?;
        outln!("loading:         {load_s:.3} s")?;
        outln!(
            "insertion:       {:.3} s, {:.0} points/s (rays {:.3} s, tree {:.3} s), {} threads",
            t.seconds,
            pps,
            t.ray_seconds,
            t.tree_seconds,
            rayon::current_num_threads()
        )?;
        outln!(
            "tree:            {} nodes, {:.2} bytes/node ({} nodes in the .bt after ML + prune)",
            full_nodes,
            bytes_per_node,
            tree.size()
        )?;
        outln!("wrote:           {}", plan.output.display())?;
        if let Some(ot) = &plan.ot {
            outln!("                 {}", ot.display())?;
        }
    }
    Ok(())
}
