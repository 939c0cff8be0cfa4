//! Argument groups shared by several commands (flattened into their `Args` with
//! `#[command(flatten)]`), so that an option is spelled, defaulted and explained once, and
//! their resolution into the library's settings (`ReadOptions`, the tree's size and range).

use super::vocab::{FormatArg, SensorModelArg, ViewpointArg};
use anyhow::{bail, Context, Result};
use octoquant::formats::{read_frames, CameraIntrinsics, DecompressionLimit, ReadOptions};
use octoquant::octree::{SensorPreset, SensorProbabilities};
use octoquant::{Frame, OccupancyParams};
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
    /// Use only every N-th pixel of TUM depth images (at least 1).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pixel_step: u32,
    /// TUM depth images: the camera intrinsics in pixels (default: TUM's recommended 525 525
    /// 319.5 239.5).
    #[arg(long, num_args = 4, value_names = ["FX", "FY", "CX", "CY"])]
    intrinsics: Option<Vec<f64>>,
    /// TUM depth images: raw depth units per metre (default 5000, TUM's convention).
    #[arg(long, value_name = "UNITS")]
    depth_scale: Option<f64>,
    /// VTK scan directories: the trajectory CSV, when it is not `trajectory.csv` (or the only
    /// `.csv`) in the directory or its parent.
    #[arg(long, value_name = "CSV", conflicts_with = "identity_poses")]
    trajectory: Option<PathBuf>,
    /// VTK scan directories: no trajectory, every scan at the origin with its points as
    /// stored (scans already in the world frame).
    #[arg(long)]
    identity_poses: bool,
    /// PCD input: how the VIEWPOINT is used: `origin` (the sensor origin only, PCL's meaning;
    /// the default), `apply` (also transform the points by it) or `ignore`.
    #[arg(long, value_enum, value_name = "USE")]
    pcd_viewpoint: Option<ViewpointArg>,
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
        if let Some([fx, fy, cx, cy]) = self.intrinsics.as_deref() {
            read.tum.intrinsics = CameraIntrinsics {
                fx: *fx,
                fy: *fy,
                cx: *cx,
                cy: *cy,
            };
        }
        if let Some(d) = self.depth_scale {
            read.tum.depth_scale = d;
        }
        read.trajectory = self.trajectory.clone();
        read.vtk_identity_poses = self.identity_poses;
        if let Some(v) = self.pcd_viewpoint {
            read.pcd.viewpoint = v.into();
        }
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
        // `{:?}` writes the shortest decimal that reads back to the same f64
        if let Some(i) = &self.intrinsics {
            let words: Vec<String> = i.iter().map(|x| format!("{x:?}")).collect();
            s.push(("intrinsics".into(), words.join(" ")));
        }
        if let Some(d) = self.depth_scale {
            s.push(("depth_scale".into(), format!("{d:?}")));
        }
        if let Some(t) = &self.trajectory {
            // absolute, so that a resume from another directory reads the same file
            let t = std::path::absolute(t).unwrap_or_else(|_| t.clone());
            s.push(("trajectory".into(), t.to_string_lossy().into_owned()));
        }
        if self.identity_poses {
            s.push(("identity_poses".into(), "true".into()));
        }
        if let Some(v) = self.pcd_viewpoint {
            if let Some(v) = clap::ValueEnum::to_possible_value(&v) {
                s.push(("pcd_viewpoint".into(), v.get_name().to_string()));
            }
        }
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
        let number = |k: &str, v: &str| -> Result<f64> {
            v.parse()
                .map_err(|_| anyhow::anyhow!("{k} {v:?} is not a number"))
        };
        let intrinsics = match get("intrinsics") {
            None => None,
            Some(v) => {
                let i = v
                    .split(' ')
                    .map(|w| number("intrinsics", w))
                    .collect::<Result<Vec<f64>>>()?;
                if i.len() != 4 {
                    bail!("intrinsics {v:?} are not four numbers");
                }
                Some(i)
            }
        };
        let pcd_viewpoint = match get("pcd_viewpoint") {
            None => None,
            Some(v) => Some(
                <ViewpointArg as clap::ValueEnum>::from_str(v, true)
                    .map_err(|_| anyhow::anyhow!("unknown PCD viewpoint use {v:?}"))?,
            ),
        };
        Ok(ReadArgs {
            format,
            global: get("global") == Some("true"),
            topic: get("topic").map(str::to_string),
            fixed_frame: get("fixed_frame").map(str::to_string),
            pixel_step,
            intrinsics,
            depth_scale: get("depth_scale")
                .map(|v| number("depth_scale", v))
                .transpose()?,
            trajectory: get("trajectory").map(PathBuf::from),
            identity_poses: get("identity_poses") == Some("true"),
            pcd_viewpoint,
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

/// All points of `path`, the frames merged in world coordinates.
pub fn read_points(
    path: &std::path::Path,
    read: &ReadOptions,
) -> Result<Vec<nalgebra::Point3<f32>>> {
    if read.format.is_none()
        && octoquant::formats::source::logical_extension(path).as_deref() == Some("ply")
    {
        return Ok(octoquant::formats::ply::read_ply_f32(path)?);
    }
    let frames = read_frames(path, read)?;
    let mut points = Vec::with_capacity(frames.iter().map(|f| f.points.len()).sum());
    for f in frames {
        points.extend(f.points);
    }
    Ok(points)
}

/// The sensor model: a named preset, optionally with its clamping or hit/miss probabilities
/// replaced (`map` and `bench`).
#[derive(clap::Args)]
pub struct SensorArgs {
    /// A named sensor model: `octomap` (OctoMap's defaults) or `kwon-yoon-2015` (the values
    /// printed by Kwon and Yoon's quantization paper: log-odds updates 0.2 / -0.1, clamping
    /// probabilities 0.1 / 0.9; see the docs of `SensorPreset`). --clamping and --sensor
    /// replace its parts.
    #[arg(long, value_enum, default_value = "octomap")]
    pub sensor_model: SensorModelArg,
    /// Clamping probabilities (OctoMap defaults 0.1192 0.971); PMIN must lie below the
    /// occupancy threshold 0.5 and PMAX at or above it, or no voxel could be free (occupied).
    #[arg(long, num_args = 2, value_names = ["PMIN", "PMAX"], allow_negative_numbers = true)]
    pub clamping: Option<Vec<f64>>,
    /// Sensor model, miss first as in graph2tree (defaults 0.4 0.7); PMISS must be below 0.5
    /// and PHIT at least 0.5.
    #[arg(long, num_args = 2, value_names = ["PMISS", "PHIT"], allow_negative_numbers = true)]
    pub sensor: Option<Vec<f64>>,
}

impl SensorArgs {
    /// The model's setter probabilities, checked (an error names the options).
    pub fn probabilities(&self) -> Result<SensorProbabilities> {
        let mut p = SensorPreset::from(self.sensor_model).probabilities();
        if let Some(v) = &self.clamping {
            (p.clamp_min, p.clamp_max) = (v[0], v[1]);
        }
        if let Some(v) = &self.sensor {
            (p.miss, p.hit) = (v[0], v[1]);
        }
        let params = p
            .params()
            .context("invalid --sensor-model/--clamping/--sensor")?;
        // The library takes any model OctoMap's setters take; a map built with one of these
        // would hold one class only, whatever the sensor saw, so the command line refuses them.
        // A voxel is occupied when its log-odds is >= the threshold: it can be free only when
        // the lower clamp lies below the threshold, occupied only when the upper one reaches it.
        if params.clamp_min >= params.occupancy_threshold {
            bail!(
                "--clamping {} {}: PMIN must lie below the occupancy threshold {}, or no voxel \
                 could ever be free",
                p.clamp_min,
                p.clamp_max,
                p.threshold
            );
        }
        if params.clamp_max < params.occupancy_threshold {
            bail!(
                "--clamping {} {}: PMAX must not lie below the occupancy threshold {}, or no \
                 voxel could ever be occupied",
                p.clamp_min,
                p.clamp_max,
                p.threshold
            );
        }
        // a miss of log-odds 0 leaves each voxel a ray crosses at the threshold: occupied
        if params.miss >= params.occupancy_threshold {
            bail!(
                "--sensor {} {}: PMISS must lie below the occupancy threshold {}, or every voxel \
                 a ray crosses would be marked occupied",
                p.miss,
                p.hit,
                p.threshold
            );
        }
        Ok(p)
    }

    /// The log-odds model, checked.
    pub fn params(&self) -> Result<OccupancyParams> {
        Ok(self.probabilities()?.params()?)
    }
}

/// The map's leaf size and the sensor's range: the options of every command that builds
/// maps (`map`, `bench`, `demo`).
#[derive(clap::Args)]
pub struct TreeArgs {
    /// Leaf size in metres (> 0).
    #[arg(long, default_value_t = 0.1, allow_negative_numbers = true)]
    pub res: f64,
    /// Maximum range in metres: farther readings only clear space (OctoMap's maxrange; with
    /// `map --color` octomap_server's sensor_model/max_range, which also clears the voxel where
    /// the ray is cut). Off by default, and 0 or less also means off (OctoMap's -1); `demo`
    /// defaults to its simulated sensors' range.
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

    /// The resolution, checked: a positive finite number of metres, at most [`MAX_RES`]
    /// (so that every voxel's coordinates are finite 32-bit floats, as the exports write them).
    pub fn resolution(&self) -> Result<f64> {
        if !(self.res.is_finite() && self.res > 0.0) {
            bail!("--res {} is not a positive number of metres", self.res);
        }
        if self.res > MAX_RES {
            bail!(
                "--res {} is too coarse: the map would span ±{:e} m, beyond what 32-bit \
                 coordinates hold (at most --res {MAX_RES:e})",
                self.res,
                self.res * 32768.0
            );
        }
        Ok(self.res)
    }
}

/// The coarsest `--res`: the map spans ±32768 leaves around the origin, and at this size its
/// farthest corner, 2^16 leaves from the origin counting its node's own size, is still a
/// finite `f32` (the type of frame points and of exported coordinates).
pub const MAX_RES: f64 = 1e33;

/// The most threads `--threads` starts: each insertion thread keeps its own key sets, emptied
/// and merged on every frame, so far more threads than cores only slow a run down (thousands
/// of them took minutes on a frame file a single thread maps in a quarter of a second).
pub const MAX_THREADS: u16 = 256;

/// `--threads N`: a count in `1..=MAX_THREADS`, with an error naming the option.
pub fn parse_threads(s: &str) -> Result<u16, String> {
    let n: u64 = s
        .parse()
        .map_err(|_| format!("{s:?} is not a whole number of threads"))?;
    if !(1..=u64::from(MAX_THREADS)).contains(&n) {
        return Err(format!("{n} threads: give 1 to {MAX_THREADS}"));
    }
    Ok(n as u16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        read: ReadArgs,
    }

    fn parse(args: &[&str]) -> ReadArgs {
        Cli::try_parse_from(std::iter::once("x").chain(args.iter().copied()))
            .unwrap_or_else(|e| panic!("{e}"))
            .read
    }

    /// Every reader option survives a checkpoint: the settings read back give the same
    /// `ReadOptions`, and each option changes them (so none is dropped on the way).
    #[test]
    fn settings_round_trip_every_reader_option() {
        let trajectory = std::env::temp_dir().join("poses.csv");
        let trajectory = trajectory.to_str().unwrap();
        let cases: Vec<Vec<&str>> = vec![
            vec![],
            vec!["--format", "pcd", "--pcd-viewpoint", "apply"],
            vec!["--pcd-viewpoint", "ignore"],
            vec!["--global", "--topic", "/points", "--fixed-frame", "map"],
            vec!["--pixel-step", "4", "--max-expansion", "0"],
            vec!["--intrinsics", "517.3", "516.5", "318.6", "255.3"],
            vec!["--depth-scale", "1000.000000000001"],
            vec!["--trajectory", trajectory],
            vec!["--identity-poses"],
        ];
        let default = parse(&[]).options();
        for args in &cases {
            let a = parse(args);
            let settings = a.to_settings();
            let back = ReadArgs::from_settings(|k| {
                settings
                    .iter()
                    .find(|(key, _)| key == k)
                    .map(|(_, v)| v.as_str())
            })
            .unwrap();
            assert_eq!(back.options(), a.options(), "{args:?}: {settings:?}");
            assert_eq!(args.is_empty(), a.options() == default, "{args:?}");
        }
        let a = parse(&["--intrinsics", "1", "2", "3", "4", "--depth-scale", "5"]);
        let tum = a.options().tum;
        assert_eq!(
            [
                tum.intrinsics.fx,
                tum.intrinsics.fy,
                tum.intrinsics.cx,
                tum.intrinsics.cy
            ],
            [1.0, 2.0, 3.0, 4.0]
        );
        assert_eq!(tum.depth_scale, 5.0);
        assert!(Cli::try_parse_from(["x", "--trajectory", "t.csv", "--identity-poses"]).is_err());
    }
}
