//! [`TileUpdates`] as bytes, for shipping between processes (Python, Dask).
//!
//! Layout, little endian: the magic `OQTU`, a `u16` version (1), the tile's depth (`u8`),
//! a zero byte, the tile's index (`u64`), the number of frames (`u32`); per frame its index
//! (`u64`), the number of free and of occupied codes (`u32` each), then the free codes and
//! the occupied codes, each list as LEB128 varints: the first code's offset from the tile's
//! first code, then each code's distance to the previous one minus one (so sorted, distinct
//! codes cost one or two bytes each); last, an FNV-1a 64-bit checksum of every byte before
//! it. [`TileUpdates::from_bytes`] checks all of it and the lists' invariants
//! ([`TileUpdates::check`]): a bad buffer is an error naming the byte, never a panic.

use crate::error::TileError;
use crate::split::{TileFrame, TileUpdates};
use crate::tile::{Tile, CODE_BITS};

const MAGIC: &[u8; 4] = b"OQTU";
const VERSION: u16 = 1;

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn put_codes(out: &mut Vec<u8>, base: u64, codes: &[u64]) {
    let mut prev: Option<u64> = None;
    for &c in codes {
        let d = match prev {
            None => c - base,
            Some(p) => c - p - 1,
        };
        put_varint(out, d);
        prev = Some(c);
    }
}

impl TileUpdates {
    /// The lists as bytes (see the module docs). Lists that break [`TileUpdates::check`]
    /// (codes outside the tile or out of order are not representable) are an error; the
    /// splitter's never do.
    pub fn to_bytes(&self) -> Result<Vec<u8>, TileError> {
        self.check()?;
        let base = self.tile.min_key().morton();
        let mut out = Vec::with_capacity(32 + 2 * self.voxel_updates() + 16 * self.frames.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.push(self.tile.depth());
        out.push(0);
        out.extend_from_slice(&self.tile.index().to_le_bytes());
        out.extend_from_slice(&(self.frames.len() as u32).to_le_bytes());
        for f in &self.frames {
            out.extend_from_slice(&f.frame.to_le_bytes());
            out.extend_from_slice(&(f.free.len() as u32).to_le_bytes());
            out.extend_from_slice(&(f.occupied.len() as u32).to_le_bytes());
            put_codes(&mut out, base, &f.free);
            put_codes(&mut out, base, &f.occupied);
        }
        let sum = fnv1a(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        Ok(out)
    }

    /// Read lists written by [`TileUpdates::to_bytes`], checking the magic, the version, the
    /// checksum, every count against the bytes left, every code against the tile, and the
    /// lists' invariants.
    pub fn from_bytes(bytes: &[u8]) -> Result<TileUpdates, TileError> {
        let mut r = Reader { bytes, at: 0 };
        if bytes.len() < 8 {
            return Err(r.err("shorter than a header and a checksum".into()));
        }
        let body = bytes.len() - 8;
        let want = u64::from_le_bytes(bytes[body..].try_into().expect("8 bytes"));
        if fnv1a(&bytes[..body]) != want {
            return Err(TileError::Decode {
                offset: body,
                message: "checksum mismatch (truncated or corrupted buffer)".into(),
            });
        }
        r.bytes = &bytes[..body];
        if r.take(4)? != MAGIC {
            return Err(TileError::Decode {
                offset: 0,
                message: "not a tile update buffer (magic is not OQTU)".into(),
            });
        }
        let version = u16::from_le_bytes(r.array()?);
        if version != VERSION {
            return Err(TileError::Decode {
                offset: 4,
                message: format!("version {version}, this build reads version {VERSION}"),
            });
        }
        let depth = r.take(1)?[0];
        r.take(1)?;
        let index = u64::from_le_bytes(r.array()?);
        let tile = Tile::new(depth, index).map_err(|e| TileError::Decode {
            offset: 6,
            message: e.to_string(),
        })?;
        let base = tile.min_key().morton();
        let span = 1u64 << (CODE_BITS - 3 * depth as u32);
        let n = u32::from_le_bytes(r.array()?) as usize;
        // each frame takes at least 16 bytes: never reserve more than the buffer can hold
        let mut frames = Vec::with_capacity(n.min(r.left() / 16));
        for _ in 0..n {
            let frame = u64::from_le_bytes(r.array()?);
            let nf = u32::from_le_bytes(r.array()?) as usize;
            let no = u32::from_le_bytes(r.array()?) as usize;
            let free = r.codes(nf, base, span)?;
            let occupied = r.codes(no, base, span)?;
            frames.push(TileFrame {
                frame,
                free,
                occupied,
            });
        }
        if r.left() != 0 {
            return Err(r.err(format!("{} bytes left after the last frame", r.left())));
        }
        let lists = TileUpdates { tile, frames };
        lists.check().map_err(|e| TileError::Decode {
            offset: 0,
            message: e.to_string(),
        })?;
        Ok(lists)
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn err(&self, message: String) -> TileError {
        TileError::Decode {
            offset: self.at,
            message,
        }
    }

    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    fn take(&mut self, n: usize) -> Result<&[u8], TileError> {
        if self.left() < n {
            return Err(self.err(format!(
                "ends early: {n} bytes wanted, {} left",
                self.left()
            )));
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], TileError> {
        Ok(self.take(N)?.try_into().expect("N bytes"))
    }

    fn varint(&mut self) -> Result<u64, TileError> {
        let start = self.at;
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = *self.take(1)?.first().expect("one byte");
            let part = (b & 0x7f) as u64;
            if shift == 63 && part > 1 {
                self.at = start;
                return Err(self.err("varint overflows 64 bits".into()));
            }
            v |= part << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        self.at = start;
        Err(self.err("varint longer than 10 bytes".into()))
    }

    /// `n` delta-coded codes inside the tile `[base, base + span)`.
    fn codes(&mut self, n: usize, base: u64, span: u64) -> Result<Vec<u64>, TileError> {
        // each code takes at least a byte
        if n > self.left() {
            return Err(self.err(format!(
                "{n} codes announced, only {} bytes left",
                self.left()
            )));
        }
        let mut out = Vec::with_capacity(n);
        let mut next = 0u64; // the smallest offset the next code may have
        for _ in 0..n {
            let at = self.at;
            let d = self.varint()?;
            let off =
                next.checked_add(d)
                    .filter(|&o| o < span)
                    .ok_or_else(|| TileError::Decode {
                        offset: at,
                        message: "code lies outside the tile".into(),
                    })?;
            out.push(base + off);
            next = off + 1;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample() -> TileUpdates {
        let tile = Tile::new(2, 37).unwrap();
        let base = tile.min_key().morton();
        let span = 1u64 << (48 - 6);
        TileUpdates {
            tile,
            frames: vec![
                TileFrame {
                    frame: 3,
                    free: vec![base, base + 1, base + 200, base + span - 2],
                    occupied: vec![base + 5, base + span - 1],
                },
                TileFrame {
                    frame: 1 << 40,
                    free: vec![],
                    occupied: vec![base + 99],
                },
            ],
        }
    }

    #[test]
    fn round_trips() {
        let s = sample();
        let b = s.to_bytes().unwrap();
        assert_eq!(&b[..4], b"OQTU");
        assert_eq!(TileUpdates::from_bytes(&b).unwrap(), s);
        let empty = TileUpdates::new(Tile::new(0, 0).unwrap());
        assert_eq!(
            TileUpdates::from_bytes(&empty.to_bytes().unwrap()).unwrap(),
            empty
        );
    }

    /// Re-seal a modified body with a valid checksum, to reach the checks behind it.
    fn reseal(mut body: Vec<u8>) -> Vec<u8> {
        let sum = fnv1a(&body);
        body.extend_from_slice(&sum.to_le_bytes());
        body
    }

    #[test]
    fn bad_buffers_are_errors() {
        let b = sample().to_bytes().unwrap();
        let body = b[..b.len() - 8].to_vec();
        // every truncation, and every single-byte change, is caught
        for n in 0..b.len() {
            assert!(
                TileUpdates::from_bytes(&b[..n]).is_err(),
                "truncated to {n}"
            );
        }
        for i in 0..b.len() {
            let mut c = b.clone();
            c[i] ^= 0x41;
            assert!(TileUpdates::from_bytes(&c).is_err(), "byte {i} changed");
        }
        let decode_msg = |bytes: Vec<u8>| match TileUpdates::from_bytes(&bytes) {
            Err(TileError::Decode { message, .. }) => message,
            other => panic!("expected a decode error, got {other:?}"),
        };
        // with a valid checksum: the checks behind it
        let mut v = body.clone();
        v[4] = 9;
        assert!(decode_msg(reseal(v)).contains("version 9"));
        let mut v = body.clone();
        v[6] = 17;
        assert!(decode_msg(reseal(v)).contains("depth"));
        let mut v = body.clone();
        v[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_msg(reseal(v)).contains("ends early"));
        let mut v = body.clone();
        v.push(0);
        assert!(decode_msg(reseal(v)).contains("left after"));
        // a huge code count after a frame header
        let mut v = body[..20].to_vec();
        v.extend_from_slice(&0u64.to_le_bytes());
        v.extend_from_slice(&u32::MAX.to_le_bytes());
        v.extend_from_slice(&0u32.to_le_bytes());
        assert!(decode_msg(reseal(v)).contains("codes announced"));
        // a code beyond the tile
        let mut v = body[..16].to_vec();
        v.extend_from_slice(&1u32.to_le_bytes());
        v.extend_from_slice(&0u64.to_le_bytes());
        v.extend_from_slice(&1u32.to_le_bytes());
        v.extend_from_slice(&0u32.to_le_bytes());
        put_varint(&mut v, 1 << 42);
        assert!(decode_msg(reseal(v)).contains("outside the tile"));
        // an endless varint
        let mut v = body[..16].to_vec();
        v.extend_from_slice(&1u32.to_le_bytes());
        v.extend_from_slice(&0u64.to_le_bytes());
        v.extend_from_slice(&1u32.to_le_bytes());
        v.extend_from_slice(&0u32.to_le_bytes());
        v.extend_from_slice(&[0xff; 11]);
        assert!(decode_msg(reseal(v)).contains("varint"));
        // free and occupied overlapping
        let mut s = sample();
        s.frames[0].occupied[0] = s.frames[0].free[1];
        s.frames[0].occupied.sort();
        assert!(s.to_bytes().is_err());
        s.frames[0].free.remove(1);
        let beyond = s.frames[0].occupied[1] + 7;
        s.frames[0].free.push(beyond);
        assert!(s.to_bytes().is_err(), "a code beyond the tile");
        assert!(decode_msg(b"nonsense-buffer!".to_vec()).contains("checksum"));
    }

    proptest! {
        #[test]
        fn any_lists_round_trip(
            depth in 0u8..=16,
            index_seed in any::<u64>(),
            frames in proptest::collection::vec(
                (proptest::collection::btree_set(any::<u64>(), 0..40), any::<u8>()), 0..5),
        ) {
            let index = if depth == 0 { 0 } else { index_seed >> (64 - 3 * depth as u32) };
            let tile = Tile::new(depth, index).unwrap();
            let base = tile.min_key().morton();
            let span = 1u64 << (48 - 3 * depth as u32);
            let mut out = Vec::new();
            for (i, (codes, split)) in frames.into_iter().enumerate() {
                let codes: std::collections::BTreeSet<u64> =
                    codes.into_iter().map(|c| base + c % span).collect();
                let (mut free, mut occupied) = (Vec::new(), Vec::new());
                for (j, c) in codes.into_iter().enumerate() {
                    if (j as u8).wrapping_add(split) % 3 == 0 {
                        occupied.push(c);
                    } else {
                        free.push(c);
                    }
                }
                out.push(TileFrame { frame: 10 * i as u64 + 2, free, occupied });
            }
            let lists = TileUpdates { tile, frames: out };
            lists.check().unwrap();
            let b = lists.to_bytes().unwrap();
            prop_assert_eq!(TileUpdates::from_bytes(&b).unwrap(), lists);
        }
    }
}
