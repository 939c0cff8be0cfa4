//! `sensor_msgs/PointCloud2` from MCAP files (ROS 1 and ROS 2 recordings), with the sensor
//! pose from `/tf_static` and `/tf`.
//!
//! - [`read_mcap`] / [`read_mcap_frames`]: every cloud of one topic as a [`Frame`] in a fixed
//!   frame, with per-cloud [`CloudStats`]; [`list_topics`] names what a file holds.
//! - [`decode_point_cloud2`]: one message, in either encoding, into a [`PointCloud2`]
//!   whose [`PointCloud2::points`] extracts `x y z` from any field layout.
//!
//! **Encodings.** `ros1` (little-endian, packed, strings as `u32` length + bytes) and `cdr`
//! (ROS 2: a 4-byte encapsulation header selecting little or big endian, then each primitive
//! aligned to its size relative to the end of that header; strings carry a NUL). The point
//! bytes follow the message's own `is_bigendian`, `point_step`, `row_step` and field offsets;
//! `x`, `y`, `z` may be `FLOAT32` or `FLOAT64`.
//!
//! **Invalid points.** Drivers store missing returns as NaN or as exactly (0, 0, 0) (the
//! Ouster driver does, even with `is_dense` set); both are skipped and counted.
//!
//! **Poses.** Each cloud is expressed in [`McapOptions::fixed_frame`] by composing the
//! transforms of `tf2_msgs/TFMessage` messages on `/tf_static` (always valid) and `/tf` (the
//! latest at or before the cloud's log time, else the first after) along the chain between
//! the two frames, in either direction. Without a fixed frame, the root of the cloud frame's
//! transform tree is used; without any transform, the cloud's own frame (identity). The
//! sensor origin is the cloud frame's origin carried through the same chain; then
//! [`McapOptions::sensor_pose`] maps the fixed frame to the world.
//!
//! The whole file is read into memory (MCAP's chunk index needs random access); chunks may
//! be uncompressed or zstd-compressed (lz4 is not built in).

use crate::error::{FormatError, Location};
use crate::Frame;
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

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

/// Point counts of one cloud.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CloudStats {
    /// Points in the message (`width * height`).
    pub points: usize,
    /// Points kept.
    pub kept: usize,
    /// Points skipped for a NaN or infinite coordinate.
    pub non_finite: usize,
    /// Points skipped for being exactly (0, 0, 0) (missing returns).
    pub zero: usize,
}

/// `sensor_msgs/PointField` datatypes.
pub mod datatype {
    /// `INT8`.
    pub const INT8: u8 = 1;
    /// `UINT8`.
    pub const UINT8: u8 = 2;
    /// `INT16`.
    pub const INT16: u8 = 3;
    /// `UINT16`.
    pub const UINT16: u8 = 4;
    /// `INT32`.
    pub const INT32: u8 = 5;
    /// `UINT32`.
    pub const UINT32: u8 = 6;
    /// `FLOAT32`.
    pub const FLOAT32: u8 = 7;
    /// `FLOAT64`.
    pub const FLOAT64: u8 = 8;
}

/// One `sensor_msgs/PointField`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PointField {
    /// Field name (`x`, `intensity`, ...).
    pub name: String,
    /// Byte offset inside a point.
    pub offset: u32,
    /// One of [`datatype`].
    pub datatype: u8,
    /// Number of elements.
    pub count: u32,
}

/// A decoded `sensor_msgs/PointCloud2`; the point bytes are kept as they are.
#[derive(Debug, Clone, PartialEq)]
pub struct PointCloud2 {
    /// `header.frame_id`.
    pub frame_id: String,
    /// `header.stamp` in seconds.
    pub stamp: f64,
    /// Rows.
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Field layout.
    pub fields: Vec<PointField>,
    /// Whether the point bytes are big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The point bytes.
    pub data: Vec<u8>,
    /// `is_dense` as recorded (not trusted: invalid points are checked regardless).
    pub is_dense: bool,
}

/// The message encodings [`decode_point_cloud2`] understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1 serialization (`ros1`).
    Ros1,
    /// ROS 2 CDR with its encapsulation header (`cdr`).
    Cdr,
}

impl Encoding {
    /// The encoding of an MCAP channel's `message_encoding`, `None` if unknown.
    pub fn from_mcap(name: &str) -> Option<Encoding> {
        match name {
            "ros1" => Some(Encoding::Ros1),
            "cdr" => Some(Encoding::Cdr),
            _ => None,
        }
    }
}

/// A decoding failure inside one message: what and at which byte of the message.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("byte {offset} of the message: {message}")]
pub struct DecodeError {
    /// Byte offset in the message where decoding failed.
    pub offset: usize,
    /// What is wrong.
    pub message: String,
}

/// Reads ROS 1 or CDR primitives from a message.
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
    /// CDR: alignment origin (just after the encapsulation header); `None` for ROS 1.
    cdr_origin: Option<usize>,
    big_endian: bool,
}

impl<'a> Reader<'a> {
    fn new(buf: &'a [u8], encoding: Encoding) -> Result<Self, DecodeError> {
        match encoding {
            Encoding::Ros1 => Ok(Reader {
                buf,
                pos: 0,
                cdr_origin: None,
                big_endian: false,
            }),
            Encoding::Cdr => {
                let head = buf.get(..4).ok_or_else(|| DecodeError {
                    offset: 0,
                    message: "shorter than the 4-byte CDR encapsulation header".into(),
                })?;
                let big_endian = match head[1] {
                    0x00 | 0x02 => true,
                    0x01 | 0x03 => false,
                    k => {
                        return Err(DecodeError {
                            offset: 0,
                            message: format!("unknown CDR encapsulation kind {:#04x}", k),
                        })
                    }
                };
                Ok(Reader {
                    buf,
                    pos: 4,
                    cdr_origin: Some(4),
                    big_endian,
                })
            }
        }
    }

    fn err(&self, message: impl Into<String>) -> DecodeError {
        DecodeError {
            offset: self.pos,
            message: message.into(),
        }
    }

    fn align(&mut self, n: usize) {
        if let Some(o) = self.cdr_origin {
            let rel = self.pos - o;
            self.pos += (n - rel % n) % n;
        }
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], DecodeError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.buf.len());
        match end {
            Some(e) => {
                let s = &self.buf[self.pos..e];
                self.pos = e;
                Ok(s)
            }
            None => Err(self.err(format!(
                "message ends inside {what} ({n} bytes needed, {} left)",
                self.buf.len().saturating_sub(self.pos)
            ))),
        }
    }

    fn u8(&mut self, what: &str) -> Result<u8, DecodeError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, DecodeError> {
        self.align(4);
        let b: [u8; 4] = self.take(4, what)?.try_into().unwrap_or([0; 4]);
        Ok(if self.big_endian {
            u32::from_be_bytes(b)
        } else {
            u32::from_le_bytes(b)
        })
    }

    fn f64(&mut self, what: &str) -> Result<f64, DecodeError> {
        self.align(8);
        let b: [u8; 8] = self.take(8, what)?.try_into().unwrap_or([0; 8]);
        Ok(if self.big_endian {
            f64::from_be_bytes(b)
        } else {
            f64::from_le_bytes(b)
        })
    }

    /// A length-prefixed string; CDR strings end in a NUL counted in the length.
    fn string(&mut self, what: &str) -> Result<String, DecodeError> {
        let n = self.u32(what)? as usize;
        let bytes = self.take(n, what)?;
        let bytes = if self.cdr_origin.is_some() {
            bytes.strip_suffix(&[0]).unwrap_or(bytes)
        } else {
            bytes
        };
        String::from_utf8(bytes.to_vec()).map_err(|_| self.err(format!("{what} is not UTF-8")))
    }

    /// A sequence count, checked against the bytes left (each element needs `min_size`).
    fn count(&mut self, what: &str, min_size: usize) -> Result<usize, DecodeError> {
        let n = self.u32(what)? as usize;
        let left = self.buf.len().saturating_sub(self.pos);
        if n.saturating_mul(min_size) > left {
            return Err(self.err(format!("{what}: count {n} exceeds the {left} bytes left")));
        }
        Ok(n)
    }

    /// `std_msgs/Header` -> (frame_id, stamp seconds).
    fn header(&mut self) -> Result<(String, f64), DecodeError> {
        if self.cdr_origin.is_none() {
            self.u32("header.seq")?;
        }
        let sec = self.u32("header.stamp.sec")?;
        let nsec = self.u32("header.stamp.nanosec")?;
        let sec = if self.cdr_origin.is_some() {
            sec as i32 as f64
        } else {
            sec as f64
        };
        let frame = self.string("header.frame_id")?;
        Ok((frame, sec + nsec as f64 * 1e-9))
    }
}

/// Decode a `sensor_msgs/PointCloud2` message in `encoding`.
///
/// Checks the layout: `x`, `y`, `z` present as `FLOAT32`/`FLOAT64` inside `point_step`,
/// `row_step ≥ width · point_step`, and enough data bytes for every point.
pub fn decode_point_cloud2(msg: &[u8], encoding: Encoding) -> Result<PointCloud2, DecodeError> {
    let mut r = Reader::new(msg, encoding)?;
    let (frame_id, stamp) = r.header()?;
    let height = r.u32("height")?;
    let width = r.u32("width")?;
    let n = r.count("fields", 13)?;
    let mut fields = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("field name")?;
        let offset = r.u32("field offset")?;
        let datatype = r.u8("field datatype")?;
        let count = r.u32("field count")?;
        fields.push(PointField {
            name,
            offset,
            datatype,
            count,
        });
    }
    let is_bigendian = r.u8("is_bigendian")? != 0;
    let point_step = r.u32("point_step")?;
    let row_step = r.u32("row_step")?;
    let len = r.count("data", 1)?;
    let data = r.take(len, "data")?.to_vec();
    let is_dense = r.u8("is_dense")? != 0;
    let cloud = PointCloud2 {
        frame_id,
        stamp,
        height,
        width,
        fields,
        is_bigendian,
        point_step,
        row_step,
        data,
        is_dense,
    };
    cloud.layout().map_err(|message| DecodeError {
        offset: msg.len(),
        message,
    })?;
    Ok(cloud)
}

impl PointCloud2 {
    /// Offsets and sizes of x, y, z; errors name the missing or unusable field.
    fn layout(&self) -> Result<[(usize, bool); 3], String> {
        let mut out = [(0usize, false); 3];
        for (slot, name) in out.iter_mut().zip(["x", "y", "z"]) {
            let f = self.fields.iter().find(|f| f.name == name).ok_or_else(|| {
                let names: Vec<&str> = self.fields.iter().map(|f| f.name.as_str()).collect();
                format!("no field {name:?} (fields: {})", names.join(", "))
            })?;
            let size = match f.datatype {
                datatype::FLOAT32 => 4,
                datatype::FLOAT64 => 8,
                d => {
                    return Err(format!(
                        "field {name:?} has datatype {d}; only FLOAT32 (7) and FLOAT64 (8) are supported"
                    ))
                }
            };
            if f.offset as u64 + size > self.point_step as u64 {
                return Err(format!(
                    "field {name:?} at offset {} does not fit in point_step {}",
                    f.offset, self.point_step
                ));
            }
            *slot = (f.offset as usize, size == 8);
        }
        let row_bytes = self.width as u64 * self.point_step as u64;
        if self.height > 0 && self.width > 0 {
            if (self.row_step as u64) < row_bytes {
                return Err(format!(
                    "row_step {} is less than width {} × point_step {}",
                    self.row_step, self.width, self.point_step
                ));
            }
            // at most (2^32)^2 · 2: u128 cannot overflow
            let need = (self.height as u128 - 1) * self.row_step as u128 + row_bytes as u128;
            if (self.data.len() as u128) < need {
                return Err(format!(
                    "data holds {} bytes, {} × {} points need {need}",
                    self.data.len(),
                    self.height,
                    self.width
                ));
            }
        }
        Ok(out)
    }

    /// The valid points (row by row) and the counts of skipped ones.
    pub fn points(&self) -> Result<(Vec<Point3<f32>>, CloudStats), String> {
        let layout = self.layout()?;
        let total = self.height as usize * self.width as usize;
        let mut stats = CloudStats {
            points: total,
            ..CloudStats::default()
        };
        let mut pts = Vec::with_capacity(total);
        let be = self.is_bigendian;
        let read = |at: usize, f64_: bool| -> f64 {
            if f64_ {
                let b: [u8; 8] = self.data[at..at + 8].try_into().unwrap_or([0; 8]);
                if be {
                    f64::from_be_bytes(b)
                } else {
                    f64::from_le_bytes(b)
                }
            } else {
                let b: [u8; 4] = self.data[at..at + 4].try_into().unwrap_or([0; 4]);
                (if be {
                    f32::from_be_bytes(b)
                } else {
                    f32::from_le_bytes(b)
                }) as f64
            }
        };
        for row in 0..self.height as usize {
            let row_base = row * self.row_step as usize;
            for col in 0..self.width as usize {
                let base = row_base + col * self.point_step as usize;
                let p = layout.map(|(off, wide)| read(base + off, wide));
                if !p.iter().all(|v| v.is_finite()) {
                    stats.non_finite += 1;
                } else if p == [0.0; 3] {
                    stats.zero += 1;
                } else {
                    pts.push(Point3::new(p[0] as f32, p[1] as f32, p[2] as f32));
                }
            }
        }
        stats.kept = pts.len();
        Ok((pts, stats))
    }
}

/// One `geometry_msgs/TransformStamped`: `parent` ← `child`.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// `header.frame_id`.
    pub parent: String,
    /// `child_frame_id`.
    pub child: String,
    /// Maps child coordinates to parent coordinates.
    pub transform: Isometry3<f64>,
}

/// Decode a `tf2_msgs/TFMessage`.
pub fn decode_tf_message(msg: &[u8], encoding: Encoding) -> Result<Vec<Transform>, DecodeError> {
    let mut r = Reader::new(msg, encoding)?;
    let n = r.count("transforms", 60)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let (parent, _) = r.header()?;
        let child = r.string("child_frame_id")?;
        let mut v = [0.0; 7];
        for (i, x) in v.iter_mut().enumerate() {
            *x = r.f64(if i < 3 { "translation" } else { "rotation" })?;
        }
        let q = Quaternion::new(v[6], v[3], v[4], v[5]);
        if !v.iter().all(|x| x.is_finite()) || q.norm() < 1e-9 {
            return Err(r.err(format!(
                "transform {parent} -> {child} is not finite or has a zero quaternion"
            )));
        }
        out.push(Transform {
            parent,
            child,
            transform: Isometry3::from_parts(
                Translation3::new(v[0], v[1], v[2]),
                UnitQuaternion::from_quaternion(q),
            ),
        });
    }
    Ok(out)
}

const CLOUD_SCHEMAS: [&str; 2] = ["sensor_msgs/PointCloud2", "sensor_msgs/msg/PointCloud2"];
const TF_SCHEMAS: [&str; 2] = ["tf2_msgs/TFMessage", "tf2_msgs/msg/TFMessage"];

fn mcap_err(path: &Path, e: ::mcap::McapError) -> FormatError {
    FormatError::syntax(
        path,
        Location::File,
        format!("not a readable MCAP file: {e}"),
    )
}

fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    std::fs::read(path).map_err(|e| FormatError::io(path, Location::File, e))
}

/// Every message of an MCAP file in file order, with its channel, through `visit`.
///
/// The `mcap` crate's `MessageStream` sets no limit on the length a record inside a chunk may
/// declare, and allocates (and zero-fills) that length before reading it: one damaged length
/// field (say 2^59 bytes) aborts the process. So the chunk headers are checked first
/// ([`check_chunk_sizes`]), and the messages are read with the crate's `MessageReader` under a
/// record length limit: the file's size or the largest chunk's decompressed size, whichever
/// is larger. No record can be longer than that in a valid file.
fn for_each_message<F>(path: &Path, bytes: &[u8], mut visit: F) -> Result<(), FormatError>
where
    F: FnMut(usize, &::mcap::Message<'static>) -> Result<(), FormatError>,
{
    let largest_chunk = check_chunk_sizes(path, bytes)?;
    let limit = usize::try_from(largest_chunk)
        .unwrap_or(usize::MAX)
        .max(bytes.len());
    let mut reader = ::mcap::sans_io::MessageReader::new_with_options(
        ::mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(limit),
    );
    let mut rest = bytes;
    let mut index = 0;
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| mcap_err(path, e))? {
            ::mcap::sans_io::MessageReadEvent::ReadRequest(need) => {
                let n = need.min(rest.len());
                reader.insert(n).copy_from_slice(&rest[..n]);
                reader.notify_read(n);
                rest = &rest[n..];
            }
            ::mcap::sans_io::MessageReadEvent::Message(m) => {
                visit(index, &m)?;
                index += 1;
            }
        }
    }
    Ok(())
}

/// The largest decompressed size a chunk may declare, given its compressed size: 1024 times
/// that (real sensor data compresses two- to tenfold) and at least 64 MiB.
fn chunk_size_limit(compressed: u64) -> u64 {
    compressed.saturating_mul(1024).max(64 << 20)
}

/// Refuse compressed chunks whose header declares an absurd decompressed size (see
/// [`chunk_size_limit`]), and return the largest size a chunk's records take decompressed (0
/// without chunks). The `mcap` crate allocates (and zero-fills) that size
/// before decompressing, so a damaged size field would abort the process instead of failing.
/// Walks the records (opcode, `u64` length, content) from the leading magic to the footer;
/// anything else malformed is left for the crate to report.
fn check_chunk_sizes(path: &Path, bytes: &[u8]) -> Result<u64, FormatError> {
    const MAGIC: &[u8] = b"\x89MCAP0\r\n";
    const OP_FOOTER: u8 = 0x02;
    const OP_CHUNK: u8 = 0x06;
    let mut largest = 0;
    if !bytes.starts_with(MAGIC) {
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
    let mut pos = MAGIC.len();
    while let (Some(&op), Some(len)) = (bytes.get(pos), u64_at(bytes, pos + 1)) {
        let start = pos + 9;
        let Some(end) = usize::try_from(len).ok().and_then(|l| start.checked_add(l)) else {
            break;
        };
        if end > bytes.len() || op == OP_FOOTER {
            break;
        }
        if op == OP_CHUNK {
            // start time, end time, uncompressed size, uncompressed CRC, compression string,
            // then the compressed records with their u64 length
            // (read within the record only: a chunk too short for them is the crate's to report)
            let rec = &bytes[start..end];
            let declared = u64_at(rec, 16);
            let name_len = u32_at(rec, 28).map(|n| n as usize);
            let records = name_len.and_then(|n| u64_at(rec, 32usize.checked_add(n)?));
            let compression = name_len.and_then(|n| rec.get(32..32usize.checked_add(n)?));
            if let (Some(declared), Some(records), Some(compression)) =
                (declared, records, compression)
            {
                // an uncompressed chunk's records are read as they lie in the file, whatever
                // size its header declares
                if compression.is_empty() {
                    largest = largest.max(records);
                    pos = end;
                    continue;
                }
                if declared > chunk_size_limit(records) {
                    return Err(FormatError::syntax(
                        path,
                        Location::Byte(pos as u64),
                        format!(
                            "chunk declares {declared} bytes decompressed from {records} ({}); \
                             the size field is damaged",
                            String::from_utf8_lossy(compression)
                        ),
                    ));
                }
                largest = largest.max(declared);
            }
        }
        pos = end;
    }
    Ok(largest)
}

fn topics_of(path: &Path, bytes: &[u8]) -> Result<Vec<TopicInfo>, FormatError> {
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
    match ::mcap::Summary::read(bytes) {
        Ok(Some(summary)) if !summary.channels.is_empty() => {
            for c in summary.channels.values() {
                add(c);
            }
        }
        _ => {
            for_each_message(path, bytes, |_, m| {
                add(&m.channel);
                Ok(())
            })?;
        }
    }
    Ok(map.into_values().collect())
}

/// The topics of an MCAP file with their message types and encodings, sorted by name.
pub fn list_topics(path: &Path) -> Result<Vec<TopicInfo>, FormatError> {
    let bytes = read_bytes(path)?;
    topics_of(path, &bytes)
}

fn describe(topics: &[TopicInfo]) -> String {
    topics
        .iter()
        .map(|t| format!("{} ({})", t.topic, t.schema))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Transforms collected from a file: static ones and timed dynamic ones per (parent, child).
/// One recorded transform of an edge: (log time, static, parent ← child).
type Stamped = (u64, bool, Isometry3<f64>);

#[derive(Default)]
struct TfTree {
    edges: HashMap<(String, String), Vec<Stamped>>,
}

impl TfTree {
    fn add(&mut self, t: Transform, time: u64, is_static: bool) {
        self.edges
            .entry((t.parent, t.child))
            .or_default()
            .push((time, is_static, t.transform));
    }

    fn at(&self, list: &[Stamped], time: u64) -> Isometry3<f64> {
        if let Some(s) = list.iter().rev().find(|e| e.1) {
            return s.2;
        }
        list.iter()
            .filter(|e| e.0 <= time)
            .max_by_key(|e| e.0)
            .or_else(|| list.iter().min_by_key(|e| e.0))
            .map(|e| e.2)
            .unwrap_or_else(Isometry3::identity)
    }

    /// The root of `frame`'s tree (following child → parent), or `frame` itself.
    fn root(&self, frame: &str) -> String {
        let mut cur = frame.to_string();
        let mut seen = vec![cur.clone()];
        while let Some(((p, _), _)) = self.edges.iter().find(|((_, c), _)| *c == cur) {
            if seen.contains(p) {
                break;
            }
            cur = p.clone();
            seen.push(cur.clone());
        }
        cur
    }

    /// `fixed ← frame` at `time`, composing edges either way; `None` if not connected.
    fn lookup(&self, fixed: &str, frame: &str, time: u64) -> Option<Isometry3<f64>> {
        let mut known: HashMap<&str, Isometry3<f64>> = HashMap::new();
        known.insert(fixed, Isometry3::identity());
        loop {
            if let Some(t) = known.get(frame) {
                return Some(*t);
            }
            let mut grew = false;
            for ((p, c), list) in &self.edges {
                match (
                    known.get(p.as_str()).copied(),
                    known.get(c.as_str()).copied(),
                ) {
                    (Some(tp), None) => {
                        known.insert(c, tp * self.at(list, time));
                        grew = true;
                    }
                    (None, Some(tc)) => {
                        known.insert(p, tc * self.at(list, time).inverse());
                        grew = true;
                    }
                    _ => {}
                }
            }
            if !grew {
                return None;
            }
        }
    }

    fn frames(&self) -> Vec<String> {
        let mut f: Vec<String> = self
            .edges
            .keys()
            .flat_map(|(p, c)| [p.clone(), c.clone()])
            .collect();
        f.sort();
        f.dedup();
        f
    }
}

/// Every cloud of the selected topic as a frame, with per-cloud counts.
///
/// Errors name the file and what is wrong: unreadable MCAP, unknown topic (listing the
/// topics), a topic that is not PointCloud2, an unknown message encoding, a malformed
/// message (with its index and byte), a fixed frame not connected to the cloud's frame.
pub fn read_mcap(
    path: &Path,
    options: &McapOptions,
) -> Result<(Vec<Frame>, Vec<CloudStats>), FormatError> {
    let bytes = read_bytes(path)?;
    let topics = topics_of(path, &bytes)?;
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
    let mut clouds: Vec<(u64, PointCloud2)> = Vec::new();
    for_each_message(path, &bytes, |index, m| {
        let ch = &m.channel;
        let schema = ch.schema.as_ref().map(|s| s.name.as_str()).unwrap_or("");
        let is_cloud = ch.topic == topic;
        let is_tf = TF_SCHEMAS.contains(&schema) && (ch.topic == "/tf" || ch.topic == "/tf_static");
        if !is_cloud && !is_tf {
            return Ok(());
        }
        let encoding = Encoding::from_mcap(&ch.message_encoding).ok_or_else(|| {
            FormatError::unsupported(
                path,
                Location::File,
                format!(
                    "topic {:?} uses message encoding {:?}; only \"ros1\" and \"cdr\" are supported",
                    ch.topic, ch.message_encoding
                ),
            )
        })?;
        let bad = |e: DecodeError| {
            FormatError::syntax(
                path,
                Location::File,
                format!("message {index} on {:?}: {e}", ch.topic),
            )
        };
        if is_cloud {
            clouds.push((
                m.log_time,
                decode_point_cloud2(&m.data, encoding).map_err(bad)?,
            ));
        } else {
            for t in decode_tf_message(&m.data, encoding).map_err(bad)? {
                tf.add(t, m.log_time, ch.topic == "/tf_static");
            }
        }
        Ok(())
    })?;

    let world = options.sensor_pose.unwrap_or_else(Isometry3::identity);
    let mut frames = Vec::with_capacity(clouds.len());
    let mut stats = Vec::with_capacity(clouds.len());
    for (i, (time, cloud)) in clouds.iter().enumerate() {
        let fixed = options
            .fixed_frame
            .clone()
            .unwrap_or_else(|| tf.root(&cloud.frame_id));
        let to_fixed = tf.lookup(&fixed, &cloud.frame_id, *time).ok_or_else(|| {
            FormatError::missing_pose(
                path,
                Location::File,
                format!(
                    "cloud {i} on {topic:?}: no transform chain from {:?} to {fixed:?} (frames in tf: {})",
                    cloud.frame_id,
                    tf.frames().join(", ")
                ),
            )
        })?;
        let pose = world * to_fixed;
        let (pts, st) = cloud.points().map_err(|message| {
            FormatError::syntax(
                path,
                Location::File,
                format!("cloud {i} on {topic:?}: {message}"),
            )
        })?;
        let points = pts
            .into_iter()
            .map(|p| (pose * p.cast::<f64>()).cast::<f32>())
            .collect();
        frames.push(Frame {
            origin: (pose * Point3::origin()).cast::<f32>(),
            points,
            stamp: Some(cloud.stamp),
            camera: None,
        });
        stats.push(st);
    }
    Ok((frames, stats))
}

/// [`read_mcap`] without the counts.
pub fn read_mcap_frames(path: &Path, options: &McapOptions) -> Result<Vec<Frame>, FormatError> {
    read_mcap(path, options).map(|(f, _)| f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdr_alignment_is_relative_to_the_payload() {
        // encapsulation (LE), then u8 1, pad to 4, u32 7, pad to 8, f64 2.5
        let mut m = vec![0, 1, 0, 0, 1, 0, 0, 0];
        m.extend_from_slice(&7u32.to_le_bytes());
        m.extend_from_slice(&2.5f64.to_le_bytes());
        let mut r = Reader::new(&m, Encoding::Cdr).unwrap();
        assert_eq!(r.u8("a").unwrap(), 1);
        assert_eq!(r.u32("b").unwrap(), 7);
        assert_eq!(r.f64("c").unwrap(), 2.5);
        assert_eq!(r.pos, m.len());
    }

    #[test]
    fn huge_dimensions_with_little_data_are_errors() {
        let field = |name: &str, offset| PointField {
            name: name.into(),
            offset,
            datatype: datatype::FLOAT32,
            count: 1,
        };
        let cloud = PointCloud2 {
            frame_id: "f".into(),
            stamp: 0.0,
            height: u32::MAX,
            width: u32::MAX,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: u32::MAX,
            row_step: u32::MAX,
            data: vec![0; 64],
            is_dense: true,
        };
        let e = cloud.points().unwrap_err();
        assert!(e.contains("row_step"), "{e}");
        let cloud = PointCloud2 {
            width: 1 << 28,
            point_step: 12,
            row_step: 12 << 28,
            ..cloud
        };
        let e = cloud.points().unwrap_err();
        assert!(e.contains("data holds 64 bytes"), "{e}");
    }

    #[test]
    fn truncated_messages_are_errors() {
        let mut r = Reader::new(&[0, 1, 0, 0, 9], Encoding::Cdr).unwrap();
        let e = r.u32("height").unwrap_err();
        assert!(e.message.contains("height"), "{e}");
        assert!(decode_point_cloud2(&[], Encoding::Ros1).is_err());
        assert!(decode_point_cloud2(&[0, 7, 0, 0], Encoding::Cdr).is_err());
    }
}
