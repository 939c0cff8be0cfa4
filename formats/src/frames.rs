//! `.frames`: the exchange format with the C++ reference program (already-transformed `f32`
//! frames, so both sides insert bit-identical points), and a lossless store of frames.
//!
//! Layout (little-endian): magic `OCTFRAME` (8 bytes), `u32` version, `u32` frame count, then
//! the frames.
//! - Version 1: per frame `f32` origin x, y, z, `u32` n, then n × (`f32` x, y, z).
//! - Version 2 adds what a frame may carry beyond its points: per frame `f32` origin x, y, z,
//!   `u32` n, `u32` flags (bit 0: a time stamp, bit 1: colours, bit 2: a depth camera; no
//!   other bit may be set), then the `f64` stamp (bit 0), the n points as in version 1, n ×
//!   `u8` r, g, b (bit 1), and the camera (bit 2): `u32` width, `u32` height, `f64` fx, fy,
//!   cx, cy, the nine `f64` entries of its rotation matrix row by row, then n × `u32` pixel
//!   (`v·width + u`).
//!
//! [`write_frames`] writes version 1 when no frame carries a stamp, colours or a camera (what
//! every reader of `.frames` reads), version 2 otherwise, so frames written and read back are
//! the same frames, bit for bit: a simulated run saved with `octoquant simulate` keeps its
//! scan times (`map --stamped`) and its depth camera's pixel grid (the faster `exact` path).

use crate::error::{FormatError, Location};
use crate::frame::{CameraPixels, Frame};
use crate::output::write_atomic;
use crate::source::{read_all, ByteReader, FieldStream, Fields, RecordProgress};
use nalgebra::{Matrix3, Point3, Rotation3};
use octoquant_octree::Color;
use octoquant_raycast::PinholeCamera;
use std::io::{self, Write};
use std::path::Path;

/// The 8-byte magic at the start of a `.frames` file.
pub const FRAMES_MAGIC: &[u8; 8] = b"OCTFRAME";
/// The newest version this crate reads and writes (it reads 1 too, and writes 1 for frames
/// that carry nothing but points).
pub const FRAMES_VERSION: u32 = 2;

/// Version 2 flag: the frame has a time stamp.
const HAS_STAMP: u32 = 1;
/// Version 2 flag: the frame has one colour per point.
const HAS_COLORS: u32 = 2;
/// Version 2 flag: the frame has a depth camera and one pixel per point.
const HAS_CAMERA: u32 = 4;
/// Bytes of a camera before its pixels: width, height, four intrinsics, nine matrix entries.
const CAMERA_BYTES: u64 = 8 + 4 * 8 + 9 * 8;
/// Largest deviation of a stored camera matrix from a rotation (`RᵀR = I`, `det R = 1`)
/// accepted on reading: far above the rounding of a matrix made from a quaternion (about
/// 1e-16), far below anything that could move a ray's pixel (the ray caster checks
/// directions to 1e-4 rad).
const ROTATION_TOL: f64 = 1e-9;

/// What a frame's header says: its origin, point count and (version 2) flags.
struct FrameHeader {
    origin: Point3<f32>,
    n: u32,
    flags: u32,
}

/// The version field, checked.
fn check_version(path: &Path, version: u32) -> Result<u32, FormatError> {
    if version == 1 || version == 2 {
        Ok(version)
    } else {
        Err(FormatError::unsupported(
            path,
            Location::Byte(8),
            format!(".frames version {version} (this build reads 1 and 2)"),
        ))
    }
}

/// Frame `i`'s header (of a file of `version`).
fn frame_header(s: &mut impl Fields, version: u32, i: u32) -> Result<FrameHeader, FormatError> {
    let what = format!("frame {i} header");
    let origin = Point3::new(s.f32(&what)?, s.f32(&what)?, s.f32(&what)?);
    let n = s.u32(&what)?;
    let flags = if version >= 2 { s.u32(&what)? } else { 0 };
    if flags & !(HAS_STAMP | HAS_COLORS | HAS_CAMERA) != 0 {
        return Err(s.error_back(
            4,
            format!(
                "frame {i}: flags {flags:#x} hold bits this version does not define (only 0x7)"
            ),
        ));
    }
    Ok(FrameHeader { origin, n, flags })
}

/// Fields of a `.frames` source that come in runs: the in-memory bytes or a file stream.
trait Runs: Fields {
    /// The next `n` bytes (a count read from the file, so perhaps absurd) into `buf`.
    fn run(&mut self, n: u64, what: &str, buf: &mut Vec<u8>) -> Result<(), FormatError>;
    /// Pass over the next `n` bytes.
    fn pass(&mut self, n: u64, what: &str) -> Result<(), FormatError>;
}

impl Runs for ByteReader<'_> {
    fn run(&mut self, n: u64, what: &str, buf: &mut Vec<u8>) -> Result<(), FormatError> {
        buf.clear();
        buf.extend_from_slice(self.take_checked(n, what)?);
        Ok(())
    }

    fn pass(&mut self, n: u64, what: &str) -> Result<(), FormatError> {
        self.take_checked(n, what).map(|_| ())
    }
}

impl Runs for FieldStream {
    fn run(&mut self, n: u64, what: &str, buf: &mut Vec<u8>) -> Result<(), FormatError> {
        buf.clear();
        self.fill(buf, n, what)
    }

    fn pass(&mut self, n: u64, what: &str) -> Result<(), FormatError> {
        self.skip(n, what)
    }
}

/// Frame `i` of a file of `version`; with `colors` false, stored colours are passed over.
/// `buf` is scratch.
fn read_frame(
    s: &mut impl Runs,
    version: u32,
    i: u32,
    colors: bool,
    buf: &mut Vec<u8>,
) -> Result<Frame, FormatError> {
    let h = frame_header(s, version, i)?;
    let n = u64::from(h.n);
    let stamp = if h.flags & HAS_STAMP != 0 {
        Some(s.f64(&format!("time stamp of frame {i}"))?)
    } else {
        None
    };
    s.run(n * 12, &format!("{n} points of frame {i}"), buf)?;
    let mut frame = Frame::new_f32(h.origin, points_from_le(buf));
    frame.stamp = stamp;
    if h.flags & HAS_COLORS != 0 {
        let what = format!("{n} colours of frame {i}");
        if colors {
            s.run(n * 3, &what, buf)?;
            let rgb = buf.chunks_exact(3).map(|c| Color::new(c[0], c[1], c[2]));
            frame.colors = Some(rgb.collect());
        } else {
            s.pass(n * 3, &what)?;
        }
    }
    if h.flags & HAS_CAMERA != 0 {
        let camera = read_camera(s, i)?;
        s.run(n * 4, &format!("{n} pixels of frame {i}"), buf)?;
        let pixels = buf
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        frame.camera = Some(CameraPixels {
            camera,
            pixels: pixels.collect(),
        });
    }
    Ok(frame)
}

/// Frame `i` passed over: its header, stamp and camera read, its points, colours and pixels
/// skipped.
fn skip_frame(s: &mut impl Runs, version: u32, i: u32) -> Result<(), FormatError> {
    let h = frame_header(s, version, i)?;
    let n = u64::from(h.n);
    if h.flags & HAS_STAMP != 0 {
        s.f64(&format!("time stamp of frame {i}"))?;
    }
    s.pass(n * 12, &format!("{n} points of frame {i}"))?;
    if h.flags & HAS_COLORS != 0 {
        s.pass(n * 3, &format!("{n} colours of frame {i}"))?;
    }
    if h.flags & HAS_CAMERA != 0 {
        // read and checked, so that a slice fails where reading the frames would
        read_camera(s, i)?;
        s.pass(n * 4, &format!("{n} pixels of frame {i}"))?;
    }
    Ok(())
}

/// Frame `i`'s camera, checked: a size with at least one pixel whose pixel numbers fit a
/// `u32`, finite intrinsics with positive focal lengths, and a rotation matrix.
fn read_camera(s: &mut impl Runs, i: u32) -> Result<PinholeCamera, FormatError> {
    let what = format!("camera of frame {i}");
    let (width, height) = (s.u32(&what)?, s.u32(&what)?);
    let mut f = [0.0; 4];
    for v in &mut f {
        *v = s.f64(&what)?;
    }
    let mut m = [0.0; 9];
    for v in &mut m {
        *v = s.f64(&what)?;
    }
    let [fx, fy, cx, cy] = f;
    let bad = |message: String| Err(s.error_back(CAMERA_BYTES, format!("frame {i}: {message}")));
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > 1 << 32 {
        return bad(format!("a camera of {width} x {height} pixels"));
    }
    if !(f.iter().all(|v| v.is_finite()) && fx > 0.0 && fy > 0.0) {
        return bad(format!(
            "camera intrinsics fx {fx}, fy {fy}, cx {cx}, cy {cy} (finite, focal lengths > 0)"
        ));
    }
    let matrix = Matrix3::from_row_slice(&m);
    let off = (matrix.transpose() * matrix - Matrix3::identity())
        .abs()
        .max();
    if !(off <= ROTATION_TOL && (matrix.determinant() - 1.0).abs() <= ROTATION_TOL) {
        return bad("the camera's matrix is not a rotation".into());
    }
    Ok(PinholeCamera {
        width,
        height,
        fx,
        fy,
        cx,
        cy,
        rotation: Rotation3::from_matrix_unchecked(matrix),
    })
}

/// The points of a frame's body: little-endian `f32` x, y, z per 12 bytes.
fn points_from_le(bytes: &[u8]) -> Vec<Point3<f32>> {
    bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
            Point3::new(f(0), f(4), f(8))
        })
        .collect()
}

/// Parse `.frames` bytes (version 1 or 2, everything stored); `path` only names the file in
/// errors.
pub fn parse_frames(path: &Path, data: &[u8]) -> Result<Vec<Frame>, FormatError> {
    let mut r = ByteReader::new(path, data);
    if r.take(8, "the OCTFRAME magic")? != FRAMES_MAGIC {
        return Err(r.error_at(8, "not a .frames file (magic is not OCTFRAME)"));
    }
    let version = check_version(path, r.u32("version")?)?;
    let n_frames = r.u32("frame count")?;
    let mut frames = Vec::with_capacity(r.capacity_for(n_frames.into(), 16));
    let mut buf = Vec::new();
    for i in 0..n_frames {
        frames.push(read_frame(&mut r, version, i, true, &mut buf)?);
    }
    if r.remaining() != 0 {
        return Err(r.error_at(
            0,
            format!("{} bytes of trailing data after the frames", r.remaining()),
        ));
    }
    Ok(frames)
}

/// Read a `.frames` file (optionally `.gz`/`.bz2`).
pub fn read_frames_file(path: &Path) -> Result<Vec<Frame>, FormatError> {
    parse_frames(path, &read_all(path)?)
}

/// A `.frames` file (optionally `.gz`/`.bz2`) read one frame at a time: only the frame being
/// read is in memory. Yields what [`parse_frames`] returns, frame by frame, with the same
/// errors (the first error ends the stream).
pub fn frames_file_stream(path: &Path) -> Result<FramesStream, FormatError> {
    let mut s = FieldStream::open(path)?;
    let magic: [u8; 8] = s.array("the OCTFRAME magic")?;
    if &magic != FRAMES_MAGIC {
        return Err(FormatError::syntax(
            path,
            Location::Byte(0),
            "not a .frames file (magic is not OCTFRAME)",
        ));
    }
    let version = check_version(path, s.u32("version")?)?;
    let count = s.u32("frame count")?;
    Ok(FramesStream {
        fields: s,
        progress: RecordProgress::new(count),
        version,
        colors: true,
        buf: Vec::new(),
    })
}

/// The frames of a `.frames` file, read as they are asked for ([`frames_file_stream`]), or
/// passed over without reading their points ([`FramesStream::skip_frames`]).
pub struct FramesStream {
    fields: FieldStream,
    progress: RecordProgress,
    version: u32,
    /// Stored colours are decoded (else passed over).
    colors: bool,
    /// Scratch for a frame's bytes.
    buf: Vec<u8>,
}

impl FramesStream {
    /// Decode stored colours into [`Frame::colors`] (the default) or pass over them, as a
    /// colourless read ([`crate::ReadOptions::colors`] off) does with every format.
    pub fn with_colors(mut self, colors: bool) -> Self {
        self.colors = colors;
        self
    }

    /// Pass over the next `n` frames (fewer when the file announces fewer), returning how
    /// many were passed: only each frame's header (and stamp and camera) is read, and an uncompressed
    /// file seeks over the rest, so reading frames `k..` of a large file costs about as much
    /// as those frames (a distributed build's slice). A frame cut short by the end of the
    /// file is the truncation error reading it gives, and ends the stream.
    pub fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        let version = self.version;
        self.progress
            .skip(&mut self.fields, n, |s, i| skip_frame(s, version, i))
    }
}

impl Iterator for FramesStream {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (version, colors, buf) = (self.version, self.colors, &mut self.buf);
        self.progress.next_item(
            &mut self.fields,
            |s, i| read_frame(s, version, i, colors, buf),
            |s| s.check_end("the frames"),
        )
    }

    /// The frames the header still announces (and perhaps the error of trailing data).
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.progress.size_hint()
    }
}

/// A count as a `u32` field, or the error of a count `.frames` cannot hold.
fn count(n: usize) -> io::Result<u32> {
    u32::try_from(n).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("count {n} too large for .frames"),
        )
    })
}

/// Write frames in the `.frames` layout: version 1 when no frame carries a stamp, colours or
/// a camera, else version 2, which keeps them. Fails on I/O, a count above `u32::MAX`, or
/// colours or pixels whose count is not the frame's point count.
pub fn write_frames(w: &mut (impl Write + ?Sized), frames: &[Frame]) -> io::Result<()> {
    let extra = |f: &Frame| f.stamp.is_some() || f.colors.is_some() || f.camera.is_some();
    let version = if frames.iter().any(extra) { 2 } else { 1 };
    w.write_all(FRAMES_MAGIC)?;
    w.write_all(&u32::to_le_bytes(version))?;
    w.write_all(&count(frames.len())?.to_le_bytes())?;
    let mut buf = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        buf.clear();
        frame_bytes(&mut buf, f, version).map_err(|message| {
            io::Error::new(io::ErrorKind::InvalidInput, format!("frame {i}: {message}"))
        })?;
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Append frame `f`'s bytes in `version`'s layout (the version's caller checked that version
/// 1 loses nothing).
fn frame_bytes(buf: &mut Vec<u8>, f: &Frame, version: u32) -> Result<(), String> {
    let n = f.points.len();
    for c in [f.origin.x, f.origin.y, f.origin.z] {
        buf.extend_from_slice(&c.to_le_bytes());
    }
    buf.extend_from_slice(&count(n).map_err(|e| e.to_string())?.to_le_bytes());
    if version >= 2 {
        let flag = |set: bool, bit: u32| if set { bit } else { 0 };
        let flags = flag(f.stamp.is_some(), HAS_STAMP)
            | flag(f.colors.is_some(), HAS_COLORS)
            | flag(f.camera.is_some(), HAS_CAMERA);
        buf.extend_from_slice(&flags.to_le_bytes());
    }
    if let Some(t) = f.stamp {
        buf.extend_from_slice(&t.to_le_bytes());
    }
    for p in &f.points {
        for c in [p.x, p.y, p.z] {
            buf.extend_from_slice(&c.to_le_bytes());
        }
    }
    if let Some(colors) = &f.colors {
        if colors.len() != n {
            return Err(format!("{} colours for {n} points", colors.len()));
        }
        for c in colors {
            buf.extend_from_slice(&[c.r, c.g, c.b]);
        }
    }
    if let Some(cam) = &f.camera {
        if cam.pixels.len() != n {
            return Err(format!("{} pixels for {n} points", cam.pixels.len()));
        }
        let c = &cam.camera;
        buf.extend_from_slice(&c.width.to_le_bytes());
        buf.extend_from_slice(&c.height.to_le_bytes());
        let m = c.rotation.matrix();
        let rows = (0..3).flat_map(|r| (0..3).map(move |k| m[(r, k)]));
        for v in [c.fx, c.fy, c.cx, c.cy].into_iter().chain(rows) {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        for px in &cam.pixels {
            buf.extend_from_slice(&px.to_le_bytes());
        }
    }
    Ok(())
}

/// Write frames to `path` atomically (temporary file, then rename).
pub fn write_frames_file(path: &Path, frames: &[Frame]) -> Result<(), FormatError> {
    Ok(write_atomic(path, |w| write_frames(w, frames))?)
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_bits() {
        let frames = vec![
            Frame::new_f32(
                Point3::new(0.1, -0.0, 3.0),
                vec![Point3::new(f32::NAN, 1.0, 2.0)],
            ),
            Frame::new_f32(Point3::origin(), vec![]),
        ];
        let mut bytes = Vec::new();
        write_frames(&mut bytes, &frames).ok();
        let back = parse_frames(Path::new("x.frames"), &bytes).unwrap_or_default();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].origin.y.to_bits(), (-0.0f32).to_bits());
        assert!(back[0].points[0].x.is_nan());
    }

    /// A frame with everything version 2 stores: a stamp, colours and a camera whose
    /// rotation is not the identity.
    fn full_frame(n: usize) -> Frame {
        let points = (0..n)
            .map(|k| Point3::new(k as f32 * 0.5, -1.25, f32::from_bits(0x7fc0_0001)))
            .collect();
        let mut f = Frame::new_f32(Point3::new(1.0, -0.0, 2.5), points);
        f.stamp = Some(1_311_868_164.363_641);
        f.colors = Some(
            (0..n)
                .map(|k| Color::new(k as u8, 200, 255 - k as u8))
                .collect(),
        );
        f.camera = Some(CameraPixels {
            camera: PinholeCamera {
                width: 640,
                height: 480,
                fx: 525.0,
                fy: 525.5,
                cx: 319.5,
                cy: 239.5,
                rotation: Rotation3::from_euler_angles(0.3, -1.1, 2.0),
            },
            pixels: (0..n as u32).map(|k| k * 641).collect(),
        });
        f
    }

    /// Every field's bits, for comparing frames that hold NaN.
    fn fingerprint(f: &Frame) -> String {
        let pts: Vec<[u32; 3]> = f
            .points
            .iter()
            .map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect();
        let cam = f.camera.as_ref().map(|c| {
            let m = c.camera.rotation.matrix();
            let bits: Vec<u64> = m.iter().map(|v| v.to_bits()).collect();
            (
                format!(
                    "{:?}",
                    (
                        c.camera.width,
                        c.camera.height,
                        c.camera.fx.to_bits(),
                        c.camera.fy.to_bits(),
                        c.camera.cx.to_bits(),
                        c.camera.cy.to_bits()
                    )
                ),
                bits,
                c.pixels.clone(),
            )
        });
        format!(
            "{:?} {pts:?} {:?} {:?} {cam:?}",
            [
                f.origin.x.to_bits(),
                f.origin.y.to_bits(),
                f.origin.z.to_bits()
            ],
            f.stamp.map(f64::to_bits),
            f.colors
        )
    }

    fn written(frames: &[Frame]) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_frames(&mut bytes, frames).unwrap_or_else(|e| panic!("{e}"));
        bytes
    }

    #[test]
    fn version_2_keeps_stamps_colours_and_cameras() {
        let mut plain =
            Frame::new_f32(Point3::new(0.0, 0.0, 1.0), vec![Point3::new(1.0, 2.0, 3.0)]);
        plain.stamp = None;
        let mut stamped = plain.clone();
        stamped.stamp = Some(-0.0);
        let frames = vec![full_frame(5), plain.clone(), stamped, full_frame(0)];
        let bytes = written(&frames);
        assert_eq!(bytes[8..12], 2u32.to_le_bytes());
        let back = parse_frames(Path::new("x.frames"), &bytes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.len(), frames.len());
        for (a, b) in frames.iter().zip(&back) {
            assert_eq!(fingerprint(a), fingerprint(b));
        }
        // frames with nothing but points stay version 1, byte for byte the old layout
        let v1 = written(&[plain]);
        assert_eq!(v1[8..12], 1u32.to_le_bytes());
        assert_eq!(v1.len(), 16 + 16 + 12);
    }

    #[test]
    fn the_stream_reads_skips_and_drops_colours_as_asked() {
        let frames: Vec<Frame> = (0..4).map(|k| full_frame(3 + k)).collect();
        let dir = std::env::temp_dir().join(format!("oq-frames-v2-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let path = dir.join("v2.frames");
        write_frames_file(&path, &frames).unwrap_or_else(|e| panic!("{e}"));
        let read = |colors: bool, skip: usize| -> Vec<Frame> {
            let mut s = frames_file_stream(&path)
                .unwrap_or_else(|e| panic!("{e}"))
                .with_colors(colors);
            assert_eq!(s.skip_frames(skip).unwrap_or_else(|e| panic!("{e}")), skip);
            s.collect::<Result<_, _>>()
                .unwrap_or_else(|e| panic!("{e}"))
        };
        let all = read(true, 0);
        let rest = read(true, 3);
        assert_eq!(fingerprint(&all[3]), fingerprint(&frames[3]));
        assert_eq!(rest.len(), 1);
        assert_eq!(fingerprint(&rest[0]), fingerprint(&frames[3]));
        let colourless = read(false, 1);
        assert_eq!(colourless.len(), 3);
        for (a, b) in colourless.iter().zip(&frames[1..]) {
            assert!(a.colors.is_none());
            let b = Frame {
                colors: None,
                ..b.clone()
            };
            assert_eq!(fingerprint(a), fingerprint(&b));
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The error of parsing `bytes`, as text.
    fn refusal(bytes: &[u8]) -> String {
        match parse_frames(Path::new("x.frames"), bytes) {
            Ok(_) => panic!("accepted"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn damaged_version_2_frames_are_refused_at_their_place() {
        let good = written(&[full_frame(2)]);
        // the flags field of frame 0 sits at byte 16 + 16
        let mut flags = good.clone();
        flags[32] |= 8;
        let e = refusal(&flags);
        assert!(e.contains("byte 32") && e.contains("flags 0xf"), "{e}");
        // the camera starts after header 20, stamp 8, points 24, colours 6
        let cam = 16 + 20 + 8 + 24 + 6;
        let at = format!("byte {cam}");
        let mut zero_width = good.clone();
        zero_width[cam..cam + 4].copy_from_slice(&0u32.to_le_bytes());
        let e = refusal(&zero_width);
        assert!(e.contains(&at) && e.contains("0 x 480 pixels"), "{e}");
        let mut bad_fx = good.clone();
        bad_fx[cam + 8..cam + 16].copy_from_slice(&(-1.0f64).to_le_bytes());
        let e = refusal(&bad_fx);
        assert!(e.contains(&at) && e.contains("fx -1"), "{e}");
        let mut nan_cy = good.clone();
        nan_cy[cam + 32..cam + 40].copy_from_slice(&f64::NAN.to_le_bytes());
        assert!(refusal(&nan_cy).contains("cy NaN"));
        // a scaled matrix, and a reflection (RᵀR = I, det -1)
        for (entry, v) in [(0, 2.0f64), (8, -1.0)] {
            let mut m = good.clone();
            let at_entry = cam + 40 + 8 * entry;
            let old = f64::from_le_bytes(m[at_entry..at_entry + 8].try_into().unwrap_or_default());
            let scaled = if entry == 0 { old * v } else { old };
            m[at_entry..at_entry + 8].copy_from_slice(&scaled.to_le_bytes());
            if entry == 8 {
                // negate the last row: still orthonormal, but a reflection
                for k in 6..9 {
                    let o = cam + 40 + 8 * k;
                    let x = f64::from_le_bytes(m[o..o + 8].try_into().unwrap_or_default());
                    m[o..o + 8].copy_from_slice(&(-x).to_le_bytes());
                }
            }
            let e = refusal(&m);
            assert!(e.contains(&at) && e.contains("not a rotation"), "{e}");
        }
        // cut inside the pixels
        let e = refusal(&good[..good.len() - 1]);
        assert!(e.contains("pixels of frame 0"), "{e}");
        let mut v3 = good.clone();
        v3[8] = 3;
        assert!(refusal(&v3).contains("version 3"));
    }

    /// Found by the `frames` fuzz target: passing over a frame skipped its camera unchecked,
    /// so a slice of a file with a bad camera failed later than reading it (or not at all).
    #[test]
    fn passing_over_a_frame_checks_its_camera_as_reading_does() {
        let mut bytes = written(&[full_frame(2), full_frame(1)]);
        // frame 0's rotation scaled: the camera starts after the header, stamp, points and
        // colours
        let m00 = 16 + 20 + 8 + 24 + 6 + 40;
        bytes[m00..m00 + 8].copy_from_slice(&2.0f64.to_le_bytes());
        let dir = std::env::temp_dir().join(format!("oq-frames-skip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        let path = dir.join("bad-camera.frames");
        std::fs::write(&path, &bytes).unwrap_or_else(|e| panic!("{e}"));
        let open = || frames_file_stream(&path).unwrap_or_else(|e| panic!("{e}"));
        let read = open().next().and_then(Result::err).map(|e| e.to_string());
        let skipped = open().skip_frames(1).err().map(|e| e.to_string());
        assert!(
            read.as_deref()
                .is_some_and(|e| e.contains("not a rotation")),
            "{read:?}"
        );
        assert_eq!(skipped, read);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn frames_whose_extras_do_not_match_their_points_are_not_written() {
        let mut f = full_frame(3);
        if let Some(c) = f.colors.as_mut() {
            c.pop();
        }
        let e = write_frames(&mut Vec::new(), &[f])
            .err()
            .map(|e| e.to_string());
        assert_eq!(e.as_deref(), Some("frame 0: 2 colours for 3 points"));
        let mut f = full_frame(3);
        if let Some(c) = f.camera.as_mut() {
            c.pixels.push(0);
        }
        let e = write_frames(&mut Vec::new(), &[f])
            .err()
            .map(|e| e.to_string());
        assert_eq!(e.as_deref(), Some("frame 0: 4 pixels for 3 points"));
    }

    #[test]
    fn bad_magic_and_huge_count() {
        let e = parse_frames(Path::new("x.frames"), b"NOTFRAMExxxxxxxx");
        assert!(matches!(e, Err(FormatError::Syntax { .. })));
        let mut b = FRAMES_MAGIC.to_vec();
        b.extend_from_slice(&1u32.to_le_bytes());
        b.extend_from_slice(&1u32.to_le_bytes());
        b.extend_from_slice(&[0u8; 12]);
        b.extend_from_slice(&u32::MAX.to_le_bytes());
        let e = parse_frames(Path::new("x.frames"), &b);
        assert!(matches!(e, Err(FormatError::Truncated { .. })));
    }
}
