//! `.frames`: the exchange format with the C++ reference program (already-transformed `f32`
//! frames, so both sides insert bit-identical points).
//!
//! Layout (little-endian): magic `OCTFRAME` (8 bytes), `u32` version = 1, `u32` frame count;
//! per frame `f32` origin x, y, z, `u32` n, then n × (`f32` x, y, z). Time stamps are not
//! stored.

use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::output::write_atomic;
use crate::source::{read_all, ByteReader, FieldStream, Fields, RecordProgress};
use nalgebra::Point3;
use std::io::{self, Write};
use std::path::Path;

/// The 8-byte magic at the start of a `.frames` file.
pub const FRAMES_MAGIC: &[u8; 8] = b"OCTFRAME";
/// The only version this crate reads and writes.
pub const FRAMES_VERSION: u32 = 1;

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

/// Parse `.frames` bytes; `path` only names the file in errors.
pub fn parse_frames(path: &Path, data: &[u8]) -> Result<Vec<Frame>, FormatError> {
    let mut r = ByteReader::new(path, data);
    if r.take(8, "the OCTFRAME magic")? != FRAMES_MAGIC {
        return Err(r.error_at(8, "not a .frames file (magic is not OCTFRAME)"));
    }
    let version = r.u32("version")?;
    if version != FRAMES_VERSION {
        return Err(FormatError::unsupported(
            path,
            Location::Byte(8),
            format!(".frames version {version} (only {FRAMES_VERSION})"),
        ));
    }
    let n_frames = r.u32("frame count")?;
    let mut frames = Vec::with_capacity(r.capacity_for(n_frames.into(), 16));
    for i in 0..n_frames {
        let (origin, n) = frame_header(&mut r, i)?;
        let bytes = r.take_checked(u64::from(n) * 12, &format!("{n} points of frame {i}"))?;
        frames.push(Frame::new_f32(origin, points_from_le(bytes)));
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
    let version = s.u32("version")?;
    if version != FRAMES_VERSION {
        return Err(FormatError::unsupported(
            path,
            Location::Byte(8),
            format!(".frames version {version} (only {FRAMES_VERSION})"),
        ));
    }
    let count = s.u32("frame count")?;
    Ok(FramesStream {
        fields: s,
        progress: RecordProgress::new(count),
    })
}

/// The frames of a `.frames` file, read as they are asked for ([`frames_file_stream`]), or
/// passed over without reading their points ([`FramesStream::skip_frames`]).
pub struct FramesStream {
    fields: FieldStream,
    progress: RecordProgress,
}

/// Frame `i`'s header: its origin and point count (from the bytes or from the stream).
fn frame_header(s: &mut impl Fields, i: u32) -> Result<(Point3<f32>, u32), FormatError> {
    let what = format!("frame {i} header");
    let origin = Point3::new(s.f32(&what)?, s.f32(&what)?, s.f32(&what)?);
    Ok((origin, s.u32(&what)?))
}

/// Frame `i`, read whole.
fn read_frame(s: &mut FieldStream, i: u32) -> Result<Frame, FormatError> {
    let (origin, n) = frame_header(s, i)?;
    let mut bytes = Vec::new();
    s.fill(
        &mut bytes,
        u64::from(n) * 12,
        &format!("{n} points of frame {i}"),
    )?;
    Ok(Frame::new_f32(origin, points_from_le(&bytes)))
}

/// Frame `i` passed over: its header read, its points skipped.
fn skip_frame(s: &mut FieldStream, i: u32) -> Result<(), FormatError> {
    let (_, n) = frame_header(s, i)?;
    s.skip(u64::from(n) * 12, &format!("{n} points of frame {i}"))
}

impl FramesStream {
    /// Pass over the next `n` frames (fewer when the file announces fewer), returning how
    /// many were passed: only each frame's 16-byte header is read, and an uncompressed file
    /// seeks over the points, so reading frames `k..` of a large file costs about as much as
    /// those frames (a distributed build's slice). A frame cut short by the end of the file is
    /// the truncation error reading it gives, and ends the stream.
    pub fn skip_frames(&mut self, n: usize) -> Result<usize, FormatError> {
        self.progress.skip(&mut self.fields, n, skip_frame)
    }
}

impl Iterator for FramesStream {
    type Item = Result<Frame, FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.progress
            .next_item(&mut self.fields, read_frame, |s| s.check_end("the frames"))
    }

    /// The frames the header still announces (and perhaps the error of trailing data).
    fn size_hint(&self) -> (usize, Option<usize>) {
        self.progress.size_hint()
    }
}

/// Write frames in the `.frames` layout. Fails on I/O or a count above `u32::MAX`.
pub fn write_frames(w: &mut (impl Write + ?Sized), frames: &[Frame]) -> io::Result<()> {
    let count = |n: usize| {
        u32::try_from(n).map_err(|_| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!("count {n} too large for .frames"),
            )
        })
    };
    w.write_all(FRAMES_MAGIC)?;
    w.write_all(&FRAMES_VERSION.to_le_bytes())?;
    w.write_all(&count(frames.len())?.to_le_bytes())?;
    let mut buf = Vec::new();
    for f in frames {
        buf.clear();
        for c in [f.origin.x, f.origin.y, f.origin.z] {
            buf.extend_from_slice(&c.to_le_bytes());
        }
        buf.extend_from_slice(&count(f.points.len())?.to_le_bytes());
        for p in &f.points {
            for c in [p.x, p.y, p.z] {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        w.write_all(&buf)?;
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
