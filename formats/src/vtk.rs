//! Legacy ASCII VTK point clouds (`DATASET POLYDATA`, as libpointmatcher writes them) and the
//! norlab trajectory CSV that gives each scan its pose.
//!
//! A sequence is a directory of `<name>_<sec>_<nanosec>.vtk` scans plus a CSV of
//! `nav_msgs/Odometry` rows. Scans are matched to rows by the stamp parsed **numerically** from
//! the file name (the nanoseconds are not zero padded, so `cloud_1690309710_85582848.vtk` is
//! 0.0856 s past the second and sorts last by name but 9th by time), and frames come out in
//! time order. World point = R(q)·p + t computed in `f64`, stored as `f32`; origin = t.

use crate::error::{FormatError, Location};
use crate::frame::{Frame, RowFrames};
use crate::pose::{rigid_transform, unit_quaternion};
use crate::source::{excerpt, read_all};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Whitespace tokens of a text buffer with their 1-based line numbers.
struct Tokens<'a> {
    rest: &'a str,
    line: u64,
}

impl<'a> Tokens<'a> {
    fn new(text: &'a str) -> Self {
        Tokens {
            rest: text,
            line: 1,
        }
    }

    /// The remainder of the current line (consumed), without its newline.
    fn line_rest(&mut self) -> &'a str {
        let end = self.rest.find('\n').unwrap_or(self.rest.len());
        let l = &self.rest[..end];
        if end < self.rest.len() {
            self.rest = &self.rest[end + 1..];
            self.line += 1;
        } else {
            self.rest = "";
        }
        l.trim_end_matches('\r')
    }

    fn next_token(&mut self) -> Option<(&'a str, u64)> {
        loop {
            let c = self.rest.chars().next()?;
            if c == '\n' {
                self.line += 1;
            }
            if c.is_ascii_whitespace() {
                self.rest = &self.rest[1..];
            } else {
                break;
            }
        }
        let end = self
            .rest
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(self.rest.len());
        let tok = &self.rest[..end];
        self.rest = &self.rest[end..];
        Some((tok, self.line))
    }
}

fn text_of<'a>(path: &Path, data: &'a [u8]) -> Result<&'a str, FormatError> {
    std::str::from_utf8(data).map_err(|e| {
        let line = data[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count() as u64
            + 1;
        FormatError::syntax(path, Location::Line(line), "not valid UTF-8 text")
    })
}

/// The points of a legacy ASCII VTK file in its own frame, as `f64` (exact for `float` data).
fn parse_vtk_points(path: &Path, data: &[u8]) -> Result<Vec<Point3<f64>>, FormatError> {
    let text = text_of(path, data)?;
    let mut t = Tokens::new(text);
    let l1 = t.line_rest();
    if !l1.trim_start().starts_with("# vtk DataFile Version") {
        return Err(FormatError::syntax(
            path,
            Location::Line(1),
            "not a legacy VTK file (no '# vtk DataFile Version' line)",
        ));
    }
    let _title = t.line_rest();
    let encoding = t.line_rest().trim();
    if encoding.eq_ignore_ascii_case("BINARY") {
        return Err(FormatError::unsupported(
            path,
            Location::Line(3),
            "binary VTK",
        ));
    }
    if !encoding.eq_ignore_ascii_case("ASCII") {
        return Err(FormatError::syntax(
            path,
            Location::Line(3),
            format!("expected ASCII or BINARY, found {encoding:?}"),
        ));
    }
    let eof = |t: &Tokens<'_>, what: &str| {
        FormatError::syntax(
            path,
            Location::Line(t.line),
            format!("file ends before {what}"),
        )
    };
    let (kw, line) = t.next_token().ok_or_else(|| eof(&t, "DATASET"))?;
    let (ds, _) = t.next_token().ok_or_else(|| eof(&t, "the dataset type"))?;
    if !kw.eq_ignore_ascii_case("DATASET") {
        return Err(FormatError::syntax(
            path,
            Location::Line(line),
            format!("expected DATASET, found {kw:?}"),
        ));
    }
    if !ds.eq_ignore_ascii_case("POLYDATA") && !ds.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
        return Err(FormatError::unsupported(
            path,
            Location::Line(line),
            format!("DATASET {ds} (only POLYDATA and UNSTRUCTURED_GRID)"),
        ));
    }
    // Skip anything (e.g. FIELD blocks) up to the POINTS keyword.
    let line = loop {
        let (tok, line) = t.next_token().ok_or_else(|| eof(&t, "a POINTS section"))?;
        if tok.eq_ignore_ascii_case("POINTS") {
            break line;
        }
    };
    let (n_tok, _) = t.next_token().ok_or_else(|| eof(&t, "the POINTS count"))?;
    let n: u64 = n_tok.parse().map_err(|_| {
        FormatError::syntax(
            path,
            Location::Line(line),
            format!("bad POINTS count {n_tok:?}"),
        )
    })?;
    let (ty, _) = t
        .next_token()
        .ok_or_else(|| eof(&t, "the POINTS data type"))?;
    let single = match ty.to_ascii_lowercase().as_str() {
        "float" => true,
        "double" => false,
        "int" | "unsigned_int" | "short" | "unsigned_short" | "long" | "unsigned_long" | "char"
        | "unsigned_char" => false,
        _ => {
            return Err(FormatError::unsupported(
                path,
                Location::Line(line),
                format!("POINTS data type {ty:?}"),
            ))
        }
    };
    // Each point takes at least 6 bytes of text ("0 0 0\n"): cap the reservation by that.
    let cap = usize::try_from(n)
        .unwrap_or(usize::MAX)
        .min(t.rest.len() / 6);
    let mut points = Vec::with_capacity(cap);
    let mut c = [0f64; 3];
    for i in 0..n {
        for v in &mut c {
            let (tok, l) = t
                .next_token()
                .ok_or_else(|| eof(&t, &format!("all {n} points (got {i})")))?;
            let parsed = if single {
                tok.parse::<f32>().map(f64::from).ok()
            } else {
                tok.parse::<f64>().ok()
            };
            *v = parsed.ok_or_else(|| {
                FormatError::syntax(
                    path,
                    Location::Line(l),
                    format!("cannot parse {:?} as a coordinate", excerpt(tok)),
                )
            })?;
        }
        points.push(Point3::new(c[0], c[1], c[2]));
    }
    Ok(points)
}

/// The points of one legacy ASCII VTK file, in the file's own frame, as `f32` storage
/// (`_f32` by the crate's precision convention).
pub fn read_vtk_points_f32(path: &Path) -> Result<Vec<Point3<f32>>, FormatError> {
    let data = read_all(path)?;
    Ok(parse_vtk_points(path, &data)?
        .into_iter()
        .map(|p| p.cast::<f32>())
        .collect())
}

/// One VTK file as a single frame with origin (0, 0, 0) and no pose applied.
pub fn read_vtk(path: &Path) -> Result<Vec<Frame>, FormatError> {
    Ok(vec![Frame::new_f32(
        Point3::origin(),
        read_vtk_points_f32(path)?,
    )])
}

/// One trajectory row: the pose T_world←scan at a stamp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampedPose {
    /// Whole seconds of the stamp.
    pub sec: u64,
    /// Nanoseconds past `sec` (< 10⁹).
    pub nanosec: u32,
    /// Position of the scan frame in the world (the sensor origin).
    pub translation: Vector3<f64>,
    /// Orientation of the scan frame (normalised when read).
    pub rotation: UnitQuaternion<f64>,
}

impl StampedPose {
    /// The stamp in seconds.
    pub fn stamp(&self) -> f64 {
        self.sec as f64 + f64::from(self.nanosec) * 1e-9
    }

    /// `R(q)·p + t` in `f64`, rounded to `f32`.
    pub fn transform(&self, p: &Point3<f64>) -> Point3<f32> {
        rigid_transform(&self.rotation.to_rotation_matrix(), &self.translation, p)
    }
}

const COLUMNS: [&str; 9] = [
    "header.stamp.sec",
    "header.stamp.nanosec",
    "pose.pose.position.x",
    "pose.pose.position.y",
    "pose.pose.position.z",
    "pose.pose.orientation.x",
    "pose.pose.orientation.y",
    "pose.pose.orientation.z",
    "pose.pose.orientation.w",
];

/// Read a trajectory CSV with a header naming (at least) the columns `header.stamp.sec`,
/// `header.stamp.nanosec`, `pose.pose.position.{x,y,z}` and `pose.pose.orientation.{x,y,z,w}`,
/// in any order. Rows come back in file order.
pub fn read_trajectory_csv(path: &Path) -> Result<Vec<StampedPose>, FormatError> {
    let mut lines = crate::source::LineReader::open(path)?;
    let (_, header) = lines
        .next_line()?
        .ok_or_else(|| FormatError::syntax(path, Location::Line(1), "empty trajectory file"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut idx = [0usize; 9];
    for (slot, col) in idx.iter_mut().zip(COLUMNS) {
        *slot = names.iter().position(|n| *n == col).ok_or_else(|| {
            FormatError::syntax(path, Location::Line(1), format!("no column {col:?}"))
        })?;
    }
    let mut poses = Vec::new();
    while let Some((at, line)) = lines.next_line()? {
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |k: usize| {
            fields.get(idx[k]).copied().ok_or_else(|| {
                FormatError::syntax(path, at, format!("missing column {:?}", COLUMNS[k]))
            })
        };
        let int = |k: usize| {
            let s = get(k)?;
            s.parse::<u64>().map_err(|_| {
                FormatError::syntax(path, at, format!("{}: bad integer {s:?}", COLUMNS[k]))
            })
        };
        let num = |k: usize| {
            let s = get(k)?;
            s.parse::<f64>().map_err(|_| {
                FormatError::syntax(path, at, format!("{}: bad number {s:?}", COLUMNS[k]))
            })
        };
        let sec = int(0)?;
        let nanosec = int(1)?;
        let nanosec = u32::try_from(nanosec)
            .ok()
            .filter(|&n| n < 1_000_000_000)
            .ok_or_else(|| {
                FormatError::syntax(path, at, format!("nanoseconds {nanosec} out of range"))
            })?;
        let translation = Vector3::new(num(2)?, num(3)?, num(4)?);
        let rotation = unit_quaternion(num(8)?, num(5)?, num(6)?, num(7)?)
            .filter(|_| translation.iter().all(|v| v.is_finite()))
            .ok_or_else(|| {
                FormatError::missing_pose(path, at, "non-finite position or zero quaternion")
            })?;
        poses.push(StampedPose {
            sec,
            nanosec,
            translation,
            rotation,
        });
    }
    Ok(poses)
}

/// The stamp in a scan file name `<anything>_<sec>_<nanosec>.vtk` (optionally `.gz`/`.bz2`),
/// parsed numerically: `cloud_1690309710_85582848.vtk` gives `(1690309710, 85582848)`.
pub fn parse_scan_stamp(file_name: &str) -> Option<(u64, u32)> {
    let lower = file_name.to_ascii_lowercase();
    let stem_len = [".vtk", ".vtk.gz", ".vtk.bz2"]
        .iter()
        .find(|s| lower.ends_with(*s))
        .map(|s| file_name.len() - s.len())?;
    let stem = &file_name[..stem_len];
    let mut parts = stem.rsplitn(3, '_');
    let nsec = parts.next()?;
    let sec = parts.next()?;
    parts.next()?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(nsec) || !digits(sec) {
        return None;
    }
    let nsec: u32 = nsec.parse().ok().filter(|&n| n < 1_000_000_000)?;
    Some((sec.parse().ok()?, nsec))
}

/// A scan file of a sequence: the seconds and nanoseconds of its stamp, and its path.
pub type ScanEntry = (u64, u32, PathBuf);

/// The `.vtk` scans of a directory with their stamps, sorted by time.
///
/// A `.vtk` file whose name carries no `_<sec>_<nanosec>` stamp is an error naming it.
pub fn list_scans(scans_dir: &Path) -> Result<Vec<ScanEntry>, FormatError> {
    let rd =
        std::fs::read_dir(scans_dir).map_err(|e| FormatError::io(scans_dir, Location::File, e))?;
    let mut scans = Vec::new();
    for entry in rd {
        let entry = entry.map_err(|e| FormatError::io(scans_dir, Location::File, e))?;
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        if crate::source::logical_extension(&path).as_deref() != Some("vtk") {
            continue;
        }
        let (sec, nsec) = parse_scan_stamp(&name).ok_or_else(|| {
            FormatError::syntax(
                &path,
                Location::File,
                "scan file name has no _<sec>_<nanosec> stamp",
            )
        })?;
        scans.push((sec, nsec, path));
    }
    scans.sort();
    Ok(scans)
}

/// Read a scan sequence: every `.vtk` in `scans_dir` matched by stamp to a row of the
/// `trajectory` CSV, transformed to the world, in time order. A scan without a row is an
/// error naming the scan; rows without a scan are ignored.
pub fn read_vtk_sequence(scans_dir: &Path, trajectory: &Path) -> Result<Vec<Frame>, FormatError> {
    vtk_sequence_frames(scans_dir, trajectory)?.collect()
}

/// [`read_vtk_sequence`] one scan at a time: the trajectory and the scan list are read
/// first, then each scan file only when its frame is asked for.
pub fn vtk_sequence_frames(
    scans_dir: &Path,
    trajectory: &Path,
) -> Result<RowFrames<ScanEntry>, FormatError> {
    let poses = read_trajectory_csv(trajectory)?;
    let mut by_stamp: HashMap<(u64, u32), StampedPose> = HashMap::with_capacity(poses.len());
    for p in poses {
        by_stamp.entry((p.sec, p.nanosec)).or_insert(p);
    }
    let scans = list_scans(scans_dir)?;
    let trajectory = trajectory.to_path_buf();
    Ok(RowFrames::new(
        scans,
        move |(sec, nsec, path): ScanEntry| {
            let pose = by_stamp.get(&(sec, nsec)).ok_or_else(|| {
                FormatError::missing_pose(
                    &path,
                    Location::File,
                    format!(
                        "no row of {} has stamp {sec}.{nsec:09}",
                        trajectory.display()
                    ),
                )
            })?;
            let data = read_all(&path)?;
            let rotation = pose.rotation.to_rotation_matrix();
            let points = parse_vtk_points(&path, &data)?
                .iter()
                .map(|p| rigid_transform(&rotation, &pose.translation, p))
                .collect();
            let mut f = Frame::new_f32(pose.translation.cast::<f32>().into(), points);
            f.stamp = Some(pose.stamp());
            Ok(f)
        },
    ))
}

/// Read a scan sequence with identity poses: every `.vtk` in `scans_dir` in stamp order, its
/// points as stored (already in the world frame), the sensor at the origin, the stamp from
/// the file name.
pub fn read_vtk_sequence_identity(scans_dir: &Path) -> Result<Vec<Frame>, FormatError> {
    let scans = list_scans(scans_dir)?;
    let mut frames = Vec::with_capacity(scans.len());
    for (sec, nsec, path) in scans {
        let data = read_all(&path)?;
        let points = parse_vtk_points(&path, &data)?;
        let mut f = Frame::new(Point3::origin(), &points);
        f.stamp = Some(sec as f64 + f64::from(nsec) * 1e-9);
        frames.push(f);
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_are_numeric() {
        assert_eq!(
            parse_scan_stamp("cloud_1690309710_85582848.vtk"),
            Some((1690309710, 85582848))
        );
        assert_eq!(parse_scan_stamp("cloud_1_2.vtk.gz"), Some((1, 2)));
        assert_eq!(parse_scan_stamp("cloud.vtk"), None);
        assert_eq!(parse_scan_stamp("cloud_1_1000000000.vtk"), None);
        assert_eq!(parse_scan_stamp("cloud_x_1.vtk"), None);
    }

    #[test]
    fn parses_points_across_lines() {
        let txt = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2 float\n1 2\n3 4 5 6\n";
        let pts = parse_vtk_points(Path::new("a.vtk"), txt).unwrap_or_default();
        assert_eq!(
            pts,
            vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]
        );
        let e = parse_vtk_points(Path::new("a.vtk"), &txt[..txt.len() - 3]);
        assert!(matches!(
            e,
            Err(FormatError::Syntax {
                at: Location::Line(7),
                ..
            })
        ));
    }
}
