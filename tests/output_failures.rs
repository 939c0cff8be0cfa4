//! Every failure explained, nothing lost: `octoquant map` into a missing or read-only
//! directory, onto its own input, onto a full disk; after a killed run. Each case: a clear
//! error (before reading the inputs where it can be known), the old output intact, no
//! temporary file left behind.

use crate::common::scratch;
use nalgebra::Point3;
use octoquant::Frame;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn octoquant() -> Command {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
}

/// A small input: a few frames of a wall.
fn write_input(path: &Path) {
    let frames: Vec<Frame> = (0..3)
        .map(|i| {
            Frame::new_f32(
                Point3::new(0.0, 0.0, 0.2 * i as f32),
                (0..400)
                    .map(|j| Point3::new(3.0, (j % 20) as f32 * 0.1, (j / 20) as f32 * 0.1))
                    .collect(),
            )
        })
        .collect();
    octoquant::formats::frames::write_frames_file(path, &frames).unwrap();
}

fn map(input: &Path, output: &Path) -> Output {
    octoquant()
        .arg("map")
        .arg(input)
        .args(["--format", "frames", "-o"])
        .arg(output)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Every file in `dir` whose name ends in `.tmp`.
fn temporaries(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(".tmp"))
        .collect()
}

/// The effective user is root (who writes into read-only directories regardless of mode).
fn is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Uid:"))
                .and_then(|l| l.split_whitespace().nth(1).map(|u| u == "0"))
        })
        .unwrap_or(false)
}

#[test]
fn missing_directory_is_an_error_before_reading_inputs() {
    let dir = scratch("fail-missing-dir");
    // the input does not exist either: the output's error must come first
    let out = map(&dir.join("absent.frames"), &dir.join("no/such/dir/map.bt"));
    let err = stderr(&out);
    assert!(!out.status.success());
    assert!(
        err.contains("no/such/dir") && err.contains("does not exist") && !err.contains("absent"),
        "{err}"
    );
    // a "directory" that is a file
    std::fs::write(dir.join("file"), b"x").unwrap();
    let out = map(&dir.join("absent.frames"), &dir.join("file/map.bt"));
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("not a directory"),
        "{err}"
    );
    // an unknown output format, also before reading
    let out = map(&dir.join("absent.frames"), &dir.join("map.png"));
    let err = stderr(&out);
    assert!(
        !out.status.success()
            && err.contains("unknown extension .png")
            && err.contains("the accepted extensions are .bt, .ot"),
        "{err}"
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
}

#[test]
fn output_equal_to_an_input_is_refused_and_the_input_kept() {
    let dir = scratch("fail-same-file");
    // a .frames file under a tree file's name, read with --format frames
    let input = dir.join("scan.bt");
    write_input(&input);
    let before = std::fs::read(&input).unwrap();
    let out = map(&input, &input);
    let err = stderr(&out);
    assert!(
        !out.status.success() && err.contains("also an input"),
        "{err}"
    );
    // the same file under another name (a hard link), and through `..`
    std::fs::hard_link(&input, dir.join("link.bt")).unwrap();
    let out = map(&input, &dir.join("link.bt"));
    assert!(!out.status.success() && stderr(&out).contains("also an input"));
    std::fs::create_dir(dir.join("sub")).unwrap();
    let out = map(&input, &dir.join("sub/../scan.bt"));
    assert!(!out.status.success() && stderr(&out).contains("also an input"));
    assert_eq!(std::fs::read(&input).unwrap(), before);
    // -o and --ot naming one file
    let out = octoquant()
        .arg("map")
        .arg(&input)
        .args(["--format", "frames", "-o"])
        .arg(dir.join("m.ot"))
        .arg("--ot")
        .arg(dir.join("sub/../m.ot"))
        .output()
        .unwrap();
    assert!(
        !out.status.success() && stderr(&out).contains("same file"),
        "{}",
        stderr(&out)
    );
    assert!(temporaries(&dir).is_empty());
}

/// Makes `dir` read-only for this process and runs `f`; returns how (for the message).
/// Not root: mode 0555. Root, who ignores modes: a read-only bind mount of `dir` in a private
/// mount namespace (`unshare -m`, the command runs inside it). Neither possible: `None`.
fn read_only_command(dir: &Path, cmd: &Command) -> Option<(Command, &'static str)> {
    let program = cmd.get_program().to_owned();
    let args: Vec<_> = cmd.get_args().map(|a| a.to_owned()).collect();
    if !is_root() {
        let mut p = std::fs::metadata(dir).unwrap().permissions();
        std::os::unix::fs::PermissionsExt::set_mode(&mut p, 0o555);
        std::fs::set_permissions(dir, p).unwrap();
        let mut c = Command::new(program);
        c.args(args);
        return Some((c, "mode 0555"));
    }
    // root: check that a read-only bind mount works here before relying on it
    let probe = Command::new("unshare")
        .args(["-m", "sh", "-c"])
        .arg(r#"mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && ! touch "$1/.probe" 2>/dev/null"#)
        .arg("sh")
        .arg(dir)
        .output();
    match probe {
        Ok(o) if o.status.success() => {
            let mut c = Command::new("unshare");
            c.args(["-m", "sh", "-c"])
                .arg(r#"mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && shift && exec "$@""#)
                .arg("sh")
                .arg(dir)
                .arg(program)
                .args(args);
            Some((c, "a read-only bind mount"))
        }
        _ => None,
    }
}

#[test]
fn read_only_directory_is_an_error_before_reading_inputs() {
    let dir = scratch("fail-read-only");
    let input = dir.join("in.frames");
    write_input(&input);
    let outdir = dir.join("out");
    std::fs::create_dir(&outdir).unwrap();
    let target = outdir.join("map.bt");
    std::fs::write(&target, b"old map").unwrap();
    let mut cmd = octoquant();
    // a missing input: the output's error must come first
    cmd.arg("map")
        .arg(dir.join("absent.frames"))
        .arg("-o")
        .arg(&target);
    let Some((mut cmd, how)) = read_only_command(&outdir, &cmd) else {
        // root without mount namespaces: the nearest failure that needs no privilege,
        // an output directory that cannot hold files because it is a file
        eprintln!("read-only directory not possible here: checking a file as directory");
        let out = map(&dir.join("absent.frames"), &input.join("map.bt"));
        assert!(!out.status.success() && stderr(&out).contains("not a directory"));
        return;
    };
    let out = cmd.output().unwrap();
    let err = stderr(&out);
    assert!(
        !out.status.success(),
        "wrote into a read-only directory ({how})"
    );
    assert!(
        err.contains("cannot create files in") && !err.contains("absent"),
        "({how}) {err}"
    );
    // with a good input: same error, the old file intact, nothing left behind
    let mut cmd = octoquant();
    cmd.arg("map").arg(&input).arg("-o").arg(&target);
    let (mut cmd, _) = read_only_command(&outdir, &cmd).unwrap();
    let out = cmd.output().unwrap();
    assert!(!out.status.success(), "({how}) {}", stderr(&out));
    let mut p = std::fs::metadata(&outdir).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut p, 0o755);
    std::fs::set_permissions(&outdir, p).unwrap();
    assert_eq!(std::fs::read(&target).unwrap(), b"old map");
    assert_eq!(std::fs::read_dir(&outdir).unwrap().count(), 1);
    eprintln!("read-only directory made with {how}");
}

#[test]
fn full_disk_is_an_error_with_the_old_file_intact() {
    let dir = scratch("fail-full-disk");
    let input = dir.join("in.frames");
    write_input(&input);
    // a device that is always full (through a link with a tree file's name): written in
    // place, not replaced, and its ENOSPC reported
    let full = Path::new("/dev/full");
    assert!(full.exists(), "/dev/full is missing");
    let link = dir.join("full.bt");
    std::os::unix::fs::symlink(full, &link).unwrap();
    let out = map(&input, &link);
    let err = stderr(&out);
    assert!(!out.status.success(), "writing /dev/full succeeded");
    assert!(
        err.contains("full.bt") && err.contains("No space left"),
        "{err}"
    );
    let meta = std::fs::metadata(&link).unwrap();
    assert!(!meta.is_file(), "/dev/full was replaced by a file");
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));

    // a regular file on a disk that fills up mid-write: the file size limit (which binds
    // root too) makes the write fail the way a full disk does, after the work
    let target = dir.join("map.bt");
    std::fs::write(&target, b"old map").unwrap();
    let out = Command::new("sh")
        .arg("-c")
        .arg(r#"trap '' XFSZ; ulimit -f 1 && exec "$@""#)
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(&input)
        // a fine map, so that the file is well past the limit (512 or 1024 bytes)
        .args(["--res", "0.02", "-o"])
        .arg(&target)
        .output()
        .unwrap();
    let err = stderr(&out);
    assert!(
        !out.status.success(),
        "a write past the size limit succeeded"
    );
    assert!(
        err.contains("cannot write") && err.contains("map.bt"),
        "{err}"
    );
    assert_eq!(std::fs::read(&target).unwrap(), b"old map");
    assert!(temporaries(&dir).is_empty(), "{:?}", temporaries(&dir));
}

/// The PID of a process that has ended.
fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

#[test]
fn temporaries_of_killed_runs_are_removed_by_the_next_run() {
    let dir = scratch("fail-stale-temporaries");
    let input = dir.join("in.frames");
    write_input(&input);
    // a run killed while writing leaves its temporary behind
    let stale = dir.join(format!(".map.bt.{}.tmp", dead_pid()));
    std::fs::write(&stale, b"half a map").unwrap();
    // not ours to remove: a live writer's (PID 1, running since boot), another target's,
    // a name outside the pattern
    let live = dir.join(".map.bt.1.tmp");
    let other = dir.join(format!(".other.bt.{}.tmp", dead_pid()));
    let lookalike = dir.join(".map.bt.12a.tmp");
    for p in [&live, &other, &lookalike] {
        std::fs::write(p, b"x").unwrap();
    }
    let out = map(&input, &dir.join("map.bt"));
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(!stale.exists(), "the stale temporary is still there");
    assert!(err.contains("removed") && err.contains(".map.bt."), "{err}");
    assert!(live.exists() && other.exists() && lookalike.exists());
    assert!(dir.join("map.bt").exists());
}
