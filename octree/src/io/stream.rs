//! A byte reader that knows its offset, for errors that name the place.

use crate::error::OctreeError;
use std::io::Read;

/// Longest header line accepted; OctoMap's are under 80 bytes.
const MAX_LINE: usize = 4096;

pub(crate) struct Stream<R> {
    inner: std::io::BufReader<R>,
    pub offset: u64,
}

impl<R: Read> Stream<R> {
    pub fn new(r: R) -> Self {
        Stream {
            inner: std::io::BufReader::with_capacity(1 << 16, r),
            offset: 0,
        }
    }

    pub fn format_err(&self, format: &'static str, offset: u64, message: String) -> OctreeError {
        OctreeError::Format {
            format,
            offset,
            message,
        }
    }

    fn io_err(&self, e: std::io::Error) -> OctreeError {
        OctreeError::Io {
            offset: self.offset,
            source: e,
        }
    }

    /// Read exactly `buf.len()` bytes; a short stream is an error at the current offset.
    pub fn exact(
        &mut self,
        buf: &mut [u8],
        format: &'static str,
        what: &str,
    ) -> Result<(), OctreeError> {
        match self.inner.read_exact(buf) {
            Ok(()) => {
                self.offset += buf.len() as u64;
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => Err(self.format_err(
                format,
                self.offset,
                format!("file ends inside {what} (truncated)"),
            )),
            Err(e) => Err(self.io_err(e)),
        }
    }

    /// One byte, or `None` at the end of the stream.
    pub fn byte(&mut self) -> Result<Option<u8>, OctreeError> {
        let mut b = [0u8];
        loop {
            match self.inner.read(&mut b) {
                Ok(0) => return Ok(None),
                Ok(_) => {
                    self.offset += 1;
                    return Ok(Some(b[0]));
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(self.io_err(e)),
            }
        }
    }

    /// A line without its `\n` (like `std::getline`); errors past [`MAX_LINE`] bytes.
    pub fn line(&mut self, format: &'static str) -> Result<String, OctreeError> {
        let start = self.offset;
        let mut v = Vec::new();
        while let Some(b) = self.byte()? {
            if b == b'\n' {
                break;
            }
            if v.len() >= MAX_LINE {
                return Err(self.format_err(format, start, "header line too long".into()));
            }
            v.push(b);
        }
        Ok(String::from_utf8_lossy(&v).into_owned())
    }

    /// Skip the rest of the current line.
    pub fn skip_line(&mut self) -> Result<(), OctreeError> {
        while let Some(b) = self.byte()? {
            if b == b'\n' {
                break;
            }
        }
        Ok(())
    }

    /// The next whitespace-separated token (like `istream >> std::string`), with its offset;
    /// `None` at the end of the stream.
    pub fn token(&mut self, format: &'static str) -> Result<Option<(String, u64)>, OctreeError> {
        let mut b = loop {
            match self.byte()? {
                None => return Ok(None),
                Some(b) if b.is_ascii_whitespace() => continue,
                Some(b) => break b,
            }
        };
        let start = self.offset - 1;
        let mut v = Vec::new();
        loop {
            if v.len() >= MAX_LINE {
                return Err(self.format_err(format, start, "header token too long".into()));
            }
            v.push(b);
            // peek: stop before whitespace without consuming more than it
            let offset = self.offset;
            let buf = self
                .inner
                .fill_buf()
                .map_err(|e| OctreeError::Io { offset, source: e })?;
            match buf.first() {
                Some(&n) if !n.is_ascii_whitespace() => {
                    b = n;
                    self.inner.consume(1);
                    self.offset += 1;
                }
                _ => break,
            }
        }
        Ok(Some((String::from_utf8_lossy(&v).into_owned(), start)))
    }

    /// Up to `n` bytes ahead, without consuming them (fewer at the end of the stream).
    pub fn peek(&mut self, n: usize) -> Result<Vec<u8>, OctreeError> {
        let offset = self.offset;
        let buf = self
            .inner
            .fill_buf()
            .map_err(|e| OctreeError::Io { offset, source: e })?;
        Ok(buf[..buf.len().min(n)].to_vec())
    }
}
use std::io::BufRead;
