//! Atomic file output: write to a temporary file beside the target, then rename.
//!
//! A failed or interrupted write never leaves a half-written file under the target name, and
//! never damages the file already there. The temporary is named `.NAME.PID.tmp` (NAME the
//! target's file name, PID the writing process); a failed write removes it, and the
//! temporaries a killed process leaves behind are recognised and removed by the next write of
//! the same target ([`remove_stale_temporaries`]). [`check_writable`] and [`check_not_input`]
//! find the failures that can be known before any work is done.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// Errors from writing an output file, naming the file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Creating, writing, syncing or renaming failed, or a check before the work found that it
    /// would.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The target file.
        path: PathBuf,
        /// What failed.
        #[source]
        source: std::io::Error,
    },
}

fn io_err(path: &Path, source: std::io::Error) -> OutputError {
    OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The directory a target lives in (`.` for a bare file name).
fn target_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn target_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into())
}

/// The temporary file name [`write_atomic`] uses for target file name `name` in process `pid`.
pub fn temporary_name(name: &str, pid: u32) -> String {
    format!(".{name}.{pid}.tmp")
}

/// If `file_name` is a temporary of [`write_atomic`] (`.NAME.PID.tmp`, PID all digits), its
/// target name and writer's PID.
pub fn parse_temporary_name(file_name: &str) -> Option<(&str, u32)> {
    let rest = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (name, pid) = rest.rsplit_once('.')?;
    if name.is_empty() || pid.is_empty() || !pid.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((name, pid.parse().ok()?))
}

/// Whether a non-regular target (a device such as `/dev/null` or `/dev/full`, a FIFO) must be
/// written in place: renaming a file over it would replace the device itself.
fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Write `path` atomically: `fill` writes into a temporary file in the same directory, which is
/// flushed, synced and renamed over `path` only if `fill` succeeded; the directory is then
/// synced so that the rename itself survives a crash. On any failure the temporary is removed
/// and the old `path` is left as it was. Stale temporaries of `path` left by killed processes
/// are removed first. A target that exists and is not a regular file (`/dev/null`, a FIFO) is
/// written in place instead, since renaming over it would replace the device.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    if is_special(path) {
        let result = (|| {
            let file = std::fs::OpenOptions::new().write(true).open(path)?;
            let mut w = std::io::BufWriter::new(file);
            fill(&mut w)?;
            w.flush()
        })();
        return result.map_err(|e| io_err(path, e));
    }
    let dir = target_dir(path);
    let name = target_name(path);
    let _ = remove_stale_temporaries(path);
    let tmp = dir.join(temporary_name(&name, std::process::id()));
    let result = (|| {
        let file = std::fs::File::create(&tmp)?;
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(io_err(path, e));
    }
    // the rename is durable once the directory is; some file systems cannot sync a directory
    if let Ok(d) = std::fs::File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Check, before any work, that [`write_atomic`] can write `path`: its directory exists and
/// is a directory, `path` is not a directory, and a file can be created in the directory (a
/// probe file under the temporary's name is created and removed at once, which catches
/// read-only directories and file systems whatever the permissions say). Existing devices and
/// FIFOs are accepted as they are written in place. Errors name the file and what is wrong.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    use std::io::{Error, ErrorKind};
    let dir = target_dir(path);
    match std::fs::metadata(&dir) {
        Err(e) if e.kind() == ErrorKind::NotFound => {
            return Err(io_err(
                path,
                Error::new(
                    ErrorKind::NotFound,
                    format!("directory {} does not exist: {e}", dir.display()),
                ),
            ))
        }
        Err(e) => return Err(io_err(path, e)),
        Ok(m) if !m.is_dir() => {
            return Err(io_err(
                path,
                Error::new(
                    ErrorKind::NotADirectory,
                    format!("{} is not a directory", dir.display()),
                ),
            ))
        }
        Ok(_) => {}
    }
    if path.file_name().is_none() || path.is_dir() {
        return Err(io_err(
            path,
            Error::new(
                ErrorKind::IsADirectory,
                "it is a directory, not a file name",
            ),
        ));
    }
    if is_special(path) {
        return Ok(());
    }
    let probe = dir.join(temporary_name(&target_name(path), std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) if e.kind() == ErrorKind::AlreadyExists => Ok(()),
        Err(e) => Err(io_err(
            path,
            Error::new(
                e.kind(),
                format!("cannot create files in {}: {e}", dir.display()),
            ),
        )),
    }
}

/// Check that `path`'s extension is one of `accepted` (lowercase, without the dot, compared
/// ignoring case); the error names the file and lists the accepted extensions.
pub fn check_extension(path: &Path, accepted: &[&str]) -> Result<(), OutputError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if ext
        .as_deref()
        .is_some_and(|e| accepted.iter().any(|a| a.eq_ignore_ascii_case(e)))
    {
        return Ok(());
    }
    let list: Vec<String> = accepted.iter().map(|a| format!(".{a}")).collect();
    let what = match &ext {
        Some(e) => format!("unknown extension .{e}"),
        None => "no extension".to_string(),
    };
    Err(io_err(
        path,
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{what}: the accepted extensions are {}", list.join(", ")),
        ),
    ))
}

/// Check an output name before any work: its extension is one of `accepted` (lowercase,
/// without the dot, compared ignoring case; an error lists them, so that a file is never
/// written under a name that mislabels its contents), [`check_writable`] passes and it is none
/// of `inputs` ([`check_not_input`]). Every command that writes a file calls this first.
pub fn check_output(path: &Path, accepted: &[&str], inputs: &[PathBuf]) -> Result<(), OutputError> {
    check_extension(path, accepted)?;
    check_writable(path)?;
    check_not_input(path, inputs)
}

/// Check that the output `path` is none of `inputs` (the same file by device and inode, or
/// by absolute path when it does not exist yet), so that a run never overwrites what it reads.
pub fn check_not_input(path: &Path, inputs: &[PathBuf]) -> Result<(), OutputError> {
    for input in inputs {
        if same_file(path, input) {
            return Err(io_err(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("it is also an input ({})", input.display()),
                ),
            ));
        }
    }
    Ok(())
}

/// Whether `a` and `b` name the same file: the same device and inode when both exist, else
/// the same absolute path with the directory resolved.
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    let resolve = |p: &Path| -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let dir = target_dir(p).canonicalize().ok()?;
        Some(dir.join(p.file_name()?))
    };
    match (resolve(a), resolve(b)) {
        (Some(x), Some(y)) => x == y,
        _ => false,
    }
}

/// Remove the temporaries of `path` (exactly `.NAME.PID.tmp` for its file name NAME) that a
/// killed process left behind: those whose process is gone, or whose PID now belongs to a
/// process started after the temporary was last written. Temporaries of live writers are
/// kept. Returns the files removed. Where the process table cannot be read (no `/proc`),
/// nothing is removed.
pub fn remove_stale_temporaries(path: &Path) -> std::io::Result<Vec<PathBuf>> {
    let name = target_name(path);
    remove_stale_temporaries_in(&target_dir(path), |n| n == name)
}

/// [`remove_stale_temporaries`] for every target in `dir` whose name `wanted` accepts.
pub fn remove_stale_temporaries_in(
    dir: &Path,
    wanted: impl Fn(&str) -> bool,
) -> std::io::Result<Vec<PathBuf>> {
    let mut removed = Vec::new();
    if !Path::new("/proc/self/stat").exists() {
        return Ok(removed);
    }
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let file_name = entry.file_name();
        let Some(file_name) = file_name.to_str() else {
            continue;
        };
        let Some((target, pid)) = parse_temporary_name(file_name) else {
            continue;
        };
        if !wanted(target) {
            continue;
        }
        let Ok(meta) = entry.metadata() else { continue };
        if !meta.is_file() {
            continue;
        }
        let modified = meta.modified().unwrap_or(SystemTime::UNIX_EPOCH);
        if writer_gone(pid, modified) && std::fs::remove_file(entry.path()).is_ok() {
            removed.push(entry.path());
        }
    }
    removed.sort();
    Ok(removed)
}

/// Whether the process `pid` that wrote a temporary last modified at `modified` is gone: no
/// such process, or the process with that PID started after the modification (the PID was
/// reused, e.g. by this very run).
fn writer_gone(pid: u32, modified: SystemTime) -> bool {
    match process_start(pid) {
        None => !Path::new(&format!("/proc/{pid}")).exists(),
        // a margin for the clock tick granularity of the start time
        Some(start) => modified + Duration::from_secs(1) < start,
    }
}

/// When process `pid` started, from `/proc/PID/stat` (field 22, in clock ticks since boot)
/// and the boot time in `/proc/stat`.
fn process_start(pid: u32) -> Option<SystemTime> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // the command name (field 2) is in parentheses and may hold spaces and parentheses
    let after = &stat[stat.rfind(')')? + 1..];
    let ticks: u64 = after.split_whitespace().nth(19)?.parse().ok()?;
    let boot: u64 = std::fs::read_to_string("/proc/stat")
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("btime "))?
        .trim()
        .parse()
        .ok()?;
    // USER_HZ is 100 on every Linux architecture in use
    Some(SystemTime::UNIX_EPOCH + Duration::from_secs(boot) + Duration::from_millis(ticks * 10))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("oq-out-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = scratch("fail");
        let target = dir.join("x.bt");
        std::fs::write(&target, b"old").unwrap();
        let r = write_atomic(&target, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "temp file left behind"
        );
        write_atomic(&target, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporary_names_round_trip() {
        assert_eq!(temporary_name("map.bt", 42), ".map.bt.42.tmp");
        assert_eq!(parse_temporary_name(".map.bt.42.tmp"), Some(("map.bt", 42)));
        assert_eq!(parse_temporary_name(".a.b.c.7.tmp"), Some(("a.b.c", 7)));
        for not in [
            "map.bt.42.tmp",
            ".map.bt.42x.tmp",
            ".map.bt..tmp",
            "..42.tmp",
            ".map.bt.42.tmp~",
            ".map.bt.99999999999999999999.tmp",
        ] {
            assert_eq!(parse_temporary_name(not), None, "{not}");
        }
    }

    /// The PID of a process that has certainly ended: a child that was waited for (its PID
    /// may be reused, in which case the reusing process started after the temporary was
    /// written, which also makes it stale).
    fn dead_pid() -> u32 {
        let mut c = std::process::Command::new("true").spawn().unwrap();
        let pid = c.id();
        c.wait().unwrap();
        pid
    }

    #[test]
    fn stale_temporaries_of_dead_writers_are_removed_and_live_ones_kept() {
        if !Path::new("/proc/self/stat").exists() {
            eprintln!("no /proc: stale temporaries are kept, nothing to test");
            return;
        }
        let dir = scratch("stale");
        let target = dir.join("map.bt");
        let dead = dir.join(temporary_name("map.bt", dead_pid()));
        // written long ago by a PID that is alive now (this process): the PID was reused
        let reused = dir.join(temporary_name("map.bt", std::process::id()));
        // a live writer: PID 1 has been running since boot, the file is new
        let live = dir.join(temporary_name("map.bt", 1));
        let other = dir.join(temporary_name("other.bt", dead_pid()));
        let lookalike = dir.join(".map.bt.12x.tmp");
        for p in [&dead, &reused, &live, &other, &lookalike] {
            std::fs::write(p, b"partial").unwrap();
        }
        let f = std::fs::File::options().write(true).open(&reused).unwrap();
        f.set_modified(SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000))
            .unwrap();
        drop(f);
        let removed = remove_stale_temporaries(&target).unwrap();
        let mut expect = vec![dead.clone(), reused.clone()];
        expect.sort();
        assert_eq!(removed, expect);
        assert!(!dead.exists() && !reused.exists());
        assert!(live.exists(), "a live writer's temporary was removed");
        assert!(other.exists(), "another target's temporary was removed");
        assert!(
            lookalike.exists(),
            "a file outside the naming pattern was removed"
        );
        // and writing the target cleans up the same way
        std::fs::write(&dead, b"partial").unwrap();
        write_atomic(&target, |w| w.write_all(b"new")).unwrap();
        assert!(!dead.exists());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn output_names_need_an_accepted_extension() {
        let dir = scratch("ext");
        let ok = |p: &Path| check_output(p, &["bt", "ot"], &[]);
        assert!(ok(&dir.join("m.bt")).is_ok());
        assert!(ok(&dir.join("m.OT")).is_ok());
        for bad in ["m.png", "m", "m.bt.gz"] {
            let e = ok(&dir.join(bad)).unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(".bt, .ot"), "{e}");
        }
        let e = ok(&dir.join("nope/m.bt")).unwrap_err().to_string();
        assert!(e.contains("does not exist"), "{e}");
        let input = dir.join("in.bt");
        std::fs::write(&input, b"x").unwrap();
        let e = check_output(&input, &["bt"], std::slice::from_ref(&input))
            .unwrap_err()
            .to_string();
        assert!(e.contains("also an input"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn checks_before_the_work() {
        let dir = scratch("check");
        let err = |p: &Path| check_writable(p).unwrap_err().to_string();
        let missing = dir.join("nope").join("x.bt");
        assert!(
            err(&missing).contains("does not exist"),
            "{}",
            err(&missing)
        );
        let file = dir.join("file");
        std::fs::write(&file, b"x").unwrap();
        let under_file = file.join("x.bt");
        assert!(err(&under_file).contains("not a directory"));
        assert!(err(&dir).contains("is a directory"));
        check_writable(&dir.join("x.bt")).unwrap();
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "probe left behind"
        );
        let input = dir.join("in.pcd");
        std::fs::write(&input, b"x").unwrap();
        let e = check_not_input(&dir.join(".").join("in.pcd"), std::slice::from_ref(&input))
            .unwrap_err();
        assert!(e.to_string().contains("also an input"), "{e}");
        check_not_input(&dir.join("out.bt"), &[input]).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn devices_are_written_in_place() {
        let null = Path::new("/dev/null");
        if !null.exists() {
            return;
        }
        write_atomic(null, |w| w.write_all(b"data")).unwrap();
        assert!(is_special(null), "/dev/null was replaced");
        let full = Path::new("/dev/full");
        if full.exists() {
            let e = write_atomic(full, |w| w.write_all(&[0u8; 100_000])).unwrap_err();
            let OutputError::Io { source, .. } = &e;
            assert_eq!(source.raw_os_error(), Some(28), "{e}"); // ENOSPC
            assert!(is_special(full), "/dev/full was replaced");
        }
    }
}
