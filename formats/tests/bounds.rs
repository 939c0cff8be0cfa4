//! Memory and time bounds on hostile input, per reader: headers that claim 2^31 points,
//! 2^40-byte chunks, absurd widths, heights and point steps, and decompression bombs must give
//! a clear error quickly while allocating little; adversarial but valid inputs must cost work
//! linear in their size.
//!
//! Memory is measured by a counting global allocator (peak live bytes and total allocated
//! bytes, taken around one reader call while the other tests wait on a lock); work is measured
//! by allocation counts and, for tf lookups, by the reader's own work counter (unit tests in
//! `mcap/tf.rs`). The bombs are built in the test by repeating one small compressed member,
//! never held whole in memory or committed.

use octoquant_alloc_count::{measure, serial, Cost, CountingAlloc};
use octoquant_formats::mcap::McapOptions;
use octoquant_formats::source::{with_decompression_limit, DecompressionLimit};
use octoquant_formats::{read_frames, FormatError, ReadOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Fixed allowance for buffers that do not depend on the input (the 64 KiB read buffers, a
/// BufReader, error strings, the decoders' state: bzip2 alone takes about 3.6 MiB... when
/// decompressing with small memory off).
const SLACK: usize = 8 << 20;

/// A scratch file for one test, removed (with its directory, once empty) when dropped.
struct Scratch(PathBuf);

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
        if let Some(dir) = self.0.parent() {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

fn scratch(name: &str, bytes: &[u8]) -> Scratch {
    let dir = std::env::temp_dir().join(format!("octoquant-bounds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{e}"));
    Scratch(path)
}

fn read(path: &Path) -> Result<Vec<octoquant_formats::Frame>, FormatError> {
    read_frames(path, &ReadOptions::default())
}

/// Read `path` and require an error whose message names the file and contains `want`, with
/// a peak allocation under `factor` times the file's size plus [`SLACK`].
fn refused(path: &Path, factor: usize, want: &str) -> Cost {
    let len = std::fs::metadata(path)
        .map(|m| m.len() as usize)
        .unwrap_or(0);
    refused_within(path, &ReadOptions::default(), factor * len + SLACK, want)
}

/// [`refused`] with `options` and a peak of at most `bound` bytes.
fn refused_within(path: &Path, options: &ReadOptions, bound: usize, want: &str) -> Cost {
    let (r, cost) = measure(|| read_frames(path, options));
    let e = match r {
        Ok(f) => panic!("{} was accepted ({} frames)", path.display(), f.len()),
        Err(e) => e.to_string(),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    assert!(e.contains(&name), "error does not name the file: {e}");
    assert!(e.contains(want), "error lacks {want:?}: {e}");
    assert!(
        cost.peak <= bound,
        "{}: peak {} bytes, more than {bound} ({e})",
        path.display(),
        cost.peak
    );
    cost
}

// ---------------------------------------------------------------- PCD

fn pcd_header(fields: &str, size: &str, ty: &str, width: u64, height: u64, data: &str) -> Vec<u8> {
    format!(
        "VERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {ty}\nCOUNT 1 1 1\nWIDTH {width}\n\
         HEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {}\nDATA {data}\n",
        width * height
    )
    .into_bytes()
}

#[test]
fn pcd_binary_claiming_2_pow_31_points() {
    let _serial = serial();
    let mut b = pcd_header("x y z", "4 4 4", "F F F", 1 << 31, 1, "binary");
    b.extend_from_slice(&[0u8; 120]);
    refused(&scratch("claims.pcd", &b), 4, "truncated");
}

#[test]
fn pcd_ascii_claiming_2_pow_31_points() {
    let _serial = serial();
    let mut b = pcd_header("x y z", "4 4 4", "F F F", 1 << 16, 1 << 15, "ascii");
    b.extend_from_slice(b"1 2 3\n4 5 6\n");
    refused(
        &scratch("claims_ascii.pcd", &b),
        4,
        "ends after 2 of 2147483648",
    );
}

#[test]
fn pcd_width_times_height_overflows() {
    let _serial = serial();
    let mut b = b"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 4294967296\n".to_vec();
    b.extend_from_slice(b"HEIGHT 4294967296\nDATA binary\n");
    refused(&scratch("overflow.pcd", &b), 4, "overflows");
}

#[test]
fn pcd_lzf_declaring_4_gib_is_refused_before_allocating() {
    let _serial = serial();
    // 357913941 points of 12 bytes: 4294967292 bytes, the largest u32 multiple of 12
    let mut b = pcd_header(
        "x y z",
        "4 4 4",
        "F F F",
        357_913_941,
        1,
        "binary_compressed",
    );
    b.extend_from_slice(&16u32.to_le_bytes());
    b.extend_from_slice(&4_294_967_292u32.to_le_bytes());
    b.extend_from_slice(&[0u8; 16]);
    refused(&scratch("lzf_claims.pcd", &b), 4, "exceed the limit");
}

/// An LZF stream of `n` zero bytes: one literal, then back references of 264 bytes (the
/// format's best ratio, about 88 to 1).
fn lzf_zeros(n: usize) -> Vec<u8> {
    let mut out = vec![0u8, 0];
    let mut done = 1;
    while done < n {
        let len = (n - done).min(264);
        if len < 3 {
            out.extend(std::iter::repeat_n([0u8, 0], len).flatten());
            done += len;
            continue;
        }
        let l = len - 2;
        if l < 7 {
            out.extend_from_slice(&[(l as u8) << 5, 0]);
        } else {
            out.extend_from_slice(&[7 << 5, (l - 7) as u8, 0]);
        }
        done += len;
    }
    out
}

#[test]
fn pcd_lzf_bomb_is_capped_by_the_limit() {
    let _serial = serial();
    let points = 1 << 20; // 12 MiB of zeros from about 140 KiB
    let lzf = lzf_zeros(points * 12);
    let mut b = pcd_header(
        "x y z",
        "4 4 4",
        "F F F",
        points as u64,
        1,
        "binary_compressed",
    );
    b.extend_from_slice(&(lzf.len() as u32).to_le_bytes());
    b.extend_from_slice(&((points * 12) as u32).to_le_bytes());
    b.extend_from_slice(&lzf);
    let path = scratch("lzf_bomb.pcd", &b);
    // the default limit (100 x) accepts the format's best ratio
    let frames = read(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(frames[0].points.len(), points);
    // a stricter one refuses it before decompressing
    let strict = ReadOptions {
        decompression: DecompressionLimit {
            max_ratio: 10,
            min_bytes: 1 << 20,
        },
        ..ReadOptions::default()
    };
    refused_within(
        &path,
        &strict,
        2 * b.len() + (1 << 20),
        "exceed the limit of",
    );
}

// ---------------------------------------------------------------- PLY

#[test]
fn ply_binary_claiming_2_pow_31_vertices() {
    let _serial = serial();
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\n\
        property float x\nproperty float y\nproperty float z\nend_header\n"
        .to_vec();
    b.extend_from_slice(&[0u8; 120]);
    refused(&scratch("claims.ply", &b), 4, "2147483648 vertex records");
}

#[test]
fn ply_record_count_that_overflows_the_byte_count() {
    let _serial = serial();
    // 2^62 records of 24 bytes: the byte count overflows u64
    let b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4611686018427387904\n\
        property double x\nproperty double y\nproperty double z\nend_header\n";
    refused(&scratch("overflow.ply", b), 4, "vertex records");
}

#[test]
fn ply_ascii_claiming_2_pow_31_vertices() {
    let _serial = serial();
    let b = b"ply\nformat ascii 1.0\nelement vertex 2147483648\nproperty float x\n\
        property float y\nproperty float z\nend_header\n1 2 3\n";
    refused(&scratch("claims_ascii.ply", b), 4, "truncated");
}

#[test]
fn ply_huge_count_of_records_without_properties_costs_nothing() {
    let _serial = serial();
    // 10^18 records of zero bytes before the vertices: nothing to read, no loop over them
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement nothing 1000000000000000000\n\
        element vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
        .to_vec();
    for c in [1f32, 2.0, 3.0] {
        b.extend_from_slice(&c.to_le_bytes());
    }
    let path = scratch("empty_records.ply", &b);
    let (r, cost) = measure(|| read(&path));
    let frames = r.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(frames[0].points.len(), 1);
    assert!(cost.calls < 100, "{cost:?}");
}

// ---------------------------------------------------------------- VTK, graph, frames

#[test]
fn vtk_claiming_2_pow_31_points() {
    let _serial = serial();
    let b =
        b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 2147483648 float\n1 2 3\n";
    refused(&scratch("claims.vtk", b), 4, "all 2147483648 points");
}

#[test]
fn graph_claiming_2_pow_32_nodes_and_points() {
    let _serial = serial();
    let mut b = u32::MAX.to_le_bytes().to_vec();
    b.extend_from_slice(&u32::MAX.to_le_bytes());
    b.extend_from_slice(&[0u8; 64]);
    refused(&scratch("claims.graph", &b), 4, "truncated");
    // a node count that the file cannot hold, with every node empty
    let mut b = u32::MAX.to_le_bytes().to_vec();
    b.extend_from_slice(&[0u8; 64]);
    refused(&scratch("claims_nodes.graph", &b), 4, "node 0");
}

#[test]
fn frames_claiming_2_pow_32_frames_and_points() {
    let _serial = serial();
    let mut b = b"OCTFRAME".to_vec();
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(&u32::MAX.to_le_bytes());
    b.extend_from_slice(&[0u8; 12]);
    b.extend_from_slice(&u32::MAX.to_le_bytes());
    refused(&scratch("claims.frames", &b), 4, "truncated");
}

// ---------------------------------------------------------------- gz / bz2 bombs

/// `members` copies of one compressed member of `member_bytes` zeros.
fn bomb(name: &str, member: &[u8], members: usize) -> Scratch {
    let path = scratch(name, b"");
    let mut f = std::fs::File::create(&*path).unwrap_or_else(|e| panic!("{e}"));
    for _ in 0..members {
        f.write_all(member).unwrap_or_else(|e| panic!("{e}"));
    }
    path
}

fn gzip_zeros(n: usize) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    let zeros = vec![0u8; 1 << 16];
    for _ in 0..n / zeros.len() {
        e.write_all(&zeros).unwrap_or_else(|e| panic!("{e}"));
    }
    e.finish().unwrap_or_else(|e| panic!("{e}"))
}

fn bzip2_zeros(n: usize) -> Vec<u8> {
    let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
    let zeros = vec![0u8; 1 << 16];
    for _ in 0..n / zeros.len() {
        e.write_all(&zeros).unwrap_or_else(|e| panic!("{e}"));
    }
    e.finish().unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn gzip_of_1_gib_of_zeros_stops_at_the_default_limit() {
    let _serial = serial();
    let member = gzip_zeros(1 << 20);
    let path = bomb("bomb.pcd.gz", &member, 1024); // 1 GiB decompressed
    let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let cap = DecompressionLimit::DEFAULT.max_output(len) as usize;
    // read_all holds what arrived: at most the cap, twice over while its buffer grows
    refused_within(
        &path,
        &ReadOptions::default(),
        3 * cap + SLACK,
        "exceed the limit",
    );
}

#[test]
fn bzip2_bomb_stops_at_a_lower_limit_set_in_the_options() {
    let _serial = serial();
    let member = bzip2_zeros(1 << 20);
    let path = bomb("bomb.xyz.bz2", &member, 1024); // 1 GiB decompressed
    let options = ReadOptions {
        decompression: DecompressionLimit {
            max_ratio: 10,
            min_bytes: 1 << 20,
        },
        ..ReadOptions::default()
    };
    let len = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
    let cap = options.decompression.max_output(len) as usize;
    refused_within(&path, &options, 3 * cap + SLACK, "line 1");
    // the same limit applies to readers called directly
    let r = with_decompression_limit(options.decompression, || {
        octoquant_formats::text::read_text(&path)
    });
    assert!(matches!(r, Err(FormatError::Io { .. })), "{r:?}");
}

// ---------------------------------------------------------------- TUM depth PNG

fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut crc = flate2::Crc::new();
    crc.update(kind);
    crc.update(data);
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    out.extend_from_slice(&crc.sum().to_be_bytes());
}

/// A PNG whose header declares `w` x `h` pixels of `depth` bits and `color` type, with a
/// few bytes of pixel data.
fn png_claiming(w: u32, h: u32, depth: u8, color: u8) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[depth, color, 0, 0, 0]);
    png_chunk(&mut out, b"IHDR", &ihdr);
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    z.write_all(&[0u8; 64]).unwrap_or_else(|e| panic!("{e}"));
    png_chunk(
        &mut out,
        b"IDAT",
        &z.finish().unwrap_or_else(|e| panic!("{e}")),
    );
    png_chunk(&mut out, b"IEND", &[]);
    out
}

#[test]
fn png_claiming_huge_images_is_refused_before_allocating() {
    let _serial = serial();
    // 8192 x 8192 16-bit gray: 128 MiB of pixels from a 100-byte file
    refused(
        &scratch("claims.png", &png_claiming(8192, 8192, 16, 0)),
        4,
        "exceed the limit",
    );
    // the same size in RGBA: refused by its type before its 512 MiB are allocated
    refused(
        &scratch("claims_rgba.png", &png_claiming(8192, 8192, 16, 6)),
        4,
        "16-bit grayscale",
    );
    // 2^31 - 1 squared, the most PNG allows (the png crate refuses it itself)
    refused(
        &scratch(
            "claims_2_31.png",
            &png_claiming(i32::MAX as u32, i32::MAX as u32, 16, 0),
        ),
        4,
        "limits are exceeded",
    );
}

// ---------------------------------------------------------------- MCAP

/// Builds MCAP files record by record (the layout of the MCAP specification).
struct Mcap(Vec<u8>);

fn string(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

impl Mcap {
    fn new() -> Mcap {
        let mut m = Mcap(b"\x89MCAP0\r\n".to_vec());
        let mut h = Vec::new();
        string(&mut h, "ros1");
        string(&mut h, "bounds test");
        m.record(0x01, &h);
        m
    }

    fn record(&mut self, op: u8, content: &[u8]) {
        self.0.push(op);
        self.0
            .extend_from_slice(&(content.len() as u64).to_le_bytes());
        self.0.extend_from_slice(content);
    }

    fn schema(&mut self, id: u16, name: &str) {
        let mut s = id.to_le_bytes().to_vec();
        string(&mut s, name);
        string(&mut s, "ros1msg");
        s.extend_from_slice(&0u32.to_le_bytes());
        self.record(0x03, &s);
    }

    fn channel(&mut self, id: u16, schema: u16, topic: &str) {
        let mut c = id.to_le_bytes().to_vec();
        c.extend_from_slice(&schema.to_le_bytes());
        string(&mut c, topic);
        string(&mut c, "ros1");
        c.extend_from_slice(&0u32.to_le_bytes());
        self.record(0x04, &c);
    }

    fn message(&mut self, channel: u16, time: u64, data: &[u8]) {
        let mut m = channel.to_le_bytes().to_vec();
        m.extend_from_slice(&0u32.to_le_bytes());
        m.extend_from_slice(&time.to_le_bytes());
        m.extend_from_slice(&time.to_le_bytes());
        m.extend_from_slice(data);
        self.record(0x05, &m);
    }

    /// A chunk declaring `declared` bytes decompressed, holding `records` as compressed data.
    fn chunk(&mut self, compression: &str, declared: u64, records: &[u8]) {
        let mut c = 0u64.to_le_bytes().to_vec();
        c.extend_from_slice(&0u64.to_le_bytes());
        c.extend_from_slice(&declared.to_le_bytes());
        c.extend_from_slice(&0u32.to_le_bytes());
        string(&mut c, compression);
        c.extend_from_slice(&(records.len() as u64).to_le_bytes());
        c.extend_from_slice(records);
        self.record(0x06, &c);
    }

    fn finish(mut self) -> Vec<u8> {
        self.record(0x0F, &0u32.to_le_bytes());
        let mut f = 0u64.to_le_bytes().to_vec();
        f.extend_from_slice(&0u64.to_le_bytes());
        f.extend_from_slice(&0u32.to_le_bytes());
        self.record(0x02, &f);
        self.0.extend_from_slice(b"\x89MCAP0\r\n");
        self.0
    }
}

/// A ROS 1 `sensor_msgs/PointCloud2` with x, y, z `FLOAT32` at offsets 0, 4, 8.
fn cloud(
    frame: &str,
    (height, width): (u32, u32),
    (point_step, row_step): (u32, u32),
    data: &[u8],
) -> Vec<u8> {
    let mut m = 0u32.to_le_bytes().to_vec(); // seq
    m.extend_from_slice(&[0u8; 8]); // stamp
    string(&mut m, frame);
    m.extend_from_slice(&height.to_le_bytes());
    m.extend_from_slice(&width.to_le_bytes());
    m.extend_from_slice(&3u32.to_le_bytes());
    for (name, off) in [("x", 0u32), ("y", 4), ("z", 8)] {
        string(&mut m, name);
        m.extend_from_slice(&off.to_le_bytes());
        m.push(7);
        m.extend_from_slice(&1u32.to_le_bytes());
    }
    m.push(0);
    m.extend_from_slice(&point_step.to_le_bytes());
    m.extend_from_slice(&row_step.to_le_bytes());
    m.extend_from_slice(&(data.len() as u32).to_le_bytes());
    m.extend_from_slice(data);
    m.push(1);
    m
}

/// A ROS 1 `tf2_msgs/TFMessage` with one identity-rotation transform `parent` ← `child`.
fn tf(parent: &str, child: &str, x: f64) -> Vec<u8> {
    let mut m = 1u32.to_le_bytes().to_vec();
    m.extend_from_slice(&0u32.to_le_bytes());
    m.extend_from_slice(&[0u8; 8]);
    string(&mut m, parent);
    string(&mut m, child);
    for v in [x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
        m.extend_from_slice(&f64::to_le_bytes(v));
    }
    m
}

fn cloud_file(messages: &[Vec<u8>]) -> Mcap {
    let mut m = Mcap::new();
    m.schema(1, "sensor_msgs/PointCloud2");
    m.channel(1, 1, "/points");
    for (i, msg) in messages.iter().enumerate() {
        m.message(1, i as u64, msg);
    }
    m
}

#[test]
fn mcap_chunk_declaring_2_pow_40_bytes() {
    let _serial = serial();
    let mut m = cloud_file(&[]);
    m.chunk("zstd", 1 << 40, &[0x28, 0xb5, 0x2f, 0xfd, 0, 0, 0, 0]);
    refused(
        &scratch("chunk.mcap", &m.finish()),
        2,
        "chunk 0 (zstd compressed)",
    );
}

#[test]
fn mcap_records_claiming_2_pow_40_bytes() {
    let _serial = serial();
    // inside an uncompressed chunk
    let mut inner = vec![0x05];
    inner.extend_from_slice(&(1u64 << 40).to_le_bytes());
    inner.extend_from_slice(&[0u8; 32]);
    let mut m = cloud_file(&[]);
    m.chunk("", inner.len() as u64, &inner);
    refused(
        &scratch("record_in_chunk.mcap", &m.finish()),
        2,
        "runs past the chunk's end",
    );
    // at the top level
    let mut m = cloud_file(&[]);
    m.0.push(0x05);
    m.0.extend_from_slice(&(1u64 << 40).to_le_bytes());
    m.0.extend_from_slice(&[0u8; 32]);
    refused(&scratch("record.mcap", &m.finish()), 2, "MCAP");
}

#[test]
fn mcap_point_cloud_with_absurd_sizes() {
    let _serial = serial();
    let data = [0u8; 48];
    // width x height x point_step far beyond the data
    let m = cloud_file(&[cloud("s", (1 << 31, 1 << 31), (1 << 31, u32::MAX), &data)]);
    refused(&scratch("cloud_sizes.mcap", &m.finish()), 2, "message 0");
    let m = cloud_file(&[cloud("s", (1 << 31, 1), (12, 12), &data)]);
    refused(
        &scratch("cloud_rows.mcap", &m.finish()),
        2,
        "data holds 48 bytes",
    );
    // a data length beyond the message
    let mut msg = cloud("s", (1, 4), (12, 48), &data);
    let at = msg.len() - 1 - data.len() - 4;
    msg[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let m = cloud_file(&[msg]);
    refused(&scratch("cloud_data_len.mcap", &m.finish()), 2, "data");
    // a field count of 2^32 - 1
    let mut msg = cloud("s", (1, 4), (12, 48), &data);
    let at = 4 + 8 + 4 + 1 + 8;
    msg[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let m = cloud_file(&[msg]);
    refused(
        &scratch("cloud_fields.mcap", &m.finish()),
        2,
        "fields: count",
    );
}

#[test]
fn mcap_tf_claiming_2_pow_32_transforms() {
    let _serial = serial();
    let mut m = cloud_file(&[cloud("s", (1, 1), (12, 12), &[0u8; 12])]);
    m.schema(2, "tf2_msgs/TFMessage");
    m.channel(2, 2, "/tf");
    let mut msg = tf("map", "s", 1.0);
    msg[..4].copy_from_slice(&u32::MAX.to_le_bytes());
    m.message(2, 0, &msg);
    refused(
        &scratch("tf_count.mcap", &m.finish()),
        2,
        "transforms: count",
    );
}

#[test]
fn mcap_summary_with_a_2_pow_40_byte_record() {
    let _serial = serial();
    let mut point = Vec::new();
    for c in [1f32, 2.0, 3.0] {
        point.extend_from_slice(&c.to_le_bytes());
    }
    let mut m = cloud_file(&[cloud("s", (1, 1), (12, 12), &point)]);
    m.record(0x0F, &0u32.to_le_bytes());
    let summary_start = m.0.len() as u64;
    m.0.push(0x08); // a chunk index claiming 2^40 bytes
    m.0.extend_from_slice(&(1u64 << 40).to_le_bytes());
    m.0.extend_from_slice(&[0u8; 40]);
    let mut f = summary_start.to_le_bytes().to_vec();
    f.extend_from_slice(&0u64.to_le_bytes());
    f.extend_from_slice(&0u32.to_le_bytes());
    m.record(0x02, &f);
    m.0.extend_from_slice(b"\x89MCAP0\r\n");
    let path = scratch("summary.mcap", &m.0);
    let (r, cost) = measure(|| read(&path));
    // the summary is unreadable, the messages are read linearly, or the file is refused
    if let Ok(frames) = r {
        assert_eq!(frames[0].points.len(), 1);
    }
    assert!(cost.peak < 1 << 20, "{cost:?}");
}

#[test]
fn mcap_zero_width_cloud_of_2_pow_32_rows_costs_nothing() {
    let _serial = serial();
    let m = cloud_file(&[cloud("s", (u32::MAX, 0), (12, 0), &[])]);
    let path = scratch("zero_width.mcap", &m.finish());
    let (r, cost) = measure(|| read(&path));
    let frames = r.unwrap_or_else(|e| panic!("{e}"));
    assert!(frames[0].points.is_empty());
    assert!(cost.peak < 1 << 20, "{cost:?}");
}

// ---------------------------------------------------------------- linear work

/// Work measured as bytes allocated in all and allocation calls, both per input byte.
fn assert_linear(path: &Path, options: &ReadOptions, bytes_per_byte: u64, calls_per_kib: u64) {
    // (an allocation per short line or tiny record is linear work too: the call bound is
    // generous, the byte bound is the tight one)
    let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let (r, cost) = measure(|| read_frames(path, options));
    r.unwrap_or_else(|e| panic!("{e}"));
    assert!(
        cost.total <= bytes_per_byte * len + SLACK as u64,
        "{}: {} bytes allocated for {len} bytes of input",
        path.display(),
        cost.total
    );
    assert!(
        cost.calls <= calls_per_kib * len / 1024 + 1000,
        "{}: {} allocations for {len} bytes of input",
        path.display(),
        cost.calls
    );
}

#[test]
fn mcap_many_tiny_records_and_many_tf_frames_cost_linear_work() {
    let _serial = serial();
    // 3000 clouds of one point, each in its own frame under "map"; 3000 tf messages; 20000
    // messages on an unrelated topic. A lookup that re-scans every edge per cloud (or a
    // search repeated per cloud) allocates per cloud in proportion to the number of frames.
    let n = 3000;
    let mut m = Mcap::new();
    m.schema(1, "sensor_msgs/PointCloud2");
    m.schema(2, "tf2_msgs/TFMessage");
    m.schema(3, "std_msgs/Empty");
    m.channel(1, 1, "/points");
    m.channel(2, 2, "/tf_static");
    m.channel(3, 3, "/noise");
    let mut point = Vec::new();
    for c in [1f32, 2.0, 3.0] {
        point.extend_from_slice(&c.to_le_bytes());
    }
    for i in 0..n {
        m.message(2, i, &tf("map", &format!("s{i}"), i as f64));
    }
    for i in 0..n {
        m.message(1, i, &cloud(&format!("s{i}"), (1, 1), (12, 12), &point));
    }
    for i in 0..20_000 {
        m.message(3, i, &[]);
    }
    let path = scratch("many.mcap", &m.finish());
    let options = ReadOptions {
        mcap: McapOptions {
            fixed_frame: Some("map".into()),
            ..McapOptions::default()
        },
        ..ReadOptions::default()
    };
    let frames = read_frames(&path, &options).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(frames.len(), n as usize);
    assert_eq!(frames[7].points[0].x, 8.0);
    assert_linear(&path, &options, 64, 160);
}

#[test]
fn long_lines_and_many_header_lines_cost_linear_work() {
    let _serial = serial();
    // a PLY header of 20000 comment lines and a 4 MiB comment, then 1000 vertices
    let mut b = b"ply\nformat ascii 1.0\n".to_vec();
    for _ in 0..20_000 {
        b.extend_from_slice(b"comment x\n");
    }
    b.extend_from_slice(b"comment ");
    b.extend(std::iter::repeat_n(b'y', 4 << 20));
    b.extend_from_slice(
        b"\nelement vertex 1000\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
    );
    for _ in 0..1000 {
        b.extend_from_slice(b"1 2 3\n");
    }
    assert_linear(&scratch("long.ply", &b), &ReadOptions::default(), 4, 16);
    // a PCD whose data is one 4 MiB line of spaces after 20000 comment lines
    let mut b = Vec::new();
    for _ in 0..20_000 {
        b.extend_from_slice(b"# comment\n");
    }
    b.extend(pcd_header("x y z", "4 4 4", "F F F", 1, 1, "ascii"));
    b.extend(std::iter::repeat_n(b' ', 4 << 20));
    b.extend_from_slice(b"\n1 2 3\n");
    assert_linear(&scratch("long.pcd", &b), &ReadOptions::default(), 4, 16);
    // a text point list with one 4 MiB line of blanks among 100000 points
    let mut b = Vec::new();
    for _ in 0..100_000 {
        b.extend_from_slice(b"1 2 3\n");
    }
    b.extend(std::iter::repeat_n(b' ', 4 << 20));
    b.extend_from_slice(b"\n");
    assert_linear(&scratch("long.xyz", &b), &ReadOptions::default(), 8, 32);
}

// ---------------------------------------------------------------- CARMEN

#[test]
fn carmen_claiming_2_pow_31_readings() {
    let _serial = serial();
    let path = scratch(
        "claims.clf",
        b"FLASER 2147483648 1 2 3 0 0 0 0 0 0 1.5 host 1.5\n",
    );
    let (r, cost) = measure(|| octoquant_formats::carmen::read_carmen_file(&path));
    let e = r.err().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        e.contains("claims.clf") && e.contains("num_readings is 2147483648"),
        "{e}"
    );
    assert!(cost.peak < SLACK, "{cost:?}");
}

#[test]
fn errors_quote_at_most_a_short_excerpt_of_a_bad_token() {
    let _serial = serial();
    // a 4 MiB token where a number should be, in each text reader
    let long = "z".repeat(4 << 20);
    let cases = [
        ("long_token.xyz", format!("1 2 {long}\n")),
        (
            "long_token.vtk",
            format!("# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n1 2 {long}\n"),
        ),
        (
            "long_token.ply",
            format!("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 {long}\n"),
        ),
        (
            "long_token.pcd",
            format!("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nDATA ascii\n1 2 {long}\n"),
        ),
    ];
    for (name, text) in cases {
        let path = scratch(name, text.as_bytes());
        let (r, cost) = measure(|| read(&path));
        let e = r.err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains(name) && e.contains("zzzz"), "{e}");
        assert!(e.len() < 400, "{name}: a {}-byte message", e.len());
        assert!(cost.peak <= 3 * text.len() + SLACK, "{name}: {cost:?}");
    }
}

// ---------------------------------------------------------------- streaming

/// The peak memory of reading `path` one frame at a time (each frame dropped before the
/// next), and the number of frames.
fn stream_peak(path: &Path, options: &ReadOptions) -> (usize, Cost) {
    let (n, cost) = measure(|| {
        let mut n = 0;
        for f in octoquant_formats::frame_stream(path, options).unwrap_or_else(|e| panic!("{e}")) {
            f.unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
        n
    });
    (n, cost)
}

/// A `.frames` file streamed: the peak is one frame and the reader's buffers, the same for
/// 100 frames as for 2000 (a file 20 times larger), far below the file's size.
#[test]
fn frames_stream_holds_one_frame_at_a_time() {
    let _serial = serial();
    let frame = octoquant_formats::Frame::new_f32(
        nalgebra::Point3::origin(),
        (0..5000)
            .map(|i| nalgebra::Point3::new(i as f32, 1.0, 2.0))
            .collect(),
    );
    let mut peaks = Vec::new();
    for n in [100usize, 2000] {
        let mut bytes = Vec::new();
        octoquant_formats::frames::write_frames(&mut bytes, &vec![frame.clone(); n]).unwrap();
        let path = scratch(&format!("many{n}.frames"), &bytes);
        let (got, cost) = stream_peak(&path, &ReadOptions::default());
        assert_eq!(got, n);
        peaks.push(cost.peak);
        // two copies of a frame (its bytes and its points) and 64 KiB buffers
        assert!(cost.peak < 4 * 60_000 + (1 << 20), "{n} frames: {cost:?}");
        assert!(cost.peak < bytes.len() / 4, "{n} frames: {cost:?}");
    }
    assert!(peaks[1] <= peaks[0] + (64 << 10), "{peaks:?}");
}

/// An MCAP file of many clouds streamed: the peak does not grow with the number of clouds
/// (the file is read by seeking, the tf tree is all that is kept between clouds).
#[test]
fn mcap_stream_holds_one_cloud_at_a_time() {
    let _serial = serial();
    let mut point = Vec::new();
    for _ in 0..2000 {
        for c in [1f32, 2.0, 3.0] {
            point.extend_from_slice(&c.to_le_bytes());
        }
    }
    let mut peaks = Vec::new();
    for n in [20u64, 400] {
        let mut m = cloud_file(&[]);
        for i in 0..n {
            m.message(1, i, &cloud("s", (1, 2000), (12, 24_000), &point));
        }
        let bytes = m.finish();
        let path = scratch(&format!("many{n}.mcap"), &bytes);
        let (got, cost) = stream_peak(&path, &ReadOptions::default());
        assert_eq!(got as u64, n);
        assert!(
            cost.peak < bytes.len() / 4 || n == 20,
            "{n} clouds: {cost:?}"
        );
        peaks.push(cost.peak);
    }
    assert!(peaks[1] <= peaks[0] + (64 << 10), "{peaks:?}");
}
