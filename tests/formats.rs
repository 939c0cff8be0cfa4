//! Sensor-format readers on the real data of `OCTOQUANT_DATA` (issue 3): counts, bit-exact
//! agreement with OctoMap's transform, writer round trips, and damaged files of every format.

use crate::common;
use nalgebra::{Point3, Vector3};
use octoquant::formats::graph::{self, GraphOptions, Pose6D, ScanGraph, ScanNode};
use octoquant::formats::{
    frames, pcd, read_frames, text, tum, vtk, FormatError, InputFormat, ReadOptions,
};
use octoquant::Frame;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

const NORLAB: &str = "lidar3d/norlab_icp_mapper_example";
const TUM: &str = "rgbd/tum_fr2_pioneer_slam2_subset";
const PCD: &str = "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd";

fn bits(p: &Point3<f32>) -> [u32; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// Frames equal bit for bit (origins and points; stamps are not compared).
fn assert_frames_bit_identical(ours: &[Frame], reference: &[Frame]) {
    assert_eq!(ours.len(), reference.len(), "frame count");
    for (i, (a, b)) in ours.iter().zip(reference).enumerate() {
        assert_eq!(bits(&a.origin), bits(&b.origin), "origin of frame {i}");
        assert_eq!(a.points.len(), b.points.len(), "point count of frame {i}");
        let diff = a
            .points
            .iter()
            .zip(&b.points)
            .position(|(p, q)| bits(p) != bits(q));
        if let Some(k) = diff {
            panic!(
                "frame {i} point {k}: ours {:?}, reference {:?}",
                a.points[k], b.points[k]
            );
        }
    }
}

fn read(path: &Path) -> Vec<Frame> {
    match read_frames(path, &ReadOptions::default()) {
        Ok(f) => f,
        Err(e) => panic!("{e}"),
    }
}

// ---------------------------------------------------------------------------------------
// .graph and .frames

#[test]
fn graph_spherical_scan_transform_is_bit_identical_to_octomap() {
    let Some(g) = common::data_file("octomap_reference/spherical_scan.graph") else {
        return;
    };
    let Some(reference) = common::data_file("octomap_reference/derived/sph.frames") else {
        return;
    };
    let ours = read(&g);
    let theirs = read(&reference);
    assert_eq!(ours.len(), 1);
    assert_eq!(ours[0].points.len(), 10201);
    assert_eq!(ours[0].origin, Point3::new(1.0, 0.0, -0.5));
    assert_frames_bit_identical(&ours, &theirs);
}

#[test]
fn graph_file_structure_and_global_option() {
    let Some(g) = common::data_file("octomap_reference/spherical_scan.graph") else {
        return;
    };
    let graph = graph::read_graph(&g).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(graph.nodes.len(), 1);
    assert!(graph.edges.is_empty());
    let node = &graph.nodes[0];
    assert_eq!(node.id, 0);
    assert_eq!(
        node.pose,
        Pose6D::from_translation(Vector3::new(1.0, 0.0, -0.5))
    );
    let global = graph::graph_to_frames(
        &graph,
        &GraphOptions {
            points_global: true,
        },
    );
    assert_eq!(global[0].points, node.points, "-g keeps points as stored");
    assert_eq!(global[0].origin, Point3::new(1.0, 0.0, -0.5));
}

#[test]
fn graph_write_round_trip_is_byte_identical() {
    let Some(g) = common::data_file("octomap_reference/spherical_scan.graph") else {
        return;
    };
    let original = std::fs::read(&g).unwrap_or_else(|e| panic!("{e}"));
    let graph = graph::read_graph(&g).unwrap_or_else(|e| panic!("{e}"));
    let dir = common::scratch("formats_graph_round_trip");
    let out = dir.join("copy.graph");
    graph::write_graph_file(&out, &graph).unwrap_or_else(|e| panic!("{e}"));
    let written = std::fs::read(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(written.len(), 285_708);
    assert!(
        written == original,
        "rewritten .graph differs from OctoMap's bytes"
    );
}

#[test]
fn graph_from_frames_with_global_option_gives_the_frames_back() {
    let frames_in = vec![
        Frame::new_f32(
            Point3::new(0.5, -1.0, 2.0),
            vec![Point3::new(1.0, 2.0, 3.0), Point3::new(-4.5, 0.1, 7.25)],
        ),
        Frame::new_f32(Point3::new(3.0, 3.0, 3.0), vec![]),
    ];
    let dir = common::scratch("formats_graph_from_frames");
    let out = dir.join("g.graph");
    graph::write_graph_file(&out, &graph::graph_from_frames(&frames_in))
        .unwrap_or_else(|e| panic!("{e}"));
    let opts = ReadOptions {
        graph: GraphOptions {
            points_global: true,
        },
        ..ReadOptions::default()
    };
    let back = read_frames(&out, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert_frames_bit_identical(&back, &frames_in);
}

/// Every field of a frame by its bits: origin, points, stamp, colours, camera and pixels.
fn frame_bits(f: &Frame) -> String {
    let pts: Vec<[u32; 3]> = f.points.iter().map(bits).collect();
    let cam = f.camera.as_ref().map(|c| {
        let k = &c.camera;
        let m: Vec<u64> = k.rotation.matrix().iter().map(|v| v.to_bits()).collect();
        let intrinsics = [k.fx, k.fy, k.cx, k.cy].map(f64::to_bits);
        (k.width, k.height, intrinsics, m, &c.pixels)
    });
    format!(
        "{:?} {pts:?} {:?} {:?} {cam:?}",
        bits(&f.origin),
        f.stamp.map(f64::to_bits),
        f.colors
    )
}

/// Real frames that carry more than points (TUM's depth camera, stamps and registered colours;
/// norlab's scan times) come back from a `.frames` file as they went in, bit for bit; read
/// without colours, the colours alone are dropped.
#[test]
fn frames_files_keep_stamps_colours_and_cameras_of_real_frames() {
    let (Some(assoc), Some(norlab)) = (
        common::data_file(&format!("{TUM}/my_association.txt")),
        common::data_file(NORLAB),
    ) else {
        return;
    };
    let coloured = ReadOptions {
        colors: true,
        ..ReadOptions::default()
    };
    let tum = read_frames(&assoc, &coloured).unwrap_or_else(|e| panic!("{e}"));
    let lidar: Vec<Frame> = read(&norlab).into_iter().take(3).collect();
    assert!(tum
        .iter()
        .all(|f| f.camera.is_some() && f.colors.is_some() && f.stamp.is_some()));
    assert!(lidar
        .iter()
        .all(|f| f.stamp.is_some() && f.camera.is_none()));
    let dir = common::scratch("formats_frames_v2");
    for (name, frames) in [("tum", &tum), ("norlab", &lidar)] {
        let path = dir.join(format!("{name}.frames"));
        frames::write_frames_file(&path, frames).unwrap_or_else(|e| panic!("{e}"));
        let back = read_frames(&path, &coloured).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back.len(), frames.len(), "{name}");
        for (i, (a, b)) in frames.iter().zip(&back).enumerate() {
            assert!(frame_bits(a) == frame_bits(b), "{name} frame {i} differs");
        }
        let plain = read(&path);
        for (i, (a, b)) in frames.iter().zip(&plain).enumerate() {
            let a = Frame {
                colors: None,
                ..a.clone()
            };
            assert!(
                frame_bits(&a) == frame_bits(b),
                "{name} frame {i} without colours"
            );
        }
    }
}

#[test]
fn frames_writer_round_trips_the_reference_files() {
    let dir = common::scratch("formats_frames_round_trip");
    for name in ["sph.frames", "scan.frames", "synth.frames"] {
        let Some(p) = common::data_file(&format!("octomap_reference/derived/{name}")) else {
            return;
        };
        let original = std::fs::read(&p).unwrap_or_else(|e| panic!("{e}"));
        let fr = frames::read_frames_file(&p).unwrap_or_else(|e| panic!("{e}"));
        assert!(!fr.is_empty(), "{name}");
        let out = dir.join(name);
        frames::write_frames_file(&out, &fr).unwrap_or_else(|e| panic!("{e}"));
        let written = std::fs::read(&out).unwrap_or_else(|e| panic!("{e}"));
        assert!(written == original, "{name} differs after read + write");
    }
}

// ---------------------------------------------------------------------------------------
// text

#[test]
fn text_scan_dat_bz2_is_bit_identical_to_the_reference_parse() {
    let Some(dat) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let Some(reference) = common::data_file("octomap_reference/derived/scan.frames") else {
        return;
    };
    assert_eq!(InputFormat::detect(&dat).ok(), Some(InputFormat::Text));
    let ours = read(&dat);
    assert_eq!(ours.len(), 1);
    assert_eq!(ours[0].points.len(), 88_206);
    assert_eq!(ours[0].origin, Point3::origin());
    assert_eq!(
        ours[0].points[0],
        Point3::new(-0.0434742, -4.82982, 0.499645)
    );
    assert_frames_bit_identical(&ours, &read(&reference));
}

#[test]
fn text_reference_origin_frames() {
    let Some(tiny) = common::data_file("octomap_reference/derived/tiny.txt") else {
        return;
    };
    let f = read(&tiny);
    assert_eq!(f.len(), 1);
    assert_eq!(f[0].origin, Point3::new(0.05, 0.05, 0.05));
    assert_eq!(f[0].points, vec![Point3::new(0.25, 0.05, 0.05)]);
}

#[test]
fn text_log_matches_the_graph_path_and_octomap_conventions() {
    let dir = common::scratch("formats_text_log");
    let log = dir.join("two.log");
    let body = "# an OctoMap log\n\
                NODE 1 2 3 0 0 1.5707963267948966\n\
                1 0 0\n\
                \n\
                \x20this line starts with a space and is skipped\n\
                0 2 0\n\
                NODE 0 0 0 0.1 -0.2 0.3\n\
                1 2 3\n";
    std::fs::write(&log, body).unwrap_or_else(|e| panic!("{e}"));
    let frames_text = read(&log);
    assert_eq!(frames_text.len(), 2);
    assert_eq!(frames_text[0].points.len(), 2);
    assert_eq!(frames_text[0].origin, Point3::new(1.0, 2.0, 3.0));
    // yaw +90°: (1,0,0) -> (0,1,0), then + (1,2,3).
    let p = frames_text[0].points[0];
    assert!((p - Point3::new(1.0, 3.0, 3.0)).norm() < 1e-6, "{p:?}");
    // The same nodes through a .graph file (log2graph + graph2tree) give the same bits.
    let graph = text::read_log_graph(&log).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(graph.nodes.iter().map(|n| n.id).collect::<Vec<_>>(), [0, 1]);
    let g = dir.join("two.graph");
    graph::write_graph_file(&g, &graph).unwrap_or_else(|e| panic!("{e}"));
    assert_frames_bit_identical(&read(&g), &frames_text);
}

// ---------------------------------------------------------------------------------------
// VTK + trajectory (norlab)

/// (file name, POINTS) of the norlab scans in chronological order (PROVENANCE §1).
const NORLAB_SCANS: [(&str, usize); 14] = [
    ("cloud_1690309709_285305600.vtk", 41400),
    ("cloud_1690309709_385259008.vtk", 41339),
    ("cloud_1690309709_485205504.vtk", 41195),
    ("cloud_1690309709_585157888.vtk", 41282),
    ("cloud_1690309709_685139200.vtk", 41623),
    ("cloud_1690309709_785777664.vtk", 41339),
    ("cloud_1690309709_885748736.vtk", 41363),
    ("cloud_1690309709_985746176.vtk", 41375),
    ("cloud_1690309710_85582848.vtk", 41406),
    ("cloud_1690309710_185535488.vtk", 41357),
    ("cloud_1690309710_285479936.vtk", 41337),
    ("cloud_1690309710_385434880.vtk", 41320),
    ("cloud_1690309710_485391104.vtk", 41384),
    ("cloud_1690309710_585328128.vtk", 41302),
];

#[test]
fn vtk_norlab_sequence_in_time_order_with_poses() {
    let Some(dir) = common::data_file(NORLAB) else {
        return;
    };
    assert_eq!(
        InputFormat::detect(&dir).ok(),
        Some(InputFormat::VtkSequence)
    );
    let frames = read(&dir);
    let counts: Vec<usize> = frames.iter().map(|f| f.points.len()).collect();
    let expected: Vec<usize> = NORLAB_SCANS.iter().map(|s| s.1).collect();
    assert_eq!(counts, expected);
    assert_eq!(frames[8].stamp, Some(1690309710.0 + 0.085582848));
    assert!(frames.windows(2).all(|w| w[0].stamp < w[1].stamp));
    let poses =
        vtk::read_trajectory_csv(&dir.join("trajectory.csv")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(poses.len(), 14);
    // The CSV is in time order too, so frame i has row i's position as its origin.
    for (f, p) in frames.iter().zip(&poses) {
        assert_eq!(f.origin, Point3::from(p.translation.cast::<f32>()));
    }
    // The transform is rigid: distances to the origin are the sensor-frame ranges.
    let local = vtk::read_vtk_points_f32(&dir.join("scans").join(NORLAB_SCANS[8].0))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(local.len(), 41406);
    for (w, l) in frames[8].points.iter().zip(&local).step_by(997) {
        let d = (w - frames[8].origin).norm() - l.coords.norm();
        assert!(d.abs() < 1e-4, "range changed by {d}");
    }
    // Same result from the CSV path and from the single-file reader.
    let via_csv = read(&dir.join("trajectory.csv"));
    assert_frames_bit_identical(&via_csv, &frames);
    let single = read(&dir.join("scans").join(NORLAB_SCANS[0].0));
    assert_eq!(single[0].points.len(), 41400);
    assert_eq!(single[0].origin, Point3::origin());
}

#[test]
fn vtk_scan_without_pose_names_the_scan() {
    let Some(dir) = common::data_file(NORLAB) else {
        return;
    };
    let work = common::scratch("formats_vtk_missing_pose");
    let scans = work.join("scans");
    std::fs::create_dir_all(&scans).unwrap_or_else(|e| panic!("{e}"));
    let name = NORLAB_SCANS[3].0;
    std::fs::copy(dir.join("scans").join(name), scans.join(name)).unwrap_or_else(|e| panic!("{e}"));
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap_or_default();
    // Keep the header and every row but the one of this scan.
    let kept: Vec<&str> = csv
        .lines()
        .filter(|l| !l.starts_with("1690309709,585157888,"))
        .collect();
    assert_eq!(kept.len(), 14);
    std::fs::write(work.join("trajectory.csv"), kept.join("\n")).unwrap_or_default();
    match read_frames(&work, &ReadOptions::default()) {
        Err(e @ FormatError::MissingPose { .. }) => {
            assert!(e.to_string().contains(name), "{e}")
        }
        other => panic!("expected a missing pose, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------
// TUM

#[test]
fn tum_association_frames_have_the_documented_valid_pixel_counts() {
    let Some(assoc) = common::data_file(&format!("{TUM}/my_association.txt")) else {
        return;
    };
    assert_eq!(
        InputFormat::detect(&assoc).ok(),
        Some(InputFormat::TumAssociation)
    );
    let frames = read(&assoc);
    assert_eq!(frames.len(), 10);
    let counts: Vec<usize> = frames.iter().map(|f| f.points.len()).collect();
    eprintln!("TUM valid pixels per frame: {counts:?}");
    assert_eq!(counts.iter().min(), Some(&248_947), "{counts:?}");
    assert_eq!(counts.iter().max(), Some(&260_748), "{counts:?}");
    assert_eq!(frames[0].stamp, Some(1311877813.991479));
    assert_eq!(frames[0].origin, Point3::new(-2.2591, -2.38, 0.5901));
    let rows = tum::read_association(&assoc).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        rows.iter().map(|r| r.line).collect::<Vec<_>>(),
        [33, 64, 95, 126, 157, 188, 219, 250, 281, 312]
    );
    // Depths are 1.07–10.50 m, so every point is that far (or a little more) from the camera.
    for f in &frames {
        for p in f.points.iter().step_by(499) {
            let r = (p - f.origin).norm();
            assert!((1.0..12.5).contains(&r), "range {r}");
        }
    }
    // The directory is detected too, and the pixel step subsamples.
    let dir = assoc.parent().unwrap_or(Path::new("."));
    assert_eq!(
        InputFormat::detect(dir).ok(),
        Some(InputFormat::TumAssociation)
    );
    let opts = ReadOptions {
        tum: tum::TumOptions {
            pixel_step: 2,
            ..tum::TumOptions::default()
        },
        ..ReadOptions::default()
    };
    let sub = read_frames(dir, &opts).unwrap_or_else(|e| panic!("{e}"));
    let n0 = sub[0].points.len();
    assert!(
        n0 * 4 > counts[0] * 9 / 10 && n0 * 4 < counts[0] * 11 / 10,
        "{n0}"
    );
}

#[test]
fn tum_single_png_and_bad_options() {
    let Some(png) = common::data_file(&format!("{TUM}/depth/1311877813.991479.png")) else {
        return;
    };
    let f = read(&png);
    assert_eq!(f[0].origin, Point3::origin());
    assert!(f[0].points.iter().all(|p| p.z >= 1.0 && p.z <= 10.6));
    let opts = ReadOptions {
        tum: tum::TumOptions {
            pixel_step: 0,
            ..tum::TumOptions::default()
        },
        ..ReadOptions::default()
    };
    assert!(matches!(
        read_frames(&png, &opts),
        Err(FormatError::InvalidOption { .. })
    ));
    let Some(rgb) = common::data_file(&format!("{TUM}/rgb/1311877813.991666.png")) else {
        return;
    };
    assert!(matches!(
        read_frames(&rgb, &ReadOptions::default()),
        Err(FormatError::Unsupported { .. })
    ));
}

// ---------------------------------------------------------------------------------------
// PCD

fn valid(points: &[Point3<f32>]) -> usize {
    points
        .iter()
        .filter(|p| p.x.is_finite() && p.y.is_finite() && p.z.is_finite())
        .count()
}

/// Write `cloud` as an `x y z` PCD in the given encoding ("ascii" or "binary").
fn write_pcd(path: &Path, points: &[Point3<f64>], encoding: &str, viewpoint: &str) {
    let mut out = format!(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n\
         WIDTH {}\nHEIGHT 1\nVIEWPOINT {viewpoint}\nPOINTS {}\nDATA {encoding}\n",
        points.len(),
        points.len()
    )
    .into_bytes();
    for p in points {
        let (x, y, z) = (p.x as f32, p.y as f32, p.z as f32);
        if encoding == "ascii" {
            out.extend_from_slice(format!("{x:?} {y:?} {z:?}\n").as_bytes());
        } else {
            for c in [x, y, z] {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    std::fs::write(path, out).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn pcd_binary_compressed_table_scene() {
    let Some(p) = common::data_file(PCD) else {
        return;
    };
    let cloud = pcd::read_pcd_cloud(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cloud.encoding, pcd::PcdEncoding::BinaryCompressed);
    assert_eq!((cloud.width, cloud.height), (640, 480));
    assert_eq!(cloud.viewpoint_rotation.i, 1.0);
    let frames = read(&p);
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].points.len(), 307_200);
    assert_eq!(valid(&frames[0].points), 209_280);
    assert_eq!(frames[0].origin, Point3::origin());
    // Camera optical frame, z forward 0.69–2.59 m: the viewpoint's 180° about x is not applied.
    let zs: Vec<f32> = frames[0]
        .points
        .iter()
        .filter(|p| p.z.is_finite())
        .map(|p| p.z)
        .collect();
    let (lo, hi) = zs
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &z| (a.min(z), b.max(z)));
    assert!(lo > 0.6 && hi < 2.7, "z range {lo}..{hi}");

    // Applying the viewpoint flips y and z.
    let apply = ReadOptions {
        pcd: pcd::PcdOptions {
            viewpoint: pcd::ViewpointUse::Apply,
        },
        ..ReadOptions::default()
    };
    let flipped = read_frames(&p, &apply).unwrap_or_else(|e| panic!("{e}"));
    let k = frames[0]
        .points
        .iter()
        .position(|p| p.z.is_finite())
        .unwrap_or(0);
    assert_eq!(flipped[0].points[k].z, -frames[0].points[k].z);

    // The same cloud re-encoded as ascii and binary reads back identically (NaN kept).
    let dir = common::scratch("formats_pcd_reencode");
    for enc in ["ascii", "binary"] {
        let q = dir.join(format!("table_{enc}.pcd"));
        write_pcd(&q, &cloud.points, enc, "0.5 0 0 1 0 0 0");
        let back = read(&q);
        assert_eq!(back[0].points.len(), 307_200, "{enc}");
        assert_eq!(valid(&back[0].points), 209_280, "{enc}");
        assert_eq!(back[0].origin, Point3::new(0.5, 0.0, 0.0), "{enc}");
        let same = back[0]
            .points
            .iter()
            .zip(&frames[0].points)
            .all(|(a, b)| bits(a) == bits(b) || (a.x.is_nan() && b.x.is_nan()));
        assert!(same, "{enc} re-encoding changed points");
    }
}

// ---------------------------------------------------------------------------------------
// Damaged inputs: every format, truncated and corrupted, gives an error naming the file.

fn expect_error_naming_file(path: &Path, options: &ReadOptions) {
    match read_frames(path, options) {
        Ok(f) => panic!(
            "{} was read without error ({} frames)",
            path.display(),
            f.len()
        ),
        Err(e) => {
            let name = path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            assert!(
                e.to_string().contains(&name),
                "error does not name {name}: {e}"
            );
        }
    }
}

/// Copies of `src` cut at several lengths, each of which must fail to read.
fn truncated_copies(src: &Path, dir: &Path, cuts: &[usize]) -> Vec<PathBuf> {
    let data = std::fs::read(src).unwrap_or_else(|e| panic!("{e}"));
    let name = src
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    cuts.iter()
        .filter(|&&c| c < data.len())
        .map(|&c| {
            let p = dir.join(format!("cut{c}_{name}"));
            std::fs::write(&p, &data[..c]).unwrap_or_else(|e| panic!("{e}"));
            p
        })
        .collect()
}

#[test]
fn damaged_binary_files_give_errors_naming_the_file() {
    let dir = common::scratch("formats_damaged_binary");
    let opts = ReadOptions::default();
    let Some(g) = common::data_file("octomap_reference/spherical_scan.graph") else {
        return;
    };
    let Some(f) = common::data_file("octomap_reference/derived/sph.frames") else {
        return;
    };
    let Some(p) = common::data_file(PCD) else {
        return;
    };
    let Some(png) = common::data_file(&format!("{TUM}/depth/1311877813.991479.png")) else {
        return;
    };
    // PCL pads binary_compressed files with zeros after the LZF data: cut inside the data.
    let pcd_bytes = std::fs::read(&p).unwrap_or_default();
    let text = String::from_utf8_lossy(&pcd_bytes[..300]).into_owned();
    let header_len = text
        .find("DATA binary_compressed\n")
        .map(|i| i + 23)
        .unwrap_or(0);
    let comp_len = u32::from_le_bytes([
        pcd_bytes[header_len],
        pcd_bytes[header_len + 1],
        pcd_bytes[header_len + 2],
        pcd_bytes[header_len + 3],
    ]) as usize;
    let pcd_data_end = header_len + 8 + comp_len;
    assert_eq!(pcd_data_end, 1_722_259);
    for src in [&g, &f, &p, &png] {
        let mut len = std::fs::metadata(src)
            .map(|m| m.len() as usize)
            .unwrap_or(0);
        if src == &p {
            len = pcd_data_end;
        }
        let cuts = [0, 3, 7, 20, 100, 301, len / 2, len - 1];
        for cut in truncated_copies(src, &dir, &cuts) {
            expect_error_naming_file(&cut, &opts);
        }
    }
    // Absurd counts: a graph claiming u32::MAX nodes / points, frames claiming u32::MAX points.
    let mut bytes = std::fs::read(&g).unwrap_or_default();
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let huge = dir.join("huge_points.graph");
    std::fs::write(&huge, &bytes).unwrap_or_default();
    expect_error_naming_file(&huge, &opts);
    bytes[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
    let huge = dir.join("huge_nodes.graph");
    std::fs::write(&huge, &bytes).unwrap_or_default();
    expect_error_naming_file(&huge, &opts);
    let mut fb = std::fs::read(&f).unwrap_or_default();
    fb[28..32].copy_from_slice(&u32::MAX.to_le_bytes());
    let huge = dir.join("huge.frames");
    std::fs::write(&huge, &fb).unwrap_or_default();
    expect_error_naming_file(&huge, &opts);
    // A depth PNG whose header (with a valid CRC) declares 60000 x 60000 pixels: refused
    // before the 7 GB of pixels are allocated, with the declared size in the message.
    let mut pb = std::fs::read(&png).unwrap_or_default();
    if pb.len() > 33 && &pb[12..16] == b"IHDR" {
        pb[16..20].copy_from_slice(&60_000u32.to_be_bytes());
        pb[20..24].copy_from_slice(&60_000u32.to_be_bytes());
        let crc = crc32(&pb[12..29]);
        pb[29..33].copy_from_slice(&crc.to_be_bytes());
        let huge = dir.join("huge.png");
        std::fs::write(&huge, &pb).unwrap_or_default();
        let e = read_frames(&huge, &opts).unwrap_err().to_string();
        assert!(e.contains("huge.png") && e.contains("60000 x 60000"), "{e}");
    } else {
        panic!("{} is not a PNG with an IHDR first", png.display());
    }
    // A wrong element tag inside the graph points.
    let mut bytes = std::fs::read(&g).unwrap_or_default();
    bytes[8..12].copy_from_slice(&5i32.to_le_bytes());
    let bad = dir.join("bad_tag.graph");
    std::fs::write(&bad, &bytes).unwrap_or_default();
    expect_error_naming_file(&bad, &opts);
    // PCD: a header claiming 4 billion points, and LZF data with flipped bytes.
    let mut big = text[..header_len]
        .replace("WIDTH 640", "WIDTH 4000000000")
        .replace("HEIGHT 480", "HEIGHT 1")
        .replace("POINTS 307200", "POINTS 4000000000")
        .into_bytes();
    big.extend_from_slice(&pcd_bytes[header_len..]);
    let huge = dir.join("huge.pcd");
    std::fs::write(&huge, &big).unwrap_or_default();
    expect_error_naming_file(&huge, &opts);
    let mut flipped = pcd_bytes.clone();
    for i in (header_len + 8..flipped.len()).step_by(997) {
        flipped[i] ^= 0xA5;
    }
    let bad = dir.join("flipped.pcd");
    std::fs::write(&bad, &flipped).unwrap_or_default();
    expect_error_naming_file(&bad, &opts);
    // Garbage with every extension.
    let garbage: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    for ext in [
        "graph", "frames", "pcd", "png", "vtk", "dat", "log", "txt", "csv",
    ] {
        let q = dir.join(format!("garbage.{ext}"));
        std::fs::write(&q, &garbage).unwrap_or_default();
        expect_error_naming_file(&q, &opts);
    }
}

#[test]
fn damaged_text_files_give_errors_naming_the_file() {
    let dir = common::scratch("formats_damaged_text");
    let opts = ReadOptions::default();
    let cases: [(&str, &str); 12] = [
        ("letters.dat", "1 2 3\n4 five 6\n"),
        ("two_numbers.dat", "1 2 3\n4 5\n"),
        ("extra.dat", "1 2 3 4\n"),
        ("point_first.log", "1 2 3\nNODE 0 0 0 0 0 0\n"),
        ("short_node.log", "NODE 0 0 0 0 0\n1 2 3\n"),
        ("nan_pose.log", "NODE nan 0 0 0 0 0\n1 2 3\n"),
        ("point_first.txt", "origin 0 0 0\n1 2 3\norigin 1 2\n"),
        (
            "short.vtk",
            "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n1 2 3\n4 5 6\n",
        ),
        ("binary.vtk", "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET POLYDATA\n"),
        (
            "bad.pcd",
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA ascii\n1 2 3\n",
        ),
        (
            "int_xyz.pcd",
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE U U U\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n",
        ),
        ("bad_row.csv", "header.stamp.sec,header.stamp.nanosec\n1,2\n"),
    ];
    for (name, body) in cases {
        let p = dir.join(name);
        std::fs::write(&p, body).unwrap_or_default();
        expect_error_naming_file(&p, &opts);
    }
    // Line numbers are reported.
    let p = dir.join("letters.dat");
    let e = read_frames(&p, &opts)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains("line 2"), "{e}");
    // NaN points in text are kept, not errors.
    let p = dir.join("nan_point.dat");
    std::fs::write(&p, "nan 1 2\n1 2 3\n").unwrap_or_default();
    let f = read(&p);
    assert_eq!(f[0].points.len(), 2);
    assert!(f[0].points[0].x.is_nan());
    // Truncated compressed text: the decompressor error names the file.
    let Some(dat) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    for cut in truncated_copies(&dat, &dir, &[10, 1000, 400_000]) {
        let renamed = cut.with_extension("dat.bz2");
        std::fs::rename(&cut, &renamed).unwrap_or_default();
        expect_error_naming_file(&renamed, &opts);
    }
    // Truncated real VTK (mid-points) and TUM association without any existing image.
    let Some(norlab) = common::data_file(NORLAB) else {
        return;
    };
    let vtk_src = norlab.join("scans").join(NORLAB_SCANS[0].0);
    for cut in truncated_copies(&vtk_src, &dir, &[5, 200, 1_000_000]) {
        let renamed = cut.with_extension("vtk");
        std::fs::rename(&cut, &renamed).unwrap_or_default();
        expect_error_naming_file(&renamed, &opts);
    }
    let assoc = dir.join("assoc.txt");
    std::fs::write(&assoc, "rgb/1.png depth/1.png 0 0 0 0 0 0 1\n").unwrap_or_default();
    expect_error_naming_file(&assoc, &opts);
}

#[test]
fn format_detection_and_names() {
    for f in InputFormat::ALL {
        assert_eq!(InputFormat::from_name(f.name()), Some(f));
    }
    let cases = [
        ("a.graph", InputFormat::Graph),
        ("a.frames.gz", InputFormat::Frames),
        ("scan.dat.bz2", InputFormat::Text),
        ("a.log", InputFormat::Text),
        ("a.vtk", InputFormat::Vtk),
        ("t.csv", InputFormat::VtkSequence),
        ("c.PCD", InputFormat::Pcd),
        ("d.png", InputFormat::TumDepth),
    ];
    for (name, f) in cases {
        assert_eq!(InputFormat::detect(Path::new(name)).ok(), Some(f), "{name}");
    }
    assert!(matches!(
        InputFormat::detect(Path::new("x.weird")),
        Err(FormatError::UnknownFormat { .. })
    ));
}

// ---------------------------------------------------------------------------------------
// Properties

fn arb_point() -> impl Strategy<Value = Point3<f32>> {
    (any::<f32>(), any::<f32>(), any::<f32>()).prop_map(|(x, y, z)| Point3::new(x, y, z))
}

fn arb_frames() -> impl Strategy<Value = Vec<Frame>> {
    prop::collection::vec(
        (arb_point(), prop::collection::vec(arb_point(), 0..20))
            .prop_map(|(o, pts)| Frame::new_f32(o, pts)),
        0..5,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn frames_write_read_round_trip(fr in arb_frames()) {
        let mut bytes = Vec::new();
        frames::write_frames(&mut bytes, &fr).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let back = frames::parse_frames(Path::new("p.frames"), &bytes)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(back.len(), fr.len());
        for (a, b) in back.iter().zip(&fr) {
            prop_assert_eq!(bits(&a.origin), bits(&b.origin));
            let pa: Vec<_> = a.points.iter().map(bits).collect();
            let pb: Vec<_> = b.points.iter().map(bits).collect();
            prop_assert_eq!(pa, pb);
        }
    }

    #[test]
    fn graph_write_read_round_trip(fr in arb_frames(), q in prop::array::uniform4(-2.0f32..2.0)) {
        let mut g: ScanGraph = graph::graph_from_frames(&fr);
        for n in &mut g.nodes {
            n.pose.rotation = nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]);
        }
        g.nodes.push(ScanNode::default());
        let mut bytes = Vec::new();
        graph::write_graph(&mut bytes, &g).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let back = graph::parse_graph(Path::new("p.graph"), &bytes)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(back.nodes.len(), g.nodes.len());
        let mut again = Vec::new();
        graph::write_graph(&mut again, &back).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!(again == bytes);
    }

    #[test]
    fn random_bytes_never_panic(data in prop::collection::vec(any::<u8>(), 0..400), n in 0usize..4000) {
        let _ = graph::parse_graph(Path::new("r.graph"), &data);
        let _ = frames::parse_frames(Path::new("r.frames"), &data);
        let _ = pcd::lzf_decompress(&data, n);
    }

    #[test]
    fn unit_rotation_preserves_length(v in prop::array::uniform3(-100.0f32..100.0),
                                      rpy in prop::array::uniform3(-3.2f64..3.2)) {
        let q = graph::quaternion_from_euler(rpy[0], rpy[1], rpy[2]);
        let v = Vector3::new(v[0], v[1], v[2]);
        let r = graph::rotate(&q, &v);
        prop_assert!((r.norm() - v.norm()).abs() <= 1e-4 * (1.0 + v.norm()));
    }
}

/// PNG's CRC-32 (the reflected polynomial 0xEDB88320), bit by bit.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// The mug scene's `rgba` field (PCL's packed `0xAARRGGBB`, field-major in the compressed
/// data) gives one colour per point; the same points and colours written as ASCII and binary
/// PCD (`rgba` as `U 4` integers, `rgb` as PCL's `F 4`) read back with the same colours.
#[test]
fn pcd_colours_of_the_table_scene_survive_every_encoding() {
    let Some(p) = common::data_file(PCD) else {
        return;
    };
    let with = ReadOptions {
        colors: true,
        ..ReadOptions::default()
    };
    let frames = read_frames(&p, &with).unwrap_or_else(|e| panic!("{e}"));
    let colors = frames[0].colors.clone().expect("the table scene has rgba");
    assert_eq!(colors.len(), 307_200);
    // a textured scene: many distinct colours, not one fill value
    let distinct: std::collections::HashSet<_> = colors.iter().collect();
    assert!(distinct.len() > 200, "{} distinct colours", distinct.len());
    // without the option nothing is decoded
    assert!(read(&p)[0].colors.is_none());
    let cloud = pcd::read_pcd_cloud(&p).unwrap_or_else(|e| panic!("{e}"));
    let dir = common::scratch("formats_pcd_colours");
    for (enc, field, kind) in [
        ("ascii", "rgba", "U"),
        ("binary", "rgb", "F"),
        ("ascii", "rgb", "F"),
    ] {
        let q = dir.join(format!("table_{enc}_{field}.pcd"));
        let mut out = format!(
            "VERSION 0.7\nFIELDS x y z {field}\nSIZE 4 4 4 4\nTYPE F F F {kind}\nCOUNT 1 1 1 1\n\
             WIDTH 640\nHEIGHT 480\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 307200\nDATA {enc}\n"
        )
        .into_bytes();
        for (pt, c) in cloud.points.iter().zip(&colors) {
            let bits = u32::from_be_bytes([0xff, c.r, c.g, c.b]);
            let [x, y, z] = [pt.x as f32, pt.y as f32, pt.z as f32];
            if enc == "ascii" {
                out.extend_from_slice(format!("{x:?} {y:?} {z:?} {bits}\n").as_bytes());
            } else {
                for v in [x, y, z] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
                out.extend_from_slice(&bits.to_le_bytes());
            }
        }
        std::fs::write(&q, out).unwrap_or_else(|e| panic!("{e}"));
        let back = read_frames(&q, &with).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back[0].colors.as_ref(), Some(&colors), "{enc} {field}");
    }
}

/// A TUM frame's colours are the RGB image's pixels at the depth pixels (registered data):
/// checked against the image decoded here with the png crate, pixel by pixel.
#[test]
fn tum_colours_come_from_the_registered_rgb_pixels() {
    let Some(assoc) = common::data_file(&format!("{TUM}/my_association.txt")) else {
        return;
    };
    let with = ReadOptions {
        colors: true,
        ..ReadOptions::default()
    };
    let mut stream =
        octoquant::formats::frame_stream(&assoc, &with).unwrap_or_else(|e| panic!("{e}"));
    let f = stream
        .next()
        .expect("a frame")
        .unwrap_or_else(|e| panic!("{e}"));
    let colors = f.colors.as_ref().expect("colours asked for");
    assert_eq!(colors.len(), f.points.len());
    let pixels = &f.camera.as_ref().expect("a depth frame").pixels;
    let rgb_path = assoc.parent().unwrap().join("rgb/1311877813.991666.png");
    let decoder = png::Decoder::new(std::fs::File::open(&rgb_path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.color_type, info.width), (png::ColorType::Rgb, 640));
    for (i, (&px, c)) in pixels.iter().zip(colors).enumerate() {
        let o = 3 * px as usize;
        assert_eq!(
            [c.r, c.g, c.b],
            [buf[o], buf[o + 1], buf[o + 2]],
            "point {i}"
        );
    }
    // a missing RGB image is an error naming it, not a colourless frame
    let dir = common::scratch("formats_tum_no_rgb");
    let depth = dir.join("depth");
    std::fs::create_dir_all(&depth).unwrap();
    std::fs::copy(
        assoc.parent().unwrap().join("depth/1311877813.991479.png"),
        depth.join("1.png"),
    )
    .unwrap();
    let a = dir.join("assoc.txt");
    std::fs::write(&a, "rgb/1.png depth/1.png 0 0 0 0 0 0 1\n").unwrap();
    let e = read_frames(&a, &with).unwrap_err().to_string();
    assert!(e.contains("rgb/1.png"), "{e}");
    // a colour image of another size is refused
    std::fs::create_dir_all(dir.join("rgb")).unwrap();
    let small = std::fs::File::create(dir.join("rgb/1.png")).unwrap();
    let mut enc = png::Encoder::new(small, 2, 2);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .unwrap()
        .write_image_data(&[0; 12])
        .unwrap();
    let e = read_frames(&a, &with).unwrap_err().to_string();
    assert!(e.contains("2 x 2") && e.contains("640 x 480"), "{e}");
    // without colours the same file reads
    assert!(read_frames(&a, &ReadOptions::default()).is_ok());
}
