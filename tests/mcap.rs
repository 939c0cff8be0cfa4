//! MCAP input: the real ROS 1 Ouster recording, and ROS 2 CDR files written here with the
//! mcap writer and read back.

use crate::common;
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use octoquant::formats::mcap::{datatype, list_topics, read_mcap, McapOptions, TopicInfo};
use std::collections::BTreeMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

const OUSTER: &str = "mcap/pointcloudset_ouster_os1/test.mcap";
const OUSTER_TOPIC: &str = "/os1_cloud_node/points";

#[test]
fn ouster_recording_gives_two_clouds_with_missing_returns_skipped() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let (frames, stats) = read_mcap(&path, &McapOptions::default()).unwrap();
    assert_eq!(frames.len(), 2);
    assert_eq!(stats.len(), 2);
    let kept: Vec<usize> = stats.iter().map(|s| s.kept).collect();
    assert_eq!(kept, [45_716, 45_809]);
    for (f, s) in frames.iter().zip(&stats) {
        assert_eq!(s.points, 131_072);
        assert_eq!(s.non_finite, 0);
        assert_eq!(s.zero, 131_072 - s.kept);
        assert_eq!(f.points.len(), s.kept);
    }
    // header stamps, not the replay log time
    assert!((frames[0].stamp.unwrap() - 1_588_075_038.629_916).abs() < 1e-5);
    assert!((frames[1].stamp.unwrap() - 1_588_075_038.729_033_5).abs() < 1e-5);
    // /tf_static: os1_sensor <- os1_lidar is (0, 0, 0.03618) and 180° about z; the root
    // frame os1_sensor is the default fixed frame, so the origin is lifted 3.6 cm.
    let o = frames[0].origin;
    assert!(o.x.abs() < 1e-6 && o.y.abs() < 1e-6, "{o}");
    assert!((o.z - 0.03618).abs() < 1e-6, "{o}");
    // valid ranges are 0.64–14.7 m from the sensor
    for p in &frames[0].points {
        let r = (p - o).norm();
        assert!((0.6..15.0).contains(&r), "range {r}");
    }
}

#[test]
fn ouster_in_its_own_frame_and_topic_listing() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let topics = list_topics(&path).unwrap();
    assert!(topics.contains(&TopicInfo {
        topic: OUSTER_TOPIC.into(),
        schema: "sensor_msgs/PointCloud2".into(),
        encoding: "ros1".into(),
    }));
    assert!(topics.iter().any(|t| t.topic == "/tf_static"));

    let own = McapOptions {
        topic: Some(OUSTER_TOPIC.into()),
        fixed_frame: Some("os1_lidar".into()),
        sensor_pose: None,
        colors: false,
    };
    let (lidar, _) = read_mcap(&path, &own).unwrap();
    let (sensor, _) = read_mcap(&path, &McapOptions::default()).unwrap();
    assert_eq!(lidar[0].origin, Point3::origin());
    // 180° about z plus the lift: (x, y, z) -> (-x, -y, z + 0.03618)
    let (a, b) = (lidar[0].points[100], sensor[0].points[100]);
    assert!(
        (b.x + a.x).abs() < 1e-5 && (b.y + a.y).abs() < 1e-5,
        "{a} {b}"
    );
    assert!((b.z - a.z - 0.03618).abs() < 1e-5, "{a} {b}");
}

#[test]
fn unknown_topic_and_frame_errors_name_what_exists() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let e = read_mcap(
        &path,
        &McapOptions {
            topic: Some("/nope".into()),
            ..McapOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("/nope") && e.contains(OUSTER_TOPIC), "{e}");
    assert!(e.contains("test.mcap"), "{e}");

    let e = read_mcap(
        &path,
        &McapOptions {
            topic: Some("/os1_cloud_node/imu".into()),
            ..McapOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("sensor_msgs/Imu"), "{e}");

    let e = read_mcap(
        &path,
        &McapOptions {
            fixed_frame: Some("map".into()),
            ..McapOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("\"map\"") && e.contains("os1_sensor"), "{e}");
}

/// A CDR serializer: encapsulation header, then primitives aligned to their size relative
/// to the end of the header.
struct Cdr {
    buf: Vec<u8>,
    be: bool,
}

impl Cdr {
    fn new(be: bool) -> Cdr {
        Cdr {
            buf: vec![0, if be { 0 } else { 1 }, 0, 0],
            be,
        }
    }
    fn align(&mut self, n: usize) {
        while !(self.buf.len() - 4).is_multiple_of(n) {
            self.buf.push(0);
        }
    }
    fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.align(4);
        let b = if self.be {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        self.buf.extend_from_slice(&b);
    }
    fn f64(&mut self, v: f64) {
        self.align(8);
        let b = if self.be {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        };
        self.buf.extend_from_slice(&b);
    }
    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }
    fn header(&mut self, sec: i32, nsec: u32, frame: &str) {
        self.u32(sec as u32);
        self.u32(nsec);
        self.string(frame);
    }
}

/// A PointCloud2 of 2 rows × 3 points with f64 x, y, z at odd offsets, a leading intensity
/// field, padded points and rows; the data follows `data_be`.
fn cloud_message(be: bool, data_be: bool, points: &[[f64; 3]; 6], fields: &[&str]) -> Vec<u8> {
    let mut c = Cdr::new(be);
    c.header(100, 500_000_000, "lidar");
    c.u32(2); // height
    c.u32(3); // width
    let layout: Vec<(&str, u32, u8)> = vec![
        ("intensity", 0, datatype::FLOAT32),
        ("x", 4, datatype::FLOAT64),
        ("y", 12, datatype::FLOAT64),
        ("z", 24, datatype::FLOAT64),
        ("rgb", 32, datatype::FLOAT32),
    ];
    let layout: Vec<_> = layout
        .into_iter()
        .filter(|f| fields.contains(&f.0))
        .collect();
    c.u32(layout.len() as u32);
    for (name, offset, dt) in &layout {
        c.string(name);
        c.u32(*offset);
        c.u8(*dt);
        c.u32(1);
    }
    c.u8(data_be as u8);
    let point_step = 40u32;
    let row_step = 3 * point_step + 8;
    c.u32(point_step);
    c.u32(row_step);
    let mut data = vec![0xEEu8; (2 * row_step) as usize];
    for (i, p) in points.iter().enumerate() {
        let base = (i / 3) * row_step as usize + (i % 3) * point_step as usize;
        for (k, off) in [4usize, 12, 24].into_iter().enumerate() {
            let b = if data_be {
                p[k].to_be_bytes()
            } else {
                p[k].to_le_bytes()
            };
            data[base + off..base + off + 8].copy_from_slice(&b);
        }
        // the packed colour 0x00RRGGBB of point i: (10 i, 20 i, 30 i)
        let bits = u32::from_be_bytes([0, 10 * i as u8, 20 * i as u8, 30 * i as u8]);
        let b = if data_be {
            bits.to_be_bytes()
        } else {
            bits.to_le_bytes()
        };
        data[base + 32..base + 36].copy_from_slice(&b);
    }
    c.u32(data.len() as u32);
    c.buf.extend_from_slice(&data);
    c.u8(1); // is_dense
    c.buf
}

fn tf_message(be: bool, transforms: &[(&str, &str, [f64; 3], [f64; 4])]) -> Vec<u8> {
    let mut c = Cdr::new(be);
    c.u32(transforms.len() as u32);
    for (parent, child, t, q) in transforms {
        c.header(0, 0, parent);
        c.string(child);
        for v in t {
            c.f64(*v);
        }
        for v in q {
            c.f64(*v);
        }
    }
    c.buf
}

struct Msg<'a> {
    topic: &'a str,
    schema: &'a str,
    encoding: &'a str,
    data: Vec<u8>,
}

fn write_mcap(path: &Path, messages: &[Msg]) {
    write_mcap_with(path, messages, Some(::mcap::Compression::Zstd));
}

fn write_mcap_with(path: &Path, messages: &[Msg], compression: Option<::mcap::Compression>) {
    let mut w = ::mcap::WriteOptions::new()
        .profile("ros2")
        .compression(compression)
        .create(Cursor::new(Vec::new()))
        .unwrap();
    let mut channels: BTreeMap<&str, u16> = BTreeMap::new();
    for (i, m) in messages.iter().enumerate() {
        let id = match channels.get(m.topic) {
            Some(&id) => id,
            None => {
                let sid = w
                    .add_schema(m.schema, "ros2msg", b"(definition omitted)")
                    .unwrap();
                let id = w
                    .add_channel(sid, m.topic, m.encoding, &BTreeMap::new())
                    .unwrap();
                channels.insert(m.topic, id);
                id
            }
        };
        let header = ::mcap::records::MessageHeader {
            channel_id: id,
            sequence: i as u32,
            log_time: 1_000 + i as u64,
            publish_time: 1_000 + i as u64,
        };
        w.write_to_known_channel(&header, &m.data).unwrap();
    }
    w.finish().unwrap();
    std::fs::write(path, w.into_inner().into_inner()).unwrap();
}

fn ros2_file(name: &str, be: bool, data_be: bool) -> PathBuf {
    let dir = common::scratch(name);
    let path = dir.join("ros2.mcap");
    let nan = f64::NAN;
    let pts = [
        [1.0, 2.0, 3.0],
        [nan, 0.0, 1.0],
        [0.0, 0.0, 0.0],
        [-4.5, 0.25, 1e-3],
        [10.0, -20.0, 0.5],
        [0.0, 0.0, 2.0],
    ];
    let s = std::f64::consts::FRAC_1_SQRT_2;
    write_mcap(
        &path,
        &[
            Msg {
                topic: "/cloud",
                schema: "sensor_msgs/msg/PointCloud2",
                encoding: "cdr",
                data: cloud_message(be, data_be, &pts, &["intensity", "x", "y", "z"]),
            },
            Msg {
                topic: "/tf_static",
                schema: "tf2_msgs/msg/TFMessage",
                encoding: "cdr",
                data: tf_message(
                    be,
                    &[
                        ("map", "base", [1.0, 2.0, 3.0], [0.0, 0.0, s, s]),
                        ("base", "lidar", [0.0, 0.0, 0.5], [0.0, 0.0, 0.0, 1.0]),
                    ],
                ),
            },
            Msg {
                topic: "/status",
                schema: "std_msgs/msg/String",
                encoding: "cdr",
                data: vec![0, 1, 0, 0, 1, 0, 0, 0, 0],
            },
        ],
    );
    path
}

fn check_ros2_round_trip(path: &Path) {
    let (frames, stats) = read_mcap(path, &McapOptions::default()).unwrap();
    assert_eq!(frames.len(), 1);
    let s = stats[0];
    assert_eq!((s.points, s.kept, s.non_finite, s.zero), (6, 4, 1, 1));
    assert!((frames[0].stamp.unwrap() - 100.5).abs() < 1e-9);
    // map <- base: 90° about z then (1, 2, 3); base <- lidar: (0, 0, 0.5)
    let pose = Isometry3::from_parts(
        Translation3::new(1.0, 2.0, 3.0),
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), std::f64::consts::FRAC_PI_2),
    ) * Isometry3::translation(0.0, 0.0, 0.5);
    let expect: Vec<Point3<f32>> = [
        [1.0, 2.0, 3.0],
        [-4.5, 0.25, 1e-3],
        [10.0, -20.0, 0.5],
        [0.0, 0.0, 2.0],
    ]
    .iter()
    .map(|p| (pose * Point3::new(p[0], p[1], p[2])).cast::<f32>())
    .collect();
    assert_eq!(frames[0].points.len(), expect.len());
    for (a, b) in frames[0].points.iter().zip(&expect) {
        assert!((a - b).norm() < 1e-5, "{a} vs {b}");
    }
    assert!((frames[0].origin - Point3::new(1.0f32, 2.0, 3.5)).norm() < 1e-6);

    // a sensor pose maps the fixed frame into the world
    let shifted = read_mcap(
        path,
        &McapOptions {
            sensor_pose: Some(Isometry3::translation(0.0, 0.0, 10.0)),
            ..McapOptions::default()
        },
    )
    .unwrap()
    .0;
    assert!((shifted[0].origin.z - 13.5).abs() < 1e-6);
}

#[test]
fn ros2_cdr_round_trip_little_endian() {
    check_ros2_round_trip(&ros2_file("mcap_cdr_le", false, false));
}

#[test]
fn ros2_cdr_round_trip_big_endian_message_and_data() {
    check_ros2_round_trip(&ros2_file("mcap_cdr_be", true, true));
}

/// PointCloud2 `rgb` in either byte order: one colour per kept point (NaN and zero points
/// dropped with theirs), none without the option or without the field; the real Ouster
/// recording has no colour field, so it gives none.
#[test]
fn pointcloud2_rgb_follows_the_kept_points() {
    let nan = f64::NAN;
    let pts = [
        [1.0, 2.0, 3.0],
        [nan, 0.0, 1.0],
        [0.0, 0.0, 0.0],
        [-4.5, 0.25, 1e-3],
        [10.0, -20.0, 0.5],
        [0.0, 0.0, 2.0],
    ];
    let kept = [0u8, 3, 4, 5];
    let colored = McapOptions {
        colors: true,
        ..McapOptions::default()
    };
    for (be, data_be) in [(false, false), (true, true), (false, true)] {
        let dir = common::scratch(&format!("mcap_rgb_{be}_{data_be}"));
        for fields in [&["x", "y", "z", "rgb"][..], &["x", "y", "z"][..]] {
            let path = dir.join(format!("{}.mcap", fields.len()));
            write_mcap(
                &path,
                &[Msg {
                    topic: "/cloud",
                    schema: "sensor_msgs/msg/PointCloud2",
                    encoding: "cdr",
                    data: cloud_message(be, data_be, &pts, fields),
                }],
            );
            let (frames, _) = read_mcap(&path, &colored).unwrap();
            assert_eq!(frames[0].points.len(), 4);
            let want: Vec<octoquant::octree::Color> = kept
                .iter()
                .map(|&i| octoquant::octree::Color::new(10 * i, 20 * i, 30 * i))
                .collect();
            let got = frames[0].colors.clone();
            if fields.contains(&"rgb") {
                assert_eq!(got, Some(want), "{be} {data_be}");
                let (plain, _) = read_mcap(&path, &McapOptions::default()).unwrap();
                assert_eq!(plain[0].colors, None);
            } else {
                assert_eq!(got, None);
            }
        }
    }
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let (frames, _) = read_mcap(&path, &colored).unwrap();
    assert!(frames.iter().all(|f| f.colors.is_none()));
}

#[test]
fn unknown_encoding_and_missing_field_are_named() {
    let dir = common::scratch("mcap_errors");
    let pts = [[1.0, 2.0, 3.0]; 6];
    let json = dir.join("json.mcap");
    write_mcap(
        &json,
        &[Msg {
            topic: "/cloud",
            schema: "sensor_msgs/msg/PointCloud2",
            encoding: "json",
            data: b"{}".to_vec(),
        }],
    );
    let e = read_mcap(&json, &McapOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("json") && e.contains("json.mcap"), "{e}");

    let noz = dir.join("noz.mcap");
    write_mcap(
        &noz,
        &[Msg {
            topic: "/cloud",
            schema: "sensor_msgs/msg/PointCloud2",
            encoding: "cdr",
            data: cloud_message(false, false, &pts, &["x", "y"]),
        }],
    );
    let e = read_mcap(&noz, &McapOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no field \"z\"") && e.contains("noz.mcap"),
        "{e}"
    );

    let garbage = dir.join("garbage.mcap");
    std::fs::write(&garbage, b"not an mcap file at all").unwrap();
    let e = read_mcap(&garbage, &McapOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("garbage.mcap") && e.contains("MCAP"), "{e}");

    // a truncated message: every prefix of a valid cloud fails cleanly, never panics
    let full = cloud_message(false, false, &pts, &["x", "y", "z"]);
    for cut in 0..full.len() {
        assert!(octoquant::formats::mcap::decode_point_cloud2(
            &full[..cut],
            octoquant::formats::mcap::Encoding::Cdr
        )
        .is_err());
    }
}

/// The first chunk record of an MCAP file: its offset and its content's offset. Walks the
/// top-level records (opcode, `u64` length, content) after the 8-byte magic.
fn first_chunk(bytes: &[u8]) -> (usize, usize) {
    let mut pos = 8;
    while bytes[pos] != 0x06 {
        pos += 9 + u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
    }
    (pos, pos + 9)
}

fn put_u64(bytes: &mut [u8], at: usize, v: u64) {
    bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

#[test]
fn damaged_length_fields_are_errors_not_aborts() {
    // The mcap crate allocates a declared length before reading it; a damaged field of 2^59
    // bytes used to abort the whole process.
    let dir = common::scratch("mcap_damaged_lengths");
    let pts = [[1.0, 2.0, 3.0]; 6];
    let msgs = [Msg {
        topic: "/cloud",
        schema: "sensor_msgs/msg/PointCloud2",
        encoding: "cdr",
        data: cloud_message(false, false, &pts, &["x", "y", "z"]),
    }];
    let huge = 1u64 << 59;

    // a zstd chunk whose header declares 2^59 bytes decompressed
    let zstd = dir.join("zstd.mcap");
    write_mcap(&zstd, &msgs);
    let mut bytes = std::fs::read(&zstd).unwrap();
    assert!(read_mcap(&zstd, &McapOptions::default()).is_ok());
    let (pos, content) = first_chunk(&bytes);
    put_u64(&mut bytes, content + 16, huge);
    std::fs::write(&zstd, &bytes).unwrap();
    let e = read_mcap(&zstd, &McapOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("zstd.mcap") && e.contains(&format!("byte {pos}")) && e.contains("chunk"),
        "{e}"
    );

    // an uncompressed chunk holding a message record that declares 2^59 bytes
    let plain = dir.join("plain.mcap");
    write_mcap_with(&plain, &msgs, None);
    let mut bytes = std::fs::read(&plain).unwrap();
    assert!(read_mcap(&plain, &McapOptions::default()).is_ok());
    let (_, content) = first_chunk(&bytes);
    let name_len = u32::from_le_bytes(bytes[content + 28..content + 32].try_into().unwrap());
    assert_eq!(name_len, 0, "the chunk is not compressed");
    // the chunk's records: opcode, u64 length, content, ...; the first message is changed
    let mut at = content + 32 + 8;
    while bytes[at] != 0x05 {
        at += 9 + u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
    }
    put_u64(&mut bytes, at + 1, huge);
    std::fs::write(&plain, &bytes).unwrap();
    let e = read_mcap(&plain, &McapOptions::default())
        .unwrap_err()
        .to_string();
    // refused by the reader's own check of records against their chunk, before the mcap
    // crate sees the length
    assert!(
        e.contains("plain.mcap") && e.contains("runs past the chunk's end"),
        "{e}"
    );

    // the real recording with two bytes of compressed data changed (found by fuzzing): the
    // decompressed records then declare absurd lengths
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[1_772_533] = 141;
    bytes[3_573_271] = 253;
    let damaged = dir.join("ouster_damaged.mcap");
    std::fs::write(&damaged, &bytes).unwrap();
    let e = read_mcap(&damaged, &McapOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("ouster_damaged.mcap"), "{e}");
}

/// The layouts an MCAP file of the same messages can take: how `rewrite` writes it.
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// zstd chunks of at most 64 KiB (many chunks), with summary and indexes.
    SmallZstdChunks,
    /// Uncompressed chunks.
    UncompressedChunks,
    /// No chunks: messages straight in the data section.
    Unchunked,
    /// zstd chunks but no summary section, no indexes, no summary offsets.
    NoSummary,
}

const LAYOUTS: [Layout; 4] = [
    Layout::SmallZstdChunks,
    Layout::UncompressedChunks,
    Layout::Unchunked,
    Layout::NoSummary,
];

/// Every message of `src` read whole into memory by the `mcap` crate's own reader, then
/// written again in `layout` (same schemas, channels, times and bytes).
fn rewrite(src: &Path, dst: &Path, layout: Layout) {
    let opts = ::mcap::WriteOptions::new();
    let opts = match layout {
        Layout::SmallZstdChunks => opts
            .compression(Some(::mcap::Compression::Zstd))
            .chunk_size(Some(64 << 10)),
        Layout::UncompressedChunks => opts.compression(None),
        Layout::Unchunked => opts.use_chunks(false),
        Layout::NoSummary => opts
            .compression(Some(::mcap::Compression::Zstd))
            .emit_summary_records(false)
            .emit_summary_offsets(false)
            .emit_statistics(false)
            .emit_message_indexes(false)
            .emit_chunk_indexes(false),
    };
    let bytes = std::fs::read(src).unwrap();
    std::fs::write(dst, rewritten(&bytes, opts)).unwrap();
}

/// Every message of the MCAP file `bytes`, read whole by the `mcap` crate's own reader,
/// written again with `opts` (same schemas, channels, times and bytes).
fn rewritten(bytes: &[u8], opts: ::mcap::WriteOptions) -> Vec<u8> {
    let mut w = opts.create(Cursor::new(Vec::new())).unwrap();
    let mut channels: BTreeMap<u16, u16> = BTreeMap::new();
    for m in ::mcap::MessageStream::new(bytes).unwrap() {
        let m = m.unwrap();
        let ch = &m.channel;
        let id = match channels.get(&ch.id) {
            Some(&id) => id,
            None => {
                let sid = match &ch.schema {
                    Some(s) => w.add_schema(&s.name, &s.encoding, &s.data).unwrap(),
                    None => 0,
                };
                let id = w
                    .add_channel(sid, &ch.topic, &ch.message_encoding, &ch.metadata)
                    .unwrap();
                channels.insert(ch.id, id);
                id
            }
        };
        let header = ::mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        w.write_to_known_channel(&header, &m.data).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

/// The frames' bits, for exact comparison (NaN included).
fn frame_bits(frames: &[octoquant::Frame]) -> Vec<(Vec<u32>, Option<u64>)> {
    frames
        .iter()
        .map(|f| {
            let mut v: Vec<u32> = f.origin.iter().map(|c| c.to_bits()).collect();
            for p in &f.points {
                v.extend(p.iter().map(|c| c.to_bits()));
            }
            (v, f.stamp.map(f64::to_bits))
        })
        .collect()
}

/// The streaming reader (seeking, one chunk at a time) gives the same frames whatever the
/// file's layout: chunked or not, compressed or not, with or without a summary. The files
/// are the crate's whole-file reading of the real recording and of our own test file,
/// written again in each layout; and the counts are those the whole-file reader found.
#[test]
fn every_layout_gives_the_same_frames() {
    let dir = common::scratch("mcap_layouts");
    let mut sources = vec![ros2_file("mcap_layouts_src", false, false)];
    // several clouds with a transform after them, in our own writer's default layout
    let multi = dir.join("multi.mcap");
    let pts = [[1.0, 2.0, 3.0]; 6];
    let mut msgs = Vec::new();
    for _ in 0..40 {
        msgs.push(Msg {
            topic: "/cloud",
            schema: "sensor_msgs/msg/PointCloud2",
            encoding: "cdr",
            data: cloud_message(false, false, &pts, &["x", "y", "z"]),
        });
    }
    msgs.push(Msg {
        topic: "/tf_static",
        schema: "tf2_msgs/msg/TFMessage",
        encoding: "cdr",
        data: tf_message(
            false,
            &[
                ("map", "base", [1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]),
                ("base", "lidar", [0.0, 0.0, 0.5], [0.0, 0.0, 0.0, 1.0]),
            ],
        ),
    });
    write_mcap(&multi, &msgs);
    sources.push(multi);
    if let Some(p) = common::data_file(OUSTER) {
        sources.push(p);
    }
    for src in &sources {
        let whole = ::mcap::MessageStream::new(&std::fs::read(src).unwrap())
            .unwrap()
            .filter(|m| {
                m.as_ref().is_ok_and(|m| {
                    m.channel
                        .schema
                        .as_ref()
                        .is_some_and(|s| s.name.contains("PointCloud2"))
                })
            })
            .count();
        let (expect, _) = read_mcap(src, &McapOptions::default()).unwrap();
        assert_eq!(expect.len(), whole, "{}", src.display());
        assert!(!expect.is_empty());
        let expect = frame_bits(&expect);
        for layout in LAYOUTS {
            let dst = dir.join(format!("{layout:?}.mcap"));
            rewrite(src, &dst, layout);
            let (got, _) = read_mcap(&dst, &McapOptions::default())
                .unwrap_or_else(|e| panic!("{} as {layout:?}: {e}", src.display()));
            assert!(
                frame_bits(&got) == expect,
                "{} as {layout:?}: other frames",
                src.display()
            );
            let topics = list_topics(&dst).unwrap();
            assert_eq!(topics, list_topics(src).unwrap(), "{layout:?}");
        }
    }
}

/// A file cut anywhere is an error naming it (or, cut exactly between records before the
/// footer, the clouds before the cut), never a panic or a hang.
#[test]
fn truncated_files_are_errors() {
    let dir = common::scratch("mcap_truncated");
    let mut sources = vec![ros2_file("mcap_truncated_src", false, false)];
    if let Some(p) = common::data_file(OUSTER) {
        sources.push(p);
    }
    for src in &sources {
        let full = frame_bits(&read_mcap(src, &McapOptions::default()).unwrap().0);
        for layout in LAYOUTS {
            let re = dir.join(format!("re-{layout:?}.mcap"));
            rewrite(src, &re, layout);
            let bytes = std::fs::read(&re).unwrap();
            let cut = dir.join("cut.mcap");
            let mut errors = 0;
            for k in 1..24 {
                let len = bytes.len() * k / 24;
                std::fs::write(&cut, &bytes[..len]).unwrap();
                match read_mcap(&cut, &McapOptions::default()) {
                    Err(e) => {
                        errors += 1;
                        assert!(e.to_string().contains("cut.mcap"), "{e}");
                    }
                    Ok((frames, _)) => {
                        let got = frame_bits(&frames);
                        assert!(
                            full.starts_with(&got),
                            "{layout:?} cut at {len}: not a prefix"
                        );
                    }
                }
            }
            assert!(
                errors > 12,
                "{} {layout:?}: only {errors} of 23 cuts refused",
                src.display()
            );
        }
    }
}

/// The top-level chunk records of an MCAP file: each one's offset and end. Walks the
/// records (opcode, `u64` length, content) after the 8-byte magic up to the footer.
fn chunks_of(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut pos = 8;
    let mut chunks = Vec::new();
    while bytes[pos] != 0x02 {
        let end =
            pos + 9 + u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap()) as usize;
        if bytes[pos] == 0x06 {
            chunks.push((pos, end));
        }
        pos = end;
    }
    chunks
}

/// A chunk whose records no longer match the CRC-32 its header states is refused before any
/// of its messages is used, naming the file and the chunk's end: a byte changed in an
/// uncompressed chunk's point data, and a damaged CRC field of the real recording's zstd
/// chunk. Undone, the same change reads as the recording.
#[test]
fn chunks_whose_crc_does_not_match_are_refused() {
    use octoquant::formats::{frame_stream, ReadOptions};
    let Some(src) = common::data_file(OUSTER) else {
        return;
    };
    let dir = common::scratch("mcap_chunk_crc");
    let plain = dir.join("uncompressed.mcap");
    rewrite(&src, &plain, Layout::UncompressedChunks);
    let whole = frame_bits(&read_mcap(&src, &McapOptions::default()).unwrap().0);
    assert_eq!(whole.len(), 2);
    let real = std::fs::read(&src).unwrap();
    let mut cases: Vec<(&str, Vec<u8>, usize, usize, u8)> = Vec::new();
    // the last chunk of the uncompressed file holds the last cloud: change one byte in the
    // middle of its records (point data), keeping the CRC field
    let mut bytes = std::fs::read(&plain).unwrap();
    let &(start, end) = chunks_of(&bytes).last().unwrap();
    let at = (start + end) / 2;
    bytes[at] ^= 0x10;
    cases.push(("uncompressed.mcap", bytes, end, at, 0x10));
    // the real recording's second chunk with its CRC field changed (chunk content: start
    // time, end time, uncompressed size, then the CRC)
    let mut bytes = real.clone();
    let chunks = chunks_of(&bytes);
    assert_eq!(chunks.len(), 2);
    let (start, end) = chunks[1];
    bytes[start + 9 + 24] ^= 0x01;
    cases.push(("zstd.mcap", bytes, end, start + 9 + 24, 0x01));
    for (name, bytes, end, at, flip) in cases {
        let path = dir.join(format!("damaged-{name}"));
        std::fs::write(&path, &bytes).unwrap();
        let e = read_mcap(&path, &McapOptions::default())
            .map(|_| ())
            .expect_err(name)
            .to_string();
        assert!(e.contains(&format!("damaged-{name}")), "{e}");
        assert!(e.contains("CRC-32"), "{e}");
        assert!(e.contains(&format!("byte {end}")), "{name}: {e}");
        // the stream's first pass reads every chunk: it refuses the file when opening it
        let opened = frame_stream(&path, &ReadOptions::default()).map(|_| ());
        assert_eq!(opened.map_err(|e| e.to_string()), Err(e), "{name}");
        // the undamaged file reads as the recording
        let mut fixed = bytes;
        fixed[at] ^= flip;
        std::fs::write(&path, &fixed).unwrap();
        let frames = read_mcap(&path, &McapOptions::default()).unwrap().0;
        assert_eq!(frame_bits(&frames), whole, "{name}");
    }
}

/// One item of a frame stream, comparable: the frame's bits or the error's text.
type Item = Result<(Vec<u32>, Option<u64>), String>;

/// The items of `path`'s frame stream after skipping `k` (the skip's error as the only item
/// when it fails), or the opening error.
fn items_after_skip(path: &Path, k: usize) -> Result<Vec<Item>, String> {
    use octoquant::formats::{frame_stream, ReadOptions};
    let mut s = frame_stream(path, &ReadOptions::default()).map_err(|e| e.to_string())?;
    if let Err(e) = s.skip_frames(k) {
        return Ok(vec![Err(e.to_string())]);
    }
    Ok(s.map(|r| {
        r.map(|f| frame_bits(std::slice::from_ref(&f)).remove(0))
            .map_err(|e| e.to_string())
    })
    .collect())
}

/// A file of 40 small clouds in many small zstd chunks with their indexes, each byte of it
/// changed in turn (every 5th): opening, skipping and reading never panic, errors name the
/// file, and the items after a skip of `k` are the whole read's items `k..` (as far as the
/// whole read goes without an error: a cloud that fails to decode is not decoded when
/// skipped).
#[test]
fn damaged_indexed_files_skip_like_they_read() {
    let dir = common::scratch("mcap_damaged_skips");
    let src = dir.join("src.mcap");
    let mut msgs = Vec::new();
    for i in 0..40 {
        let v = f64::from(i);
        msgs.push(Msg {
            topic: "/cloud",
            schema: "sensor_msgs/msg/PointCloud2",
            encoding: "cdr",
            data: cloud_message(false, false, &[[v, 1.0, 2.0]; 6], &["x", "y", "z"]),
        });
        if i % 3 == 0 {
            msgs.push(Msg {
                topic: "/status",
                schema: "std_msgs/msg/String",
                encoding: "cdr",
                data: vec![0, 1, 0, 0, 1, 0, 0, 0, 0],
            });
        }
    }
    write_mcap(&src, &msgs);
    // the same messages again in chunks of about two messages
    let opts = ::mcap::WriteOptions::new()
        .compression(Some(::mcap::Compression::Zstd))
        .chunk_size(Some(300));
    let bytes = rewritten(&std::fs::read(&src).unwrap(), opts);
    let chunks = ::mcap::Summary::read(&bytes)
        .unwrap()
        .map_or(0, |s| s.chunk_indexes.len());
    assert!(chunks > 20, "{chunks} chunks");
    let cut = dir.join("cut.mcap");
    let ks = [1, 7, 20, 39, 41];
    for at in (8..bytes.len()).step_by(5) {
        let mut b = bytes.clone();
        b[at] ^= 0xa5;
        std::fs::write(&cut, &b).unwrap();
        let whole = match items_after_skip(&cut, 0) {
            Ok(items) => items,
            Err(e) => {
                assert!(e.contains("cut.mcap"), "byte {at}: {e}");
                for k in ks {
                    assert_eq!(items_after_skip(&cut, k), Err(e.clone()), "byte {at}");
                }
                continue;
            }
        };
        let good = whole.iter().take_while(|i| i.is_ok()).count();
        for item in &whole {
            if let Err(e) = item {
                assert!(e.contains("cut.mcap"), "byte {at}: {e}");
            }
        }
        for k in ks {
            let got = items_after_skip(&cut, k).unwrap_or_else(|e| panic!("byte {at}: {e}"));
            if k <= good {
                let start = k.min(whole.len());
                assert_eq!(got, whole[start..], "byte {at} skip {k}");
            }
        }
    }
}
