//! Plain-text scans: OctoMap point lists, OctoMap's `NODE` log format, and the reference
//! program's `origin` frames. Which one a file is comes from its first significant line.
//!
//! * **Point list** (`scan.dat`, `Pointcloud::read`): `x y z` per line, one frame with origin
//!   (0, 0, 0), as octovis loads it.
//! * **Log** (`ScanGraph::readPlainASCII`, used by `log2graph`): `NODE x y z roll pitch yaw`
//!   starts a node, then `x y z` lines in the node's sensor frame. Each node becomes a frame
//!   exactly as graph2tree would insert it after `log2graph` (see [`crate::graph`]). As in
//!   OctoMap, lines starting with a space are skipped in this mode. Unlike OctoMap, a last
//!   line without a newline is kept, and a malformed line is an error rather than zeros.
//! * **Reference frames**: `origin OX OY OZ` starts a frame; the following `x y z` lines are
//!   its world points.
//!
//! Everywhere blank lines and `#` comments are skipped, numbers are parsed straight to `f32`
//! (`str::parse::<f32>`, as `istream >> float` does; never through `f64`), `nan`/`inf` are
//! accepted for points, and every error names the file and line.

use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::graph::{graph_to_frames, GraphOptions, Pose6D, ScanGraph, ScanNode};
use crate::source::{excerpt, LineReader};
use nalgebra::{Point3, Vector3};
use std::path::Path;

/// The kind of text file, from its first significant line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextKind {
    /// `x y z` lines only.
    PointList,
    /// OctoMap log: `NODE` lines followed by sensor-frame points.
    Log,
    /// Reference-program frames: `origin` lines followed by world points.
    OriginFrames,
}

fn classify(first_token: &str) -> TextKind {
    if first_token.starts_with("NODE") {
        TextKind::Log
    } else if first_token == "origin" {
        TextKind::OriginFrames
    } else {
        TextKind::PointList
    }
}

enum Parsed {
    Points(Vec<Point3<f32>>),
    Log(ScanGraph),
    Frames(Vec<Frame>),
}

fn parse_f32(path: &Path, at: Location, tok: &str) -> Result<f32, FormatError> {
    tok.parse::<f32>().map_err(|_| {
        FormatError::syntax(
            path,
            at,
            format!("cannot parse {:?} as a number", excerpt(tok)),
        )
    })
}

/// Parse exactly three numbers from `toks`.
fn parse_xyz<'a>(
    path: &Path,
    at: Location,
    mut toks: impl Iterator<Item = &'a str>,
    what: &str,
) -> Result<Point3<f32>, FormatError> {
    let mut c = [0f32; 3];
    for v in &mut c {
        let tok = toks
            .next()
            .ok_or_else(|| FormatError::syntax(path, at, format!("{what}: expected 3 numbers")))?;
        *v = parse_f32(path, at, tok)?;
    }
    if let Some(extra) = toks.next() {
        return Err(FormatError::syntax(
            path,
            at,
            format!("{what}: unexpected extra field {extra:?} after 3 numbers"),
        ));
    }
    Ok(Point3::new(c[0], c[1], c[2]))
}

fn finite_pose(path: &Path, at: Location, vals: &[f32]) -> Result<(), FormatError> {
    if vals.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(FormatError::missing_pose(
            path,
            at,
            "the pose has a non-finite value",
        ))
    }
}

fn parse(path: &Path) -> Result<Parsed, FormatError> {
    let mut lines = LineReader::open(path)?;
    let mut kind: Option<TextKind> = None;
    let mut points: Vec<Point3<f32>> = Vec::new();
    let mut nodes: Vec<ScanNode> = Vec::new();
    let mut frames: Vec<Frame> = Vec::new();
    while let Some((at, line)) = lines.next_line()? {
        let trimmed = line.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let mut toks = trimmed.split_ascii_whitespace();
        let first = toks.next().unwrap_or_default();
        let k = *kind.get_or_insert(classify(first));
        match k {
            TextKind::PointList => {
                points.push(parse_xyz(
                    path,
                    at,
                    trimmed.split_ascii_whitespace(),
                    "point",
                )?);
            }
            TextKind::Log => {
                if line.starts_with(' ') {
                    continue;
                }
                if first.starts_with("NODE") {
                    let mut v = [0f32; 6];
                    for x in &mut v {
                        let tok = toks.next().ok_or_else(|| {
                            FormatError::syntax(path, at, "NODE needs x y z roll pitch yaw")
                        })?;
                        *x = parse_f32(path, at, tok)?;
                    }
                    finite_pose(path, at, &v)?;
                    let pose = Pose6D::from_euler(
                        Vector3::new(v[0], v[1], v[2]),
                        f64::from(v[3]),
                        f64::from(v[4]),
                        f64::from(v[5]),
                    );
                    let id = u32::try_from(nodes.len())
                        .map_err(|_| FormatError::syntax(path, at, "more than 2^32 nodes"))?;
                    nodes.push(ScanNode {
                        id,
                        pose,
                        points: Vec::new(),
                    });
                } else {
                    let p = parse_xyz(path, at, trimmed.split_ascii_whitespace(), "point")?;
                    match nodes.last_mut() {
                        Some(n) => n.points.push(p),
                        None => {
                            return Err(FormatError::missing_pose(
                                path,
                                at,
                                "a point comes before the first NODE line",
                            ))
                        }
                    }
                }
            }
            TextKind::OriginFrames => {
                if first == "origin" {
                    let o = parse_xyz(path, at, toks, "origin")?;
                    finite_pose(path, at, &[o.x, o.y, o.z])?;
                    frames.push(Frame::new_f32(o, Vec::new()));
                } else {
                    let p = parse_xyz(path, at, trimmed.split_ascii_whitespace(), "point")?;
                    match frames.last_mut() {
                        Some(f) => f.points.push(p),
                        None => {
                            return Err(FormatError::missing_pose(
                                path,
                                at,
                                "a point comes before the first origin line",
                            ))
                        }
                    }
                }
            }
        }
    }
    Ok(match kind {
        None | Some(TextKind::PointList) => Parsed::Points(points),
        Some(TextKind::Log) => Parsed::Log(ScanGraph {
            nodes,
            edges: Vec::new(),
        }),
        Some(TextKind::OriginFrames) => Parsed::Frames(frames),
    })
}

/// Read any of the three text kinds as frames (optionally `.gz`/`.bz2`).
///
/// A point list gives one frame at the origin (an empty file gives one empty frame); a log
/// gives one frame per `NODE`, transformed like graph2tree; origin frames are taken as is.
pub fn read_text(path: &Path) -> Result<Vec<Frame>, FormatError> {
    Ok(match parse(path)? {
        Parsed::Points(points) => vec![Frame::new_f32(Point3::origin(), points)],
        Parsed::Log(graph) => graph_to_frames(&graph, &GraphOptions::default()),
        Parsed::Frames(frames) => frames,
    })
}

/// Read an OctoMap log as the ScanGraph `log2graph` builds from it (nodes with ids 0.., points
/// in the sensor frame; the odometry edges `log2graph` adds are not built).
pub fn read_log_graph(path: &Path) -> Result<ScanGraph, FormatError> {
    match parse(path)? {
        Parsed::Log(graph) => Ok(graph),
        _ => Err(FormatError::syntax(
            path,
            Location::Line(1),
            "not an OctoMap log (no NODE line first)",
        )),
    }
}

/// Which kind of text file `path` is, from its first significant line (`None` when it has
/// none).
pub fn text_kind(path: &Path) -> Result<Option<TextKind>, FormatError> {
    let mut lines = LineReader::open(path)?;
    while let Some((_, line)) = lines.next_line()? {
        let t = line.trim_start();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let first = t.split_ascii_whitespace().next().unwrap_or_default();
        return Ok(Some(classify(first)));
    }
    Ok(None)
}
