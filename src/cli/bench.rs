//! `octoquant bench INPUT... --res R`: the insertion modes side by side on the same frames,
//! optionally against the C++ OctoMap reference program, as ratios.

use super::args::{InputArgs, SensorArgs, TreeArgs};
use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use octoquant::octree::io::write_bt;
use octoquant::octree::{SensorPreset, SensorProbabilities};
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::Frame;
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(clap::Args)]
pub struct Args {
    #[command(flatten)]
    tree: TreeArgs,
    #[command(flatten)]
    sensor: SensorArgs,
    /// Threads for the multi-threaded runs, 1 to 256 (default: all cores).
    #[arg(long, value_name = "N", value_parser = super::args::parse_threads)]
    threads: Option<u16>,
    /// The C++ reference program (tools/octoquant-ref) to time OctoMap on the same frames.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// A peer program timed on the same frames, as NAME=PROGRAM (repeatable), e.g.
    /// `bonxai=target/bonxai-peer/bonxai-peer` (tools/bonxai-peer): it is run as
    /// `PROGRAM RES FRAMES [MAX_RANGE]` and prints `frame I POINTS SECONDS` per frame and
    /// `memory BYTES`.
    #[arg(long, value_parser = parse_peer)]
    peer: Vec<(String, PathBuf)>,
    /// Use only the first N frames (at least 1).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    frames: Option<u64>,
    #[command(flatten)]
    input: InputArgs,
    /// Repeat every run (each mode, and OctoMap) this many times, interleaved, and take
    /// medians over all of them: single-frame inputs then still give a stable figure.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..))]
    repeat: u64,
    /// Print one JSON object.
    #[arg(long)]
    json: bool,
}

struct Run {
    mode: InsertMode,
    threads: usize,
    /// Frame times of every repetition.
    frame_ms: Vec<f64>,
    /// Per repetition: seconds spent casting rays and updating the tree.
    ray_s: Vec<f64>,
    tree_s: Vec<f64>,
    /// Points inserted over all repetitions.
    points: usize,
    /// Rays cast in one repetition, and those of depth images that skipped their heads.
    rays: usize,
    heads_skipped: usize,
    nodes: usize,
    bytes_per_node: f64,
    bt: Vec<u8>,
    /// The map of the first repetition, to compare classes with the exact mode's.
    tree: octoquant::octree::OcTree,
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        (s[n / 2 - 1] + s[n / 2]) / 2.0
    }
}

/// Time one mode on `pool`'s threads. The pools live for the whole `bench` run, as a
/// program's pool does: a pool built for every run made each two-thread run pay its new
/// threads' start (their first tasks, their first allocations), about 15 ms on 10 TUM frames
/// where the frames take 30, which no longer-lived program pays per run.
fn run_mode(frames: &[Frame], opts: &MapperOptions, pool: &rayon::ThreadPool) -> Result<Run> {
    let threads = pool.current_num_threads();
    let (mut mapper, frame_ms) = pool.install(|| -> Result<_> {
        // as `map` without --checkpoint: no frame fingerprints
        let mut mapper = Mapper::new(opts.clone())?.without_checkpoints();
        let mut ms = mapper
            .insert_frames(frames)
            .iter()
            .map(|st| st.seconds * 1e3)
            .collect::<Vec<_>>();
        if threads > 1 {
            // pipelined frames overlap: a frame's `seconds` is a share of a step, and frames
            // cast in pairs share unevenly (the last pair's step is only its tree updates), so
            // a median of shares is no frame's cost; each frame counts the run's mean
            let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
            ms.fill(mean);
        }
        mapper.finish();
        Ok((mapper, ms))
    })?;
    let st = *mapper.stats();
    let tree = mapper.tree_mut();
    tree.shrink_to_fit();
    let nodes = tree.size();
    let bytes_per_node = tree.memory_usage() as f64 / nodes.max(1) as f64;
    let mut bt = Vec::new();
    write_bt(tree, &mut bt)?;
    let tree = mapper.into_tree();
    Ok(Run {
        mode: opts.mode,
        threads,
        frame_ms,
        ray_s: vec![st.total.ray_seconds],
        tree_s: vec![st.total.tree_seconds],
        points: st.total.points,
        rays: st.total.rays,
        heads_skipped: st.total.heads_skipped,
        nodes,
        bytes_per_node,
        bt,
        tree,
    })
}

/// One OctoMap timing: frame times in ms and the `.bt` it wrote.
type RefRun = (Vec<f64>, Vec<u8>);

/// `NAME=PROGRAM` of `--peer`.
fn parse_peer(s: &str) -> Result<(String, PathBuf), String> {
    match s.split_once('=') {
        Some((name, prog)) if !name.is_empty() && !prog.is_empty() => {
            Ok((name.to_string(), PathBuf::from(prog)))
        }
        _ => Err(format!("expected NAME=PROGRAM, got {s:?}")),
    }
}

/// A peer's frame times (ms) over all repetitions and its last reported memory (bytes).
#[derive(Default)]
struct PeerRun {
    frame_ms: Vec<f64>,
    memory: Option<u64>,
}

/// Time a peer program on the frames file (see `--peer`).
fn run_peer(
    name: &str,
    prog: &Path,
    frames_file: &Path,
    opts: &MapperOptions,
    into: &mut PeerRun,
) -> Result<()> {
    let mut cmd = Command::new(prog);
    cmd.arg(format!("{:.17e}", opts.resolution))
        .arg(frames_file);
    if let Some(m) = opts.max_range {
        cmd.arg(format!("{m:.17e}"));
    }
    let out = cmd
        .output()
        .with_context(|| format!("cannot run peer {name} ({})", prog.display()))?;
    if !out.status.success() {
        bail!(
            "peer {name} ({}) failed: {}",
            prog.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let before = into.frame_ms.len();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["frame", _, _, secs] => into
                .frame_ms
                .extend(secs.parse::<f64>().ok().map(|s| s * 1e3)),
            ["memory", bytes] => into.memory = bytes.parse().ok(),
            _ => {}
        }
    }
    if into.frame_ms.len() == before {
        bail!("peer {name} ({}) printed no frame times", prog.display());
    }
    Ok(())
}

/// The bench's scratch directory, removed however the bench ends.
struct ScratchDir(PathBuf);

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

impl Run {
    /// Add the figures of a repetition of the same run.
    fn absorb(&mut self, again: Run) {
        self.frame_ms.extend(again.frame_ms);
        self.ray_s.extend(again.ray_s);
        self.tree_s.extend(again.tree_s);
        self.points += again.points;
    }
}

/// Time OctoMap's insertPointCloud per frame with the reference program, at the resolution
/// and maximum range of `opts`, with `discretize` when its mode is
/// [`InsertMode::Discretize`], and the sensor model `sensor` (given to OctoMap's setters as
/// the same probabilities, unless it is OctoMap's default); returns the frame times in ms and
/// the .bt it wrote.
fn run_reference(
    prog: &Path,
    frames_file: &Path,
    opts: &MapperOptions,
    sensor: &SensorProbabilities,
    dir: &Path,
) -> Result<(Vec<f64>, Vec<u8>)> {
    let discretize = opts.mode == InsertMode::Discretize;
    let bt = dir.join(if discretize { "ref_disc.bt" } else { "ref.bt" });
    let mut ins = format!("insert {}", frames_file.display());
    if let Some(m) = opts.max_range {
        ins.push_str(&format!(" maxrange {m:.17e}"));
    }
    if discretize {
        ins.push_str(" discretize");
    }
    let params = if *sensor == SensorPreset::OctoMap.probabilities() {
        String::new()
    } else {
        let p = sensor;
        format!(
            "params {:.17e} {:.17e} {:.17e} {:.17e} {:.17e}\n",
            p.hit, p.miss, p.clamp_min, p.clamp_max, p.threshold
        )
    };
    let script = format!(
        "tree {:.17e}\n{params}{ins}\nwrite_bt {}\n",
        opts.resolution,
        bt.display()
    );
    let sp = dir.join("bench_script.txt");
    std::fs::write(&sp, script)?;
    let out = Command::new(prog)
        .arg("script")
        .arg(&sp)
        .output()
        .with_context(|| format!("cannot run the reference program {}", prog.display()))?;
    if !out.status.success() {
        bail!(
            "the reference program {} failed: {}",
            prog.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let ms = String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            (w.next() == Some("frame")).then(|| w.nth(2)?.parse::<f64>().ok())?
        })
        .map(|s| s * 1e3)
        .collect();
    Ok((ms, std::fs::read(&bt)?))
}

/// Check, before any work, that `prog` can be run: a path to an executable file, or a bare
/// name found as one on `PATH`. The error names `what` and the program.
fn check_program(what: &str, prog: &Path) -> Result<()> {
    let runnable = |p: &Path| {
        std::fs::metadata(p).is_ok_and(|m| {
            #[cfg(unix)]
            {
                use std::os::unix::fs::PermissionsExt;
                m.is_file() && m.permissions().mode() & 0o111 != 0
            }
            #[cfg(not(unix))]
            {
                m.is_file()
            }
        })
    };
    let bare = prog.components().count() == 1 && !prog.as_os_str().is_empty();
    let found = if bare {
        std::env::var_os("PATH")
            .is_some_and(|path| std::env::split_paths(&path).any(|d| runnable(&d.join(prog))))
    } else {
        runnable(prog)
    };
    if !found {
        bail!(
            "cannot run {what} {}: {}",
            prog.display(),
            if bare {
                "no such program on PATH"
            } else if prog.exists() {
                "not an executable file"
            } else {
                "no such file"
            }
        );
    }
    Ok(())
}

pub fn run(a: &Args) -> Result<()> {
    if a.input.inputs.is_empty() {
        bail!("bench needs input files (see `octoquant bench --help`)");
    }
    if let Some(prog) = &a.reference {
        check_program("the reference program", prog)?;
    }
    for (name, prog) in &a.peer {
        check_program(&format!("peer {name}:"), prog)?;
    }
    let sensor = a.sensor.probabilities()?;
    let base = MapperOptions {
        resolution: a.tree.resolution()?,
        max_range: a.tree.max_range()?,
        params: sensor.params()?,
        ..MapperOptions::default()
    };
    let mut frames = a.input.read_frames()?;
    if let Some(n) = a.frames {
        frames.truncate(usize::try_from(n).unwrap_or(usize::MAX));
    }
    if frames.is_empty() {
        bail!("no frames to time: the inputs hold none");
    }
    let all = a.threads.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        usize::from,
    );
    let modes = [
        InsertMode::Exact,
        InsertMode::Quantized,
        InsertMode::QuantizedBresenham,
    ];
    let thread_counts = if all > 1 { vec![1, all] } else { vec![1] };
    let pools = thread_counts
        .iter()
        .map(|&n| rayon::ThreadPoolBuilder::new().num_threads(n).build())
        .collect::<Result<Vec<_>, _>>()?;
    // a pool's threads are slow on their first tasks (their start, first allocations and
    // wake-ups: about 15 ms on two threads), which the first repetition alone would pay and
    // which a program mapping a stream pays once; an untimed run of a few frames on each pool
    // takes it out of every timed run
    for pool in &pools {
        let warm = MapperOptions {
            mode: InsertMode::Exact,
            ..base.clone()
        };
        run_mode(&frames[..frames.len().min(3)], &warm, pool)?;
    }
    let mut runs: Vec<Run> = Vec::new();
    let mut reference: Option<(RefRun, RefRun)> = None;
    let mut peers: Vec<PeerRun> = a.peer.iter().map(|_| PeerRun::default()).collect();
    let scratch =
        ScratchDir(std::env::temp_dir().join(format!("octoquant-bench-{}", std::process::id())));
    let dir = &scratch.0;
    let ff = dir.join("frames.frames");
    if a.reference.is_some() || !a.peer.is_empty() {
        std::fs::create_dir_all(dir)?;
        octoquant::formats::frames::write_frames_file(&ff, &frames)?;
    }
    // repetitions interleave every mode and OctoMap, so a slow spell of a shared machine
    // hits all of them alike
    for rep in 0..a.repeat {
        let mut i = 0;
        for pool in &pools {
            for mode in modes {
                let opts = MapperOptions {
                    mode,
                    ..base.clone()
                };
                let run = run_mode(&frames, &opts, pool)?;
                if rep == 0 {
                    runs.push(run);
                } else {
                    runs[i].absorb(run);
                }
                i += 1;
            }
        }
        if let Some(prog) = &a.reference {
            let exact = run_reference(prog, &ff, &base, &sensor, dir)?;
            let discretize = MapperOptions {
                mode: InsertMode::Discretize,
                ..base.clone()
            };
            let disc = run_reference(prog, &ff, &discretize, &sensor, dir)?;
            match &mut reference {
                None => reference = Some((exact, disc)),
                Some(((e, _), (d, _))) => {
                    e.extend(exact.0);
                    d.extend(disc.0);
                }
            }
        }
        for ((name, prog), into) in a.peer.iter().zip(&mut peers) {
            run_peer(name, prog, &ff, &base, into)?;
        }
    }
    drop(scratch);
    let exact1 = median(&runs[0].frame_ms);
    let points: usize = frames.iter().map(|f| f.points.len()).sum();
    let mut rows = Vec::new();
    for r in &runs {
        let med = median(&r.frame_ms);
        let total_s: f64 = r.frame_ms.iter().sum::<f64>() / 1e3;
        let vs_octomap = reference.as_ref().map(|((e, ebt), (d, dbt))| {
            // exact and Bresenham against OctoMap's default insertion, quantized against
            // OctoMap's discretize; "same .bt" only means something for the exact modes
            let (ms, bt) = if r.mode == InsertMode::Quantized {
                (d, dbt)
            } else {
                (e, ebt)
            };
            (median(ms) / med, *bt == r.bt)
        });
        // share of voxels with the same class (unknown/free/occupied) as the exact map
        let exact = runs
            .iter()
            .find(|x| x.mode == InsertMode::Exact && x.threads == r.threads)
            .unwrap_or(&runs[0]);
        let classes = octoquant::octree::compare_classes(&exact.tree, &r.tree)?;
        // and with the quantized map: the same end points, DDA rays
        let quantized = runs
            .iter()
            .find(|x| x.mode == InsertMode::Quantized && x.threads == r.threads)
            .unwrap_or(&runs[0]);
        let vs_quantized = octoquant::octree::compare_classes(&quantized.tree, &r.tree)?;
        rows.push((r, med, total_s, vs_octomap, classes, vs_quantized));
    }
    // with threads, frames overlap: the whole run's time is the fair measure of its speed-up
    let one_thread_total = |mode: InsertMode| {
        rows.iter()
            .find(|(r, ..)| r.mode == mode && r.threads == 1)
            .map(|&(_, _, total_s, ..)| total_s)
    };
    let total_speedup = |r: &Run, total_s: f64| {
        (r.threads > 1)
            .then(|| one_thread_total(r.mode))
            .flatten()
            .map(|one| one / total_s.max(1e-12))
    };
    if a.json {
        use serde_json::{json, Value};
        let mut list = Vec::new();
        for (r, med, total_s, vs, classes, vs_q) in &rows {
            let c = &classes.counts;
            let mut run = json!({
                "mode": r.mode.name(),
                "threads": r.threads,
                "median_ms": med,
                "points_per_second": r.points as f64 / total_s.max(1e-12),
                "ray_seconds": median(&r.ray_s),
                "tree_seconds": median(&r.tree_s),
                "rays": r.rays,
                "heads_skipped": r.heads_skipped,
                "nodes": r.nodes,
                "bytes_per_node": r.bytes_per_node,
                "speedup_vs_exact": exact1 / med.max(1e-12),
                "class_agreement_with_exact": classes.agreement(),
                "class_agreement_with_quantized": vs_q.agreement(),
                "classes_vs_exact": c,
            });
            if let Some(x) = total_speedup(r, *total_s) {
                run["total_time_speedup_vs_one_thread"] = json!(x);
            }
            if let Some((ratio, same)) = vs {
                run["speedup_vs_octomap"] = json!(ratio);
                run["bt_identical_to_octomap"] = json!(same);
            }
            if !peers.is_empty() {
                let ratios: serde_json::Map<String, Value> = a
                    .peer
                    .iter()
                    .zip(&peers)
                    .map(|((name, _), p)| {
                        (name.clone(), json!(median(&p.frame_ms) / med.max(1e-12)))
                    })
                    .collect();
                run["speedup_vs_peers"] = Value::Object(ratios);
            }
            list.push(run);
        }
        let mut summary = json!({
            "frames": frames.len(),
            "repetitions": a.repeat,
            "points": points,
            "res": base.resolution,
            "max_range": base.max_range,
            "runs": list,
        });
        if let Some(((e, _), (d, _))) = &reference {
            summary["octomap_median_ms"] = json!(median(e));
            summary["octomap_discretize_median_ms"] = json!(median(d));
        }
        if !peers.is_empty() {
            let list: Vec<Value> = a
                .peer
                .iter()
                .zip(&peers)
                .map(|((name, prog), p)| {
                    json!({
                        "name": name,
                        "program": json_path(prog),
                        "median_ms": median(&p.frame_ms),
                        "memory_bytes": p.memory,
                    })
                })
                .collect();
            summary["peers"] = Value::Array(list);
        }
        print_json(&summary)?;
        return Ok(());
    }
    outln!(
        "{} frames, {} points, res {} m, max range {}, {} repetitions (medians over all)",
        frames.len(),
        points,
        base.resolution,
        base.max_range.map_or("off".into(), |m| format!("{m} m")),
        a.repeat
    )?;
    if let Some(((e, _), (d, _))) = &reference {
        outln!(
            "OctoMap 1.9.7 (reference program): insertPointCloud median {:.1} ms/frame, discretize {:.1} ms/frame",
            median(e),
            median(d)
        )?;
    }
    outln!(
        "{:<19} {:>7} {:>10} {:>12} {:>8} {:>8} {:>10} {:>7} {:>9} {:>10} {:>9} {:>8} {:>8}",
        "mode",
        "threads",
        "ms/frame",
        "points/s",
        "rays s",
        "tree s",
        "nodes",
        "B/node",
        "vs exact",
        "vs OctoMap",
        "same .bt",
        "agree %",
        "agree q%"
    )?;
    for (r, med, total_s, vs, classes, vs_q) in &rows {
        outln!(
            "{:<19} {:>7} {:>10.2} {:>12.0} {:>8.3} {:>8.3} {:>10} {:>7.2} {:>8.2}x {:>10} {:>9} {:>8.3} {:>8.3}",
            r.mode.name(),
            r.threads,
            med,
            r.points as f64 / total_s.max(1e-12),
            median(&r.ray_s),
            median(&r.tree_s),
            r.nodes,
            r.bytes_per_node,
            exact1 / med.max(1e-12),
            vs.map_or("-".into(), |(x, _)| format!("{x:.2}x")),
            vs.map_or("-".into(), |(_, s)| if s {
                "yes".into()
            } else {
                "NO".to_string()
            }),
            100.0 * classes.agreement(),
            100.0 * vs_q.agreement(),
        )?;
    }
    for ((name, _), p) in a.peer.iter().zip(&peers) {
        let peer_ms = median(&p.frame_ms);
        let ratios: Vec<String> = rows
            .iter()
            .map(|(r, med, ..)| {
                format!(
                    "{} {}t {:.2}x",
                    r.mode.name(),
                    r.threads,
                    peer_ms / med.max(1e-12)
                )
            })
            .collect();
        outln!(
            "peer {name}: median {peer_ms:.2} ms/frame, memory {}; speed-up against it: {}",
            p.memory
                .map_or("-".into(), |m| format!("{:.1} MB", m as f64 / 1e6)),
            ratios.join(", ")
        )?;
    }
    let threaded: Vec<String> = rows
        .iter()
        .filter_map(|&(r, _, total_s, ..)| {
            total_speedup(r, total_s).map(|x| format!("{} {}t {x:.2}x", r.mode.name(), r.threads))
        })
        .collect();
    if !threaded.is_empty() {
        outln!(
            "threads against one thread, by the whole run's time (frames overlap, so this, not the median frame, is the speed-up): {}",
            threaded.join(", ")
        )?;
    }
    outln!("ms/frame: with 1 thread the median frame; with more, frames overlap, so the run's time per frame (median over repetitions)")?;
    outln!("agree %: share of voxels known to either map with the same class (free/occupied/unknown) as the exact map; agree q%: the same against the quantized map (same end points, DDA rays)")?;
    // depth images: how many exact rays were walked only where their neighbours do not cover
    if let Some(r) = runs
        .iter()
        .find(|r| r.mode == InsertMode::Exact && r.heads_skipped > 0)
    {
        outln!(
            "exact: {} of the {} rays skipped their heads (depth images: covered by neighbouring pixels' rays)",
            r.heads_skipped,
            r.rays
        )?;
    }
    // where the Bresenham map's classes differ from the exact one's
    let bresenham = InsertMode::QuantizedBresenham;
    if let Some((r, _, _, _, c, _)) = rows.iter().find(|row| row.0.mode == bresenham) {
        use octoquant::octree::VoxelClass::{Free, Occupied, Unknown};
        outln!(
            "{} vs exact ({} thread): voxels free in exact but unknown {} / occupied {}; occupied in exact but unknown {} / free {}; unknown in exact but free {} / occupied {}",
            bresenham.name(),
            r.threads,
            c.count(Free, Unknown),
            c.count(Free, Occupied),
            c.count(Occupied, Unknown),
            c.count(Occupied, Free),
            c.count(Unknown, Free),
            c.count(Unknown, Occupied),
        )?;
    }
    Ok(())
}
