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

#[test]
fn mcap_slices_are_the_whole_read_after_any_skip() {
    let Some(path) = common::data_file("mcap/pointcloudset_ouster_os1/test.mcap") else {
        return;
    };
    check_slices(&path, &ReadOptions::default(), &[0, 1, 2, 3, 50]);
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
