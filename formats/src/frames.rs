//! `.frames`: the exchange format with the C++ reference program (already-transformed `f32`
//! frames, so both sides insert bit-identical points).
//!
//! Layout (little-endian): magic `OCTFRAME` (8 bytes), `u32` version = 1, `u32` frame count;
//! per frame `f32` origin x, y, z, `u32` n, then n × (`f32` x, y, z). Time stamps are not
//! stored.

use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::output::write_atomic;
use crate::source::{read_all, ByteReader};
use nalgebra::Point3;
use std::io::{self, Write};
use std::path::Path;

/// The 8-byte magic at the start of a `.frames` file.
pub const FRAMES_MAGIC: &[u8; 8] = b"OCTFRAME";
/// The only version this crate reads and writes.
pub const FRAMES_VERSION: u32 = 1;

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
        let what = format!("frame {i} header");
        let origin = Point3::new(r.f32(&what)?, r.f32(&what)?, r.f32(&what)?);
        let n = r.u32(&what)?;
        let bytes = r.take_checked(u64::from(n) * 12, &format!("{n} points of frame {i}"))?;
        let points = bytes
            .chunks_exact(12)
            .map(|c| {
                let f = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
                Point3::new(f(0), f(4), f(8))
            })
            .collect();
        frames.push(Frame::new(origin, points));
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
            Frame::new(
                Point3::new(0.1, -0.0, 3.0),
                vec![Point3::new(f32::NAN, 1.0, 2.0)],
            ),
            Frame::new(Point3::origin(), vec![]),
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
