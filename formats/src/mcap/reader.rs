//! Reading an MCAP file: its topics ([`list_topics`]) and every cloud of one topic posed in a
//! fixed frame ([`read_mcap`], or one cloud at a time with [`mcap_frames`]), through the
//! chunk-size checks that keep a damaged file from aborting the process.
//!
//! The file is never read whole: the checks seek from record header to record header, the
//! summary is read by seeking to the footer, and messages come from the `mcap` crate's
//! sans-io reader fed from the file, which holds one chunk (compressed and decompressed) at a
//! time. A first pass keeps only the tf messages (the pose of a cloud may depend on
//! transforms logged after it); the second decodes and poses the clouds as they come, and
//! skips clouds by jumping over whole chunks where the summary's chunk indexes and the
//! message index records place them ([`McapFrames::skip_clouds`]), checking the clouds it
//! reads after a jump against what the first pass saw.

use super::cdr::{DecodeError, Encoding};
use super::pointcloud2::{decode_point_cloud2, CloudStats, PointCloud2, CLOUD_SCHEMAS};
use super::tf::{decode_tf_message, TfTree, TF_SCHEMAS};
use crate::error::{FormatError, Location};
use crate::frame::Frame;
use crate::pose::isometry_transform;
use crate::source::decompression_limit;
use nalgebra::{Isometry3, Point3};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// How [`read_mcap`] selects and places clouds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct McapOptions {
    /// The PointCloud2 topic; `None` picks the only one (an error when there are several).
    pub topic: Option<String>,
    /// Express points in this tf frame; `None`: the root of the cloud frame's tf tree (or
    /// the cloud frame itself when the file has no transforms).
    pub fixed_frame: Option<String>,
    /// Pose of the fixed frame in the world, applied last (identity by default).
    pub sensor_pose: Option<Isometry3<f64>>,
    /// Read each point's colour from the cloud's `rgb`/`rgba` field into [`Frame::colors`]
    /// (set from [`crate::ReadOptions::colors`] by [`crate::read_frames`]).
    pub colors: bool,
}

/// A topic of an MCAP file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// Schema name (message type), empty when the channel has no schema.
    pub schema: String,
    /// Message encoding (`ros1`, `cdr`, ...).
    pub encoding: String,
}

fn mcap_err(path: &Path, e: ::mcap::McapError) -> FormatError {
    FormatError::syntax(
        path,
        Location::File,
        format!("not a readable MCAP file: {e}"),
    )
}

/// What the readers need of a file: reads at an offset, and its length.
trait Input: Read + Seek {}
impl<T: Read + Seek> Input for T {}

/// Bytes read ahead by the file's buffer. Small, because the header check
/// ([`check_chunk_sizes`]) and the chunk jumps seek from record to record: each seek past the
/// buffer refills it, and a larger buffer would pull in most of every chunk skipped (with
/// 64 KiB it read the file a second time). Records and chunks of this size or more are
/// read straight into the reader's own buffer.
const READ_BUFFER: usize = 1 << 12;

fn open_file(path: &Path) -> Result<BufReader<File>, FormatError> {
    File::open(path)
        .map(|f| BufReader::with_capacity(READ_BUFFER, f))
        .map_err(|e| FormatError::io(path, Location::File, e))
}

fn file_len(path: &Path, r: &mut impl Input) -> Result<u64, FormatError> {
    r.seek(SeekFrom::End(0))
        .map_err(|e| FormatError::io(path, Location::File, e))
}

/// Move to `at`, keeping a buffered reader's buffer when `at` is inside it.
fn seek_to(path: &Path, r: &mut impl Input, at: u64) -> Result<(), FormatError> {
    let io = |e| FormatError::io(path, Location::Byte(at), e);
    let cur = r.stream_position().map_err(io)?;
    match i64::try_from(i128::from(at) - i128::from(cur)) {
        Ok(d) => r.seek_relative(d).map_err(io),
        Err(_) => r.seek(SeekFrom::Start(at)).map(drop).map_err(io),
    }
}

/// Up to `n` bytes at `at` (fewer at the end of the input); `n` is bounded by the caller.
fn read_at(path: &Path, r: &mut impl Input, at: u64, n: u64) -> Result<Vec<u8>, FormatError> {
    seek_to(path, r, at)?;
    let mut buf = Vec::new();
    r.take(n)
        .read_to_end(&mut buf)
        .map_err(|e| FormatError::io(path, Location::Byte(at), e))?;
    Ok(buf)
}

/// Fill `buf` from `at` as far as the input goes; the number of bytes read.
fn read_into(
    path: &Path,
    r: &mut impl Input,
    at: u64,
    buf: &mut [u8],
) -> Result<usize, FormatError> {
    seek_to(path, r, at)?;
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(k) => got += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(FormatError::io(path, Location::Byte(at), e)),
        }
    }
    Ok(got)
}

/// The messages of an MCAP file in file order, each with its index and channel.
///
/// The `mcap` crate's `MessageStream` sets no limit on the length a record inside a chunk may
/// declare, and allocates (and zero-fills) that length before reading it: one damaged length
/// field (say 2^59 bytes) aborts the process. So the chunk headers are checked first
/// ([`check_chunk_sizes`]), and the messages are read with the crate's `MessageReader` under a
/// record length limit: the file's size or the largest chunk's decompressed size, whichever
/// is larger. No record can be longer than that in a valid file. The reader asks for bytes
/// as it needs them: one chunk is in memory at a time.
///
/// The records come from the crate's `LinearReader` (which opens the chunks), and only the
/// three kinds a message needs (schema, channel, message) are parsed, linked by the crate's
/// `ChannelAccumulator` with the checks its `MessageReader` applies. The others (attachments,
/// metadata, indexes, statistics) are skipped unparsed: the crate's `parse_record` panics on
/// an attachment whose body is shorter than its own header says (`mcap` 0.26, `read.rs`:
/// `&body[header_len..body.len() - 4]`), and a mapper needs none of them. A data end record
/// ends the data section wherever it is (a valid file has one, outside any chunk).
struct Messages<R> {
    path: PathBuf,
    input: R,
    /// The input's length.
    len: u64,
    /// The record length limit (see above).
    limit: usize,
    /// Bytes of the input not yet handed to the reader.
    left: u64,
    reader: ::mcap::sans_io::LinearReader,
    channels: ::mcap::read::ChannelAccumulator<'static>,
    /// When set, the first definition of each schema and channel read, in file order (what a
    /// reader that jumps over chunks needs to know of the channels defined in them).
    definitions: Option<Definitions>,
    /// After the data end record: the summary, whose records are not messages.
    past_data_end: bool,
    done: bool,
    index: usize,
}

/// The schema and channel records of a file, each id's first in file order.
#[derive(Default)]
struct Definitions {
    records: Vec<Definition>,
    seen: std::collections::BTreeSet<(bool, u16)>,
}

enum Definition {
    Schema(::mcap::records::SchemaHeader, Vec<u8>),
    Channel(::mcap::records::Channel),
}

impl Definitions {
    /// Keep `d()` when it is the first record of its kind with id `id`.
    fn add(&mut self, channel: bool, id: u16, d: impl FnOnce() -> Definition) {
        if self.seen.insert((channel, id)) {
            self.records.push(d());
        }
    }
}

/// The crate's record reader under the record length `limit`, at the start of a file or (a
/// jump) at a top-level record. A chunk whose header states the CRC-32 of its records
/// (nonzero) is checked against it before any of its records is handed on, so a damaged
/// chunk gives no message: a bit flipped in an uncompressed chunk, or in a compressed one
/// that its codec does not notice, would otherwise change a point without a word.
fn linear_reader(limit: usize, at_start: bool) -> ::mcap::sans_io::LinearReader {
    ::mcap::sans_io::LinearReader::new_with_options(
        ::mcap::sans_io::LinearReaderOptions::default()
            .with_record_length_limit(limit)
            .with_emit_chunks(false)
            .with_prevalidate_chunk_crcs(true)
            .with_skip_start_magic(!at_start),
    )
}

impl<R: Input> Messages<R> {
    /// Check the chunk headers of `input`, then read its messages from the start.
    fn new(path: &Path, mut input: R) -> Result<Self, FormatError> {
        let len = file_len(path, &mut input)?;
        let largest_chunk = check_chunk_sizes(path, &mut input, len)?;
        let limit = usize::try_from(largest_chunk.max(len)).unwrap_or(usize::MAX);
        Self::checked(path, input, len, limit)
    }

    /// Read the messages of `input` from the start, its chunk headers already checked by
    /// another reader of the same file (of length `len`), which found the limit `limit`.
    fn checked(path: &Path, mut input: R, len: u64, limit: usize) -> Result<Self, FormatError> {
        input
            .seek(SeekFrom::Start(0))
            .map_err(|e| FormatError::io(path, Location::File, e))?;
        Ok(Messages {
            path: path.to_path_buf(),
            input,
            len,
            limit,
            left: len,
            reader: linear_reader(limit, true),
            channels: ::mcap::read::ChannelAccumulator::default(),
            definitions: None,
            past_data_end: false,
            done: false,
            index: 0,
        })
    }

    /// Go on reading at the top-level record at byte `at` (a chunk) as if every record before
    /// it had been read: the message there is message number `index` of the file, and the
    /// schemas and channels are `known` (those of the whole file, which a valid file defines
    /// before their messages). The caller checks that the messages that follow are those of
    /// a linear read.
    fn jump(&mut self, at: u64, index: usize, known: &Definitions) -> Result<(), FormatError> {
        let path = &self.path;
        let Some(left) = self.len.checked_sub(at) else {
            return Err(FormatError::syntax(
                path,
                Location::Byte(at),
                "a chunk index points past the end of the file",
            ));
        };
        let mut channels = ::mcap::read::ChannelAccumulator::default();
        for d in &known.records {
            match d {
                Definition::Schema(h, data) => channels.add_schema_from_slice(h.clone(), data),
                Definition::Channel(c) => channels.add_channel(c.clone()),
            }
            .map_err(|e| mcap_err(path, e))?;
        }
        seek_to(path, &mut self.input, at)?;
        self.left = left;
        self.reader = linear_reader(self.limit, false);
        self.channels = channels;
        self.past_data_end = false;
        self.done = false;
        self.index = index;
        Ok(())
    }

    /// The next message with its index, or `None` after the last (or after an error).
    fn next_message(&mut self) -> Result<Option<(usize, ::mcap::Message<'static>)>, FormatError> {
        if self.done {
            return Ok(None);
        }
        let r = self.next_message_inner();
        if !matches!(r, Ok(Some(_))) {
            self.done = true;
        }
        r
    }

    fn next_message_inner(
        &mut self,
    ) -> Result<Option<(usize, ::mcap::Message<'static>)>, FormatError> {
        use ::mcap::records::{op, Record};
        use ::mcap::sans_io::LinearReadEvent;
        let path = &self.path;
        let err = |e| mcap_err(path, e);
        while let Some(event) = self.reader.next_event() {
            let event = match event {
                Err(::mcap::McapError::BadChunkCrc { saved, calculated }) => {
                    // the chunk was the last record handed to the reader
                    let end = self.len - self.left;
                    return Err(FormatError::syntax(
                        path,
                        Location::Byte(end),
                        format!(
                            "the chunk that ends at this byte is damaged: its records' CRC-32 \
                             is {calculated:08x}, its header says {saved:08x}"
                        ),
                    ));
                }
                e => e,
            };
            let (opcode, data) = match event.map_err(err)? {
                LinearReadEvent::ReadRequest(need) => {
                    // never more than the input still holds: a length field cannot make
                    // this allocate past the file
                    let n = usize::try_from(self.left).map_or(need, |l| need.min(l));
                    let at = self.left;
                    let buf = self.reader.insert(n);
                    let mut got = 0;
                    while got < n {
                        match self.input.read(&mut buf[got..]) {
                            Ok(0) => break,
                            Ok(k) => got += k,
                            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                            Err(e) => return Err(FormatError::io(path, Location::Byte(at), e)),
                        }
                    }
                    self.left -= got as u64;
                    self.reader.notify_read(got);
                    continue;
                }
                LinearReadEvent::Record { opcode, data } => (opcode, data),
            };
            if opcode == op::DATA_END {
                self.past_data_end = true;
                continue;
            }
            if self.past_data_end || ![op::SCHEMA, op::CHANNEL, op::MESSAGE].contains(&opcode) {
                continue;
            }
            match ::mcap::parse_record(opcode, data).map_err(err)? {
                Record::Schema { header, data } => {
                    if let Some(d) = &mut self.definitions {
                        d.add(false, header.id, || {
                            Definition::Schema(header.clone(), data.to_vec())
                        });
                    }
                    self.channels
                        .add_schema_from_slice(header, &data)
                        .map_err(err)?
                }
                Record::Channel(channel) => {
                    if let Some(d) = &mut self.definitions {
                        d.add(true, channel.id, || Definition::Channel(channel.clone()));
                    }
                    self.channels.add_channel(channel).map_err(err)?
                }
                Record::Message { header, data } => {
                    let Some(channel) = self.channels.get(header.channel_id) else {
                        return Err(err(::mcap::McapError::UnknownChannel(
                            header.sequence,
                            header.channel_id,
                        )));
                    };
                    let i = self.index;
                    self.index += 1;
                    let m = ::mcap::Message {
                        channel,
                        sequence: header.sequence,
                        log_time: header.log_time,
                        publish_time: header.publish_time,
                        data: std::borrow::Cow::Owned(data.into_owned()),
                    };
                    return Ok(Some((i, m)));
                }
                _ => {}
            }
        }
        Ok(None)
    }
}

/// Every message of an MCAP file in file order, with its channel, through `visit`.
fn for_each_message<F>(path: &Path, input: impl Input, mut visit: F) -> Result<(), FormatError>
where
    F: FnMut(usize, &::mcap::Message<'static>) -> Result<(), FormatError>,
{
    let mut messages = Messages::new(path, input)?;
    while let Some((i, m)) = messages.next_message()? {
        visit(i, &m)?;
    }
    Ok(())
}

/// Refuse compressed chunks whose header declares a decompressed size beyond the thread's
/// [`decompression_limit`] for their compressed size, and return the largest size a chunk's records take decompressed (0
/// without chunks). The `mcap` crate allocates (and zero-fills) that size
/// before decompressing, so a damaged size field would abort the process instead of failing.
/// Walks the records (opcode, `u64` length, content) from the leading magic to the footer;
/// anything else malformed is left for the crate to report.
fn check_chunk_sizes(path: &Path, input: &mut impl Input, len: u64) -> Result<u64, FormatError> {
    const MAGIC: &[u8] = b"\x89MCAP0\r\n";
    const OP_FOOTER: u8 = 0x02;
    const OP_CHUNK: u8 = 0x06;
    let mut largest = 0;
    if read_at(path, input, 0, MAGIC.len() as u64)? != MAGIC {
        return Ok(largest);
    }
    let u64_at = |b: &[u8], at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(
            b.get(at..at.checked_add(8)?)?.try_into().ok()?,
        ))
    };
    let u32_at = |b: &[u8], at: usize| -> Option<u32> {
        Some(u32::from_le_bytes(
            b.get(at..at.checked_add(4)?)?.try_into().ok()?,
        ))
    };
    let limit = decompression_limit();
    let mut chunk = 0u64;
    let mut pos = MAGIC.len() as u64;
    loop {
        let mut head = [0u8; 9];
        let got = read_into(path, input, pos, &mut head)?;
        let (Some(&op), Some(rec_len)) = (head[..got].first(), u64_at(&head[..got], 1)) else {
            break;
        };
        let start = pos + 9;
        let Some(end) = start.checked_add(rec_len) else {
            break;
        };
        if op == OP_FOOTER {
            break;
        }
        if op == OP_CHUNK {
            let index = chunk;
            chunk += 1;
            // start time, end time, uncompressed size, uncompressed CRC, compression string,
            // then the compressed records with their u64 length
            // (read within the record only: a chunk too short for them is the crate's to report;
            // a chunk cut short by the end of the file is read by the crate as far as it goes)
            let rec_in_file = end.min(len).saturating_sub(start);
            let mut fixed = [0u8; 32];
            let got = read_into(
                path,
                input,
                start,
                &mut fixed[..rec_in_file.min(32) as usize],
            )?;
            let declared = u64_at(&fixed[..got], 16);
            let name_len = u32_at(&fixed[..got], 28).map(u64::from);
            // the compression name and the records' length, when the chunk holds them
            let tail = match name_len {
                Some(n) if 40 + n <= rec_in_file => Some(read_at(path, input, start + 32, n + 8)?),
                _ => None,
            };
            if let (Some(declared), Some(n), Some(tail)) = (declared, name_len, tail) {
                let n_us = tail.len() - 8;
                let compression = &tail[..n_us];
                let records = u64_at(&tail, n_us).unwrap_or(0);
                // the compressed bytes the file holds: a chunk cut short by the end of the
                // file may claim any size
                let records = records.min(rec_in_file.saturating_sub(40 + n));
                // an uncompressed chunk's records are read as they lie in the file, whatever
                // size its header declares
                if compression.is_empty() {
                    let body = read_at(path, input, start + 40 + n, records)?;
                    if let Some(at) = record_overrun(&body) {
                        return Err(FormatError::syntax(
                            path,
                            Location::Byte(pos + 49 + n + at as u64),
                            "a record inside an uncompressed chunk runs past the chunk's end",
                        ));
                    }
                    largest = largest.max(records);
                    pos = end;
                    continue;
                }
                if let Some(msg) = limit.check(records, declared) {
                    return Err(FormatError::syntax(
                        path,
                        Location::Byte(pos),
                        format!(
                            "chunk {index} ({} compressed) declares a decompressed size that is \
                             damaged or a decompression bomb: {msg}",
                            String::from_utf8_lossy(compression)
                        ),
                    ));
                }
                largest = largest.max(declared);
            }
        }
        if end > len {
            break;
        }
        pos = end;
    }
    Ok(largest)
}

/// The offset of the first record (opcode, `u64` length, content) in `records`, the body of
/// an uncompressed chunk, that does not fit in it; `None` when they tile it exactly. The
/// `mcap` crate subtracts each record's length from the chunk's remaining size unchecked, so
/// one that overruns the chunk would underflow there (a panic with overflow checks on).
fn record_overrun(records: &[u8]) -> Option<usize> {
    let mut at = 0usize;
    while at < records.len() {
        let len = records
            .get(at + 1..at + 9)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()));
        let next = len
            .and_then(|l| usize::try_from(l).ok())
            .and_then(|l| (at + 9).checked_add(l));
        match next {
            Some(n) if n <= records.len() => at = n,
            _ => return Some(at),
        }
    }
    None
}

/// Whether the summary section (from the footer's `summary_start` to the footer record)
/// holds a record the `mcap` crate's summary reader cannot be trusted with: a chunk (it
/// descends into it, reaching the unchecked subtraction `record_overrun` guards against) or
/// an attachment (its `parse_record` slices the body unchecked: a panic on a short one).
/// Neither belongs there. Walks records as the crate does, up to the footer record or the
/// end of the file.
fn summary_has_foreign_record(
    path: &Path,
    input: &mut impl Input,
    len: u64,
) -> Result<bool, FormatError> {
    const OP_FOOTER: u8 = 0x02;
    const OP_CHUNK: u8 = 0x06;
    const OP_ATTACHMENT: u8 = 0x09;
    // footer: opcode 0x02, u64 length, summary_start, summary_offset_start, CRC; then magic
    let Some(footer) = len.checked_sub(8 + 29) else {
        return Ok(false);
    };
    let u64_of = |b: &[u8], at: usize| {
        b.get(at..at + 8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap_or_default()))
    };
    let Some(mut pos) = u64_of(&read_at(path, input, footer + 9, 8)?, 0) else {
        return Ok(false);
    };
    if pos == 0 {
        return Ok(false);
    }
    while pos < len {
        let head = read_at(path, input, pos, 9)?;
        let (Some(&op), Some(rec_len)) = (head.first(), u64_of(&head, 1)) else {
            return Ok(false);
        };
        match op {
            OP_FOOTER => return Ok(false),
            OP_CHUNK | OP_ATTACHMENT => return Ok(true),
            _ => {}
        }
        match (pos + 9).checked_add(rec_len) {
            Some(end) if end <= len => pos = end,
            _ => return Ok(false),
        }
    }
    Ok(false)
}

/// The summary section, read by seeking to the footer (what `mcap::Summary::read` does on a
/// whole file in memory).
fn read_summary(
    path: &Path,
    input: &mut impl Input,
    len: u64,
) -> Result<Option<::mcap::Summary>, FormatError> {
    use ::mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
    let mut reader =
        SummaryReader::new_with_options(SummaryReaderOptions::default().with_file_size(len));
    let io = |e| FormatError::io(path, Location::File, e);
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| mcap_err(path, e))? {
            SummaryReadEvent::ReadRequest(n) => {
                let got = input.read(reader.insert(n)).map_err(io)?;
                reader.notify_read(got);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let at = input.seek(to).map_err(io)?;
                reader.notify_seeked(at);
            }
        }
    }
    Ok(reader.finish())
}

fn topics_of(path: &Path, mut input: impl Input) -> Result<Vec<TopicInfo>, FormatError> {
    let mut map: BTreeMap<String, TopicInfo> = BTreeMap::new();
    let mut add = |c: &::mcap::Channel| {
        map.entry(c.topic.clone()).or_insert_with(|| TopicInfo {
            topic: c.topic.clone(),
            schema: c
                .schema
                .as_ref()
                .map(|s| s.name.clone())
                .unwrap_or_default(),
            encoding: c.message_encoding.clone(),
        });
    };
    let len = file_len(path, &mut input)?;
    // A chunk in the summary section (where none belongs) would reach the crate's unchecked
    // chunk-record subtraction (see `record_overrun`) outside the records pre-checked above,
    // an attachment its unchecked slicing (see `Messages`): such a file is read linearly
    // instead.
    let summary = if summary_has_foreign_record(path, &mut input, len)? {
        None
    } else {
        read_summary(path, &mut input, len).ok().flatten()
    };
    match summary {
        Some(summary) if !summary.channels.is_empty() => {
            // by channel id: the summary's map iterates in a random order, and of two
            // channels on one topic the first added is the one listed
            let mut channels: Vec<_> = summary.channels.iter().collect();
            channels.sort_unstable_by_key(|(id, _)| **id);
            for (_, c) in channels {
                add(c);
            }
        }
        _ => {
            for_each_message(path, input, |_, m| {
                add(&m.channel);
                Ok(())
            })?;
        }
    }
    Ok(map.into_values().collect())
}

/// The clouds an MCAP file announces for the topic [`mcap_frames`] would read (the one
/// given, else the only PointCloud2 topic), from the statistics record of its summary
/// section, without reading any message; `None` when the file has no such record or the
/// topic is not clear from it.
pub fn announced_clouds(path: &Path, options: &McapOptions) -> Option<usize> {
    let mut input = open_file(path).ok()?;
    let len = file_len(path, &mut input).ok()?;
    if summary_has_foreign_record(path, &mut input, len).ok()? {
        return None;
    }
    let summary = read_summary(path, &mut input, len).ok()??;
    let stats = summary.stats.as_ref()?;
    let is_cloud = |c: &::mcap::Channel| {
        c.schema
            .as_ref()
            .is_some_and(|s| CLOUD_SCHEMAS.contains(&s.name.as_str()))
    };
    let topic = match &options.topic {
        Some(t) => t.clone(),
        None => {
            let mut clouds: Vec<&str> = summary
                .channels
                .values()
                .filter(|c| is_cloud(c))
                .map(|c| c.topic.as_str())
                .collect();
            clouds.sort_unstable();
            clouds.dedup();
            match clouds.as_slice() {
                [one] => one.to_string(),
                _ => return None,
            }
        }
    };
    let mut n = 0u64;
    for (id, c) in &summary.channels {
        if c.topic == topic {
            n = n.checked_add(*stats.channel_message_counts.get(id)?)?;
        }
    }
    usize::try_from(n).ok()
}

/// The topics of an MCAP file with their message types and encodings, sorted by name.
pub fn list_topics(path: &Path) -> Result<Vec<TopicInfo>, FormatError> {
    topics_of(path, open_file(path)?)
}

fn describe(topics: &[TopicInfo]) -> String {
    topics
        .iter()
        .map(|t| format!("{} ({})", t.topic, t.schema))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Every cloud of the selected topic as a frame, with per-cloud counts: [`mcap_frames`]
/// collected.
///
/// Errors name the file and what is wrong: unreadable MCAP, unknown topic (listing the
/// topics), a topic that is not PointCloud2, an unknown message encoding, a malformed
/// message (with its index and byte), a fixed frame not connected to the cloud's frame.
pub fn read_mcap(
    path: &Path,
    options: &McapOptions,
) -> Result<(Vec<Frame>, Vec<CloudStats>), FormatError> {
    let mut frames = Vec::new();
    let mut stats = Vec::new();
    for r in mcap_frames(path, options)? {
        let (f, s) = r?;
        frames.push(f);
        stats.push(s);
    }
    Ok((frames, stats))
}

/// [`read_mcap_frames`] with the counts, one cloud at a time: the topic is chosen and every
/// transform of `/tf` and `/tf_static` is read first (a pass over the file that keeps only
/// the transforms), then each cloud is decoded and posed when it is asked for. Errors are
/// those of [`read_mcap`]; the stream ends after the first.
pub fn mcap_frames(path: &Path, options: &McapOptions) -> Result<McapFrames, FormatError> {
    let topics = topics_of(path, open_file(path)?)?;
    let topic = match &options.topic {
        Some(t) => {
            let info = topics.iter().find(|i| &i.topic == t).ok_or_else(|| {
                FormatError::InvalidOption {
                    path: path.to_path_buf(),
                    message: format!("no topic {t:?}; the file has: {}", describe(&topics)),
                }
            })?;
            if !CLOUD_SCHEMAS.contains(&info.schema.as_str()) {
                return Err(FormatError::InvalidOption {
                    path: path.to_path_buf(),
                    message: format!(
                        "topic {t:?} carries {:?}, not sensor_msgs/PointCloud2",
                        info.schema
                    ),
                });
            }
            t.clone()
        }
        None => {
            let clouds: Vec<&TopicInfo> = topics
                .iter()
                .filter(|i| CLOUD_SCHEMAS.contains(&i.schema.as_str()))
                .collect();
            match clouds.as_slice() {
                [one] => one.topic.clone(),
                [] => {
                    return Err(FormatError::InvalidOption {
                        path: path.to_path_buf(),
                        message: format!(
                            "no sensor_msgs/PointCloud2 topic; the file has: {}",
                            describe(&topics)
                        ),
                    })
                }
                many => {
                    return Err(FormatError::InvalidOption {
                        path: path.to_path_buf(),
                        message: format!(
                            "several PointCloud2 topics ({}); choose one",
                            many.iter()
                                .map(|i| i.topic.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    })
                }
            }
        }
    };

    let mut tf = TfTree::default();
    let mut total = 0usize;
    let mut marks = Vec::new();
    let mut first = Messages::new(path, open_file(path)?)?;
    first.definitions = Some(Definitions::default());
    while let Some((index, m)) = first.next_message()? {
        let ch = &m.channel;
        let schema = ch.schema.as_ref().map(|s| s.name.as_str()).unwrap_or("");
        let is_cloud = ch.topic == topic;
        let is_tf = TF_SCHEMAS.contains(&schema) && (ch.topic == "/tf" || ch.topic == "/tf_static");
        if !is_cloud && !is_tf {
            continue;
        }
        total += usize::from(is_cloud);
        let encoding = message_encoding(path, ch)?;
        if is_cloud {
            marks.push(CloudMark::of(index, &m));
        }
        if is_tf {
            for t in
                decode_tf_message(&m.data, encoding).map_err(|e| bad_message(path, index, ch, e))?
            {
                tf.add(t, m.log_time, ch.topic == "/tf_static");
            }
        }
    }
    let definitions = first.definitions.take().unwrap_or_default();
    // the stream reads the same file: its chunk headers are checked
    let (first_len, first_limit) = (first.len, first.limit);
    drop(first);
    let mut input = open_file(path)?;
    let chunks = ChunkIndexes::of(path, &mut input, &topic, &definitions);
    Ok(McapFrames {
        path: path.to_path_buf(),
        topic,
        fixed_frame: options.fixed_frame.clone(),
        colors: options.colors,
        world: options.sensor_pose.unwrap_or_else(Isometry3::identity),
        tf,
        messages: Messages::checked(path, input, first_len, first_limit)?,
        clouds: 0,
        total,
        done: false,
        marks,
        definitions,
        chunks,
        jumped: false,
    })
}

/// What the first pass saw of one cloud message: its number among the file's messages, log
/// time, length and CRC-32. A read that jumped over chunks checks each cloud it finds after
/// the jump against these, so that wrong indexes cannot change what it yields.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct CloudMark {
    index: usize,
    log_time: u64,
    len: usize,
    crc: u32,
}

impl CloudMark {
    fn of(index: usize, m: &::mcap::Message<'_>) -> CloudMark {
        CloudMark {
            index,
            log_time: m.log_time,
            len: m.data.len(),
            crc: crc32fast::hash(&m.data),
        }
    }
}

/// One chunk as the summary's chunk index describes it.
#[derive(Debug, Clone)]
struct IndexedChunk {
    /// The chunk record's offset (its opcode) and length (opcode and length field included).
    start: u64,
    len: u64,
    /// Offsets of its message index records, by channel, and their total length.
    message_indexes: BTreeMap<u16, u64>,
    message_index_len: u64,
    /// Length of its records decompressed.
    uncompressed: u64,
}

/// The chunks of a file in file order, from its summary's chunk indexes, and what their
/// message index records say they hold (read on demand, [`ChunkIndexes::counts`]).
struct ChunkIndexes {
    chunks: Vec<IndexedChunk>,
    /// The channels of the topic.
    topic_channels: std::collections::BTreeSet<u16>,
    /// Per chunk read so far: (messages, clouds) its message indexes list; `None` once one
    /// of them is unreadable or inconsistent (the indexes are then not used).
    counts: Option<Vec<(usize, usize)>>,
    /// The file, unbuffered: the message index records are read at their exact length.
    file: Option<File>,
}

impl ChunkIndexes {
    /// The chunk indexes of the file's summary when it has some, in file order, each chunk
    /// after the end of the one before it and before the summary; `None` otherwise (no
    /// summary, no chunk index, a chunk in the summary, overlapping chunks...).
    fn of(
        path: &Path,
        input: &mut BufReader<File>,
        topic: &str,
        known: &Definitions,
    ) -> Option<ChunkIndexes> {
        let len = file_len(path, input).ok()?;
        if summary_has_foreign_record(path, input, len).ok()? {
            return None;
        }
        let summary = read_summary(path, input, len).ok()??;
        let mut chunks: Vec<IndexedChunk> = summary
            .chunk_indexes
            .iter()
            .map(|c| IndexedChunk {
                start: c.chunk_start_offset,
                len: c.chunk_length,
                message_indexes: c.message_index_offsets.clone(),
                message_index_len: c.message_index_length,
                uncompressed: c.uncompressed_size,
            })
            .collect();
        chunks.sort_by_key(|c| c.start);
        let mut end = 8u64; // the leading magic
        for c in &chunks {
            let c_end = c.start.checked_add(c.len)?;
            if c.start < end || c.len < 9 || c_end > len {
                return None;
            }
            end = c_end;
        }
        if chunks.is_empty() {
            return None;
        }
        let topic_channels = known
            .records
            .iter()
            .filter_map(|d| match d {
                Definition::Channel(c) if c.topic == topic => Some(c.id),
                _ => None,
            })
            .collect();
        Some(ChunkIndexes {
            chunks,
            topic_channels,
            counts: Some(Vec::new()),
            file: File::open(path).ok(),
        })
    }

    /// The chunk holding cloud number `cloud` by the indexes: its offset, and the messages
    /// and clouds before it; `None` when the indexes do not say (or not consistently).
    fn chunk_of_cloud(&mut self, cloud: usize) -> Option<(u64, usize, usize)> {
        let (mut messages, mut clouds) = (0usize, 0usize);
        for k in 0..self.chunks.len() {
            let (m, c) = self.counts(k)?;
            if clouds.checked_add(c)? > cloud {
                return Some((self.chunks[k].start, messages, clouds));
            }
            messages = messages.checked_add(m)?;
            clouds += c;
        }
        None
    }

    /// The (messages, clouds) of chunk `k` by its message index records, read once.
    fn counts(&mut self, k: usize) -> Option<(usize, usize)> {
        let known = self.counts.as_ref()?;
        if let Some(&c) = known.get(k) {
            return Some(c);
        }
        debug_assert_eq!(known.len(), k);
        let c = self.read_counts(k);
        match (c, self.counts.as_mut()) {
            (Some(c), Some(v)) => {
                v.push(c);
                Some(c)
            }
            _ => {
                self.counts = None;
                None
            }
        }
    }

    /// Chunk `k`'s record header, and its message index records: each where the chunk
    /// index says, a message index (opcode 0x07) of the channel it is listed for, its entries
    /// (16 bytes each) inside the record and pointing inside the decompressed chunk.
    fn read_counts(&mut self, k: usize) -> Option<(usize, usize)> {
        let chunk = self.chunks.get(k)?;
        let file = self.file.as_mut()?;
        let mut head = [0u8; 9];
        file.seek(SeekFrom::Start(chunk.start)).ok()?;
        file.read_exact(&mut head).ok()?;
        if head[0] != 0x06 || u64::from_le_bytes(head[1..].try_into().ok()?) != chunk.len - 9 {
            return None;
        }
        let (Some(&first), Some(&last)) = (
            chunk.message_indexes.values().min(),
            chunk.message_indexes.values().max(),
        ) else {
            return Some((0, 0));
        };
        let block_end = first.checked_add(chunk.message_index_len)?;
        if first < chunk.start + chunk.len || last >= block_end {
            return None;
        }
        // bounded by the file: the chunk index checks kept every chunk inside it
        let file_len = file.seek(SeekFrom::End(0)).ok()?;
        if block_end > file_len {
            return None;
        }
        let mut block = vec![0u8; usize::try_from(chunk.message_index_len).ok()?];
        file.seek(SeekFrom::Start(first)).ok()?;
        file.read_exact(&mut block).ok()?;
        let (mut messages, mut clouds) = (0usize, 0usize);
        for (&channel, &at) in &chunk.message_indexes {
            let rec = block.get(usize::try_from(at - first).ok()?..)?;
            let rec_len =
                usize::try_from(u64::from_le_bytes(rec.get(1..9)?.try_into().ok()?)).ok()?;
            let body = rec.get(9..9usize.checked_add(rec_len)?)?;
            if rec[0] != 0x07 || u16::from_le_bytes(body.get(..2)?.try_into().ok()?) != channel {
                return None;
            }
            let n = usize::try_from(u32::from_le_bytes(body.get(2..6)?.try_into().ok()?)).ok()?;
            let entries = body.get(6..6usize.checked_add(n)?)?;
            if n % 16 != 0 {
                return None;
            }
            for e in entries.chunks_exact(16) {
                if u64::from_le_bytes(e[8..].try_into().ok()?) >= chunk.uncompressed {
                    return None;
                }
            }
            messages = messages.checked_add(n / 16)?;
            if self.topic_channels.contains(&channel) {
                clouds += n / 16;
            }
        }
        Some((messages, clouds))
    }
}

fn message_encoding(path: &Path, ch: &::mcap::Channel) -> Result<Encoding, FormatError> {
    Encoding::from_mcap(&ch.message_encoding).ok_or_else(|| {
        FormatError::unsupported(
            path,
            Location::File,
            format!(
                "topic {:?} uses message encoding {:?}; only \"ros1\" and \"cdr\" are supported",
                ch.topic, ch.message_encoding
            ),
        )
    })
}

fn bad_message(path: &Path, index: usize, ch: &::mcap::Channel, e: DecodeError) -> FormatError {
    FormatError::syntax(
        path,
        Location::File,
        format!("message {index} on {:?}: {e}", ch.topic),
    )
}

/// The clouds of one MCAP topic as posed frames, read one chunk at a time ([`mcap_frames`]).
pub struct McapFrames {
    path: PathBuf,
    topic: String,
    fixed_frame: Option<String>,
    colors: bool,
    world: Isometry3<f64>,
    tf: TfTree,
    messages: Messages<BufReader<File>>,
    /// Clouds yielded or skipped so far.
    clouds: usize,
    /// Messages on the topic, counted by the first pass: one frame each, unless one fails.
    total: usize,
    done: bool,
    /// What the first pass saw of each cloud.
    marks: Vec<CloudMark>,
    /// The file's schemas and channels, from the first pass.
    definitions: Definitions,
    /// The summary's chunk indexes, when the file has them.
    chunks: Option<ChunkIndexes>,
    /// Whether `messages` jumped over chunks: the clouds read since are checked against
    /// `marks`, and the file is read again from its start at the first difference.
    jumped: bool,
}

impl std::fmt::Debug for McapFrames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapFrames")
            .field("path", &self.path)
            .field("topic", &self.topic)
            .field("clouds", &self.clouds)
            .finish_non_exhaustive()
    }
}

impl McapFrames {
    /// The next message on the topic (its index in the file), or `None` after the last.
    fn next_topic_message(
        &mut self,
    ) -> Result<Option<(usize, ::mcap::Message<'static>)>, FormatError> {
        let path = self.path.as_path();
        let topic = &self.topic;
        loop {
            match self.messages.next_message()? {
                None => return Ok(None),
                Some((index, m)) => {
                    let ch = &m.channel;
                    let schema = ch.schema.as_ref().map(|s| s.name.as_str()).unwrap_or("");
                    let is_tf = TF_SCHEMAS.contains(&schema)
                        && (ch.topic == "/tf" || ch.topic == "/tf_static");
                    // the first pass refused any unknown encoding in order; the same here
                    if ch.topic == *topic || is_tf {
                        message_encoding(path, ch)?;
                    }
                    if ch.topic == *topic {
                        return Ok(Some((index, m)));
                    }
                }
            }
        }
    }

    /// The next message on the topic as [`Self::next_topic_message`] gives it; after a jump
    /// over chunks, checked against the first pass's mark of the cloud it should be, and on
    /// any difference (or error, or early end) the file is read again linearly from its
    /// start to the same cloud: a jump can save reading, never change what comes out.
    fn next_cloud_message(
        &mut self,
    ) -> Result<Option<(usize, ::mcap::Message<'static>)>, FormatError> {
        loop {
            let r = self.next_topic_message();
            if !self.jumped {
                return r;
            }
            match r {
                Ok(Some((i, m))) if self.marks.get(self.clouds) == Some(&CloudMark::of(i, &m)) => {
                    return Ok(Some((i, m)))
                }
                Ok(None) if self.clouds >= self.total => return Ok(None),
                _ => self.read_again()?,
            }
        }
    }

    /// Start the file again from its start (no jump) and pass the clouds passed so far.
    fn read_again(&mut self) -> Result<(), FormatError> {
        self.chunks = None;
        self.jumped = false;
        let (len, limit) = (self.messages.len, self.messages.limit);
        self.messages = Messages::checked(&self.path, open_file(&self.path)?, len, limit)?;
        let target = std::mem::take(&mut self.clouds);
        while self.clouds < target {
            match self.next_topic_message()? {
                Some(_) => self.clouds += 1,
                None => {
                    return Err(FormatError::syntax(
                        &self.path,
                        Location::File,
                        format!(
                            "the file changed while it was read: it has {} clouds on {:?} now, \
                             {} before",
                            self.clouds, self.topic, self.total
                        ),
                    ))
                }
            }
        }
        Ok(())
    }

    /// Move the reader to the chunk holding cloud `cloud` when the file's chunk and message
    /// indexes place it in a chunk after the reader (whose last cloud read is in a chunk
    /// before it); nothing otherwise.
    fn jump_to_cloud(&mut self, cloud: usize) -> Result<(), FormatError> {
        let Some(chunks) = self.chunks.as_mut() else {
            return Ok(());
        };
        let Some((at, messages, clouds)) = chunks.chunk_of_cloud(cloud) else {
            return Ok(());
        };
        if clouds <= self.clouds || cloud >= self.total {
            return Ok(());
        }
        match self.messages.jump(at, messages, &self.definitions) {
            Ok(()) => {
                self.clouds = clouds;
                self.jumped = true;
                Ok(())
            }
            // the reader may be anywhere now: read again from the start
            Err(_) => self.read_again(),
        }
    }

    /// Pass over the next `n` clouds of the topic without decoding them (the transforms were
    /// all read by the first pass, so the clouds after them come out the same); returns how
    /// many were passed, fewer after the last.
    ///
    /// When the file's summary has chunk indexes and its message index records say which
    /// chunk holds the first cloud after the skip, the chunks before that one are passed
    /// without being read (their message index records are read instead), and the clouds
    /// read after that are checked against what the first pass saw of them; otherwise, or
    /// at a difference, the chunks are read up to that cloud.
    pub fn skip_clouds(&mut self, n: usize) -> Result<usize, FormatError> {
        let start = self.clouds;
        let target = start.saturating_add(n).min(self.total);
        if n > 0 && !self.done && target > 0 {
            // land in the chunk of the first cloud after the skip (or of the last cloud)
            let landing = target.min(self.total - 1);
            if let Err(e) = self.jump_to_cloud(landing) {
                self.done = true;
                return Err(e);
            }
        }
        let goal = start.saturating_add(n);
        while self.clouds < goal && !self.done {
            match self.next_cloud_message() {
                Ok(Some(_)) => self.clouds += 1,
                Ok(None) => self.done = true,
                Err(e) => {
                    self.done = true;
                    return Err(e);
                }
            }
        }
        Ok(self.clouds.saturating_sub(start))
    }

    /// The next cloud of the topic, decoded and posed, or `None` after the last.
    fn next_cloud(&mut self) -> Result<Option<(Frame, CloudStats)>, FormatError> {
        let Some((index, m)) = self.next_cloud_message()? else {
            return Ok(None);
        };
        let path = self.path.as_path();
        let topic = &self.topic;
        let ch = &m.channel;
        let encoding = message_encoding(path, ch)?;
        let cloud: PointCloud2 =
            decode_point_cloud2(&m.data, encoding).map_err(|e| bad_message(path, index, ch, e))?;
        let i = self.clouds;
        let time = m.log_time;
        let fixed = self
            .fixed_frame
            .clone()
            .unwrap_or_else(|| self.tf.root(&cloud.frame_id));
        let to_fixed = match self.tf.lookup(&fixed, &cloud.frame_id, time) {
            Ok(t) => t,
            Err(why) => {
                return Err(FormatError::missing_pose(
                    path,
                    Location::File,
                    format!(
                        "cloud {i} on {topic:?}: {why} from {:?} to {fixed:?} (frames in tf: {})",
                        cloud.frame_id,
                        self.tf.frames().join(", ")
                    ),
                ))
            }
        };
        let pose = self.world * to_fixed;
        let (pts, colors, st) = cloud.points_colors_f32(self.colors).map_err(|message| {
            FormatError::syntax(
                path,
                Location::File,
                format!("cloud {i} on {topic:?}: {message}"),
            )
        })?;
        let points = pts
            .into_iter()
            .map(|p| isometry_transform(&pose, &p))
            .collect();
        self.clouds += 1;
        Ok(Some((
            Frame {
                origin: isometry_transform(&pose, &Point3::origin()),
                points,
                stamp: Some(cloud.stamp),
                camera: None,
                colors,
            },
            st,
        )))
    }
}

impl Iterator for McapFrames {
    type Item = Result<(Frame, CloudStats), FormatError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let r = self.next_cloud().transpose();
        self.done = !matches!(r, Some(Ok(_)));
        r
    }

    /// Exact: every message on the topic, counted before the first was read, is one frame
    /// (the stream ends early only with an error, which is the last item).
    fn size_hint(&self) -> (usize, Option<usize>) {
        if self.done {
            return (0, Some(0));
        }
        let left = self.total.saturating_sub(self.clouds);
        (left, Some(left))
    }
}

/// [`read_mcap`] without the counts.
pub fn read_mcap_frames(path: &Path, options: &McapOptions) -> Result<Vec<Frame>, FormatError> {
    read_mcap(path, options).map(|(f, _)| f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    /// An MCAP file with one uncompressed chunk holding `body` as its records, then `tail`.
    fn file_with_chunk(body: &[u8], tail: &[u8]) -> Vec<u8> {
        let mut chunk = Vec::new();
        chunk.extend_from_slice(&0u64.to_le_bytes()); // start time
        chunk.extend_from_slice(&0u64.to_le_bytes()); // end time
        chunk.extend_from_slice(&(body.len() as u64).to_le_bytes()); // uncompressed size
        chunk.extend_from_slice(&0u32.to_le_bytes()); // uncompressed CRC (0: not checked)
        chunk.extend_from_slice(&0u32.to_le_bytes()); // compression "" (none)
        chunk.extend_from_slice(&(body.len() as u64).to_le_bytes());
        chunk.extend_from_slice(body);
        let mut f = b"\x89MCAP0\r\n".to_vec();
        f.push(0x06);
        f.extend_from_slice(&(chunk.len() as u64).to_le_bytes());
        f.extend_from_slice(&chunk);
        f.extend_from_slice(tail);
        f
    }

    /// A file of magic, then `records` as its summary section (no data section), then a
    /// footer pointing at them and the closing magic.
    fn summary_only(records: &[u8]) -> Vec<u8> {
        let mut f = b"\x89MCAP0\r\n".to_vec();
        let summary_start = f.len() as u64;
        f.extend_from_slice(records);
        f.push(0x02);
        f.extend_from_slice(&20u64.to_le_bytes());
        f.extend_from_slice(&summary_start.to_le_bytes());
        f.extend_from_slice(&0u64.to_le_bytes());
        f.extend_from_slice(&0u32.to_le_bytes());
        f.extend_from_slice(b"\x89MCAP0\r\n");
        f
    }

    /// An attachment record whose body is shorter than its own fields say: 16 bytes of times,
    /// two empty strings and a data length (32 bytes), then only 2 of the 4 CRC bytes.
    fn short_attachment() -> Vec<u8> {
        let mut body = vec![0u8; 16];
        body.extend_from_slice(&0u32.to_le_bytes()); // name ""
        body.extend_from_slice(&0u32.to_le_bytes()); // media type ""
        body.extend_from_slice(&0u64.to_le_bytes()); // data length 0
        body.extend_from_slice(&[0, 0]); // half a CRC
        let mut r = vec![0x09];
        r.extend_from_slice(&(body.len() as u64).to_le_bytes());
        r.extend_from_slice(&body);
        r
    }

    /// Found by the `mcap` fuzz target (session 15, 7.8 million executions into the run on the
    /// chunk-by-chunk reader): the `mcap` crate's `parse_record` slices an attachment's body
    /// up to `len - 4` from the end of its header, and panicked on one shorter than that.
    /// Attachments are now skipped unparsed, at the top level and inside chunks, and the
    /// messages around them still read.
    #[test]
    fn short_attachment_record_is_skipped_not_a_panic() {
        let path = Path::new("attachment.mcap");
        let mut top = b"\x89MCAP0\r\n".to_vec();
        top.extend_from_slice(&short_attachment());
        let in_chunk = file_with_chunk(&short_attachment(), &[]);
        for bytes in [top, in_chunk] {
            let mut m = Messages::new(path, Cursor::new(&bytes)).unwrap();
            // the file then just ends: an error about the end, or no message; never a panic
            assert!(
                !matches!(m.next_message(), Ok(Some(_))),
                "a message from a file that has none"
            );
            let _ = topics_of(path, Cursor::new(&bytes));
        }
        // the same record in the summary section (found by the `mcap` fuzz target on the
        // `mcap-skip` branch: the crate's summary reader parses every record there with
        // `parse_record`): the summary is not used, the file is read linearly
        let f = summary_only(&short_attachment());
        let len = f.len() as u64;
        assert!(summary_has_foreign_record(path, &mut Cursor::new(&f), len).unwrap());
        let _ = topics_of(path, Cursor::new(&f));
        // the record itself is what the crate refuses to slice: check the test builds it
        let r = short_attachment();
        assert!(std::panic::catch_unwind(|| ::mcap::parse_record(0x09, &r[9..])).is_err());
    }

    /// Found by the `mcap` fuzz target: a record inside an uncompressed chunk longer than the
    /// chunk made the `mcap` crate's remaining-size subtraction overflow (a panic in debug
    /// builds). It is now an error naming the byte of that record.
    #[test]
    fn record_running_past_an_uncompressed_chunk_is_an_error() {
        let path = Path::new("overrun.mcap");
        // an unknown record (opcode 0x7f) claiming 100 bytes in a 12-byte chunk body, with
        // enough file after the chunk for the crate to read them from
        let mut body = vec![0x7f];
        body.extend_from_slice(&100u64.to_le_bytes());
        body.extend_from_slice(&[1, 2, 3]);
        let bytes = file_with_chunk(&body, &[0u8; 200]);
        let e = topics_of(path, Cursor::new(&bytes))
            .unwrap_err()
            .to_string();
        assert!(e.contains("runs past the chunk's end"), "{e}");
        assert!(e.contains("overrun.mcap"), "{e}");
        // the record starts right after magic (8), chunk opcode and length (9) and the
        // chunk's fixed fields (40)
        assert!(e.contains("byte 57"), "{e}");

        // records that tile the chunk exactly pass this check
        let mut ok = vec![0x7f];
        ok.extend_from_slice(&3u64.to_le_bytes());
        ok.extend_from_slice(&[1, 2, 3]);
        assert_eq!(record_overrun(&ok), None);
        assert_eq!(record_overrun(&body), Some(0));
        assert_eq!(record_overrun(&ok[..5]), Some(0));
        // the same chunk with the file cut inside it (after its records): still an error
        let mut cut = file_with_chunk(&body, &[0u8; 200]);
        let chunk_len_at = 9;
        cut[chunk_len_at..chunk_len_at + 8].copy_from_slice(&(40u64 + 12 + 300).to_le_bytes());
        let e = topics_of(path, Cursor::new(&cut)).unwrap_err().to_string();
        assert!(e.contains("runs past the chunk's end"), "{e}");

        // the same chunk in the summary section (found by the fuzz target after the fix
        // above: `Summary::read` walks that section with the same unchecked subtraction)
        let in_summary = file_with_chunk(&body, &[]);
        let f = summary_only(&[&in_summary[8..], &[0u8; 200][..]].concat());
        assert!(summary_has_foreign_record(path, &mut Cursor::new(&f), f.len() as u64).unwrap());
        let e = topics_of(path, Cursor::new(&f)).unwrap_err().to_string();
        assert!(e.contains("runs past the chunk's end"), "{e}");

        // a zstd chunk cut short by the end of the file, claiming 2^40 compressed bytes and
        // 2^49 decompressed (found by the fuzz target: the crate tried to allocate them)
        let mut chunk = Vec::new();
        chunk.extend_from_slice(&[0u8; 16]);
        chunk.extend_from_slice(&(1u64 << 49).to_le_bytes());
        chunk.extend_from_slice(&0u32.to_le_bytes());
        chunk.extend_from_slice(&4u32.to_le_bytes());
        chunk.extend_from_slice(b"zstd");
        chunk.extend_from_slice(&(1u64 << 40).to_le_bytes());
        chunk.extend_from_slice(&[0x28, 0xb5, 0x2f, 0xfd, 0, 0, 0, 0]);
        let mut f = b"\x89MCAP0\r\n".to_vec();
        f.push(0x06);
        f.extend_from_slice(&(1u64 << 41).to_le_bytes());
        f.extend_from_slice(&chunk);
        let e = topics_of(path, Cursor::new(&f)).unwrap_err().to_string();
        // refused before any allocation: by the decompression limit, or as a damaged size
        assert!(e.contains("damaged") && e.contains("chunk"), "{e}");

        // an uncompressed chunk cut short by the end of the file, claiming 2^52 bytes of
        // records: the record length limit it feeds stays within the file (found by the fuzz
        // target: with the claimed size as the limit, a record in a later zstd chunk claiming
        // 844 TB passed and the crate tried to allocate it)
        let mut cut = file_with_chunk(&ok, &[]);
        cut[9..17].copy_from_slice(&(1u64 << 53).to_le_bytes());
        cut[17 + 32..17 + 40].copy_from_slice(&(1u64 << 52).to_le_bytes());
        let largest = check_chunk_sizes(path, &mut Cursor::new(&cut), cut.len() as u64).unwrap();
        assert!(largest <= cut.len() as u64, "{largest}");

        let mut two = ok.clone();
        two.extend_from_slice(&body);
        assert_eq!(record_overrun(&two), Some(ok.len()));
    }

    /// Two channels on one topic, the first without a schema: the topic is listed with the
    /// first channel's (none), every time, although the summary's channel map iterates in a
    /// random order (found by the fuzz target: one file's "no PointCloud2 topic" error named
    /// `/imu ()` in one opening and `/imu (sensor_msgs/Imu)` in the next).
    #[test]
    fn topics_from_a_summary_are_listed_in_channel_order() {
        let mut w = ::mcap::WriteOptions::new()
            .create(Cursor::new(Vec::new()))
            .unwrap();
        let meta = std::collections::BTreeMap::new();
        let bare = w.add_channel(0, "/imu", "cdr", &meta).unwrap();
        let sid = w.add_schema("sensor_msgs/msg/Imu", "ros2msg", b"").unwrap();
        let typed = w.add_channel(sid, "/imu", "cdr", &meta).unwrap();
        for (i, channel_id) in [bare, typed].into_iter().enumerate() {
            let header = ::mcap::records::MessageHeader {
                channel_id,
                sequence: i as u32,
                log_time: i as u64,
                publish_time: i as u64,
            };
            w.write_to_known_channel(&header, &[1, 2, 3]).unwrap();
        }
        w.finish().unwrap();
        let bytes = w.into_inner().into_inner();
        let path = Path::new("two-channels.mcap");
        for _ in 0..32 {
            let topics = topics_of(path, Cursor::new(&bytes)).unwrap();
            assert_eq!(topics.len(), 1);
            assert_eq!(topics[0].schema, "", "{topics:?}");
        }
    }
}
