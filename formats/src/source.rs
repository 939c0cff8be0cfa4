//! The byte source of every reader: a file opened with transparent `.gz`/`.bz2` decompression
//! ([`open`], [`read_all`]) and the extension that names its format ([`logical_extension`]),
//! plus the two cursors the readers share over those bytes: a line reader (text lines with
//! their 1-based numbers) and a byte reader (little-endian values with their offsets), so every
//! error names the file and the line or byte of the problem.
//!
//! # Bounds on hostile input
//! Two rules keep a damaged or malicious file from exhausting memory:
//! - **Size fields never drive an allocation past the input.** A count or length read from a
//!   file reserves at most what the remaining bytes can hold (see `ByteReader::capacity_for`);
//!   buffers grow as data actually arrives.
//! - **Decompressed data is capped** by a [`DecompressionLimit`]: at most
//!   [`DecompressionLimit::max_ratio`] times the compressed size, or
//!   [`DecompressionLimit::min_bytes`], whichever is larger (by default 100 × and 64 MiB). It
//!   applies to `.gz`/`.bz2` files, PCD `binary_compressed` (LZF) data, MCAP chunks and PNG
//!   pixels; a declared decompressed size is checked before anything is allocated. The
//!   limit in force is the calling thread's ([`decompression_limit`]); [`read_frames`]
//!   sets it from [`ReadOptions::decompression`], and [`with_decompression_limit`] sets it
//!   around any other reader call.
//!
//! [`read_frames`]: crate::read_frames
//! [`ReadOptions::decompression`]: crate::ReadOptions::decompression

use crate::error::{FormatError, Location};
use std::cell::Cell;
use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek};
use std::path::{Path, PathBuf};

/// How far compressed data may expand: the output of one compressed stream (a `.gz`/`.bz2`
/// file, an LZF block, an MCAP chunk, a PNG's pixels) may be at most `max_ratio` times its
/// compressed size or `min_bytes`, whichever is larger. Beyond that a reader fails with an
/// error naming the file and the place instead of filling memory (a decompression bomb).
///
/// Real sensor data compresses 2 to 10 fold; raise the limit (or use
/// [`DecompressionLimit::UNLIMITED`]) for legitimately extreme files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DecompressionLimit {
    /// Output allowed per compressed byte.
    pub max_ratio: u64,
    /// Output always allowed, however small the compressed input.
    pub min_bytes: u64,
}

impl DecompressionLimit {
    /// The default: 100 × the compressed size, at least 64 MiB.
    pub const DEFAULT: DecompressionLimit = DecompressionLimit {
        max_ratio: 100,
        min_bytes: 64 << 20,
    };

    /// No limit at all (for trusted inputs that expand more than the default allows).
    pub const UNLIMITED: DecompressionLimit = DecompressionLimit {
        max_ratio: u64::MAX,
        min_bytes: u64::MAX,
    };

    /// The most output allowed from `compressed` bytes of input.
    pub fn max_output(&self, compressed: u64) -> u64 {
        compressed
            .saturating_mul(self.max_ratio)
            .max(self.min_bytes)
    }

    /// Why `output` bytes from `compressed` are refused, or `None` when they are allowed.
    pub(crate) fn check(&self, compressed: u64, output: u64) -> Option<String> {
        let max = self.max_output(compressed);
        (output > max).then(|| {
            format!(
                "{output} bytes decompressed from {compressed} exceed the limit of {max} \
                 ({} x the compressed size, at least {} bytes); raise it \
                 (ReadOptions::decompression, the command line's --max-expansion) if the \
                 file is trusted",
                self.max_ratio, self.min_bytes
            )
        })
    }
}

impl Default for DecompressionLimit {
    fn default() -> Self {
        DecompressionLimit::DEFAULT
    }
}

thread_local! {
    static LIMIT: Cell<DecompressionLimit> = const { Cell::new(DecompressionLimit::DEFAULT) };
}

/// The decompression limit the readers on this thread apply (the default unless inside
/// [`with_decompression_limit`] or [`crate::read_frames`]).
pub fn decompression_limit() -> DecompressionLimit {
    LIMIT.with(Cell::get)
}

/// Run `f` with `limit` as this thread's decompression limit, restoring the previous one
/// afterwards (also when `f` panics).
pub fn with_decompression_limit<T>(limit: DecompressionLimit, f: impl FnOnce() -> T) -> T {
    struct Restore(DecompressionLimit);
    impl Drop for Restore {
        fn drop(&mut self) {
            LIMIT.with(|l| l.set(self.0));
        }
    }
    let _restore = Restore(LIMIT.with(|l| l.replace(limit)));
    f()
}

/// A decompressor's output, cut off with an `InvalidData` error once it passes `max` bytes.
struct Capped<R> {
    inner: R,
    out: u64,
    compressed: u64,
    limit: DecompressionLimit,
}

impl<R: Read> Read for Capped<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.out += n as u64;
        match self.limit.check(self.compressed, self.out) {
            None => Ok(n),
            Some(msg) => Err(std::io::Error::new(std::io::ErrorKind::InvalidData, msg)),
        }
    }
}

/// The compression of an input file, told from its first bytes ([`compression_in`]) or its
/// last extension ([`compression_of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Plain file.
    None,
    /// gzip (`.gz`), possibly several concatenated members.
    Gzip,
    /// bzip2 (`.bz2`), possibly several concatenated streams.
    Bzip2,
}

/// The compression of `path` from its extension (case-insensitive).
pub fn compression_of(path: &Path) -> Compression {
    match lower_ext(path).as_deref() {
        Some("gz") => Compression::Gzip,
        Some("bz2") => Compression::Bzip2,
        _ => Compression::None,
    }
}

/// The compression its first bytes show: gzip's `1f 8b 08` (deflate), or bzip2's `BZh`, a
/// block size digit and the magic of a first block or of an empty stream's end; `None` for
/// anything else (every format octoquant reads starts otherwise).
pub fn compression_in(head: &[u8]) -> Option<Compression> {
    const BLOCK: [u8; 6] = [0x31, 0x41, 0x59, 0x26, 0x53, 0x59];
    const END: [u8; 6] = [0x17, 0x72, 0x45, 0x38, 0x50, 0x90];
    match head {
        [0x1f, 0x8b, 0x08, ..] => Some(Compression::Gzip),
        [b'B', b'Z', b'h', b'1'..=b'9', rest @ ..]
            if rest.len() >= 6 && (rest[..6] == BLOCK || rest[..6] == END) =>
        {
            Some(Compression::Bzip2)
        }
        _ => None,
    }
}

/// The extension that names the format, lower-case, after removing a `.gz`/`.bz2` suffix:
/// `scan.dat.bz2` gives `dat`.
pub fn logical_extension(path: &Path) -> Option<String> {
    match compression_of(path) {
        Compression::None => lower_ext(path),
        _ => path.file_stem().and_then(|s| lower_ext(Path::new(s))),
    }
}

fn lower_ext(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// Open `path` for buffered reading, decompressing gzip and bzip2 on the fly (recognised by
/// their magic bytes whatever the file is called, or by a `.gz`/`.bz2` name) under this
/// thread's [`decompression_limit`] (relative to the compressed file's size): past it, reads
/// fail with an `InvalidData` error that says so.
pub fn open(path: &Path) -> Result<Box<dyn BufRead + Send>, FormatError> {
    Ok(match open_skippable(path)? {
        Opened::Plain { reader, .. } => Box::new(reader),
        Opened::Stream(reader) => reader,
    })
}

/// An input opened by [`open_skippable`]: a regular file stored as it is, which can pass over
/// bytes without reading them, or a stream (decompressed data, a pipe), which has to read them.
pub enum Opened {
    /// An uncompressed regular file and its length in bytes.
    Plain {
        /// The file, buffered.
        reader: BufReader<File>,
        /// Bytes in the file when it was opened.
        len: u64,
    },
    /// A gzip or bzip2 file, decompressed under the decompression limit, or an input that is
    /// not a regular file.
    Stream(Box<dyn BufRead + Send>),
}

impl Opened {
    /// Pass over the next `n` bytes (fewer at the end of the input), returning how many were
    /// passed. An uncompressed file moves its position without reading (what lets a reader
    /// jump to the part of a large file it needs); compressed data is decoded and dropped.
    pub fn skip(&mut self, n: u64) -> std::io::Result<u64> {
        match self {
            Opened::Plain { reader, len } => {
                let at = reader.stream_position()?;
                let n = n.min(len.saturating_sub(at));
                // a skip within `len` fits an `i64`: file lengths do
                reader.seek_relative(i64::try_from(n).map_err(std::io::Error::other)?)?;
                Ok(n)
            }
            Opened::Stream(reader) => std::io::copy(&mut reader.take(n), &mut std::io::sink()),
        }
    }
}

impl Read for Opened {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Opened::Plain { reader, .. } => reader.read(buf),
            Opened::Stream(reader) => reader.read(buf),
        }
    }
}

impl BufRead for Opened {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        match self {
            Opened::Plain { reader, .. } => reader.fill_buf(),
            Opened::Stream(reader) => reader.fill_buf(),
        }
    }

    fn consume(&mut self, amt: usize) {
        match self {
            Opened::Plain { reader, .. } => reader.consume(amt),
            Opened::Stream(reader) => reader.consume(amt),
        }
    }
}

/// [`open`], keeping an uncompressed file seekable (see [`Opened::skip`]).
pub fn open_skippable(path: &Path) -> Result<Opened, FormatError> {
    let file = File::open(path).map_err(|e| FormatError::io(path, Location::File, e))?;
    let meta = file.metadata().ok();
    let compressed = meta.as_ref().map_or(0, |m| m.len());
    let regular = meta.is_some_and(|m| m.is_file());
    let mut raw = BufReader::with_capacity(1 << 16, file);
    // the first bytes decide; the extension only when they show no compression (a file
    // named .gz that is not gzip then fails in the decoder, naming the file)
    let head = raw
        .fill_buf()
        .map_err(|e| FormatError::io(path, Location::File, e))?;
    let compression = compression_in(head).unwrap_or_else(|| compression_of(path));
    let capped = |inner| Capped {
        inner,
        out: 0,
        compressed,
        limit: decompression_limit(),
    };
    Ok(match compression {
        Compression::None if regular => Opened::Plain {
            reader: raw,
            len: compressed,
        },
        Compression::None => Opened::Stream(Box::new(raw)),
        Compression::Gzip => Opened::Stream(Box::new(BufReader::with_capacity(
            1 << 16,
            capped(Box::new(flate2::bufread::MultiGzDecoder::new(raw)) as Box<dyn Read + Send>),
        ))),
        Compression::Bzip2 => Opened::Stream(Box::new(BufReader::with_capacity(
            1 << 16,
            capped(Box::new(bzip2::bufread::MultiBzDecoder::new(raw))),
        ))),
    })
}

/// Little-endian fields with errors naming the file and offset, from memory ([`ByteReader`])
/// or from a file read as it goes ([`FieldStream`]): what a record parser is written against,
/// so that a whole-file parse and a stream read the same records with the same errors. The
/// typed fields are written once, over [`Fields::array`].
pub(crate) trait Fields {
    /// The next `N` bytes, or the truncation error naming `what`.
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], FormatError>;

    /// A syntax error `back` bytes before the current offset.
    fn error_back(&self, back: u64, message: String) -> FormatError;

    /// A little-endian `u32`.
    fn u32(&mut self, what: &str) -> Result<u32, FormatError> {
        self.array(what).map(u32::from_le_bytes)
    }

    /// A little-endian `i32`.
    fn i32(&mut self, what: &str) -> Result<i32, FormatError> {
        self.array(what).map(i32::from_le_bytes)
    }

    /// A little-endian `f32`.
    fn f32(&mut self, what: &str) -> Result<f32, FormatError> {
        self.array(what).map(f32::from_le_bytes)
    }

    /// A little-endian `f64`.
    fn f64(&mut self, what: &str) -> Result<f64, FormatError> {
        self.array(what).map(f64::from_le_bytes)
    }
}

impl Fields for ByteReader<'_> {
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], FormatError> {
        let s = self.take(N, what)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    fn error_back(&self, back: u64, message: String) -> FormatError {
        self.error_at(usize::try_from(back).unwrap_or(usize::MAX), message)
    }
}

impl Fields for FieldStream {
    fn array<const N: usize>(&mut self, what: &str) -> Result<[u8; N], FormatError> {
        let mut a = [0u8; N];
        let start = self.pos;
        let mut got = 0;
        while got < N {
            let buf = self
                .inner
                .fill_buf()
                .map_err(|e| FormatError::io(&self.path, Location::Byte(self.pos), e))?;
            if buf.is_empty() {
                break;
            }
            let k = buf.len().min(N - got);
            a[got..got + k].copy_from_slice(&buf[..k]);
            self.inner.consume(k);
            got += k;
            self.pos += k as u64;
        }
        if got < N {
            return Err(self.truncated(what, N as u64, start));
        }
        Ok(a)
    }

    fn error_back(&self, back: u64, message: String) -> FormatError {
        FormatError::syntax(
            &self.path,
            Location::Byte(self.pos.saturating_sub(back)),
            message,
        )
    }
}

/// Little-endian fields read one after another from a file, tracking the offset so that
/// every error names the file and byte: the streaming counterpart of [`ByteReader`], for
/// formats read a frame at a time (`.frames`, `.graph`). A field cut short by the end of the
/// file is the same truncation error `ByteReader` gives on the whole file's bytes.
pub(crate) struct FieldStream {
    path: PathBuf,
    inner: Opened,
    pos: u64,
}

impl FieldStream {
    /// `path` opened at its first byte ([`open_skippable`]).
    pub(crate) fn open(path: &Path) -> Result<Self, FormatError> {
        Ok(FieldStream {
            path: path.to_path_buf(),
            inner: open_skippable(path)?,
            pos: 0,
        })
    }

    /// Bytes consumed so far.
    pub(crate) fn pos(&self) -> u64 {
        self.pos
    }

    /// Bytes left in the file, when that is known without reading them (an uncompressed
    /// regular file).
    pub(crate) fn remaining(&self) -> Option<u64> {
        match &self.inner {
            Opened::Plain { len, .. } => Some(len.saturating_sub(self.pos)),
            Opened::Stream(_) => None,
        }
    }

    /// The truncation error of `n` bytes of `what` wanted from byte `start`, at the current
    /// offset (the end of the file).
    pub(crate) fn truncated(&self, what: &str, n: u64, start: u64) -> FormatError {
        FormatError::Truncated {
            path: self.path.clone(),
            offset: self.pos,
            what: format!("{what} ({n} bytes from byte {start})"),
        }
    }

    /// Append exactly `n` bytes to `buf`, growing it as data arrives (a length read from the
    /// file never allocates past what the file holds).
    pub(crate) fn fill(
        &mut self,
        buf: &mut Vec<u8>,
        n: u64,
        what: &str,
    ) -> Result<(), FormatError> {
        let start = self.pos;
        let got = (&mut self.inner)
            .take(n)
            .read_to_end(buf)
            .map_err(|e| FormatError::io(&self.path, Location::Byte(self.pos), e))?;
        self.pos += got as u64;
        if (got as u64) < n {
            return Err(self.truncated(what, n, start));
        }
        Ok(())
    }

    /// Pass over exactly `n` bytes without reading them where the file allows
    /// ([`Opened::skip`]); the same truncation error as [`FieldStream::fill`].
    pub(crate) fn skip(&mut self, n: u64, what: &str) -> Result<(), FormatError> {
        let start = self.pos;
        let got = self
            .inner
            .skip(n)
            .map_err(|e| FormatError::io(&self.path, Location::Byte(start), e))?;
        self.pos += got;
        if got < n {
            return Err(self.truncated(what, n, start));
        }
        Ok(())
    }

    /// At the end of the data: nothing may follow (else the error counts the bytes left,
    /// `after` naming what they follow).
    pub(crate) fn check_end(&mut self, after: &str) -> Result<(), FormatError> {
        let at = self.pos;
        let trailing = std::io::copy(&mut self.inner, &mut std::io::sink())
            .map_err(|e| FormatError::io(&self.path, Location::Byte(at), e))?;
        if trailing != 0 {
            return Err(FormatError::syntax(
                &self.path,
                Location::Byte(at),
                format!("{trailing} bytes of trailing data after {after}"),
            ));
        }
        Ok(())
    }
}

/// How far a stream of records read one at a time from a [`FieldStream`] has come (the
/// frame streams of `.frames` and `.graph` files): records left, the next one's index, and
/// whether the stream has ended (after the end check that follows the last record, or at
/// the first error, which ends it).
pub(crate) struct RecordProgress {
    left: u32,
    next: u32,
    done: bool,
}

impl RecordProgress {
    /// A stream of `count` records, none read.
    pub(crate) fn new(count: u32) -> Self {
        RecordProgress {
            left: count,
            next: 0,
            done: false,
        }
    }

    /// The next item: the next record as `read` makes it from the fields (given its
    /// index), or after the last record the error of the end check `finish`, if any.
    pub(crate) fn next_item<T>(
        &mut self,
        fields: &mut FieldStream,
        read: impl FnOnce(&mut FieldStream, u32) -> Result<T, FormatError>,
        finish: impl FnOnce(&mut FieldStream) -> Result<(), FormatError>,
    ) -> Option<Result<T, FormatError>> {
        if self.done {
            return None;
        }
        if self.left == 0 {
            self.done = true;
            return finish(fields).err().map(Err);
        }
        let r = read(fields, self.next);
        self.advance(r.is_ok());
        Some(r)
    }

    /// Pass over the next `n` records with `skip` (fewer when fewer are left); how many were
    /// passed. An error ends the stream.
    pub(crate) fn skip(
        &mut self,
        fields: &mut FieldStream,
        n: usize,
        mut skip: impl FnMut(&mut FieldStream, u32) -> Result<(), FormatError>,
    ) -> Result<usize, FormatError> {
        let mut passed = 0;
        while passed < n && self.left > 0 && !self.done {
            let r = skip(fields, self.next);
            self.advance(r.is_ok());
            r?;
            passed += 1;
        }
        Ok(passed)
    }

    fn advance(&mut self, ok: bool) {
        if ok {
            self.next += 1;
            self.left -= 1;
        } else {
            self.done = true;
        }
    }

    /// The records still announced (and perhaps the end check's error).
    pub(crate) fn size_hint(&self) -> (usize, Option<usize>) {
        if self.done {
            return (0, Some(0));
        }
        let left = self.left as usize;
        (left, Some(left + 1))
    }
}

/// The whole (decompressed) contents of `path`. A read or decompression error reports the
/// number of decompressed bytes obtained before it.
pub fn read_all(path: &Path) -> Result<Vec<u8>, FormatError> {
    let mut r = open(path)?;
    let mut data = Vec::new();
    if compression_of(path) == Compression::None {
        if let Ok(m) = std::fs::metadata(path) {
            data.reserve(usize::try_from(m.len()).unwrap_or(0));
        }
    }
    let mut buf = vec![0u8; 1 << 16];
    loop {
        match r.read(&mut buf) {
            Ok(0) => return Ok(data),
            Ok(n) => data.extend_from_slice(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(FormatError::io(path, Location::Byte(data.len() as u64), e)),
        }
    }
}

/// The first 40 characters of `s`, for quoting a token in an error message: a message never
/// copies an unbounded token of the input (a 1 GB line of zeros stays a short message).
pub(crate) fn excerpt(s: &str) -> &str {
    s.char_indices().nth(40).map_or(s, |(cut, _)| &s[..cut])
}

/// Reads a text file line by line, keeping the 1-based line number for error messages.
pub(crate) struct LineReader<'p> {
    path: &'p Path,
    inner: Box<dyn BufRead + Send>,
    buf: Vec<u8>,
    line_no: u64,
}

impl<'p> LineReader<'p> {
    /// Open `path` (decompressing as needed).
    pub(crate) fn open(path: &'p Path) -> Result<Self, FormatError> {
        Ok(LineReader {
            path,
            inner: open(path)?,
            buf: Vec::new(),
            line_no: 0,
        })
    }

    /// The next line without its `\n` / `\r\n` and with its location, or `None` at the end
    /// of the file.
    pub(crate) fn next_line(&mut self) -> Result<Option<(Location, &str)>, FormatError> {
        self.buf.clear();
        let n = self
            .inner
            .read_until(b'\n', &mut self.buf)
            .map_err(|e| FormatError::io(self.path, Location::Line(self.line_no + 1), e))?;
        if n == 0 {
            return Ok(None);
        }
        self.line_no += 1;
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
        }
        if self.buf.last() == Some(&b'\r') {
            self.buf.pop();
        }
        let at = Location::Line(self.line_no);
        std::str::from_utf8(&self.buf)
            .map(|l| Some((at, l)))
            .map_err(|_| FormatError::syntax(self.path, at, "not valid UTF-8 text"))
    }
}

/// A little-endian cursor over a byte buffer whose errors name the file and offset.
pub(crate) struct ByteReader<'a> {
    path: &'a Path,
    data: &'a [u8],
    pos: usize,
}

impl<'a> ByteReader<'a> {
    /// A cursor at the start of `data`, which was read from `path`.
    pub(crate) fn new(path: &'a Path, data: &'a [u8]) -> Self {
        ByteReader { path, data, pos: 0 }
    }

    /// Current offset.
    pub(crate) fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes left.
    pub(crate) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// The next `n` bytes.
    pub(crate) fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], FormatError> {
        if self.remaining() < n {
            return Err(FormatError::Truncated {
                path: self.path.to_path_buf(),
                offset: self.data.len() as u64,
                what: format!("{what} ({n} bytes from byte {})", self.pos),
            });
        }
        let s = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    /// The next `n` bytes for a length computed from file data (which may be absurd).
    pub(crate) fn take_checked(&mut self, n: u64, what: &str) -> Result<&'a [u8], FormatError> {
        match usize::try_from(n) {
            Ok(n) => self.take(n, what),
            Err(_) => Err(FormatError::Truncated {
                path: self.path.to_path_buf(),
                offset: self.data.len() as u64,
                what: format!("{what} ({n} bytes from byte {})", self.pos),
            }),
        }
    }

    /// A syntax error at the current offset (or `back` bytes before it).
    pub(crate) fn error_at(&self, back: usize, message: impl Into<String>) -> FormatError {
        FormatError::syntax(
            self.path,
            Location::Byte(self.pos.saturating_sub(back) as u64),
            message,
        )
    }

    /// A capacity for `count` records of `record_bytes` each that the remaining data can hold,
    /// so a corrupt count never makes a huge allocation.
    pub(crate) fn capacity_for(&self, count: u64, record_bytes: usize) -> usize {
        let fit = self.remaining() / record_bytes.max(1);
        usize::try_from(count).unwrap_or(usize::MAX).min(fit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logical_extension_strips_compression() {
        assert_eq!(
            logical_extension(Path::new("a/scan.dat.bz2")).as_deref(),
            Some("dat")
        );
        assert_eq!(
            logical_extension(Path::new("x.GRAPH.gz")).as_deref(),
            Some("graph")
        );
        assert_eq!(
            logical_extension(Path::new("x.pcd")).as_deref(),
            Some("pcd")
        );
        assert_eq!(logical_extension(Path::new("x.gz")), None);
    }

    /// Compressed files are read whatever they are called; plain files are not mistaken for
    /// compressed ones.
    #[test]
    fn compression_is_told_by_magic_bytes() {
        use std::io::Write;
        let text = b"NODE 0 0 0 0 0 0\n1 2 3\n".repeat(50);
        let dir = std::env::temp_dir().join(format!("octoquant-magic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        gz.write_all(&text).unwrap();
        let gz = gz.finish().unwrap();
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default());
        bz.write_all(&text).unwrap();
        let bz = bz.finish().unwrap();
        let empty_bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::default())
            .finish()
            .unwrap();
        assert_eq!(compression_in(&gz), Some(Compression::Gzip));
        assert_eq!(compression_in(&bz), Some(Compression::Bzip2));
        assert_eq!(compression_in(&empty_bz), Some(Compression::Bzip2));
        assert_eq!(compression_in(b"BZh9 is not a block"), None);
        assert_eq!(compression_in(&text), None);
        for (name, bytes) in [
            ("scan.txt", &gz),
            ("scan2.txt", &bz),
            ("scan.dat.bz2", &gz),
            ("plain.txt", &text),
        ] {
            let p = dir.join(name);
            std::fs::write(&p, bytes).unwrap();
            assert_eq!(read_all(&p).unwrap(), text, "{name}");
        }
        // a file named .gz that holds no gzip data fails in the decoder, naming the file
        let p = dir.join("fake.txt.gz");
        std::fs::write(&p, &text).unwrap();
        let err = read_all(&p).unwrap_err().to_string();
        assert!(err.contains("fake.txt.gz"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn byte_reader_reports_truncation() {
        let data = [1u8, 0, 0, 0, 7];
        let mut r = ByteReader::new(Path::new("f.bin"), &data);
        assert_eq!(r.u32("count").ok(), Some(1));
        let e = r.u32("id").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("f.bin") && e.contains("truncated"), "{e}");
        assert_eq!(r.capacity_for(u64::from(u32::MAX), 12), 0);
    }
}
