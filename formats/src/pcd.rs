//! PCD v0.7 point clouds (PCL): `ascii`, `binary` and `binary_compressed` data, any
//! `FIELDS`/`SIZE`/`TYPE`/`COUNT` layout with `x`, `y`, `z` stored as `F 4` or `F 8` (the first
//! element is used when a count is above 1).
//!
//! `binary` data is point-major (one record of all fields per point); `binary_compressed` is
//! a `u32` compressed size, a `u32` uncompressed size and an LZF stream that decompresses to
//! **field-major** data (all values of the first field, then the second, ...).
//!
//! # VIEWPOINT
//! `VIEWPOINT tx ty tz qw qx qy qz` is the acquisition pose. PCL stores it in the cloud's
//! `sensor_origin_`/`sensor_orientation_` and never applies it to the points: the points are
//! already in the cloud's frame, and the viewpoint says where the sensor was in that frame.
//! Hence the default [`ViewpointUse::OriginOnly`]: the origin is the viewpoint translation and
//! the points are unchanged. [`ViewpointUse::Apply`] is for writers that stored sensor-frame
//! points with their pose in VIEWPOINT (world = R(q)·p + t in `f64`, origin = t);
//! [`ViewpointUse::Ignore`] uses origin (0, 0, 0).
//!
//! Invalid points (NaN) are kept; insertion skips and counts them.

use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::organized::fit_pinhole_camera;
use crate::packed_color::{parse_packed_token, unpack_rgb};
use crate::pose::{rigid_transform, unit_quaternion};
use crate::source::{decompression_limit, excerpt, read_all, ByteReader, Fields};
use nalgebra::{Point3, Quaternion, Rotation3, Vector3};
use octoquant_octree::Color;
use std::path::Path;

/// What to do with the PCD `VIEWPOINT` (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewpointUse {
    /// Origin = viewpoint translation; points unchanged (PCL's meaning).
    #[default]
    OriginOnly,
    /// Points transformed by the viewpoint pose; origin = its translation.
    Apply,
    /// Origin (0, 0, 0); points unchanged.
    Ignore,
}

/// Options for PCD files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PcdOptions {
    /// How the `VIEWPOINT` is used.
    pub viewpoint: ViewpointUse,
}

/// The data encoding of a PCD file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PcdEncoding {
    /// One text line per point.
    Ascii,
    /// Little-endian records, point-major.
    Binary,
    /// LZF-compressed, field-major.
    BinaryCompressed,
}

/// One `FIELDS` entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PcdField {
    /// Field name.
    pub name: String,
    /// Bytes per element (1, 2, 4 or 8).
    pub size: usize,
    /// `F`, `I` or `U`.
    pub kind: char,
    /// Elements per point.
    pub count: usize,
}

/// A PCD cloud as stored: points in the file's frame plus the header facts.
#[derive(Debug, Clone, PartialEq)]
pub struct PcdCloud {
    /// `x y z` of every point in file order (NaN kept); `F 4` values are exact.
    pub points: Vec<Point3<f64>>,
    /// `WIDTH`.
    pub width: u64,
    /// `HEIGHT`.
    pub height: u64,
    /// The fields.
    pub fields: Vec<PcdField>,
    /// The data encoding.
    pub encoding: PcdEncoding,
    /// `VIEWPOINT` translation.
    pub viewpoint_translation: Vector3<f64>,
    /// `VIEWPOINT` rotation `Quaternion::new(qw, qx, qy, qz)`, as stored.
    pub viewpoint_rotation: Quaternion<f64>,
    /// The colour of every point from the `rgb` or `rgba` field (PCL's packed `0xAARRGGBB`,
    /// see [`crate::packed_color`]), when it was asked for and the file has one.
    pub colors: Option<Vec<Color>>,
}

struct Header {
    fields: Vec<PcdField>,
    width: u64,
    height: u64,
    points: u64,
    viewpoint: [f64; 7],
    encoding: PcdEncoding,
    /// Byte offset of the data (just after the DATA line).
    data_start: usize,
    /// Line number of the DATA line.
    data_line: u64,
}

fn parse_header(path: &Path, data: &[u8]) -> Result<Header, FormatError> {
    let mut pos = 0usize;
    let mut line_no = 0u64;
    let mut names: Option<Vec<String>> = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut kinds: Option<Vec<char>> = None;
    let mut counts: Option<Vec<usize>> = None;
    let (mut width, mut height, mut points) = (None, None, None);
    let mut viewpoint = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0];
    loop {
        if pos >= data.len() {
            return Err(FormatError::syntax(
                path,
                Location::Line(line_no),
                "header ends without a DATA line",
            ));
        }
        let end = data[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(data.len(), |i| pos + i);
        line_no += 1;
        let at = Location::Line(line_no);
        let line = std::str::from_utf8(&data[pos..end])
            .map_err(|_| FormatError::syntax(path, at, "header line is not text"))?
            .trim();
        pos = (end + 1).min(data.len());
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut toks = line.split_ascii_whitespace();
        let key = toks.next().unwrap_or_default().to_ascii_uppercase();
        let vals: Vec<&str> = toks.collect();
        let int = |s: &str| {
            s.parse::<u64>()
                .map_err(|_| FormatError::syntax(path, at, format!("{key}: bad integer {s:?}")))
        };
        let one = |v: &[&str]| match v {
            [s] => int(s),
            _ => Err(FormatError::syntax(
                path,
                at,
                format!("{key} takes one value"),
            )),
        };
        match key.as_str() {
            "VERSION" => {}
            "FIELDS" => names = Some(vals.iter().map(|s| s.to_string()).collect()),
            "SIZE" => {
                let v = vals
                    .iter()
                    .map(|s| match int(s)? {
                        n @ (1 | 2 | 4 | 8) => Ok(n as usize),
                        n => Err(FormatError::syntax(
                            path,
                            at,
                            format!("SIZE {n} is not 1, 2, 4 or 8"),
                        )),
                    })
                    .collect::<Result<_, _>>()?;
                sizes = Some(v);
            }
            "TYPE" => {
                let v = vals
                    .iter()
                    .map(|s| match s.to_ascii_uppercase().as_str() {
                        "F" => Ok('F'),
                        "I" => Ok('I'),
                        "U" => Ok('U'),
                        _ => Err(FormatError::syntax(
                            path,
                            at,
                            format!("TYPE {s:?} is not F, I or U"),
                        )),
                    })
                    .collect::<Result<_, _>>()?;
                kinds = Some(v);
            }
            "COUNT" => {
                let v = vals
                    .iter()
                    .map(|s| match int(s)? {
                        0 => Err(FormatError::syntax(path, at, "COUNT 0")),
                        n if n > 1 << 20 => Err(FormatError::syntax(
                            path,
                            at,
                            format!("COUNT {n} is absurd"),
                        )),
                        n => Ok(n as usize),
                    })
                    .collect::<Result<_, _>>()?;
                counts = Some(v);
            }
            "WIDTH" => width = Some(one(&vals)?),
            "HEIGHT" => height = Some(one(&vals)?),
            "POINTS" => points = Some(one(&vals)?),
            "VIEWPOINT" => {
                if vals.len() != 7 {
                    return Err(FormatError::syntax(path, at, "VIEWPOINT takes 7 numbers"));
                }
                for (v, s) in viewpoint.iter_mut().zip(&vals) {
                    *v = s.parse().map_err(|_| {
                        FormatError::syntax(path, at, format!("VIEWPOINT: bad number {s:?}"))
                    })?;
                }
            }
            "DATA" => {
                let encoding = match vals.first().map(|s| s.to_ascii_lowercase()).as_deref() {
                    Some("ascii") => PcdEncoding::Ascii,
                    Some("binary") => PcdEncoding::Binary,
                    Some("binary_compressed") => PcdEncoding::BinaryCompressed,
                    other => {
                        return Err(FormatError::unsupported(
                            path,
                            at,
                            format!("DATA {}", other.unwrap_or("(missing)")),
                        ))
                    }
                };
                let names = names.ok_or_else(|| FormatError::syntax(path, at, "no FIELDS line"))?;
                let n = names.len();
                let sizes = sizes.ok_or_else(|| FormatError::syntax(path, at, "no SIZE line"))?;
                let kinds = kinds.ok_or_else(|| FormatError::syntax(path, at, "no TYPE line"))?;
                let counts = counts.unwrap_or_else(|| vec![1; n]);
                if sizes.len() != n || kinds.len() != n || counts.len() != n {
                    return Err(FormatError::syntax(
                        path,
                        at,
                        format!(
                            "FIELDS has {n} entries but SIZE {}, TYPE {}, COUNT {}",
                            sizes.len(),
                            kinds.len(),
                            counts.len()
                        ),
                    ));
                }
                let fields = (0..n)
                    .map(|i| PcdField {
                        name: names[i].clone(),
                        size: sizes[i],
                        kind: kinds[i],
                        count: counts[i],
                    })
                    .collect();
                let width = width.ok_or_else(|| FormatError::syntax(path, at, "no WIDTH line"))?;
                let height = height.unwrap_or(1);
                let wh = width
                    .checked_mul(height)
                    .ok_or_else(|| FormatError::syntax(path, at, "WIDTH × HEIGHT overflows"))?;
                let points = points.unwrap_or(wh);
                if points != wh {
                    return Err(FormatError::syntax(
                        path,
                        at,
                        format!("POINTS {points} differs from WIDTH × HEIGHT = {wh}"),
                    ));
                }
                return Ok(Header {
                    fields,
                    width,
                    height,
                    points,
                    viewpoint,
                    encoding,
                    data_start: pos,
                    data_line: line_no,
                });
            }
            _ => {
                return Err(FormatError::syntax(
                    path,
                    at,
                    format!("unknown header keyword {key:?}"),
                ))
            }
        }
    }
}

/// Where one of `x`, `y`, `z` is.
#[derive(Clone, Copy)]
struct Slot {
    /// Index among the text tokens of a point.
    token: usize,
    /// Byte offset in a point record.
    offset: usize,
    /// Bytes of the whole field per point (size × count).
    stride: usize,
    /// Bytes per element (4 or 8).
    size: usize,
}

fn xyz_slots(path: &Path, h: &Header) -> Result<([Slot; 3], usize, usize), FormatError> {
    let at = Location::Line(h.data_line);
    let mut slots = [None; 3];
    let (mut token, mut offset) = (0usize, 0usize);
    for f in &h.fields {
        if let Some(k) = ["x", "y", "z"].iter().position(|n| *n == f.name) {
            if f.kind != 'F' || (f.size != 4 && f.size != 8) {
                return Err(FormatError::unsupported(
                    path,
                    at,
                    format!(
                        "field {} is {} {} (only F 4 or F 8)",
                        f.name, f.kind, f.size
                    ),
                ));
            }
            slots[k] = Some(Slot {
                token,
                offset,
                stride: f.size * f.count,
                size: f.size,
            });
        }
        token += f.count;
        offset += f.size * f.count;
    }
    match slots {
        [Some(x), Some(y), Some(z)] => Ok(([x, y, z], token, offset)),
        _ => Err(FormatError::syntax(path, at, "FIELDS lacks one of x, y, z")),
    }
}

/// Where the packed colour field (`rgb`, else `rgba`) is, with its `TYPE`; `None` when the
/// file has neither. The field must be 4 bytes wide (PCL's layout).
fn color_slot(path: &Path, h: &Header) -> Result<Option<(Slot, char)>, FormatError> {
    let at = Location::Line(h.data_line);
    for name in ["rgb", "rgba"] {
        let (mut token, mut offset) = (0usize, 0usize);
        for f in &h.fields {
            if f.name == name {
                if f.size != 4 {
                    return Err(FormatError::unsupported(
                        path,
                        at,
                        format!(
                            "colour field {name} is {} {} (only 4-byte packed colours)",
                            f.kind, f.size
                        ),
                    ));
                }
                let slot = Slot {
                    token,
                    offset,
                    stride: f.size * f.count,
                    size: 4,
                };
                return Ok(Some((slot, f.kind)));
            }
            token += f.count;
            offset += f.size * f.count;
        }
    }
    Ok(None)
}

fn read_packed(bytes: &[u8]) -> Color {
    unpack_rgb(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
}

fn read_float(bytes: &[u8], size: usize) -> f64 {
    if size == 4 {
        f64::from(f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
    } else {
        f64::from_le_bytes([
            bytes[0], bytes[1], bytes[2], bytes[3], bytes[4], bytes[5], bytes[6], bytes[7],
        ])
    }
}

/// Decompress an LZF stream (liblzf's format, as PCL writes it) into exactly `out_len`
/// bytes. Errors give the offset in `input` and what is wrong.
pub fn lzf_decompress(input: &[u8], out_len: usize) -> Result<Vec<u8>, (usize, String)> {
    // An LZF stream expands at most ~88× (a 3-byte back reference copies 264 bytes).
    let mut out = Vec::with_capacity(out_len.min(input.len().saturating_mul(90)));
    let mut ip = 0usize;
    while ip < input.len() {
        let start = ip;
        let ctrl = usize::from(input[ip]);
        ip += 1;
        if ctrl < 32 {
            let len = ctrl + 1;
            let lit = input
                .get(ip..ip + len)
                .ok_or((start, format!("literal run of {len} bytes past the end")))?;
            if out.len() + len > out_len {
                return Err((start, "output exceeds the declared size".into()));
            }
            out.extend_from_slice(lit);
            ip += len;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += usize::from(*input.get(ip).ok_or((start, "cut back reference".into()))?);
                ip += 1;
            }
            let low = usize::from(*input.get(ip).ok_or((start, "cut back reference".into()))?);
            ip += 1;
            let dist = ((ctrl & 0x1f) << 8) + low + 1;
            len += 2;
            if dist > out.len() {
                return Err((
                    start,
                    "back reference before the start of the output".into(),
                ));
            }
            if out.len() + len > out_len {
                return Err((start, "output exceeds the declared size".into()));
            }
            let from = out.len() - dist;
            for k in 0..len {
                let b = out[from + k];
                out.push(b);
            }
        }
    }
    if out.len() != out_len {
        return Err((
            input.len(),
            format!("decompressed {} bytes, header says {out_len}", out.len()),
        ));
    }
    Ok(out)
}

fn parse_pcd(path: &Path, data: &[u8], want_colors: bool) -> Result<PcdCloud, FormatError> {
    let h = parse_header(path, data)?;
    let (slots, tokens_per_point, point_step) = xyz_slots(path, &h)?;
    let color = if want_colors {
        color_slot(path, &h)?
    } else {
        None
    };
    let body = &data[h.data_start..];
    let n = h.points;
    let mut points = Vec::new();
    let mut colors = Vec::new();
    match h.encoding {
        PcdEncoding::Ascii => {
            let text = std::str::from_utf8(body).map_err(|e| {
                let line = body[..e.valid_up_to()]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count();
                FormatError::syntax(
                    path,
                    Location::Line(h.data_line + 1 + line as u64),
                    "data is not text",
                )
            })?;
            points.reserve(usize::try_from(n).unwrap_or(usize::MAX).min(body.len() / 6));
            let mut line_no = h.data_line;
            for line in text.lines() {
                line_no += 1;
                let at = Location::Line(line_no);
                let t = line.trim();
                if t.is_empty() {
                    continue;
                }
                if points.len() as u64 == n {
                    return Err(FormatError::syntax(
                        path,
                        at,
                        format!("more data lines than POINTS {n}"),
                    ));
                }
                let toks: Vec<&str> = t.split_ascii_whitespace().collect();
                if toks.len() != tokens_per_point {
                    return Err(FormatError::syntax(
                        path,
                        at,
                        format!("{} values, expected {tokens_per_point}", toks.len()),
                    ));
                }
                let mut c = [0f64; 3];
                for (v, s) in c.iter_mut().zip(&slots) {
                    let tok = toks[s.token];
                    let parsed = if s.size == 4 {
                        tok.parse::<f32>().map(f64::from).ok()
                    } else {
                        tok.parse::<f64>().ok()
                    };
                    *v = parsed.ok_or_else(|| {
                        FormatError::syntax(
                            path,
                            at,
                            format!("cannot parse {:?} as a number", excerpt(tok)),
                        )
                    })?;
                }
                points.push(Point3::new(c[0], c[1], c[2]));
                if let Some((slot, kind)) = color {
                    let tok = toks[slot.token];
                    colors.push(parse_packed_token(tok, kind).ok_or_else(|| {
                        FormatError::syntax(
                            path,
                            at,
                            format!("cannot parse {:?} as a packed colour", excerpt(tok)),
                        )
                    })?);
                }
            }
            if points.len() as u64 != n {
                return Err(FormatError::syntax(
                    path,
                    Location::Line(line_no),
                    format!("file ends after {} of {n} points", points.len()),
                ));
            }
        }
        PcdEncoding::Binary => {
            let mut r = ByteReader::new(path, data);
            r.take(h.data_start, "header")?;
            let bytes = r.take_checked(
                n.saturating_mul(point_step as u64),
                &format!("{n} binary points of {point_step} bytes"),
            )?;
            points.reserve(n as usize);
            for rec in bytes.chunks_exact(point_step.max(1)) {
                let c = slots.map(|s| read_float(&rec[s.offset..], s.size));
                points.push(Point3::new(c[0], c[1], c[2]));
            }
            if let Some((slot, _)) = color {
                colors.reserve(n as usize);
                for rec in bytes.chunks_exact(point_step.max(1)) {
                    colors.push(read_packed(&rec[slot.offset..]));
                }
            }
        }
        PcdEncoding::BinaryCompressed => {
            let mut r = ByteReader::new(path, data);
            r.take(h.data_start, "header")?;
            let comp_len = r.u32("compressed size")?;
            let raw_len = r.u32("uncompressed size")?;
            let expected = n.saturating_mul(point_step as u64);
            if u64::from(raw_len) != expected {
                return Err(r.error_at(
                    4,
                    format!("uncompressed size {raw_len} is not POINTS × point size = {expected}"),
                ));
            }
            if let Some(msg) = decompression_limit().check(comp_len.into(), raw_len.into()) {
                return Err(r.error_at(4, format!("LZF data: {msg}")));
            }
            let comp_start = r.pos();
            let comp = r.take(comp_len as usize, "the compressed data")?;
            let raw = if raw_len == 0 {
                Vec::new()
            } else {
                lzf_decompress(comp, raw_len as usize).map_err(|(off, msg)| {
                    FormatError::syntax(
                        path,
                        Location::Byte((comp_start + off) as u64),
                        format!("LZF data: {msg}"),
                    )
                })?
            };
            let n = n as usize;
            points.reserve(n);
            // Field-major: the block of a field starts at n × (bytes of the fields before).
            for i in 0..n {
                let c = slots.map(|s| read_float(&raw[n * s.offset + i * s.stride..], s.size));
                points.push(Point3::new(c[0], c[1], c[2]));
            }
            if let Some((slot, _)) = color {
                colors.reserve(n);
                for i in 0..n {
                    colors.push(read_packed(&raw[n * slot.offset + i * slot.stride..]));
                }
            }
        }
    }
    let v = h.viewpoint;
    Ok(PcdCloud {
        points,
        width: h.width,
        height: h.height,
        fields: h.fields,
        encoding: h.encoding,
        viewpoint_translation: Vector3::new(v[0], v[1], v[2]),
        viewpoint_rotation: Quaternion::new(v[3], v[4], v[5], v[6]),
        colors: color.map(|_| colors),
    })
}

/// Read a PCD file as stored (points in the file's frame, viewpoint in the header fields),
/// without colours.
pub fn read_pcd_cloud(path: &Path) -> Result<PcdCloud, FormatError> {
    read_pcd_cloud_with(path, false)
}

/// [`read_pcd_cloud`], with the points' colours when `colors` is set and the file has an `rgb`
/// or `rgba` field ([`PcdCloud::colors`]).
pub fn read_pcd_cloud_with(path: &Path, colors: bool) -> Result<PcdCloud, FormatError> {
    parse_pcd(path, &read_all(path)?, colors)
}

/// Read a PCD file as one frame, using the viewpoint as [`PcdOptions::viewpoint`] says.
pub fn read_pcd(path: &Path, options: &PcdOptions) -> Result<Vec<Frame>, FormatError> {
    read_pcd_with(path, options, false)
}

/// [`read_pcd`], with [`Frame::colors`] from the `rgb`/`rgba` field when `colors` is set and
/// the file has one.
pub fn read_pcd_with(
    path: &Path,
    options: &PcdOptions,
    colors: bool,
) -> Result<Vec<Frame>, FormatError> {
    let mut cloud = read_pcd_cloud_with(path, colors)?;
    let colors = cloud.colors.take();
    let t = cloud.viewpoint_translation;
    let bad_pose = |what: &str| FormatError::missing_pose(path, Location::File, what);
    // the camera's orientation in the frame's coordinates (for an organised cloud's fit)
    let mut rotation = Rotation3::identity();
    let frame = match options.viewpoint {
        ViewpointUse::Ignore => Frame::new(Point3::origin(), &cloud.points),
        ViewpointUse::OriginOnly => {
            if !t.iter().all(|c| c.is_finite()) {
                return Err(bad_pose("VIEWPOINT translation is not finite"));
            }
            Frame::new(t.into(), &cloud.points)
        }
        ViewpointUse::Apply => {
            let q = cloud.viewpoint_rotation;
            let rot = unit_quaternion(q.w, q.i, q.j, q.k)
                .filter(|_| t.iter().all(|c| c.is_finite()))
                .ok_or_else(|| bad_pose("VIEWPOINT is not finite or has a zero quaternion"))?;
            rotation = rot.to_rotation_matrix();
            Frame::new_f32(
                t.cast::<f32>().into(),
                cloud
                    .points
                    .iter()
                    .map(|p| rigid_transform(&rotation, &t, p))
                    .collect(),
            )
        }
    };
    // an organised cloud from a depth camera: its pixels speed up exact insertion
    let camera = fit_pinhole_camera(
        &frame.points,
        &frame.origin,
        rotation,
        cloud.width,
        cloud.height,
    );
    Ok(vec![Frame {
        colors,
        camera,
        ..frame
    }])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lzf_literals_and_back_references() {
        // "abc" literal, then a back reference of length 6 at distance 3: "abcabcabc".
        let input = [2u8, b'a', b'b', b'c', (4 << 5), 2];
        assert_eq!(lzf_decompress(&input, 9).ok(), Some(b"abcabcabc".to_vec()));
        assert!(lzf_decompress(&input, 8).is_err());
        assert!(lzf_decompress(&[(1 << 5), 9], 3).is_err());
        assert!(lzf_decompress(&[5, b'a'], 6).is_err());
    }

    #[test]
    fn ascii_with_counts_and_nan() {
        let txt = b"VERSION 0.7\nFIELDS n x y z\nSIZE 4 4 4 8\nTYPE F F F F\nCOUNT 2 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 1 2 3 1 0 0 0\nPOINTS 2\nDATA ascii\n9 9 1 2 3\n9 9 nan nan nan\n";
        let c = parse_pcd(Path::new("t.pcd"), txt, false);
        let c = c
            .as_ref()
            .map(|c| (c.points.len(), c.points[0], c.viewpoint_translation));
        assert!(
            matches!(c, Ok((2, p, t)) if p == Point3::new(1.0, 2.0, 3.0) && t.x == 1.0),
            "{c:?}"
        );
    }

    #[test]
    fn packed_colours_in_every_encoding() {
        let head = |data: &str| {
            format!("VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA {data}\n")
        };
        let want = vec![Color::new(255, 128, 1), Color::new(1, 2, 3)];
        let ascii = head("ascii") + "1 2 3 16744449\n4 5 6 66051\n";
        let p = Path::new("t.pcd");
        let c = parse_pcd(p, ascii.as_bytes(), true).map(|c| c.colors);
        assert_eq!(c.ok(), Some(Some(want.clone())));
        // not asked for: not decoded
        let c = parse_pcd(p, ascii.as_bytes(), false).map(|c| c.colors);
        assert_eq!(c.ok(), Some(None));
        let mut bin = head("binary").into_bytes();
        for (i, bits) in [0x00ff_8001u32, 0x0001_0203].iter().enumerate() {
            for v in [i as f32, 1.0, 2.0] {
                bin.extend_from_slice(&v.to_le_bytes());
            }
            bin.extend_from_slice(&bits.to_le_bytes());
        }
        let c = parse_pcd(p, &bin, true).map(|c| c.colors);
        assert_eq!(c.ok(), Some(Some(want)));
        // a colour token that is no number names the line
        let bad = head("ascii") + "1 2 3 16744449\n4 5 6 blue\n";
        let e = parse_pcd(p, bad.as_bytes(), true).unwrap_err().to_string();
        assert!(e.contains("line 11") && e.contains("packed colour"), "{e}");
        // a short colour field is refused, not misread
        let short = head("ascii").replace("SIZE 4 4 4 4", "SIZE 4 4 4 2") + "1 2 3 4\n4 5 6 7\n";
        let e = parse_pcd(p, short.as_bytes(), true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("colour field rgb"), "{e}");
    }
}
