//! PLY point clouds: read `x y z` (and on request `red green blue`) of the `vertex` element,
//! write `x y z` float vertices (and, for coloured maps, `uchar red green blue`).
//!
//! Reads `ascii` and `binary_little_endian` 1.0 with any scalar properties besides
//! `x`, `y`, `z` (which must be `float` or `double`), and other elements before or after
//! `vertex` (list properties included). `binary_big_endian` is reported as unsupported.
//! `double` coordinates are rounded to `f32`, the precision of [`Frame`] points. Files may be
//! `.gz`/`.bz2` compressed. Non-finite coordinates are passed through; consumers skip them.

use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::output::{write_atomic, OutputError};
use crate::source;
use nalgebra::Point3;
use octoquant_octree::Color;
use std::io::Write;
use std::path::Path;

/// Vertex positions and, when read, one colour per vertex ([`parse_ply_colored`]).
pub type ColoredPoints = (Vec<Point3<f32>>, Option<Vec<Color>>);

/// PLY body encodings this module writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    /// `format ascii 1.0`: one `x y z` line per vertex, shortest round-trip decimal.
    Ascii,
    /// `format binary_little_endian 1.0`: 12 bytes per vertex.
    #[default]
    BinaryLittleEndian,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    /// Little-endian value at the start of `b` (which holds at least `size()` bytes).
    fn read_le(self, b: &[u8]) -> f64 {
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
            Scalar::U16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
            Scalar::I32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::U32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            Scalar::F64 => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar(Scalar, String),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
}

/// Read the vertex positions of a PLY file, as `f32` (the `.frames` and OctoMap storage type;
/// `_f32` by the crate's precision convention).
pub fn read_ply_f32(path: &Path) -> Result<Vec<Point3<f32>>, FormatError> {
    let data = source::read_all(path)?;
    parse_ply_f32(path, &data)
}

/// Read a PLY file as one frame with origin (0, 0, 0) and no stamp.
pub fn read_ply_frames(path: &Path) -> Result<Vec<Frame>, FormatError> {
    read_ply_frames_with(path, false)
}

/// [`read_ply_frames`], with [`Frame::colors`] from the vertex's `red green blue` when
/// `colors` is set and the file has them.
pub fn read_ply_frames_with(path: &Path, colors: bool) -> Result<Vec<Frame>, FormatError> {
    let data = source::read_all(path)?;
    let (points, colors) = parse_ply_colored(path, &data, colors)?;
    Ok(vec![Frame {
        colors,
        ..Frame::new_f32(Point3::origin(), points)
    }])
}

/// Parse PLY bytes into `f32` vertex positions (see [`read_ply_f32`]); `path` only names the
/// input in errors.
pub fn parse_ply_f32(path: &Path, data: &[u8]) -> Result<Vec<Point3<f32>>, FormatError> {
    parse_ply_colored(path, data, false).map(|(p, _)| p)
}

/// [`parse_ply_f32`] with the vertex colours when `colors` is set: the `red`, `green` and
/// `blue` properties (`uchar`), `None` when the vertex has none of them. A vertex with only
/// some of them, or of another type, is an error.
pub fn parse_ply_colored(
    path: &Path,
    data: &[u8],
    colors: bool,
) -> Result<ColoredPoints, FormatError> {
    let (format, elements, body) = parse_header(path, data)?;
    match format {
        Format::Ascii => read_ascii(path, data, body, &elements, colors),
        Format::BinaryLe => read_binary(path, data, body, &elements, colors),
    }
}

/// What each vertex property is: 0..3 `x y z`, 3..6 `red green blue` (when asked for), or
/// nothing; and whether the colour is there.
fn vertex_roles(path: &Path, el: &Element, colors: bool) -> Result<(Vec<u8>, bool), FormatError> {
    let xyz = xyz_props(path, el)?;
    let mut roles = vec![NO_ROLE; el.props.len()];
    for (a, &k) in xyz.iter().enumerate() {
        roles[k] = a as u8;
    }
    if !colors {
        return Ok((roles, false));
    }
    let mut rgb = [None; 3];
    for (k, p) in el.props.iter().enumerate() {
        if let Property::Scalar(t, name) = p {
            let Some(c) = ["red", "green", "blue"].iter().position(|n| n == name) else {
                continue;
            };
            if *t != Scalar::U8 {
                return Err(FormatError::unsupported(
                    path,
                    Location::File,
                    format!("vertex property {name} is not uchar (colours are 0..255 bytes)"),
                ));
            }
            rgb[c] = Some(k);
        }
    }
    match rgb {
        [None, None, None] => Ok((roles, false)),
        [Some(r), Some(g), Some(b)] => {
            for (c, k) in [r, g, b].into_iter().enumerate() {
                roles[k] = 3 + c as u8;
            }
            Ok((roles, true))
        }
        _ => Err(FormatError::syntax(
            path,
            Location::File,
            "vertex has some of red, green, blue but not all three",
        )),
    }
}

/// The role of a vertex property that is neither a coordinate nor a colour channel.
const NO_ROLE: u8 = u8::MAX;

/// Returns the format, the elements and the byte offset of the body.
fn parse_header(path: &Path, data: &[u8]) -> Result<(Format, Vec<Element>, usize), FormatError> {
    let mut pos = 0usize;
    let mut line_no = 0u64;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = data[pos..].iter().position(|&b| b == b'\n') else {
            return Err(FormatError::Truncated {
                path: path.to_path_buf(),
                offset: data.len() as u64,
                what: "a PLY header ending in end_header".into(),
            });
        };
        line_no += 1;
        let at = Location::Line(line_no);
        let line = std::str::from_utf8(&data[pos..pos + len])
            .map_err(|_| FormatError::syntax(path, at, "header is not text"))?
            .trim_end_matches('\r');
        pos += len + 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if words != ["ply"] {
                return Err(FormatError::syntax(
                    path,
                    at,
                    "not a PLY file (no `ply` line)",
                ));
            }
            continue;
        }
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match (words.get(1).copied(), words.get(2).copied()) {
                    (Some("ascii"), Some("1.0")) => Format::Ascii,
                    (Some("binary_little_endian"), Some("1.0")) => Format::BinaryLe,
                    (Some("binary_big_endian"), _) => {
                        return Err(FormatError::unsupported(path, at, "binary_big_endian PLY"))
                    }
                    _ => {
                        return Err(FormatError::syntax(
                            path,
                            at,
                            format!("bad format line `{}`", source::excerpt(line)),
                        ))
                    }
                });
            }
            Some("element") => {
                let (Some(name), Some(count), None) = (words.get(1), words.get(2), words.get(3))
                else {
                    return Err(FormatError::syntax(
                        path,
                        at,
                        "expected `element NAME COUNT`",
                    ));
                };
                let count: u64 = count
                    .parse()
                    .map_err(|_| FormatError::syntax(path, at, format!("bad count `{count}`")))?;
                elements.push(Element {
                    name: (*name).to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(FormatError::syntax(path, at, "property before any element"));
                };
                let scalar = |s: &str| {
                    Scalar::parse(s).ok_or_else(|| {
                        FormatError::syntax(path, at, format!("unknown property type `{s}`"))
                    })
                };
                let prop = match words.as_slice() {
                    ["property", "list", c, i, _name] => Property::List {
                        count: scalar(c)?,
                        item: scalar(i)?,
                    },
                    ["property", t, name] => Property::Scalar(scalar(t)?, (*name).to_string()),
                    _ => {
                        return Err(FormatError::syntax(
                            path,
                            at,
                            format!("bad property line `{}`", source::excerpt(line)),
                        ))
                    }
                };
                el.props.push(prop);
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(FormatError::syntax(
                    path,
                    at,
                    format!("unknown header keyword `{other}`"),
                ))
            }
        }
    }
    let Some(format) = format else {
        return Err(FormatError::syntax(
            path,
            Location::File,
            "no format line in the header",
        ));
    };
    if !elements.iter().any(|e| e.name == "vertex") {
        return Err(FormatError::syntax(
            path,
            Location::File,
            "no vertex element",
        ));
    }
    Ok((format, elements, pos))
}

/// Positions of x, y, z among the vertex's scalar properties (by property number).
fn xyz_props(path: &Path, el: &Element) -> Result<[usize; 3], FormatError> {
    let mut idx = [usize::MAX; 3];
    for (k, p) in el.props.iter().enumerate() {
        if let Property::Scalar(t, name) = p {
            let axis = match name.as_str() {
                "x" => 0,
                "y" => 1,
                "z" => 2,
                _ => continue,
            };
            if !matches!(t, Scalar::F32 | Scalar::F64) {
                return Err(FormatError::unsupported(
                    path,
                    Location::File,
                    format!("vertex property {name} is not float or double"),
                ));
            }
            idx[axis] = k;
        }
    }
    if idx.contains(&usize::MAX) {
        return Err(FormatError::syntax(
            path,
            Location::File,
            "vertex lacks x, y or z",
        ));
    }
    Ok(idx)
}

fn read_binary(
    path: &Path,
    data: &[u8],
    mut pos: usize,
    elements: &[Element],
    want_colors: bool,
) -> Result<ColoredPoints, FormatError> {
    let truncated = |offset: usize, what: &str| FormatError::Truncated {
        path: path.to_path_buf(),
        offset: offset as u64,
        what: what.into(),
    };
    for el in elements {
        let is_vertex = el.name == "vertex";
        let (roles, has_colors) = if is_vertex {
            vertex_roles(path, el, want_colors)?
        } else {
            (Vec::new(), false)
        };
        // The fewest bytes a record takes (its scalars and the count of each list): the count
        // must fit in the remaining data before anything is reserved or looped over.
        let min_record: u64 = el
            .props
            .iter()
            .map(|p| match p {
                Property::Scalar(t, _) => t.size() as u64,
                Property::List { count, .. } => count.size() as u64,
            })
            .sum();
        let remaining = (data.len() - pos) as u64;
        if min_record
            .checked_mul(el.count)
            .is_none_or(|need| need > remaining)
        {
            return Err(truncated(
                data.len(),
                &format!("{} {} records", el.count, el.name),
            ));
        }
        if min_record == 0 {
            // records without properties hold no bytes (a vertex always has x, y, z)
            continue;
        }
        let mut points = Vec::new();
        let mut colors = Vec::new();
        if is_vertex {
            points.reserve(el.count as usize);
            if has_colors {
                colors.reserve(el.count as usize);
            }
        }
        for _ in 0..el.count {
            let mut xyz_v = [0f64; 3];
            let mut rgb = [0u8; 3];
            for (k, p) in el.props.iter().enumerate() {
                match p {
                    Property::Scalar(t, _) => {
                        let end = pos + t.size();
                        if end > data.len() {
                            return Err(truncated(pos, &format!("a {} property", el.name)));
                        }
                        match roles.get(k).copied() {
                            Some(a @ 0..=2) => xyz_v[a as usize] = t.read_le(&data[pos..end]),
                            Some(c @ 3..=5) => rgb[c as usize - 3] = data[pos],
                            _ => {}
                        }
                        pos = end;
                    }
                    Property::List { count, item } => {
                        let end = pos + count.size();
                        if end > data.len() {
                            return Err(truncated(pos, "a list count"));
                        }
                        let n = count.read_le(&data[pos..end]);
                        if !(0.0..=1e12).contains(&n) {
                            return Err(FormatError::syntax(
                                path,
                                Location::Byte(pos as u64),
                                format!("bad list count {n}"),
                            ));
                        }
                        let bytes = n as usize * item.size();
                        if bytes > data.len() - end {
                            return Err(truncated(end, "list items"));
                        }
                        pos = end + bytes;
                    }
                }
            }
            if is_vertex {
                points.push(Point3::new(
                    xyz_v[0] as f32,
                    xyz_v[1] as f32,
                    xyz_v[2] as f32,
                ));
                if has_colors {
                    colors.push(Color::new(rgb[0], rgb[1], rgb[2]));
                }
            }
        }
        if is_vertex {
            return Ok((points, has_colors.then_some(colors)));
        }
    }
    Ok((Vec::new(), None))
}

fn read_ascii(
    path: &Path,
    data: &[u8],
    body: usize,
    elements: &[Element],
    want_colors: bool,
) -> Result<ColoredPoints, FormatError> {
    let text = std::str::from_utf8(&data[body..])
        .map_err(|_| FormatError::syntax(path, Location::Byte(body as u64), "body is not text"))?;
    let header_lines = data[..body].iter().filter(|&&b| b == b'\n').count() as u64;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (header_lines + 1 + i as u64, l))
        .filter(|(_, l)| !l.trim().is_empty());
    for el in elements {
        let is_vertex = el.name == "vertex";
        let (xyz, rgb) = if is_vertex {
            let (roles, has_colors) = vertex_roles(path, el, want_colors)?;
            let find = |r: u8| roles.iter().position(|&x| x == r).unwrap_or(0);
            let rgb = has_colors.then(|| [find(3), find(4), find(5)]);
            (Some(xyz_props(path, el)?), rgb)
        } else {
            (None, None)
        };
        let mut points = Vec::new();
        let mut colors = Vec::new();
        if is_vertex {
            // Never reserve more than the text could hold (at least 6 bytes per vertex).
            points.reserve((el.count as usize).min(text.len() / 6));
            if rgb.is_some() {
                colors.reserve((el.count as usize).min(text.len() / 12));
            }
        }
        for _ in 0..el.count {
            let Some((no, line)) = lines.next() else {
                return Err(FormatError::Truncated {
                    path: path.to_path_buf(),
                    offset: data.len() as u64,
                    what: format!("{} {} lines", el.count, el.name),
                });
            };
            if let Some(xyz) = &xyz {
                let words: Vec<&str> = line.split_whitespace().collect();
                let mut v = [0f32; 3];
                for (a, &k) in xyz.iter().enumerate() {
                    let w = words.get(k).ok_or_else(|| {
                        FormatError::syntax(path, Location::Line(no), "too few values")
                    })?;
                    let x: f64 = w.parse().map_err(|_| {
                        FormatError::syntax(
                            path,
                            Location::Line(no),
                            format!("bad number `{}`", source::excerpt(w)),
                        )
                    })?;
                    v[a] = x as f32;
                }
                points.push(Point3::new(v[0], v[1], v[2]));
                if let Some(rgb) = &rgb {
                    let mut c = [0u8; 3];
                    for (ch, &k) in c.iter_mut().zip(rgb) {
                        let w = words.get(k).ok_or_else(|| {
                            FormatError::syntax(path, Location::Line(no), "too few values")
                        })?;
                        *ch = w.parse().map_err(|_| {
                            FormatError::syntax(
                                path,
                                Location::Line(no),
                                format!("bad colour `{}` (0..255)", source::excerpt(w)),
                            )
                        })?;
                    }
                    colors.push(Color::new(c[0], c[1], c[2]));
                }
            }
        }
        if is_vertex {
            return Ok((points, rgb.map(|_| colors)));
        }
    }
    Ok((Vec::new(), None))
}

/// Write `points` as a PLY with one `vertex` element of `float x, y, z`.
pub fn write_ply<W: Write + ?Sized>(
    w: &mut W,
    points: &[Point3<f32>],
    encoding: PlyEncoding,
) -> std::io::Result<()> {
    write_ply_colored(w, points, None, encoding)
}

/// [`write_ply`] with, when `colors` is given, `uchar red, green, blue` after the coordinates
/// of each vertex (the layout [`parse_ply_colored`] and common viewers read). `colors` must
/// hold one colour per point; a length mismatch is an `InvalidInput` error, nothing written.
pub fn write_ply_colored<W: Write + ?Sized>(
    w: &mut W,
    points: &[Point3<f32>],
    colors: Option<&[Color]>,
    encoding: PlyEncoding,
) -> std::io::Result<()> {
    if colors.is_some_and(|c| c.len() != points.len()) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "one colour per point is needed",
        ));
    }
    let format = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
    };
    let color_props = if colors.is_some() {
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    } else {
        ""
    };
    write!(
        w,
        "ply\nformat {format} 1.0\ncomment written by octoquant\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n{color_props}end_header\n",
        points.len()
    )?;
    let color_at = |i: usize| colors.map(|c| c[i]);
    match encoding {
        PlyEncoding::Ascii => {
            for (i, p) in points.iter().enumerate() {
                match color_at(i) {
                    Some(c) => writeln!(w, "{} {} {} {} {} {}", p.x, p.y, p.z, c.r, c.g, c.b)?,
                    None => writeln!(w, "{} {} {}", p.x, p.y, p.z)?,
                }
            }
        }
        PlyEncoding::BinaryLittleEndian => {
            const CHUNK: usize = 1 << 16;
            let mut buf = Vec::with_capacity(15 * points.len().min(CHUNK));
            for (k, chunk) in points.chunks(CHUNK).enumerate() {
                buf.clear();
                for (j, p) in chunk.iter().enumerate() {
                    buf.extend_from_slice(&p.x.to_le_bytes());
                    buf.extend_from_slice(&p.y.to_le_bytes());
                    buf.extend_from_slice(&p.z.to_le_bytes());
                    if let Some(c) = color_at(k * CHUNK + j) {
                        buf.extend_from_slice(&c.to_array());
                    }
                }
                w.write_all(&buf)?;
            }
        }
    }
    Ok(())
}

/// Write `points` to `path` atomically (temporary file, then rename).
pub fn write_ply_file(
    path: &Path,
    points: &[Point3<f32>],
    encoding: PlyEncoding,
) -> Result<(), OutputError> {
    write_atomic(path, |w| write_ply(w, points, encoding))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pts() -> Vec<Point3<f32>> {
        vec![
            Point3::new(1.0, -2.5, 3.25),
            Point3::new(0.1, 1e-7, -1e6),
            Point3::new(f32::MAX, f32::MIN_POSITIVE, -0.0),
        ]
    }

    fn bits(p: &[Point3<f32>]) -> Vec<[u32; 3]> {
        p.iter()
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect()
    }

    #[test]
    fn colours_round_trip_and_hostile_colour_properties() {
        let colors = [
            Color::new(1, 2, 3),
            Color::new(255, 0, 128),
            Color::new(9, 9, 9),
        ];
        let p = Path::new("t.ply");
        for enc in [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian] {
            let mut buf = Vec::new();
            write_ply_colored(&mut buf, &pts(), Some(&colors), enc).unwrap();
            let (back, c) = parse_ply_colored(p, &buf, true).unwrap();
            assert_eq!(bits(&back), bits(&pts()), "{enc:?}");
            assert_eq!(c.as_deref(), Some(&colors[..]), "{enc:?}");
            // not asked for: positions only
            assert_eq!(parse_ply_colored(p, &buf, false).unwrap().1, None);
        }
        // colourless files give no colours when asked
        let mut buf = Vec::new();
        write_ply(&mut buf, &pts(), PlyEncoding::Ascii).unwrap();
        assert_eq!(parse_ply_colored(p, &buf, true).unwrap().1, None);
        let head = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n";
        let partial = format!("{head}property uchar red\nend_header\n1 2 3 4\n");
        let e = parse_ply_colored(p, partial.as_bytes(), true).unwrap_err();
        assert!(e.to_string().contains("not all three"), "{e}");
        let wide = format!("{head}property float red\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 4 5 6\n");
        let e = parse_ply_colored(p, wide.as_bytes(), true).unwrap_err();
        assert!(e.to_string().contains("not uchar"), "{e}");
        let big = format!("{head}property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 4 5 256\n");
        let e = parse_ply_colored(p, big.as_bytes(), true).unwrap_err();
        assert!(e.to_string().contains("bad colour `256`"), "{e}");
        let short = format!("{head}property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n1 2 3 4 5\n");
        assert!(parse_ply_colored(p, short.as_bytes(), true).is_err());
        let mismatch = write_ply_colored(
            &mut Vec::new(),
            &pts(),
            Some(&colors[..1]),
            PlyEncoding::Ascii,
        );
        assert!(mismatch.is_err());
    }

    #[test]
    fn round_trip_both_encodings_bit_exact() {
        for enc in [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian] {
            let mut buf = Vec::new();
            write_ply(&mut buf, &pts(), enc).unwrap();
            let back = parse_ply_f32(Path::new("t.ply"), &buf).unwrap();
            assert_eq!(bits(&back), bits(&pts()), "{enc:?}");
        }
    }

    /// Found by the `ply` fuzz target (a timeout): a binary element with no properties and a
    /// count of 42,949,672,950 passed the size check (0 bytes each) and was then looped over
    /// record by record. Such an element takes no bytes and is now skipped at once.
    #[test]
    fn binary_element_without_properties_and_a_huge_count_is_skipped() {
        let mut data = b"ply\nformat binary_little_endian 1.0\nelement junk 42949672950\n\
            element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
            .to_vec();
        for c in [1.0f32, 2.0, 3.0] {
            data.extend_from_slice(&c.to_le_bytes());
        }
        let points = parse_ply_f32(Path::new("empty-element.ply"), &data).unwrap();
        assert_eq!(points, vec![Point3::new(1.0, 2.0, 3.0)]);
        // a count whose byte size overflows u64 is truncation, not an overflow panic
        let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\n\
            property float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse_ply_f32(Path::new("huge.ply"), huge).unwrap_err();
        assert!(matches!(e, FormatError::Truncated { .. }), "{e}");
    }

    #[test]
    fn reads_doubles_extra_properties_and_other_elements() {
        let mut b = b"ply\r\nformat binary_little_endian 1.0\r\ncomment x\r\n\
            element camera 1\r\nproperty list uchar int idx\r\nproperty uchar k\r\n\
            element vertex 2\r\nproperty uchar red\r\nproperty double z\r\nproperty double x\r\n\
            property short s\r\nproperty double y\r\nelement face 1\r\n\
            property list uchar int vertex_indices\r\nend_header\r\n"
            .to_vec();
        b.extend_from_slice(&[2, 1, 0, 0, 0, 2, 0, 0, 0, 9]); // camera: list of 2 ints, k
        for (x, y, z) in [(1.5f64, 2.5f64, 3.5f64), (-1.0, 0.25, 1e-3)] {
            b.push(255);
            b.extend_from_slice(&z.to_le_bytes());
            b.extend_from_slice(&x.to_le_bytes());
            b.extend_from_slice(&(-3i16).to_le_bytes());
            b.extend_from_slice(&y.to_le_bytes());
        }
        let p = parse_ply_f32(Path::new("t.ply"), &b).unwrap();
        assert_eq!(
            p,
            vec![
                Point3::new(1.5, 2.5, 3.5),
                Point3::new(-1.0, 0.25, 1e-3f64 as f32)
            ]
        );
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
            property uchar q\nproperty float y\nproperty float z\nelement face 0\n\
            property list uchar int vertex_indices\nend_header\n1 7 2 3\n\n-4 0 5.5 nan\n";
        let p = parse_ply_f32(Path::new("a.ply"), ascii).unwrap();
        assert_eq!(p[0], Point3::new(1.0, 2.0, 3.0));
        assert_eq!((p[1].x, p[1].y), (-4.0, 5.5));
        assert!(p[1].z.is_nan());
    }

    #[test]
    fn malformed_files_are_errors_naming_the_place() {
        let path = Path::new("bad.ply");
        let cases: &[(&[u8], &str)] = &[
            (b"", "truncated"),
            (b"plx\n", "line 1"),
            (b"ply\nformat binary_big_endian 1.0\nend_header\n", "unsupported"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty int x\nproperty float y\nproperty float z\nend_header\n1 2 3\n", "not float"),
            (b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n", "truncated"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 zz 3\n", "line 8"),
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n", "truncated"),
            (b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n\x00\x00", "truncated"),
            (b"ply\nformat ascii 1.0\nend_header\n", "no vertex"),
            (b"ply\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n", "no format"),
        ];
        for (data, want) in cases {
            let e = parse_ply_f32(path, data).unwrap_err().to_string();
            assert!(
                e.contains("bad.ply") && e.contains(want),
                "{e:?} lacks {want:?}"
            );
        }
    }
}
