//! Long runs that survive being killed: `map --checkpoint DIR` / `map --resume DIR` and the
//! library's `Mapper::insert_run` / `Mapper::resume` end with the same `.bt`/`.ot` bytes as
//! an uninterrupted run, in every insertion mode, lazy or not, with one thread or several,
//! however often the run is killed (SIGKILL at seeded random moments).

use crate::common::{first_diff, scratch};
use octoquant::checkpoint::{Checkpoint, RunIdentity};
use octoquant::octree::io::{write_bt, write_ot};
use octoquant::pipeline::{CheckpointOptions, InsertMode, Mapper, MapperOptions};
use octoquant::scene::{
    scan_lidar, scan_terrestrial, ScanOptions, Scene, SpinningLidar, TerrestrialScanner,
};
use octoquant::Frame;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The built-in scene's frames (terrestrial scans and the lidar path), every `step`-th point.
fn scene_frames(step: usize) -> Vec<Frame> {
    let scene = Scene::builtin();
    let opts = ScanOptions::default();
    let (mut frames, _) =
        scan_terrestrial(&scene, &TerrestrialScanner::builtin(&scene), &opts).unwrap();
    frames.extend(
        scan_lidar(&scene, &SpinningLidar::builtin_path(), &opts)
            .unwrap()
            .0,
    );
    for f in &mut frames {
        f.points = f.points.iter().step_by(step).copied().collect();
        f.camera = None;
    }
    frames
}

const MODES: [InsertMode; 5] = [
    InsertMode::Exact,
    InsertMode::Discretize,
    InsertMode::Quantized,
    InsertMode::QuantizedBresenham,
    InsertMode::Simple,
];

fn files(tree: &mut octoquant::OcTree) -> (Vec<u8>, Vec<u8>) {
    let (mut ot, mut bt) = (Vec::new(), Vec::new());
    write_ot(tree, &mut ot).unwrap();
    write_bt(tree, &mut bt).unwrap();
    (ot, bt)
}

/// In the library: stop after a checkpoint at every possible interval position, resume from
/// the directory alone, and compare with the uninterrupted run, for every mode, lazy or not,
/// one thread or two.
#[test]
fn library_resume_is_byte_identical_in_every_mode() {
    let frames: Vec<Frame> = scene_frames(16).into_iter().step_by(3).collect();
    assert!(frames.len() >= 30, "{} frames", frames.len());
    let dir = scratch("checkpoint-library");
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            for mode in MODES {
                for lazy in [false, true] {
                    let options = MapperOptions {
                        resolution: 0.3,
                        mode,
                        lazy,
                        max_range: Some(30.0),
                        ..MapperOptions::default()
                    };
                    let what = format!("{} lazy={lazy} threads={threads}", mode.name());
                    let mut whole = Mapper::new(options.clone()).unwrap();
                    whole.insert_frames(&frames);
                    let expect = files(&mut whole.into_tree());

                    let identity = RunIdentity::new(&options, Vec::new(), &frames);
                    let ck = CheckpointOptions {
                        dir: dir.join(format!("{}-{lazy}-{threads}", mode.name())),
                        every: 7,
                    };
                    // the first part of the run, as a process killed after frame 2·7
                    let mut first = Mapper::new(options.clone()).unwrap();
                    first
                        .insert_run(&frames[..15], Some((&ck, &identity)), |_| {})
                        .unwrap();
                    drop(first);
                    let c = Checkpoint::load(&ck.dir).unwrap();
                    assert_eq!(c.frames_done, 15, "{what}: the end of a slice checkpoints");
                    let mut other = options.clone();
                    other.lazy = !lazy;
                    let e = Mapper::resume(&ck.dir, &RunIdentity::new(&other, Vec::new(), &frames))
                        .err()
                        .unwrap_or_else(|| panic!("{what}: resumed with other options"));
                    assert!(e.to_string().contains("option lazy"), "{e}");
                    let mut rest = Mapper::resume(&ck.dir, &identity).unwrap();
                    assert_eq!(rest.stats().frames, 15);
                    rest.insert_run(&frames, Some((&ck, &identity)), |_| {})
                        .unwrap();
                    assert_eq!(rest.stats().frames, frames.len());
                    let got = files(&mut rest.into_tree());
                    assert!(
                        got.0 == expect.0,
                        "{what}: .ot {}",
                        first_diff(&got.0, &expect.0)
                    );
                    assert!(
                        got.1 == expect.1,
                        "{what}: .bt {}",
                        first_diff(&got.1, &expect.1)
                    );
                    // and the final checkpoint alone gives the same files again
                    let c = Checkpoint::load(&ck.dir).unwrap();
                    assert_eq!(c.frames_done, frames.len());
                    let again = files(&mut Mapper::from_checkpoint(&c).unwrap().into_tree());
                    assert!(again == expect, "{what}: final checkpoint");
                }
            }
        });
    }
}

/// A small deterministic generator (xorshift64*), for the kill moments.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn octoquant() -> Command {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
}

fn run_ok(cmd: &mut Command, what: &str) {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Files whose name ends in `.tmp` in `dir`.
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect()
}

/// Waits until `ck` holds a checkpoint from the middle of a run of `total` frames (some but
/// not all frames done) or `child` has exited.
fn wait_for_mid_run_checkpoint(ck: &Path, total: usize, child: &mut std::process::Child) {
    loop {
        if let Ok(c) = Checkpoint::load(ck) {
            if c.frames_done > 0 && c.frames_done < total {
                return;
            }
        }
        if child.try_wait().unwrap().is_some() {
            return;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The CLI, killed with SIGKILL at seeded random moments, again and again, and resumed each
/// time with `map --resume DIR` alone: the final `.bt` and `.ot` equal an uninterrupted run's,
/// in every mode, lazy or not, one thread or two; no temporary file survives.
#[test]
fn killed_and_resumed_runs_end_byte_identical() {
    let dir = scratch("checkpoint-kill");
    let input = dir.join("scene.frames");
    let all = scene_frames(8);
    octoquant::formats::frames::write_frames_file(&input, &all).unwrap();
    let configs: [(&str, &[&str], &str); 6] = [
        ("exact", &[], "1"),
        ("discretize", &[], "2"),
        ("quantized", &["--lazy"], "2"),
        ("quantized+bresenham", &[], "1"),
        ("simple", &[], "2"),
        ("exact", &["--lazy", "--max-range", "20"], "2"),
    ];
    const KILLS_PER_CONFIG: usize = 4;
    let mut rng = Rng(0x5eed_0c70_0a4e_2201);
    let (mut kills, mut resumed_mid_run) = (0, 0);
    for (i, (mode, extra, threads)) in configs.iter().enumerate() {
        let what = format!("--mode {mode} {extra:?} with {threads} threads");
        let base = |out: &str| {
            let mut c = octoquant();
            c.arg("map")
                .arg(&input)
                .args(["--res", "0.3", "--mode", mode])
                .args(*extra)
                .arg("-o")
                .arg(dir.join(format!("{out}{i}.bt")))
                .arg("--ot")
                .arg(dir.join(format!("{out}{i}.ot")))
                .env("RAYON_NUM_THREADS", threads)
                .stdout(Stdio::null())
                .stderr(Stdio::piped());
            c
        };
        let t = Instant::now();
        run_ok(&mut base("ref"), &what);
        let uninterrupted = t.elapsed().as_secs_f64();

        let ck = dir.join(format!("ck{i}"));
        let start = || {
            let mut c = if Checkpoint::exists(&ck) {
                let mut c = octoquant();
                c.args(["map", "--resume"])
                    .arg(&ck)
                    .env("RAYON_NUM_THREADS", threads)
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped());
                c
            } else {
                let mut c = base("out");
                c.arg("--checkpoint").arg(&ck).args(["--every", "4"]);
                c
            };
            c.spawn().unwrap()
        };
        let mut killed_here = 0;
        let mut attempts = 0;
        while killed_here < KILLS_PER_CONFIG {
            attempts += 1;
            assert!(attempts < 50, "{what}: runs keep finishing before the kill");
            if let Ok(c) = Checkpoint::load(&ck) {
                // (the CLI streams its inputs: the checkpoint does not know the total)
                assert_eq!(c.identity.frames, None);
                if c.frames_done > 0 && c.frames_done < all.len() {
                    resumed_mid_run += 1;
                }
            }
            let mut child = start();
            if killed_here == 0 {
                // the first kill of each configuration lands just after a checkpoint from the
                // middle of the run is written (waiting for it, not guessing a delay), so every
                // configuration resumes from the middle however fast the machine is
                wait_for_mid_run_checkpoint(&ck, all.len(), &mut child);
            } else {
                // anywhere from the start-up to near the end of an uninterrupted run
                let delay = Duration::from_secs_f64((0.15 + 0.6 * rng.unit()) * uninterrupted);
                std::thread::sleep(delay);
            }
            if child.try_wait().unwrap().is_none() {
                child.kill().unwrap(); // SIGKILL
                child.wait().unwrap();
                kills += 1;
                killed_here += 1;
            } else {
                let out = child.wait_with_output().unwrap();
                assert!(
                    out.status.success(),
                    "{what}: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
                // it finished before the kill: start the run over to kill it more
                std::fs::remove_dir_all(&ck).unwrap();
            }
        }
        // the last resume runs to the end
        let out = start().wait_with_output().unwrap();
        assert!(
            out.status.success(),
            "{what}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        for ext in ["bt", "ot"] {
            let a = std::fs::read(dir.join(format!("ref{i}.{ext}"))).unwrap();
            let b = std::fs::read(dir.join(format!("out{i}.{ext}"))).unwrap();
            assert!(
                a == b,
                "{what}: .{ext} after {killed_here} kills: {}",
                first_diff(&b, &a)
            );
        }
        assert_eq!(temporaries(&dir), Vec::<PathBuf>::new(), "{what}");
        assert_eq!(temporaries(&ck), Vec::<PathBuf>::new(), "{what}");
        let names = std::fs::read_dir(&ck).unwrap().count();
        assert_eq!(
            names, 2,
            "{what}: the checkpoint holds its manifest and one tree"
        );
    }
    assert!(
        kills >= 20,
        "only {kills} kills landed on a running process"
    );
    assert!(
        resumed_mid_run >= configs.len(),
        "only {resumed_mid_run} resumes from the middle of a run"
    );
    eprintln!("{kills} kills, {resumed_mid_run} resumes from the middle of a run");
}

/// A resume refuses changed inputs and other options, before any work, and a new run
/// refuses to overwrite an existing checkpoint.
#[test]
fn resume_refuses_another_run() {
    let dir = scratch("checkpoint-refuse");
    let input = dir.join("scene.frames");
    let frames: Vec<Frame> = scene_frames(32).into_iter().take(6).collect();
    octoquant::formats::frames::write_frames_file(&input, &frames).unwrap();
    let ck = dir.join("ck");
    let map = |args: &[&str]| {
        octoquant()
            .arg("map")
            .arg(&input)
            .args(["--res", "0.5", "-o"])
            .arg(dir.join("m.bt"))
            .arg("--checkpoint")
            .arg(&ck)
            .args(args)
            .output()
            .unwrap()
    };
    let out = map(&[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // again with --checkpoint: refused, the checkpoint is kept
    let out = map(&[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--resume"), "{err}");
    // --resume with other options: refused by the command line
    let out = octoquant()
        .args(["map", "--res", "0.2", "--resume"])
        .arg(&ck)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot be used with"));
    // a changed input: refused, naming it
    let mut changed = frames.clone();
    changed[2].points.pop();
    octoquant::formats::frames::write_frames_file(&input, &changed).unwrap();
    let out = octoquant()
        .args(["map", "--resume"])
        .arg(&ck)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("scene.frames") && err.contains("differs"),
        "{err}"
    );
    // the same size, other content: refused by the frames' fingerprint
    let mut changed = frames.clone();
    changed[2].points[0].x += 0.5;
    octoquant::formats::frames::write_frames_file(&input, &changed).unwrap();
    let out = octoquant()
        .args(["map", "--resume"])
        .arg(&ck)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("frames' content"),
        "{err}"
    );
    // the original again: resumes (the run was complete: rewrites the output)
    octoquant::formats::frames::write_frames_file(&input, &frames).unwrap();
    std::fs::remove_file(dir.join("m.bt")).unwrap();
    let out = octoquant()
        .args(["map", "--resume"])
        .arg(&ck)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.join("m.bt").exists());
    // no checkpoint at all
    let out = octoquant()
        .args(["map", "--resume"])
        .arg(dir.join("nowhere"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no checkpoint here"),
        "{err}"
    );
}

/// With two threads the next frame's rays are cast while a frame goes into the tree, yet a
/// checkpoint saved after frame `i` (a checkpoint after every frame here) holds exactly the
/// frames up to `i`: its tree is, byte for byte, that of inserting them one by one, for
/// every `i`.
#[test]
fn every_checkpoint_of_a_pipelined_run_holds_exactly_its_frames() {
    let frames: Vec<Frame> = scene_frames(16).into_iter().step_by(5).take(12).collect();
    let options = MapperOptions {
        resolution: 0.3,
        max_range: Some(30.0),
        ..MapperOptions::default()
    };
    // only the .ot: writing a .bt turns the tree to maximum likelihood and prunes it
    let ot = |tree: &mut octoquant::OcTree| {
        let mut out = Vec::new();
        write_ot(tree, &mut out).unwrap();
        out
    };
    let mut prefix = Mapper::new(options.clone()).unwrap();
    let expect: Vec<Vec<u8>> = frames
        .iter()
        .map(|f| {
            prefix.insert(f);
            ot(prefix.tree_mut())
        })
        .collect();
    let dir = scratch("checkpoint-every-frame");
    let ck = CheckpointOptions {
        dir: dir.clone(),
        every: 1,
    };
    let identity = RunIdentity::new(&options, Vec::new(), &frames);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let mut seen = Vec::new();
    pool.install(|| {
        let mut m = Mapper::new(options.clone()).unwrap();
        m.insert_run(&frames, Some((&ck, &identity)), |done| {
            let c = Checkpoint::load(&dir).unwrap();
            assert_eq!(c.frames_done, done);
            let got = ot(&mut c.load_tree().unwrap());
            assert!(
                got == expect[done - 1],
                "checkpoint after frame {done}: {}",
                first_diff(&got, &expect[done - 1])
            );
            seen.push(done);
        })
        .unwrap();
    });
    assert_eq!(seen, (1..=frames.len()).collect::<Vec<_>>());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `Mapper::without_checkpoints` (what `map` without `--checkpoint`, `bench` and Python use)
/// digests no frame and changes nothing in the map: on real TUM depth frames, whose digest
/// covers points and pixels, its tree equals the default mapper's, with one thread and with
/// two (pipelined); saving a checkpoint from it, or asking a run for checkpoints, is refused
/// before anything is written or inserted.
#[test]
fn a_mapper_without_checkpoints_builds_the_same_tree_and_saves_none() {
    let Some(assoc) =
        crate::common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let mut frames =
        octoquant::formats::read_frames(&assoc, &octoquant::formats::ReadOptions::default())
            .unwrap();
    frames.truncate(3);
    assert!(frames.iter().all(|f| f.camera.is_some()), "depth images");
    let options = MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    };
    let ot = |m: &mut Mapper| {
        let mut out = Vec::new();
        write_ot(m.tree_mut(), &mut out).unwrap();
        out
    };
    let mut with = Mapper::new(options.clone()).unwrap();
    for f in &frames {
        with.insert(f);
    }
    let want = ot(&mut with);
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut m = Mapper::new(options.clone()).unwrap().without_checkpoints();
        pool.install(|| m.insert_frames(&frames));
        assert_eq!(m.stats().frames, 3);
        let got = ot(&mut m);
        assert!(
            got == want,
            "{threads} threads: {}",
            first_diff(&got, &want)
        );
    }
    let dir = scratch("checkpoint-untracked").join("ck");
    let mut m = Mapper::new(options.clone()).unwrap().without_checkpoints();
    m.insert(&frames[0]);
    let identity = RunIdentity::new(&options, Vec::new(), &frames);
    let e = m.save_checkpoint(&dir, &identity).unwrap_err();
    assert!(e.to_string().contains("no fingerprint"), "{e}");
    assert!(!dir.exists(), "nothing written");
    let ck = CheckpointOptions {
        dir: dir.clone(),
        every: 1,
    };
    let mut fresh = Mapper::new(options).unwrap().without_checkpoints();
    let e = fresh
        .insert_run(&frames, Some((&ck, &identity)), |_| {})
        .unwrap_err();
    assert!(e.to_string().contains("no fingerprint"), "{e}");
    assert_eq!(fresh.stats().frames, 0, "refused before inserting");
    assert!(!dir.exists(), "nothing written");
    // a run continued with fewer frames than are in the tree is still refused: without a
    // fingerprint the count is checked
    let mut three = Mapper::new(MapperOptions {
        resolution: 0.05,
        ..MapperOptions::default()
    })
    .unwrap()
    .without_checkpoints();
    three.insert_run(&frames, None, |_| {}).unwrap();
    let e = three.insert_run(&frames[..2], None, |_| {}).unwrap_err();
    assert!(e.to_string().contains("the number of frames"), "{e}");
    assert!(e.to_string().contains("no fingerprint kept"), "{e}");
    // with all of them it skips them and inserts nothing more
    three.insert_run(&frames, None, |_| {}).unwrap();
    assert_eq!(three.stats().frames, 3);
}
