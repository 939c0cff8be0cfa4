//! Checkpoints of a long mapping run, so that a killed run resumes where it stopped and ends
//! with the same files, byte for byte.
//!
//! A checkpoint directory holds the tree as an `.ot` file (`tree-NNNNNNNNNN.ot`, every node's
//! log-odds as it is in memory, which reads back exactly) and a manifest (`checkpoint`, text)
//! naming that file with its length and hash, the number of frames already inserted, the
//! run's [`RunIdentity`] (mapper options, input files, a fingerprint of the frames,
//! application settings) and the running statistics. [`Checkpoint::save`] writes the tree
//! file, then atomically replaces the manifest, then deletes the previous tree file: a kill at
//! any moment leaves either the old or the new checkpoint, complete. [`Checkpoint::load`]
//! checks the tree file against the manifest, and [`RunIdentity::check_same`] refuses to
//! resume a run with other options or changed inputs.
//!
//! [`crate::pipeline::Mapper::insert_run`], [`crate::pipeline::Mapper::save_checkpoint`] and
//! [`crate::pipeline::Mapper::resume`] are the entry points.

use crate::map_stats::{FrameStats, MapStats};
use crate::mapper_options::{options_to_settings, parse_num, set_option, MapperOptions};
use crate::output::{remove_stale_temporaries_in, write_atomic, OutputError};
use crate::Frame;
use octoquant_octree::io::{read_ot, write_ot};
use octoquant_octree::{OcTree, OccupancyParams, OctreeError};
use std::io::Write;
use std::path::{Path, PathBuf};

/// The manifest's file name inside a checkpoint directory.
pub const MANIFEST: &str = "checkpoint";
const MAGIC: &str = "octoquant-checkpoint 3";
/// How every manifest's first line begins, whatever its format version.
const MAGIC_STEM: &str = "octoquant-checkpoint ";

/// Errors from saving, loading or checking a checkpoint; each names the directory or file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckpointError {
    /// The directory holds no manifest.
    #[error("{}: no checkpoint here (no '{MANIFEST}' file)", dir.display())]
    Missing {
        /// The checkpoint directory.
        dir: PathBuf,
    },
    /// Reading a checkpoint file failed.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The manifest is not one this version wrote.
    #[error("{}: line {line}: {message}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The tree file does not match the manifest, or does not parse.
    #[error("{}: damaged checkpoint tree: {message}", path.display())]
    Tree {
        /// The tree file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The checkpoint belongs to another run: other options or changed inputs.
    #[error("cannot resume from {}: {what} differs (checkpoint: {saved}; now: {now})", dir.display())]
    Mismatch {
        /// The checkpoint directory.
        dir: PathBuf,
        /// Which setting or input.
        what: String,
        /// Its value in the checkpoint.
        saved: String,
        /// Its value in this run.
        now: String,
    },
    /// The mapper was made [`without_checkpoints`](crate::pipeline::Mapper::without_checkpoints):
    /// it kept no fingerprint of its frames, so it cannot save a checkpoint.
    #[error("cannot save a checkpoint in {}: this mapper keeps no fingerprint of its frames (made without checkpoints)", dir.display())]
    NotTracked {
        /// The checkpoint directory asked for.
        dir: PathBuf,
    },
    /// Creating the directory or removing old files failed.
    #[error("cannot write checkpoint in {}: {source}", dir.display())]
    Io {
        /// The checkpoint directory.
        dir: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing a checkpoint file failed (the previous checkpoint is intact).
    #[error(transparent)]
    Write(#[from] OutputError),
}

/// One input file as recorded in a checkpoint: where it was, its size and modification time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputFile {
    /// The path (absolute when the application made it so).
    pub path: PathBuf,
    /// Length in bytes (for a directory input, the sum over its files, not recursive).
    pub size: u64,
    /// Modification time in nanoseconds since 1970, when known. Informative only: a file
    /// copied or touched without a change in content may still resume.
    pub modified_ns: Option<u128>,
}

impl InputFile {
    /// Record `path` as it is now on disk.
    pub fn stat(path: &Path) -> std::io::Result<Self> {
        let meta = std::fs::metadata(path)?;
        let size = if meta.is_dir() {
            let mut total = 0;
            for e in std::fs::read_dir(path)? {
                let m = e?.metadata()?;
                if m.is_file() {
                    total += m.len();
                }
            }
            total
        } else {
            meta.len()
        };
        let modified_ns = meta
            .modified()
            .ok()
            .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
            .map(|d| d.as_nanos());
        Ok(InputFile {
            path: path.to_path_buf(),
            size,
            modified_ns,
        })
    }
}

/// What makes a run the same run: the same mapper options, the same input files, the same
/// frames (by count and fingerprint) and the same application settings. A checkpoint resumes
/// only a run with an identical identity, which is what makes the result byte-identical.
#[derive(Debug, Clone, PartialEq)]
pub struct RunIdentity {
    /// The mapper options.
    pub options: MapperOptions,
    /// The input files, in order (empty for frames that come from elsewhere, e.g. the scene
    /// simulator).
    pub inputs: Vec<InputFile>,
    /// Frames in the whole run, when known before it starts (`None` for a run whose frames
    /// are streamed from their files: see [`RunIdentity::streamed`]).
    pub frames: Option<usize>,
    /// [`frames_fingerprint`] of the whole run's frames, when known before it starts.
    pub frames_hash: Option<u64>,
    /// Application settings that must match too, or that a resume takes over (output paths,
    /// reader options), as `(key, value)`; keys are single words.
    pub settings: Vec<(String, String)>,
}

impl RunIdentity {
    /// The identity of a run of `frames` with `options`, read from `inputs`.
    pub fn new(options: &MapperOptions, inputs: Vec<InputFile>, frames: &[Frame]) -> Self {
        RunIdentity {
            options: options.clone(),
            inputs,
            frames: Some(frames.len()),
            frames_hash: Some(frames_fingerprint(frames)),
            settings: Vec::new(),
        }
    }

    /// The identity of a run whose frames are read while it runs ([`crate::pipeline::Mapper::insert_stream`]):
    /// the whole run's frames are not known up front, so a resume checks the frames it skips
    /// against the checkpoint's [`Checkpoint::done_hash`] instead, and the input files by size.
    pub fn streamed(options: &MapperOptions, inputs: Vec<InputFile>) -> Self {
        RunIdentity {
            options: options.clone(),
            inputs,
            frames: None,
            frames_hash: None,
            settings: Vec::new(),
        }
    }

    /// Add an application setting (`key` a single word, `value` any text).
    pub fn with_setting(mut self, key: &str, value: impl Into<String>) -> Self {
        self.settings.push((key.to_string(), value.into()));
        self
    }

    /// The value of application setting `key`.
    pub fn setting(&self, key: &str) -> Option<&str> {
        self.settings
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// Check, before reading them, that the input files still have the sizes recorded here
    /// (a changed input is refused before any work).
    pub fn check_inputs_on_disk(&self, dir: &Path) -> Result<(), CheckpointError> {
        for input in &self.inputs {
            let now = InputFile::stat(&input.path).map_err(|e| CheckpointError::Mismatch {
                dir: dir.to_path_buf(),
                what: format!("input {}", input.path.display()),
                saved: format!("{} bytes", input.size),
                now: e.to_string(),
            })?;
            if now.size != input.size {
                return Err(CheckpointError::Mismatch {
                    dir: dir.to_path_buf(),
                    what: format!("input {}", input.path.display()),
                    saved: format!("{} bytes", input.size),
                    now: format!("{} bytes", now.size),
                });
            }
        }
        Ok(())
    }

    /// Check that this run (`self`) is the run `saved` in the checkpoint at `dir`; the first
    /// difference is the error. Modification times are not compared (the frames' fingerprint
    /// decides whether the content changed).
    pub fn check_same(&self, saved: &RunIdentity, dir: &Path) -> Result<(), CheckpointError> {
        let mismatch = |what: &str, saved: String, now: String| {
            Err(CheckpointError::Mismatch {
                dir: dir.to_path_buf(),
                what: what.to_string(),
                saved,
                now,
            })
        };
        let a = options_to_settings(&saved.options);
        let b = options_to_settings(&self.options);
        for ((k, va), (_, vb)) in a.iter().zip(&b) {
            if va != vb {
                return mismatch(&format!("option {k}"), va.clone(), vb.clone());
            }
        }
        let paths = |r: &RunIdentity| {
            r.inputs
                .iter()
                .map(|i| i.path.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        };
        if saved.inputs.len() != self.inputs.len()
            || saved
                .inputs
                .iter()
                .zip(&self.inputs)
                .any(|(x, y)| x.path != y.path)
        {
            return mismatch("the input list", paths(saved), paths(self));
        }
        for (x, y) in saved.inputs.iter().zip(&self.inputs) {
            if x.size != y.size {
                return mismatch(
                    &format!("input {}", x.path.display()),
                    format!("{} bytes", x.size),
                    format!("{} bytes", y.size),
                );
            }
        }
        let count = |n: Option<usize>| n.map_or("(streamed, not known)".into(), |n| n.to_string());
        if saved.frames != self.frames {
            return mismatch(
                "the number of frames",
                count(saved.frames),
                count(self.frames),
            );
        }
        if saved.frames_hash != self.frames_hash {
            let hash = |h: Option<u64>| {
                h.map_or("(not known)".into(), |h| format!("fingerprint {h:016x}"))
            };
            return mismatch(
                "the frames' content",
                hash(saved.frames_hash),
                hash(self.frames_hash),
            );
        }
        let mut keys: Vec<&str> = saved
            .settings
            .iter()
            .chain(&self.settings)
            .map(|(k, _)| k.as_str())
            .collect();
        keys.sort();
        keys.dedup();
        for k in keys {
            let (x, y) = (saved.setting(k), self.setting(k));
            if x != y {
                let show =
                    |v: Option<&str>| v.map_or("(not set)".to_string(), |v| format!("{v:?}"));
                return mismatch(&format!("setting {k}"), show(x), show(y));
            }
        }
        Ok(())
    }
}

/// A 64-bit fingerprint of frames as the mapper sees them: the count, then each frame's
/// [`frame_digest`]. Equal frames give equal fingerprints on every machine.
pub fn frames_fingerprint(frames: &[Frame]) -> u64 {
    let mut h = Fnv::new();
    h.word(frames.len() as u32);
    for f in frames {
        h.wide(frame_digest(f));
    }
    h.0
}

/// The running fingerprint of frames fed one at a time ([`FramesFingerprint::add`]): of
/// every frame's [`frame_digest`], in order. Unlike [`frames_fingerprint`] it needs no count
/// up front, so a streamed run can record the fingerprint of the frames it has inserted, and
/// a resume can check the frames it skips.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FramesFingerprint(u64);

impl Default for FramesFingerprint {
    fn default() -> Self {
        FramesFingerprint(Fnv::new().0)
    }
}

impl FramesFingerprint {
    /// The fingerprint of no frames.
    pub fn new() -> Self {
        Self::default()
    }

    /// Continue from a value [`FramesFingerprint::value`] gave.
    pub fn from_value(v: u64) -> Self {
        FramesFingerprint(v)
    }

    /// Feed the next frame.
    pub fn add(&mut self, f: &Frame) {
        self.add_digest(frame_digest(f));
    }

    /// Feed the next frame by its [`frame_digest`], computed elsewhere (the pipelined run
    /// finds it on another thread while the previous frame goes into the tree).
    pub fn add_digest(&mut self, digest: u64) {
        let mut h = Fnv(self.0);
        h.wide(digest);
        self.0 = h.0;
    }

    /// The fingerprint of the frames fed so far.
    pub fn value(&self) -> u64 {
        self.0
    }
}

/// Independent FNV-1a chains a frame's points and pixels are spread over.
const DIGEST_LANES: usize = 8;

/// A 64-bit digest of one frame: its origin, every point and every camera pixel by their bit
/// patterns, and the camera. Point `k` goes into chain `k % 8` of eight FNV-1a chains (one
/// 64-bit word for x and y, one for z), and so do the pixels, so that neighbouring points'
/// multiplications do not wait for each other: a single chain over every 32-bit word cost
/// about a millisecond per 300 000-point depth image, serial between the pipelined frames.
pub fn frame_digest(f: &Frame) -> u64 {
    let mut h = Fnv::new();
    for c in f.origin.iter() {
        h.word(c.to_bits());
    }
    h.word(f.points.len() as u32);
    h.chains(&f.points, |l, p| {
        let xy = u64::from(p.x.to_bits()) | (u64::from(p.y.to_bits()) << 32);
        Fnv::mix(Fnv::mix(l, xy), u64::from(p.z.to_bits()))
    });
    match &f.camera {
        None => h.word(0),
        Some(cam) => {
            h.word(1);
            h.bytes(format!("{:?}", cam.camera).as_bytes());
            h.word(cam.pixels.len() as u32);
            h.chains(&cam.pixels, |l, &px| Fnv::mix(l, u64::from(px)));
        }
    }
    h.0
}

/// FNV-1a, 64-bit.
struct Fnv(u64);

impl Fnv {
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn word(&mut self, w: u32) {
        self.0 = Self::mix(self.0, u64::from(w));
    }
    /// One step over a 64-bit word.
    fn wide(&mut self, w: u64) {
        self.0 = Self::mix(self.0, w);
    }
    /// Item `k` of `items` into chain `k % 8` of [`DIGEST_LANES`] FNV-1a chains (`step` feeds
    /// one item to a chain's value), then each chain's value into this hash in turn.
    fn chains<T>(&mut self, items: &[T], step: impl Fn(u64, &T) -> u64) {
        let mut lanes = [Fnv::new().0; DIGEST_LANES];
        for group in items.chunks(DIGEST_LANES) {
            for (l, item) in lanes.iter_mut().zip(group) {
                *l = step(*l, item);
            }
        }
        lanes.iter().for_each(|&l| self.wide(l));
    }
    /// The FNV-1a step: xor, then multiply.
    #[inline(always)]
    fn mix(h: u64, w: u64) -> u64 {
        (h ^ w).wrapping_mul(Self::PRIME)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u64::from(x)).wrapping_mul(Self::PRIME);
        }
    }
}

/// A writer that counts and hashes what passes through.
struct HashingWriter<'a> {
    inner: &'a mut dyn Write,
    hash: Fnv,
    len: u64,
}

impl Write for HashingWriter<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.bytes(&buf[..n]);
        self.len += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

fn stats_fields(s: &MapStats) -> Vec<(&'static str, String)> {
    let t = &s.total;
    vec![
        ("frames", s.frames.to_string()),
        ("points", t.points.to_string()),
        ("non_finite", t.non_finite.to_string()),
        ("outside_map", t.outside_map.to_string()),
        ("zero", t.zero.to_string()),
        ("dropped_zero", t.dropped.zero.to_string()),
        ("dropped_min_range", t.dropped.min_range.to_string()),
        ("dropped_crop_sensor", t.dropped.crop_sensor.to_string()),
        ("dropped_crop_world", t.dropped.crop_world.to_string()),
        ("dropped_z_band", t.dropped.z_band.to_string()),
        ("dropped_ground", t.dropped.ground.to_string()),
        ("ground_clearing", t.clearing.to_string()),
        ("reduced", t.reduced.to_string()),
        ("rays", t.rays.to_string()),
        ("heads_skipped", t.heads_skipped.to_string()),
        ("free", t.free.to_string()),
        ("occupied", t.occupied.to_string()),
        ("seconds", format!("{:?}", t.seconds)),
        ("ray_seconds", format!("{:?}", t.ray_seconds)),
        ("tree_seconds", format!("{:?}", t.tree_seconds)),
    ]
}

fn set_stat(s: &mut MapStats, key: &str, v: &str) -> Result<bool, String> {
    let t: &mut FrameStats = &mut s.total;
    match key {
        "frames" => s.frames = parse_num(v)?,
        "points" => t.points = parse_num(v)?,
        "non_finite" => t.non_finite = parse_num(v)?,
        "outside_map" => t.outside_map = parse_num(v)?,
        "zero" => t.zero = parse_num(v)?,
        "dropped_zero" => t.dropped.zero = parse_num(v)?,
        "dropped_min_range" => t.dropped.min_range = parse_num(v)?,
        "dropped_crop_sensor" => t.dropped.crop_sensor = parse_num(v)?,
        "dropped_crop_world" => t.dropped.crop_world = parse_num(v)?,
        "dropped_z_band" => t.dropped.z_band = parse_num(v)?,
        "dropped_ground" => t.dropped.ground = parse_num(v)?,
        "ground_clearing" => t.clearing = parse_num(v)?,
        "reduced" => t.reduced = parse_num(v)?,
        "rays" => t.rays = parse_num(v)?,
        "heads_skipped" => t.heads_skipped = parse_num(v)?,
        "free" => t.free = parse_num(v)?,
        "occupied" => t.occupied = parse_num(v)?,
        "seconds" => t.seconds = parse_num(v)?,
        "ray_seconds" => t.ray_seconds = parse_num(v)?,
        "tree_seconds" => t.tree_seconds = parse_num(v)?,
        _ => return Ok(false),
    }
    Ok(true)
}

/// Escape a value for one manifest line.
fn escape(v: &str) -> String {
    v.replace('\\', "\\\\")
        .replace('\n', "\\n")
        .replace('\r', "\\r")
}

fn unescape(v: &str) -> String {
    let mut out = String::with_capacity(v.len());
    let mut it = v.chars();
    while let Some(c) = it.next() {
        if c == '\\' {
            match it.next() {
                Some('n') => out.push('\n'),
                Some('r') => out.push('\r'),
                Some(o) => out.push(o),
                None => out.push('\\'),
            }
        } else {
            out.push(c);
        }
    }
    out
}

/// A saved checkpoint: where the run stood.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    /// The checkpoint directory.
    pub dir: PathBuf,
    /// Frames of the run already in the tree: the run continues with frame `frames_done`.
    pub frames_done: usize,
    /// The run this checkpoint belongs to.
    pub identity: RunIdentity,
    /// The statistics up to `frames_done`.
    pub stats: MapStats,
    /// [`FramesFingerprint`] of the first `frames_done` frames: a resume checks the frames it
    /// skips against it.
    pub done_hash: u64,
    tree_file: String,
    tree_len: u64,
    tree_hash: u64,
}

impl Checkpoint {
    /// Whether `dir` holds a checkpoint manifest.
    pub fn exists(dir: &Path) -> bool {
        dir.join(MANIFEST).is_file()
    }

    /// Save `tree` with the run's position (`stats.frames` frames done) into `dir`, creating
    /// it if needed: the tree file first, then the manifest atomically, then the previous
    /// tree file is deleted. Stale temporaries of killed saves are removed.
    pub fn save(
        dir: &Path,
        tree: &OcTree,
        stats: &MapStats,
        done_hash: u64,
        identity: &RunIdentity,
    ) -> Result<(), CheckpointError> {
        let io = |source| CheckpointError::Io {
            dir: dir.to_path_buf(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(io)?;
        let _ = remove_stale_temporaries_in(dir, is_checkpoint_file);
        let tree_file = format!("tree-{:010}.ot", stats.frames);
        let (mut len, mut hash) = (0, 0);
        write_atomic(&dir.join(&tree_file), |w| {
            let mut hw = HashingWriter {
                inner: w,
                hash: Fnv::new(),
                len: 0,
            };
            write_ot(tree, &mut hw)?;
            len = hw.len;
            hash = hw.hash.0;
            Ok(())
        })?;
        let mut m = String::new();
        let mut line = |k: &str, v: &str| {
            m.push_str(k);
            m.push(' ');
            m.push_str(&escape(v));
            m.push('\n');
        };
        line("frames_done", &stats.frames.to_string());
        line("tree", &tree_file);
        line("tree_bytes", &len.to_string());
        line("tree_hash", &format!("{hash:016x}"));
        line("done_hash", &format!("{done_hash:016x}"));
        line(
            "frames",
            &identity.frames.map_or("-".into(), |n| n.to_string()),
        );
        line(
            "frames_hash",
            &identity
                .frames_hash
                .map_or("-".into(), |h| format!("{h:016x}")),
        );
        for (k, v) in options_to_settings(&identity.options) {
            line(&format!("option.{k}"), &v);
        }
        for i in &identity.inputs {
            let t = i.modified_ns.map_or("-".into(), |t| t.to_string());
            line(
                "input",
                &format!("{} {} {}", i.size, t, i.path.to_string_lossy()),
            );
        }
        for (k, v) in &identity.settings {
            line(&format!("setting.{k}"), v);
        }
        for (k, v) in stats_fields(stats) {
            line(&format!("stat.{k}"), &v);
        }
        m.push_str("end\n");
        write_atomic(&dir.join(MANIFEST), |w| {
            w.write_all(MAGIC.as_bytes())?;
            w.write_all(b"\n")?;
            w.write_all(m.as_bytes())
        })?;
        // the manifest now names the new tree: older tree files are garbage
        for e in std::fs::read_dir(dir).map_err(io)?.flatten() {
            let name = e.file_name();
            let name = name.to_string_lossy();
            if name != tree_file && is_tree_file(&name) {
                std::fs::remove_file(e.path()).map_err(io)?;
            }
        }
        Ok(())
    }

    /// Read the manifest in `dir` (not yet the tree: see [`Checkpoint::load_tree`]).
    pub fn load(dir: &Path) -> Result<Checkpoint, CheckpointError> {
        let path = dir.join(MANIFEST);
        let text = match std::fs::read_to_string(&path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(CheckpointError::Missing {
                    dir: dir.to_path_buf(),
                })
            }
            Err(source) => return Err(CheckpointError::Read { path, source }),
            Ok(t) => t,
        };
        let bad = |line: usize, message: String| CheckpointError::Manifest {
            path: path.clone(),
            line,
            message,
        };
        let mut lines = text.lines().enumerate();
        match lines.next() {
            Some((_, MAGIC)) => {}
            Some((_, other)) if other.starts_with(MAGIC_STEM) => {
                return Err(bad(
                    1,
                    format!(
                        "a checkpoint of another octoquant version ({other:?}; this one reads \
                         {MAGIC:?}): run again without resuming"
                    ),
                ))
            }
            _ => {
                return Err(bad(
                    1,
                    format!("not a checkpoint manifest (expected {MAGIC:?})"),
                ))
            }
        }
        let mut options = MapperOptions::default();
        let mut stats = MapStats::default();
        let mut inputs = Vec::new();
        let mut settings = Vec::new();
        let (mut frames_done, mut tree_file, mut tree_len, mut tree_hash) =
            (None, None, None, None);
        let (mut frames, mut frames_hash, mut done_hash) = (None, None, None);
        let mut ended = false;
        let hex = |v: &str| u64::from_str_radix(v, 16).map_err(|_| format!("{v:?} is not hex"));
        for (i, l) in lines {
            let n = i + 1;
            if l == "end" {
                ended = true;
                break;
            }
            let (k, v) = l
                .split_once(' ')
                .ok_or_else(|| bad(n, format!("{l:?} has no value")))?;
            let v = unescape(v);
            let r: Result<(), String> = (|| {
                match k {
                    "frames_done" => frames_done = Some(parse_num(&v)?),
                    "tree" if is_tree_file(&v) => tree_file = Some(v.clone()),
                    "tree" => return Err(format!("{v:?} is not a checkpoint tree file name")),
                    "tree_bytes" => tree_len = Some(parse_num(&v)?),
                    "tree_hash" => tree_hash = Some(hex(&v)?),
                    "frames" if v == "-" => frames = Some(None),
                    "frames" => frames = Some(Some(parse_num(&v)?)),
                    "frames_hash" if v == "-" => frames_hash = Some(None),
                    "frames_hash" => frames_hash = Some(Some(hex(&v)?)),
                    "done_hash" => done_hash = Some(hex(&v)?),
                    "input" => {
                        let mut it = v.splitn(3, ' ');
                        let (Some(size), Some(t), Some(p)) = (it.next(), it.next(), it.next())
                        else {
                            return Err("input needs size, time and path".into());
                        };
                        inputs.push(InputFile {
                            path: PathBuf::from(p),
                            size: parse_num(size)?,
                            modified_ns: if t == "-" { None } else { Some(parse_num(t)?) },
                        });
                    }
                    _ => {
                        if let Some(o) = k.strip_prefix("option.") {
                            if !set_option(&mut options, o, &v)? {
                                return Err(format!("unknown option {o:?}"));
                            }
                        } else if let Some(s) = k.strip_prefix("stat.") {
                            if !set_stat(&mut stats, s, &v)? {
                                return Err(format!("unknown statistic {s:?}"));
                            }
                        } else if let Some(s) = k.strip_prefix("setting.") {
                            settings.push((s.to_string(), v.clone()));
                        } else {
                            return Err(format!("unknown key {k:?}"));
                        }
                    }
                }
                Ok(())
            })();
            r.map_err(|m| bad(n, m))?;
        }
        let last = text.lines().count();
        if !ended {
            return Err(bad(
                last,
                "no 'end' line: the manifest is incomplete".into(),
            ));
        }
        let need = |what: &str| bad(last, format!("no '{what}' line"));
        let frames_done: usize = frames_done.ok_or_else(|| need("frames_done"))?;
        let frames: Option<usize> = frames.ok_or_else(|| need("frames"))?;
        if frames.is_some_and(|n| frames_done > n) || stats.frames != frames_done {
            return Err(bad(
                last,
                format!(
                    "{frames_done} frames done of {}, statistics count {}",
                    frames.map_or("a streamed run".into(), |n| n.to_string()),
                    stats.frames
                ),
            ));
        }
        Ok(Checkpoint {
            dir: dir.to_path_buf(),
            frames_done,
            identity: RunIdentity {
                options,
                inputs,
                frames,
                frames_hash: frames_hash.ok_or_else(|| need("frames_hash"))?,
                settings,
            },
            stats,
            done_hash: done_hash.ok_or_else(|| need("done_hash"))?,
            tree_file: tree_file.ok_or_else(|| need("tree"))?,
            tree_len: tree_len.ok_or_else(|| need("tree_bytes"))?,
            tree_hash: tree_hash.ok_or_else(|| need("tree_hash"))?,
        })
    }

    /// Read the checkpoint's tree, checked against the manifest's length and hash, with the
    /// exact resolution and sensor model of the checkpoint's options (the `.ot` header keeps
    /// only six digits of the resolution, and no sensor model).
    pub fn load_tree(&self) -> Result<OcTree, CheckpointError> {
        let path = self.dir.join(&self.tree_file);
        let data = std::fs::read(&path).map_err(|source| CheckpointError::Read {
            path: path.clone(),
            source,
        })?;
        let damaged = |message: String| CheckpointError::Tree {
            path: path.clone(),
            message,
        };
        let mut h = Fnv::new();
        h.bytes(&data);
        if data.len() as u64 != self.tree_len || h.0 != self.tree_hash {
            return Err(damaged(format!(
                "{} bytes with hash {:016x}, the manifest says {} bytes with hash {:016x}",
                data.len(),
                h.0,
                self.tree_len,
                self.tree_hash
            )));
        }
        let resolution = self.identity.options.resolution;
        let data = with_exact_resolution(&data, resolution)
            .ok_or_else(|| damaged("no 'res' line in the header".into()))?;
        let mut tree = read_ot(&data[..]).map_err(|e: OctreeError| damaged(e.to_string()))?;
        if tree.resolution().to_bits() != resolution.to_bits() {
            return Err(damaged(format!(
                "resolution {} instead of {resolution}",
                tree.resolution()
            )));
        }
        let params: OccupancyParams = self.identity.options.params;
        tree.set_params(params);
        Ok(tree)
    }
}

/// `data` (an `.ot` file) with its header's `res` line replaced by the exact `resolution`.
fn with_exact_resolution(data: &[u8], resolution: f64) -> Option<Vec<u8>> {
    let end = find(data, b"\ndata\n")?;
    let start = find(&data[..end], b"\nres ")? + 1;
    let line_end = start + data[start..].iter().position(|&b| b == b'\n')?;
    let mut out = Vec::with_capacity(data.len() + 32);
    out.extend_from_slice(&data[..start]);
    out.extend_from_slice(format!("res {resolution:?}").as_bytes());
    out.extend_from_slice(&data[line_end..]);
    Some(out)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// `tree-` + 10 digits + `.ot`.
fn is_tree_file(name: &str) -> bool {
    name.strip_prefix("tree-")
        .and_then(|r| r.strip_suffix(".ot"))
        .is_some_and(|d| d.len() == 10 && d.bytes().all(|b| b.is_ascii_digit()))
}

/// The files a checkpoint directory holds: the manifest and tree files.
fn is_checkpoint_file(name: &str) -> bool {
    name == MANIFEST || is_tree_file(name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapper_options::InsertMode;
    use nalgebra::Point3;

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oq-ckpt-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    fn frames() -> Vec<Frame> {
        (0..4)
            .map(|i| {
                Frame::new_f32(
                    Point3::new(0.0, 0.0, i as f32 * 0.1),
                    (0..50)
                        .map(|j| Point3::new(2.0 + j as f32 * 0.013, 1.0 - j as f32 * 0.07, 0.3))
                        .collect(),
                )
            })
            .collect()
    }

    #[test]
    fn save_load_and_refuse_other_runs() {
        let dir = scratch("roundtrip");
        let fr = frames();
        let options = MapperOptions {
            resolution: 0.123456789,
            ..MapperOptions::default()
        };
        let mut tree = OcTree::with_params(options.resolution, options.params).unwrap();
        for p in &fr[0].points {
            tree.update_point(
                &p.cast(),
                octoquant_octree::Update::Hit,
                octoquant_octree::InnerNodes::Refresh,
            )
            .unwrap();
        }
        let stats = MapStats {
            frames: 2,
            ..MapStats::default()
        };
        let id = RunIdentity::new(&options, Vec::new(), &fr).with_setting("output", "a b\nc.bt");
        Checkpoint::save(&dir, &tree, &stats, 7, &id).unwrap();
        // a second save replaces the first, leaving one tree file
        let stats3 = MapStats {
            frames: 3,
            ..MapStats::default()
        };
        Checkpoint::save(&dir, &tree, &stats3, 9, &id).unwrap();
        let names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 2, "{names:?}");
        let c = Checkpoint::load(&dir).unwrap();
        assert_eq!(c.frames_done, 3);
        assert_eq!(c.done_hash, 9);
        assert_eq!(c.identity, id);
        let back = c.load_tree().unwrap();
        assert_eq!(back.resolution(), 0.123456789);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        write_ot(&tree, &mut a).unwrap();
        write_ot(&back, &mut b).unwrap();
        assert_eq!(a, b);

        // other options, other frames, other settings: refused, naming the difference
        let mut other = id.clone();
        other.options.mode = InsertMode::Discretize;
        let e = other.check_same(&c.identity, &dir).unwrap_err().to_string();
        assert!(e.contains("option mode") && e.contains("discretize"), "{e}");
        let mut fr2 = fr.clone();
        fr2[3].points[7].x += 1e-6;
        let other =
            RunIdentity::new(&options, Vec::new(), &fr2).with_setting("output", "a b\nc.bt");
        let e = other.check_same(&c.identity, &dir).unwrap_err().to_string();
        assert!(e.contains("frames' content"), "{e}");
        let other = RunIdentity::new(&options, Vec::new(), &fr).with_setting("output", "x.bt");
        let e = other.check_same(&c.identity, &dir).unwrap_err().to_string();
        assert!(e.contains("setting output"), "{e}");
        id.check_same(&c.identity, &dir).unwrap();

        // a damaged tree file is detected
        let tree_path = dir.join("tree-0000000003.ot");
        let mut bytes = std::fs::read(&tree_path).unwrap();
        let last = bytes.len() - 1;
        bytes[last] ^= 1;
        std::fs::write(&tree_path, bytes).unwrap();
        let e = Checkpoint::load(&dir).unwrap().load_tree().unwrap_err();
        assert!(matches!(e, CheckpointError::Tree { .. }), "{e}");
        // a truncated manifest too
        let m = std::fs::read_to_string(dir.join(MANIFEST)).unwrap();
        std::fs::write(dir.join(MANIFEST), &m[..m.len() - 4]).unwrap();
        let e = Checkpoint::load(&dir).unwrap_err().to_string();
        assert!(e.contains("incomplete"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(matches!(
            Checkpoint::load(&dir),
            Err(CheckpointError::Missing { .. })
        ));
    }

    /// `frame_digest` written out from its definition, one point and one pixel at a time by
    /// index: FNV-1a over the origin, the count, eight chains (point `k` in chain `k % 8`:
    /// x and y as one 64-bit word, then z), the camera tag, the camera's text, the pixel
    /// count and eight chains of pixels.
    fn naive_digest(f: &Frame) -> u64 {
        const BASIS: u64 = 0xcbf2_9ce4_8422_2325;
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        let step = |h: u64, w: u64| (h ^ w).wrapping_mul(PRIME);
        let mut h = BASIS;
        for c in [f.origin.x, f.origin.y, f.origin.z] {
            h = step(h, c.to_bits() as u64);
        }
        h = step(h, f.points.len() as u64);
        let mut chains = [BASIS; 8];
        for (k, p) in f.points.iter().enumerate() {
            let xy = p.x.to_bits() as u64 + ((p.y.to_bits() as u64) << 32);
            chains[k % 8] = step(step(chains[k % 8], xy), p.z.to_bits() as u64);
        }
        for c in chains {
            h = step(h, c);
        }
        match &f.camera {
            None => step(h, 0),
            Some(cam) => {
                h = step(h, 1);
                for b in format!("{:?}", cam.camera).bytes() {
                    h = step(h, b as u64);
                }
                h = step(h, cam.pixels.len() as u64);
                let mut chains = [BASIS; 8];
                for (k, &px) in cam.pixels.iter().enumerate() {
                    chains[k % 8] = step(chains[k % 8], px as u64);
                }
                for c in chains {
                    h = step(h, c);
                }
                h
            }
        }
    }

    fn camera_frame(points: Vec<[f32; 3]>, pixels: Vec<u32>) -> Frame {
        let camera = octoquant_raycast::PinholeCamera {
            width: 64,
            height: 48,
            fx: 50.0,
            fy: 50.0,
            cx: 31.5,
            cy: 23.5,
            rotation: nalgebra::Rotation3::identity(),
        };
        Frame {
            origin: Point3::new(0.25, -1.5, 0.75),
            points: points.into_iter().map(Point3::from).collect(),
            camera: Some(crate::frame::CameraPixels { camera, pixels }),
            ..Frame::default()
        }
    }

    proptest::proptest! {
        /// The digest is its definition, for any number of points (chains partly filled
        /// included), with a camera and without.
        #[test]
        fn frame_digest_follows_its_definition(
            points in proptest::collection::vec(proptest::array::uniform3(-1e3f32..1e3), 0..40),
            with_camera: bool,
            seed: u32,
        ) {
            let pixels = (0..points.len() as u32).map(|k| k.wrapping_mul(seed) % 3072).collect();
            let mut f = camera_frame(points, pixels);
            if !with_camera {
                f.camera = None;
            }
            proptest::prop_assert_eq!(frame_digest(&f), naive_digest(&f));
        }
    }

    /// Any change a mapper would see changes the digest: one bit of any coordinate of any
    /// point, two points swapped (in one chain and across chains), a pixel, the origin, the
    /// camera; and the running fingerprint is the chain of the frames' digests.
    #[test]
    fn frame_digest_sees_every_change() {
        let points: Vec<[f32; 3]> = (0..21)
            .map(|k| [k as f32 * 0.5, 1.0 - k as f32, 2.0 + (k % 3) as f32])
            .collect();
        let f = camera_frame(points.clone(), (0..21).map(|k| 100 + 3 * k).collect());
        let d = frame_digest(&f);
        for k in 0..points.len() {
            for a in 0..3 {
                let mut g = f.clone();
                g.points[k][a] = f32::from_bits(g.points[k][a].to_bits() ^ 1);
                assert_ne!(frame_digest(&g), d, "point {k} axis {a}");
            }
        }
        for (i, j) in [(0, 8), (0, 1), (3, 20)] {
            let mut g = f.clone();
            g.points.swap(i, j);
            assert_ne!(frame_digest(&g), d, "points {i} and {j} swapped");
        }
        let mut g = f.clone();
        g.camera.as_mut().unwrap().pixels[7] += 1;
        assert_ne!(frame_digest(&g), d);
        let mut g = f.clone();
        g.origin.z += 1e-3;
        assert_ne!(frame_digest(&g), d);
        let mut g = f.clone();
        g.camera.as_mut().unwrap().camera.fx = 50.5;
        assert_ne!(frame_digest(&g), d);
        let mut g = f.clone();
        g.camera = None;
        assert_ne!(frame_digest(&g), d);

        let mut running = FramesFingerprint::new();
        running.add(&f);
        running.add(&g);
        let mut by_digest = FramesFingerprint::new();
        by_digest.add_digest(frame_digest(&f));
        by_digest.add_digest(frame_digest(&g));
        assert_eq!(running, by_digest);
        let mut swapped = FramesFingerprint::new();
        swapped.add(&g);
        swapped.add(&f);
        assert_ne!(running, swapped);
    }

    /// A manifest of another format version is refused with a message that says so.
    #[test]
    fn a_manifest_of_another_version_is_named_as_such() {
        let dir = scratch("version");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join(MANIFEST),
            "octoquant-checkpoint 2\nframes_done 3\n",
        )
        .unwrap();
        let err = Checkpoint::load(&dir).unwrap_err().to_string();
        assert!(err.contains("another octoquant version"), "{err}");
        assert!(err.contains("line 1"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
