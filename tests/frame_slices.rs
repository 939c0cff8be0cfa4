//! Reading a slice of an input (`FrameStream::skip_frames`, what each task of a distributed
//! build does): the frames after the skipped ones are exactly those of a whole read, a
//! `.frames` file skips without reading the skipped points, VTK sequences and TUM
//! associations without opening the skipped files, MCAP files without decoding the skipped
//! clouds, and a damaged `.frames` file fails the same way whether its frames are skipped or
//! read.

use crate::common;
use nalgebra::Point3;
use octoquant::formats::{frame_stream, frames, FormatError, ReadOptions};
use octoquant::Frame;
use std::io::Write;
use std::path::{Path, PathBuf};

const NORLAB: &str = "lidar3d/norlab_icp_mapper_example";
const TUM: &str = "rgbd/tum_fr2_pioneer_slam2_subset";

/// Every coordinate's bits, so that NaN and -0.0 compare as stored.
fn bits(frames: &[Frame]) -> Vec<(Vec<u32>, Option<u64>)> {
    frames
        .iter()
        .map(|f| {
            let coords = std::iter::once(&f.origin)
                .chain(&f.points)
                .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
                .collect();
            (coords, f.stamp.map(f64::to_bits))
        })
        .collect()
}

/// The frames of `path` after skipping `k`, and how many the skip passed.
fn after_skip(path: &Path, options: &ReadOptions, k: usize) -> (usize, Vec<Frame>) {
    let mut s = frame_stream(path, options).unwrap_or_else(|e| panic!("{e}"));
    let passed = s.skip_frames(k).unwrap_or_else(|e| panic!("{e}"));
    let rest = s
        .collect::<Result<Vec<_>, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    (passed, rest)
}

/// Skipping `k` frames then reading the rest gives the whole read's frames `k..`, for every
/// `k` up to past the end.
fn check_slices(path: &Path, options: &ReadOptions, ks: &[usize]) {
    let whole: Vec<Frame> = frame_stream(path, options)
        .unwrap_or_else(|e| panic!("{e}"))
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    for &k in ks {
        let (passed, rest) = after_skip(path, options, k);
        let start = k.min(whole.len());
        assert_eq!(passed, start, "{} skip {k}", path.display());
        assert_eq!(
            bits(&rest),
            bits(&whole[start..]),
            "{} skip {k}",
            path.display()
        );
    }
}

/// Frames with 0 to a few hundred points, odd bit patterns included.
fn sample_frames() -> Vec<Frame> {
    (0..7u32)
        .map(|i| {
            let points = (0..i * 37)
                .map(|j| {
                    let v = (i * 1000 + j) as f32 * 0.01;
                    match j % 11 {
                        3 => Point3::new(f32::NAN, -0.0, v),
                        7 => Point3::new(f32::INFINITY, v, -v),
                        _ => Point3::new(v, -v, 0.5 * v),
                    }
                })
                .collect();
            Frame::new_f32(Point3::new(i as f32, -0.0, 1.5), points)
        })
        .collect()
}

fn write(path: &Path, frames: &[Frame]) {
    frames::write_frames_file(path, frames).unwrap_or_else(|e| panic!("{e}"));
}

/// A gzip copy of `plain` beside it (`NAME.gz`).
fn gzipped(plain: &Path) -> PathBuf {
    let mut name = plain.as_os_str().to_owned();
    name.push(".gz");
    let gz = PathBuf::from(name);
    let mut enc = flate2::write::GzEncoder::new(
        std::fs::File::create(&gz).unwrap_or_else(|e| panic!("{e}")),
        flate2::Compression::fast(),
    );
    enc.write_all(&std::fs::read(plain).unwrap_or_default())
        .unwrap_or_else(|e| panic!("{e}"));
    enc.finish().unwrap_or_else(|e| panic!("{e}"));
    gz
}

#[test]
fn frames_files_plain_and_compressed_give_the_whole_read_after_any_skip() {
    let dir = common::scratch("frame_slices_frames");
    let plain = dir.join("s.frames");
    write(&plain, &sample_frames());
    let gz = gzipped(&plain);
    for path in [&plain, &gz] {
        check_slices(path, &ReadOptions::default(), &[0, 1, 2, 5, 6, 7, 8, 100]);
        // skips in steps land where one skip does
        let mut s = frame_stream(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.skip_frames(2).ok(), Some(2));
        assert_eq!(s.skip_frames(0).ok(), Some(0));
        assert_eq!(s.skip_frames(3).ok(), Some(3));
        let rest: Vec<Frame> = s
            .collect::<Result<_, _>>()
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(bits(&rest), bits(&sample_frames()[5..]));
    }
}

/// Bytes this thread has asked the kernel to read so far (`rchar` of
/// `/proc/thread-self/io`), or `None` where the kernel does not say.
fn bytes_read_by_this_thread() -> Option<u64> {
    let io = std::fs::read_to_string("/proc/thread-self/io").ok()?;
    io.lines()
        .find_map(|l| l.strip_prefix("rchar:"))
        .and_then(|v| v.trim().parse().ok())
}

#[test]
fn a_plain_frames_file_is_skipped_without_reading_the_skipped_points() {
    // frame 0 claims 8 Mi points (96 MiB, a hole in the file), frame 1 is small
    let dir = common::scratch("frame_slices_sparse");
    let path = dir.join("big.frames");
    let n0: u32 = 8 << 20;
    let mut head = Vec::new();
    head.extend_from_slice(frames::FRAMES_MAGIC);
    head.extend_from_slice(&1u32.to_le_bytes());
    head.extend_from_slice(&2u32.to_le_bytes());
    head.extend_from_slice(&[0u8; 12]);
    head.extend_from_slice(&n0.to_le_bytes());
    let mut tail = Vec::new();
    for v in [1.0f32, 2.0, 3.0] {
        tail.extend_from_slice(&v.to_le_bytes());
    }
    tail.extend_from_slice(&1u32.to_le_bytes());
    for v in [4.0f32, 5.0, 6.0] {
        tail.extend_from_slice(&v.to_le_bytes());
    }
    let file = std::fs::File::create(&path).unwrap_or_else(|e| panic!("{e}"));
    let body = head.len() as u64 + u64::from(n0) * 12;
    use std::io::{Seek, SeekFrom};
    let mut f = std::io::BufWriter::new(file);
    f.write_all(&head).unwrap_or_else(|e| panic!("{e}"));
    f.seek(SeekFrom::Start(body))
        .unwrap_or_else(|e| panic!("{e}"));
    f.write_all(&tail).unwrap_or_else(|e| panic!("{e}"));
    f.flush().unwrap_or_else(|e| panic!("{e}"));
    drop(f);

    let Some(before) = bytes_read_by_this_thread() else {
        common::skip::<()>("/proc/thread-self/io (per-thread I/O accounting)");
        return;
    };
    let mut s = frame_stream(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.skip_frames(1).ok(), Some(1));
    let frame = s.next().map(|r| r.unwrap_or_else(|e| panic!("{e}")));
    let read = bytes_read_by_this_thread().unwrap_or(u64::MAX) - before;
    assert!(s.next().is_none());
    let frame = frame.unwrap_or_else(|| panic!("frame 1 missing"));
    assert_eq!(frame.origin, Point3::new(1.0, 2.0, 3.0));
    assert_eq!(frame.points, vec![Point3::new(4.0, 5.0, 6.0)]);
    // the 96 MiB of frame 0 were not read: only the headers and a buffer's worth
    assert!(read < 1 << 20, "{read} bytes read to skip one frame");
}

#[test]
fn a_truncated_frames_file_fails_alike_when_skipped_or_read() {
    let dir = common::scratch("frame_slices_truncated");
    let whole = dir.join("whole.frames");
    write(&whole, &sample_frames());
    let bytes = std::fs::read(&whole).unwrap_or_default();
    // cut inside frame 3's points, and inside frame 4's header
    let frame_start = |i: usize| -> usize {
        16 + sample_frames()[..i]
            .iter()
            .map(|f| 16 + 12 * f.points.len())
            .sum::<usize>()
    };
    for cut in [frame_start(3) + 16 + 40, frame_start(4) + 7] {
        let path = dir.join(format!("cut{cut}.frames"));
        std::fs::write(&path, &bytes[..cut]).unwrap_or_else(|e| panic!("{e}"));
        let read_err = frame_stream(&path, &ReadOptions::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .find_map(Result::err)
            .unwrap_or_else(|| panic!("no error reading {cut}"));
        let mut s = frame_stream(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let skip_err = s
            .skip_frames(7)
            .err()
            .unwrap_or_else(|| panic!("no error skipping {cut}"));
        assert!(
            matches!(skip_err, FormatError::Truncated { .. }),
            "{skip_err}"
        );
        assert_eq!(skip_err.to_string(), read_err.to_string());
        // the error ends the stream
        assert!(s.next().is_none());
    }
}

/// Skipping the first `k` frames of `path` reads fewer bytes than the smallest of `files`
/// (the files of those frames): they are not opened.
fn skip_reads_none_of(path: &Path, options: &ReadOptions, k: usize, files: &[PathBuf]) {
    let smallest = files
        .iter()
        .map(|f| std::fs::metadata(f).map(|m| m.len()).unwrap_or(0))
        .min()
        .unwrap_or(0);
    assert!(smallest > 4096, "{smallest}");
    let mut s = frame_stream(path, options).unwrap_or_else(|e| panic!("{e}"));
    let Some(before) = bytes_read_by_this_thread() else {
        common::skip::<()>("/proc/thread-self/io (per-thread I/O accounting)");
        return;
    };
    assert_eq!(s.skip_frames(k).ok(), Some(k));
    let read = bytes_read_by_this_thread().unwrap_or(u64::MAX) - before;
    assert!(read < smallest, "{read} bytes read to skip {k} frames");
}

/// A copy of `files` into `dir` with the first one (in name order) replaced by garbage.
fn copy_with_first_damaged(files: &[PathBuf], dir: &Path) {
    std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{e}"));
    for (i, f) in files.iter().enumerate() {
        let to = dir.join(f.file_name().unwrap_or_default());
        if i == 0 {
            std::fs::write(&to, b"not what the name says").unwrap_or_else(|e| panic!("{e}"));
        } else {
            std::fs::copy(f, &to).unwrap_or_else(|e| panic!("{e}"));
        }
    }
}

fn sorted_files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .map(|e| e.unwrap_or_else(|e| panic!("{e}")).path())
        .collect();
    v.sort();
    v
}

#[test]
fn vtk_sequences_skip_scans_without_opening_them() {
    let Some(dir) = common::data_file(NORLAB) else {
        return;
    };
    let options = ReadOptions::default();
    check_slices(&dir, &options, &[0, 1, 6, 13, 14, 20]);
    let scans = sorted_files(&dir.join("scans"));
    skip_reads_none_of(&dir, &options, 6, &scans[..6]);
    // the first scan damaged: reading it fails, skipping it never opens it
    let work = common::scratch("frame_slices_vtk");
    copy_with_first_damaged(&sorted_files(&dir.join("scans")), &work.join("scans"));
    std::fs::copy(dir.join("trajectory.csv"), work.join("trajectory.csv"))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut s = frame_stream(&work, &options).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(s.next(), Some(Err(_))));
    let (passed, rest) = after_skip(&work, &options, 1);
    assert_eq!(passed, 1);
    let (_, original) = after_skip(&dir, &options, 1);
    assert_eq!(rest.len(), 13);
    assert_eq!(bits(&rest), bits(&original));
}

#[test]
fn tum_associations_skip_rows_without_decoding_their_images() {
    let Some(dir) = common::data_file(TUM) else {
        return;
    };
    let assoc = dir.join("my_association.txt");
    let options = ReadOptions::default();
    check_slices(&assoc, &options, &[0, 1, 4, 9, 10, 11]);
    let depth = sorted_files(&dir.join("depth"));
    skip_reads_none_of(&assoc, &options, 4, &depth[..4]);
    // the first depth image damaged: reading it fails, skipping it never decodes it
    let work = common::scratch("frame_slices_tum");
    copy_with_first_damaged(&sorted_files(&dir.join("depth")), &work.join("depth"));
    std::fs::write(
        work.join("my_association.txt"),
        std::fs::read(&assoc).unwrap_or_default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let work_assoc = work.join("my_association.txt");
    let mut s = frame_stream(&work_assoc, &options).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(s.next(), Some(Err(_))));
    let (passed, rest) = after_skip(&work_assoc, &options, 1);
    assert_eq!(passed, 1);
    let (_, original) = after_skip(&assoc, &options, 1);
    assert_eq!(rest.len(), 9);
    assert_eq!(bits(&rest), bits(&original));
}

const OUSTER: &str = "mcap/pointcloudset_ouster_os1/test.mcap";

/// The chunk index records of an MCAP file's summary section (0 without a summary).
fn chunk_count(bytes: &[u8]) -> usize {
    ::mcap::Summary::read(bytes)
        .unwrap_or_else(|e| panic!("{e}"))
        .map_or(0, |s| s.chunk_indexes.len())
}

/// The real recording's messages written `rounds` times over, in zstd chunks of at most
/// 64 KiB (each 6 MB cloud takes a chunk of its own; the small messages share theirs), with
/// or without the summary section and its indexes. Round `r` shifts every log time by `r`
/// seconds and each cloud's `header.stamp` by `r` seconds (bytes 4..8 of a ROS 1
/// PointCloud2: after `header.seq`), so that no two clouds give the same frame.
fn ouster_in_chunks(src: &Path, dst: &Path, rounds: u32, summary: bool) {
    let bytes = std::fs::read(src).unwrap_or_else(|e| panic!("{e}"));
    let mut opts = ::mcap::WriteOptions::new()
        .compression(Some(::mcap::Compression::Zstd))
        .chunk_size(Some(64 << 10));
    if !summary {
        opts = opts
            .emit_summary_records(false)
            .emit_summary_offsets(false)
            .emit_statistics(false)
            .emit_message_indexes(false)
            .emit_chunk_indexes(false);
    }
    let mut w = opts
        .create(std::io::Cursor::new(Vec::new()))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut channels = std::collections::BTreeMap::new();
    for r in 0..rounds {
        for m in ::mcap::MessageStream::new(&bytes).unwrap_or_else(|e| panic!("{e}")) {
            let m = m.unwrap_or_else(|e| panic!("{e}"));
            let ch = &m.channel;
            let id = match channels.get(&ch.id) {
                Some(&id) => id,
                None => {
                    let sid = match &ch.schema {
                        Some(s) => w
                            .add_schema(&s.name, &s.encoding, &s.data)
                            .unwrap_or_else(|e| panic!("{e}")),
                        None => 0,
                    };
                    let id = w
                        .add_channel(sid, &ch.topic, &ch.message_encoding, &ch.metadata)
                        .unwrap_or_else(|e| panic!("{e}"));
                    channels.insert(ch.id, id);
                    id
                }
            };
            let mut data = m.data.into_owned();
            if ch.topic == "/os1_cloud_node/points" {
                let sec = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
                data[4..8].copy_from_slice(&(sec + r).to_le_bytes());
            }
            let shift = u64::from(r) * 1_000_000_000;
            let header = ::mcap::records::MessageHeader {
                channel_id: id,
                sequence: m.sequence,
                log_time: m.log_time + shift,
                publish_time: m.publish_time + shift,
            };
            w.write_to_known_channel(&header, &data)
                .unwrap_or_else(|e| panic!("{e}"));
        }
    }
    w.finish().unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(dst, w.into_inner().into_inner()).unwrap_or_else(|e| panic!("{e}"));
}

/// Bytes read (`rchar`) by skipping `k` clouds of `path` and reading the next one, not
/// counting the opening (whose first pass reads the transforms).
fn bytes_to_skip(path: &Path, k: usize) -> Option<u64> {
    let mut s = frame_stream(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let before = bytes_read_by_this_thread()?;
    assert_eq!(s.skip_frames(k).ok(), Some(k));
    assert!(matches!(s.next(), Some(Ok(_))));
    Some(bytes_read_by_this_thread()? - before)
}

/// Skips in several steps, between frames read, land where one skip does.
fn check_steps(path: &Path, whole: &[Frame]) {
    let mut s = frame_stream(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut got = Vec::new();
    assert_eq!(s.skip_frames(3).ok(), Some(3));
    assert_eq!(s.skip_frames(0).ok(), Some(0));
    got.push(s.next().and_then(Result::ok));
    assert_eq!(s.skip_frames(4).ok(), Some(4));
    got.push(s.next().and_then(Result::ok));
    got.push(s.next().and_then(Result::ok));
    assert_eq!(s.skip_frames(1).ok(), Some(1));
    let got: Vec<Frame> = got
        .into_iter()
        .map(|f| f.unwrap_or_else(|| panic!("a frame missing after a skip")))
        .collect();
    let want = [whole[3].clone(), whole[8].clone(), whole[9].clone()];
    assert_eq!(bits(&got), bits(&want), "{}", path.display());
    let rest: Vec<Frame> = s
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bits(&rest), bits(&whole[11..]), "{}", path.display());
}

#[test]
fn mcap_slices_are_the_whole_read_after_any_skip() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    check_slices(&path, &ReadOptions::default(), &[0, 1, 2, 3, 50]);
    let real = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
    // the recording has 2 chunks (and 2 clouds): too few to skip chunks over, so the same
    // messages are written again, 8 rounds in chunks of at most 64 KiB
    let chunks = chunk_count(&real);
    assert!(chunks >= 1, "{chunks} chunk indexes");
    let dir = common::scratch("frame_slices_mcap");
    let indexed = dir.join("indexed.mcap");
    let plain = dir.join("no_summary.mcap");
    ouster_in_chunks(&path, &indexed, 8, true);
    ouster_in_chunks(&path, &plain, 8, false);
    let bytes = std::fs::read(&indexed).unwrap_or_else(|e| panic!("{e}"));
    assert!(chunk_count(&bytes) > 16, "{} chunks", chunk_count(&bytes));
    assert_eq!(chunk_count(&std::fs::read(&plain).unwrap_or_default()), 0);
    let ks = [0, 1, 2, 3, 7, 8, 14, 15, 16, 17, 100];
    let whole: Vec<Frame> = frame_stream(&indexed, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(whole.len(), 16);
    for p in [&indexed, &plain] {
        check_slices(p, &ReadOptions::default(), &ks);
        check_steps(p, &whole);
    }
    // the same frames with or without the indexes
    let (_, from_plain) = after_skip(&plain, &ReadOptions::default(), 0);
    assert_eq!(bits(&from_plain), bits(&whole));
}

/// A skip of most clouds of a file with chunk and message indexes, then the read of the
/// next, reads only that cloud's chunk (and the message indexes before it), not the chunks
/// it passes.
#[test]
fn an_indexed_mcap_file_skips_chunks_without_reading_them() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let dir = common::scratch("frame_slices_mcap_bytes");
    let indexed = dir.join("indexed.mcap");
    ouster_in_chunks(&path, &indexed, 8, true);
    let size = std::fs::metadata(&indexed).map_or(0, |m| m.len());
    let Some(read) = bytes_to_skip(&indexed, 15) else {
        common::skip::<()>("/proc/thread-self/io (per-thread I/O accounting)");
        return;
    };
    eprintln!("skip 15 of 16 clouds and read the last: {read} bytes read of {size}");
    // the last cloud's chunk is about 1/16 of the file
    assert!(
        read < size / 8,
        "{read} bytes read to skip 15 clouds of {size}"
    );
    // without the indexes the chunks are read (and decompressed) to find the clouds
    let plain = dir.join("no_summary.mcap");
    ouster_in_chunks(&path, &plain, 8, false);
    let read = bytes_to_skip(&plain, 15).unwrap_or(0);
    eprintln!("skip 15 of 16 clouds and read the last, no summary: {read} bytes read");
    assert!(
        read > size / 2,
        "{read} bytes read to skip 15 clouds of {size}"
    );
}

/// Opening an MCAP file reads it about once: its first pass (transforms, cloud records)
/// must read every chunk, but the check of the chunk headers before it reads only the
/// headers, and the stream the frames come from checks them again without reading the
/// chunks' bodies either. Reading every frame after it reads the file once more.
#[test]
fn opening_an_mcap_file_reads_it_about_once() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let dir = common::scratch("frame_slices_mcap_open");
    let indexed = dir.join("indexed.mcap");
    ouster_in_chunks(&path, &indexed, 8, true);
    let size = std::fs::metadata(&indexed).map_or(0, |m| m.len());
    let Some(before) = bytes_read_by_this_thread() else {
        common::skip::<()>("/proc/thread-self/io (per-thread I/O accounting)");
        return;
    };
    let s = frame_stream(&indexed, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let opened = bytes_read_by_this_thread().unwrap_or(0) - before;
    let frames = s.count();
    let read = bytes_read_by_this_thread().unwrap_or(0) - before;
    eprintln!("{frames} frames: opening read {opened} bytes, the whole read {read}, of {size}");
    assert_eq!(frames, 16);
    assert!(
        opened < size + size / 10,
        "opening read {opened} bytes of a {size}-byte file"
    );
    assert!(
        read < 2 * size + size / 5,
        "opening and reading every frame read {read} bytes of a {size}-byte file"
    );
}

/// Message indexes that lie (the records of one chunk's cloud claim no message) or a chunk
/// damaged before the slice: a skip gives the whole read's frames or the whole read's
/// error, never other frames.
#[test]
fn lying_indexes_and_damaged_chunks_before_a_slice() {
    let Some(path) = common::data_file(OUSTER) else {
        return;
    };
    let dir = common::scratch("frame_slices_mcap_lies");
    let indexed = dir.join("indexed.mcap");
    ouster_in_chunks(&path, &indexed, 6, true);
    let whole: Vec<Frame> = frame_stream(&indexed, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    let bytes = std::fs::read(&indexed).unwrap_or_else(|e| panic!("{e}"));
    let summary = ::mcap::Summary::read(&bytes)
        .unwrap_or_else(|e| panic!("{e}"))
        .unwrap_or_else(|| panic!("no summary"));
    let cloud_channel = summary
        .channels
        .values()
        .find(|c| c.topic == "/os1_cloud_node/points")
        .map(|c| c.id)
        .unwrap_or_else(|| panic!("no cloud channel"));
    let mut cloud_chunks: Vec<_> = summary
        .chunk_indexes
        .iter()
        .filter(|c| c.message_index_offsets.contains_key(&cloud_channel))
        .collect();
    cloud_chunks.sort_by_key(|c| c.chunk_start_offset);
    assert_eq!(cloud_chunks.len(), whole.len());
    // the message index of cloud 2's chunk says it has none (its entry array emptied; the
    // record keeps its length, trailing bytes being allowed)
    let mut lie = bytes.clone();
    let at = cloud_chunks[2].message_index_offsets[&cloud_channel] as usize;
    assert_eq!(lie[at], 0x07);
    lie[at + 11..at + 15].copy_from_slice(&0u32.to_le_bytes());
    let lying = dir.join("lying.mcap");
    std::fs::write(&lying, &lie).unwrap_or_else(|e| panic!("{e}"));
    for k in [0, 1, 2, 3, 5, 6, 11, 12, 13] {
        let (passed, rest) = after_skip(&lying, &ReadOptions::default(), k);
        assert_eq!(passed, k.min(12), "skip {k}");
        assert_eq!(
            bits(&rest),
            bits(&whole[k.min(12)..]),
            "lying index, skip {k}"
        );
    }
    check_steps(&lying, &whole);
    // a message index record that is not one (its opcode changed: a linear read passes it
    // as an unknown record): the indexes are not used
    let mut odd = bytes.clone();
    let at = cloud_chunks[4].message_index_offsets[&cloud_channel] as usize;
    odd[at] = 0x7f;
    let unusable = dir.join("unusable.mcap");
    std::fs::write(&unusable, &odd).unwrap_or_else(|e| panic!("{e}"));
    for k in [0, 4, 5, 11] {
        let (passed, rest) = after_skip(&unusable, &ReadOptions::default(), k);
        assert_eq!(passed, k, "skip {k}");
        assert_eq!(bits(&rest), bits(&whole[k..]), "unusable index, skip {k}");
    }
    // cloud 1's chunk damaged inside its compressed data: the file fails when opened, so
    // alike whether cloud 1 is skipped or read, with an error naming it
    let mut bad = bytes.clone();
    let c = cloud_chunks[1];
    let mid = (c.chunk_start_offset + c.chunk_length / 2) as usize;
    for b in &mut bad[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let damaged = dir.join("damaged.mcap");
    std::fs::write(&damaged, &bad).unwrap_or_else(|e| panic!("{e}"));
    let e = frame_stream(&damaged, &ReadOptions::default())
        .err()
        .unwrap_or_else(|| panic!("a damaged chunk read without an error"));
    assert!(e.to_string().contains("damaged.mcap"), "{e}");
}

#[test]
fn graph_files_stream_their_nodes_and_skip_their_points() {
    use octoquant::formats::graph::{self, GraphOptions};
    let dir = common::scratch("frame_slices_graph");
    // a written graph of several nodes, plain and gzipped, in both point conventions
    let g = graph::graph_from_frames(&sample_frames());
    let plain = dir.join("s.graph");
    graph::write_graph_file(&plain, &g).unwrap_or_else(|e| panic!("{e}"));
    let gz = gzipped(&plain);
    for path in [&plain, &gz] {
        for points_global in [false, true] {
            let options = ReadOptions {
                graph: GraphOptions { points_global },
                ..ReadOptions::default()
            };
            // the stream gives what the whole-file parse gives
            let parsed = graph::graph_to_frames(
                &graph::read_graph(path).unwrap_or_else(|e| panic!("{e}")),
                &options.graph,
            );
            let (_, streamed) = after_skip(path, &options, 0);
            assert_eq!(bits(&streamed), bits(&parsed));
            check_slices(path, &options, &[0, 1, 3, 6, 7, 9]);
        }
    }
    // the real ScanGraph file too
    if let Some(real) = common::data_file("octomap_reference/spherical_scan.graph") {
        let parsed = graph::graph_to_frames(
            &graph::read_graph(&real).unwrap_or_else(|e| panic!("{e}")),
            &GraphOptions::default(),
        );
        let (_, streamed) = after_skip(&real, &ReadOptions::default(), 0);
        assert_eq!(bits(&streamed), bits(&parsed));
        check_slices(&real, &ReadOptions::default(), &[0, 1, 2]);
    }
    // every cut of the file fails, streamed or parsed, and never yields a wrong frame
    let bytes = std::fs::read(&plain).unwrap_or_default();
    let whole = graph::graph_to_frames(&g, &GraphOptions::default());
    for cut in (0..bytes.len()).step_by(97) {
        let path = dir.join("cut.graph");
        std::fs::write(&path, &bytes[..cut]).unwrap_or_else(|e| panic!("{e}"));
        assert!(graph::parse_graph(&path, &bytes[..cut]).is_err());
        let mut got = Vec::new();
        let mut failed = false;
        for r in graph::graph_file_stream(&path, &GraphOptions::default())
            .into_iter()
            .flatten()
        {
            match r {
                Ok(f) => got.push(f),
                Err(_) => failed = true,
            }
        }
        let opened = graph::graph_file_stream(&path, &GraphOptions::default()).is_ok();
        assert!(failed || !opened, "cut at {cut} read without an error");
        assert_eq!(bits(&got), bits(&whole[..got.len()]), "cut at {cut}");
    }
}

#[test]
fn a_plain_graph_file_is_skipped_without_reading_the_skipped_points() {
    use octoquant::formats::graph;
    let dir = common::scratch("frame_slices_graph_big");
    let path = dir.join("big.graph");
    let mut frames = vec![Frame::new_f32(
        Point3::new(1.0, 2.0, 3.0),
        vec![Point3::new(0.5, 0.25, 0.125); 200_000],
    )];
    frames.push(Frame::new_f32(
        Point3::origin(),
        vec![Point3::new(4.0, 5.0, 6.0)],
    ));
    graph::write_graph_file(&path, &graph::graph_from_frames(&frames))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut s = frame_stream(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let Some(before) = bytes_read_by_this_thread() else {
        common::skip::<()>("/proc/thread-self/io (per-thread I/O accounting)");
        return;
    };
    assert_eq!(s.skip_frames(1).ok(), Some(1));
    let read = bytes_read_by_this_thread().unwrap_or(u64::MAX) - before;
    // 200 000 points are 5.6 MB in the file
    assert!(read < 1 << 20, "{read} bytes read to skip one node");
    let rest: Vec<Frame> = s
        .collect::<Result<_, _>>()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(rest.len(), 1);
    assert_eq!(rest[0].points.len(), 1);
}
