//! Argument groups shared by several commands (flattened into their `Args` with
//! `#[command(flatten)]`), so that an option is spelled, defaulted and explained once, and
//! their resolution into the library's settings (`ReadOptions`, the tree's size and range).

use super::vocab::FormatArg;
use anyhow::{bail, Result};
use octoquant::formats::{read_frames, DecompressionLimit, ReadOptions};
use octoquant::Frame;
use std::path::PathBuf;

/// How sensor files are read: the options of every command that reads them (`map`, `bench`,
/// `reduce`).
#[derive(clap::Args, Clone)]
pub struct ReadArgs {
    /// Input format, instead of guessing from the file name.
    #[arg(long, value_enum, ignore_case = true)]
    format: Option<FormatArg>,
    /// For .graph input: points are already in world coordinates (graph2tree -g).
    #[arg(long)]
    global: bool,
    /// MCAP input: the PointCloud2 topic (default: the only one).
    #[arg(long)]
    topic: Option<String>,
    /// MCAP input: express clouds in this tf frame (default: the root of the tf tree).
    #[arg(long)]
    fixed_frame: Option<String>,
    /// Use only every N-th pixel of TUM depth images.
    #[arg(long, default_value_t = 1)]
    pixel_step: u32,
    /// Compressed input (.gz/.bz2, PCD binary_compressed, MCAP chunks, PNG) may expand to N
    /// times its size (and always to 64 MiB) before the read fails as a decompression bomb;
    /// 0: no limit.
    #[arg(long, default_value_t = 100, value_name = "N")]
    max_expansion: u64,
}

impl ReadArgs {
    /// The reader settings these arguments ask for.
    pub fn options(&self) -> ReadOptions {
        let mut read = ReadOptions {
            format: self.format.map(Into::into),
            ..ReadOptions::default()
        };
        read.graph.points_global = self.global;
        read.mcap.topic = self.topic.clone();
        read.mcap.fixed_frame = self.fixed_frame.clone();
        read.tum.pixel_step = self.pixel_step.max(1);
        read.decompression = match self.max_expansion {
            0 => DecompressionLimit::UNLIMITED,
            n => DecompressionLimit {
                max_ratio: n,
                ..DecompressionLimit::DEFAULT
            },
        };
        read
    }

    /// These options as `(key, value)` settings, for a checkpoint to record and a resume to
    /// take over ([`ReadArgs::from_settings`] reads them back).
    pub fn to_settings(&self) -> Vec<(String, String)> {
        let mut s = Vec::new();
        if let Some(f) = self.format {
            if let Some(v) = clap::ValueEnum::to_possible_value(&f) {
                s.push(("format".into(), v.get_name().to_string()));
            }
        }
        if self.global {
            s.push(("global".into(), "true".into()));
        }
        if let Some(t) = &self.topic {
            s.push(("topic".into(), t.clone()));
        }
        if let Some(f) = &self.fixed_frame {
            s.push(("fixed_frame".into(), f.clone()));
        }
        s.push(("pixel_step".into(), self.pixel_step.to_string()));
        s.push(("max_expansion".into(), self.max_expansion.to_string()));
        s
    }

    /// The options [`ReadArgs::to_settings`] recorded; `get` looks a key up.
    pub fn from_settings<'a>(get: impl Fn(&str) -> Option<&'a str>) -> Result<ReadArgs> {
        let format = match get("format") {
            None => None,
            Some(f) => Some(
                <FormatArg as clap::ValueEnum>::from_str(f, true)
                    .map_err(|_| anyhow::anyhow!("unknown input format {f:?}"))?,
            ),
        };
        let pixel_step = match get("pixel_step") {
            None => 1,
            Some(p) => p
                .parse()
                .map_err(|_| anyhow::anyhow!("pixel_step {p:?} is not a number"))?,
        };
        let max_expansion = match get("max_expansion") {
            None => DecompressionLimit::DEFAULT.max_ratio,
            Some(m) => m
                .parse()
                .map_err(|_| anyhow::anyhow!("max_expansion {m:?} is not a number"))?,
        };
        Ok(ReadArgs {
            format,
            global: get("global") == Some("true"),
            topic: get("topic").map(str::to_string),
            fixed_frame: get("fixed_frame").map(str::to_string),
            pixel_step,
            max_expansion,
        })
    }
}

/// Sensor files and how to read them: the inputs of `map` and `bench`.
#[derive(clap::Args)]
pub struct InputArgs {
    /// Input files (.graph, .frames, .txt/.dat/.log, .vtk or a VTK scan directory, .pcd, TUM
    /// association file or depth .png, .mcap, .ply; gzip/bzip2 are decompressed on the fly). `map`
    /// without any maps the built-in scene.
    pub inputs: Vec<PathBuf>,
    #[command(flatten)]
    pub read: ReadArgs,
}

impl InputArgs {
    /// Every input's frames, in the order given (none without inputs).
    pub fn read_frames(&self) -> Result<Vec<Frame>> {
        let read = self.read.options();
        let mut frames = Vec::new();
        for p in &self.inputs {
            frames.extend(read_frames(p, &read)?);
        }
        Ok(frames)
    }
}

/// The map's leaf size and the sensor's range: the options of every command that builds
/// maps (`map`, `bench`, `demo`).
#[derive(clap::Args)]
pub struct TreeArgs {
    /// Leaf size in metres (> 0).
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub res: f64,
    /// Maximum range in metres: farther readings only clear space (OctoMap's maxrange). Off
    /// by default, and 0 or less also means off (OctoMap's -1); `demo` defaults to its
    /// simulated sensors' range.
    #[arg(long, allow_negative_numbers = true)]
    pub max_range: Option<f64>,
}

impl TreeArgs {
    /// The maximum range, checked: `None` when off (absent, 0 or negative); an error for NaN.
    pub fn max_range(&self) -> Result<Option<f64>> {
        match self.max_range {
            Some(m) if m.is_nan() => bail!("--max-range is NaN"),
            Some(m) if m <= 0.0 => Ok(None),
            m => Ok(m),
        }
    }

    /// The resolution, checked: a positive finite number of metres.
    pub fn resolution(&self) -> Result<f64> {
        if !(self.res.is_finite() && self.res > 0.0) {
            bail!("--res {} is not a positive number of metres", self.res);
        }
        Ok(self.res)
    }
}
