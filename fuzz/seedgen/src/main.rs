//! Writes the committed seed corpora of the fuzz targets into `fuzz/seeds/<target>/`, every
//! file made here with octoquant's own writers or spelled out by hand: nothing is cut from
//! recorded data. Deterministic: running it twice gives the same files.
//!
//! `cargo run --manifest-path fuzz/Cargo.toml -p octoquant-fuzz-seeds [-- OUT_DIR]`
//! (OUT_DIR defaults to `fuzz/seeds`).

use nalgebra::{Point3, Rotation3};
use octoquant_formats::frame::{CameraPixels, Frame};
use octoquant_formats::frames::write_frames;
use octoquant_formats::graph::{graph_from_frames, write_graph};
use octoquant_formats::mcap::datatype;
use octoquant_formats::ply::{write_ply, PlyEncoding};
use octoquant_formats::PinholeCamera;
use octoquant_octree::io::{write_bt, write_color_ot, write_ot};
use octoquant_octree::{Color, ColorOcTree, InnerNodes, Key, OcTree, Update};
use std::collections::BTreeMap;
use std::io::{Cursor, Write};
use std::path::{Path, PathBuf};

fn main() {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../seeds"));
    let mut seeds = Seeds { out, count: 0 };
    trees(&mut seeds);
    color_trees(&mut seeds);
    pcd(&mut seeds);
    ply(&mut seeds);
    vtk(&mut seeds);
    graph_and_frames(&mut seeds);
    text(&mut seeds);
    carmen(&mut seeds);
    tum(&mut seeds);
    mcap(&mut seeds);
    source(&mut seeds);
    octree_ops(&mut seeds);
    rows(&mut seeds);
    distance_map(&mut seeds);
    stamped_ops(&mut seeds);
    frame_pairs(&mut seeds);
    scan_sets(&mut seeds);
    color_point_clouds(&mut seeds);
    color_passes(&mut seeds);
    binvox(&mut seeds);
    count_frames(&mut seeds);
    tiles(&mut seeds);
    let checked = check_seeds(&seeds.out);
    println!(
        "wrote {} seeds under {}, {checked} of them read back by the library",
        seeds.count,
        seeds.out.display()
    );
}

/// Read every seed meant to be valid with the library's own readers, so a seed that drifted
/// out of its format (and would only test the first error path) fails the generator.
/// Returns how many were read.
fn check_seeds(out: &Path) -> usize {
    use octoquant_formats::{carmen, frames, graph, mcap as m, pcd, ply, source, text, tum, vtk};
    let mut n = 0;
    let files = |t: &str| {
        let mut v: Vec<PathBuf> = std::fs::read_dir(out.join(t))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        v
    };
    let ok = |what: &str, p: &Path, r: Result<(), String>| {
        if let Err(e) = r {
            panic!("{what} seed {} does not read: {e}", p.display());
        }
    };
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    for p in files("bt").iter().chain(&files("ot")) {
        ok(
            "tree",
            p,
            octoquant_octree::io::read_tree(bytes(p).as_slice())
                .map(drop)
                .map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in &files("color_ot") {
        ok(
            "ColorOcTree",
            p,
            octoquant_octree::io::read_color_ot(bytes(p).as_slice())
                .map(drop)
                .map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("binvox") {
        ok(
            "binvox",
            &p,
            octoquant_formats::binvox::read_binvox(&p)
                .map(drop)
                .map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("pcd") {
        ok(
            "pcd",
            &p,
            pcd::read_pcd_cloud(&p).map(drop).map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("ply")
        .into_iter()
        .filter(|p| !p.ends_with("binary-be.ply"))
    {
        ok(
            "ply",
            &p,
            ply::read_ply_f32(&p).map(drop).map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("vtk") {
        let r = match p.extension().and_then(|e| e.to_str()) {
            Some("vtk") => vtk::read_vtk(&p).map(drop),
            Some("csv") => vtk::read_trajectory_csv(&p).map(drop),
            _ => continue,
        };
        ok("vtk", &p, r.map_err(|e| e.to_string()));
        n += 1;
    }
    for p in files("graph") {
        ok(
            "graph",
            &p,
            graph::read_graph(&p).map(drop).map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("frames") {
        ok(
            "frames",
            &p,
            frames::read_frames_file(&p)
                .map(drop)
                .map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("text") {
        let r = if p.extension().is_some_and(|e| e == "log") {
            text::read_log_graph(&p).map(drop)
        } else {
            text::read_text(&p).map(drop)
        };
        ok("text", &p, r.map_err(|e| e.to_string()));
        n += 1;
    }
    for p in files("carmen") {
        let scans = carmen::read_carmen_file(&p).map_err(|e| e.to_string());
        ok(
            "carmen",
            &p,
            scans.and_then(|s| {
                if s.is_empty() {
                    Err("no scans".into())
                } else {
                    Ok(())
                }
            }),
        );
        n += 1;
    }
    for p in files("tum_assoc")
        .into_iter()
        .filter(|p| !p.ends_with("bad-quaternion.txt"))
    {
        ok(
            "tum",
            &p,
            tum::read_association(&p)
                .map(drop)
                .map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("tum_png") {
        ok(
            "png",
            &p,
            tum::read_depth_png(&p).map(drop).map_err(|e| e.to_string()),
        );
        n += 1;
    }
    for p in files("mcap") {
        let r = m::read_mcap(&p, &m::McapOptions::default()).map_err(|e| e.to_string());
        ok(
            "mcap",
            &p,
            r.and_then(|(f, _)| {
                if f.is_empty() {
                    Err("no clouds".into())
                } else {
                    Ok(())
                }
            }),
        );
        n += 1;
    }
    for p in files("mcap_cloud").iter().chain(&files("mcap_tf")) {
        let data = bytes(p);
        let enc = if data[0] & 1 == 0 {
            m::Encoding::Ros1
        } else {
            m::Encoding::Cdr
        };
        let r = if p.starts_with(out.join("mcap_tf")) {
            m::decode_tf_message(&data[1..], enc).map(drop)
        } else {
            m::decode_point_cloud2(&data[1..], enc).map(drop)
        };
        ok("message", p, r.map_err(|e| e.to_string()));
        n += 1;
    }
    for p in files("source") {
        let data = bytes(&p);
        let ext = if data[0] & 1 == 0 {
            "txt.gz"
        } else {
            "txt.bz2"
        };
        let tmp =
            std::env::temp_dir().join(format!("octoquant-seed-check-{}.{ext}", std::process::id()));
        std::fs::write(&tmp, &data[1..]).unwrap();
        let r = source::read_all(&tmp).map(drop).map_err(|e| e.to_string());
        std::fs::remove_file(&tmp).unwrap();
        ok("compressed", &p, r);
        n += 1;
    }
    n
}

struct Seeds {
    out: PathBuf,
    count: usize,
}

impl Seeds {
    fn put(&mut self, target: &str, name: &str, data: &[u8]) {
        let dir = self.out.join(target);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let path = dir.join(name);
        std::fs::write(&path, data).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        self.count += 1;
    }
}

/// A little deterministic scene: a few dozen points on a wall and a floor seen from a
/// sensor at (0, 0, 1).
fn scene_points(n: usize, phase: f32) -> Vec<Point3<f32>> {
    (0..n)
        .map(|i| {
            let t = i as f32 / n as f32;
            if i % 2 == 0 {
                Point3::new(2.0, -1.0 + 2.0 * t, 0.2 + phase + t)
            } else {
                Point3::new(0.5 + 1.5 * t, -0.5 + t + phase, 0.0)
            }
        })
        .collect()
}

// ---- .bt / .ot ----------------------------------------------------------------------

fn small_tree(voxels: u16, with_misses: bool) -> OcTree {
    let mut tree = OcTree::new(0.1).unwrap();
    for i in 0..voxels {
        let k = Key::new(0x8000 + i % 4, 0x8000 + (i / 4) % 4, 0x8000 + i / 16);
        tree.update_node(k, Update::Hit, InnerNodes::Refresh);
        if with_misses && i % 3 == 0 {
            let far = Key::new(0x7ff0 - i, 0x8000, 0x8000 + i);
            tree.update_node(far, Update::Miss, InnerNodes::Refresh);
        }
    }
    tree
}

fn trees(s: &mut Seeds) {
    let mut cases = vec![
        ("empty", OcTree::new(0.05).unwrap()),
        ("one-voxel", small_tree(1, false)),
        ("block", small_tree(16, false)),
        ("mixed", small_tree(40, true)),
    ];
    // A pruned block: 8 equal siblings merge into their parent.
    let mut pruned = OcTree::new(0.2).unwrap();
    for i in 0..8u16 {
        pruned.update_node(
            Key::new(0x8000 | (i & 1), 0x8000 | ((i >> 1) & 1), 0x8000 | (i >> 2)),
            Update::Hit,
            InnerNodes::Refresh,
        );
    }
    cases.push(("pruned", pruned));
    for (name, mut tree) in cases {
        let mut ot = Vec::new();
        write_ot(&tree, &mut ot).unwrap();
        s.put("ot", &format!("{name}.ot"), &ot);
        let mut bt = Vec::new();
        write_bt(&mut tree, &mut bt).unwrap();
        s.put("bt", &format!("{name}.bt"), &bt);
    }
}

/// `ColorOcTree` `.ot` files: empty, a few coloured voxels (set, averaged, integrated; one
/// left white), and a pruned block whose parent keeps the children's average colour.
fn color_trees(s: &mut Seeds) {
    s.put(
        "color_ot",
        "empty.ot",
        &color_ot_bytes(&ColorOcTree::new(0.05).unwrap()),
    );
    let mut few = ColorOcTree::new(0.1).unwrap();
    for i in 0..6u16 {
        let key = Key::new(0x8000 + 3 * i, 0x7ff0 + i, 0x8000 - i);
        let update = if i % 2 == 0 {
            Update::Hit
        } else {
            Update::Miss
        };
        few.update_node(key, update, InnerNodes::Refresh);
        let c = Color::new((40 * i) as u8, (255 - 30 * i) as u8, 7 * i as u8);
        match i % 4 {
            0 => few.set_node_color(key, c),
            1 => few.average_node_color(key, c),
            2 => few.integrate_node_color(key, c),
            _ => None,
        };
    }
    few.update_inner_occupancy();
    s.put("color_ot", "few.ot", &color_ot_bytes(&few));
    let mut pruned = ColorOcTree::new(0.2).unwrap();
    for i in 0..8u16 {
        let key = Key::new(0x8000 | (i & 1), 0x8000 | ((i >> 1) & 1), 0x8000 | (i >> 2));
        pruned.update_node(key, Update::Hit, InnerNodes::Refresh);
        pruned.set_node_color(key, Color::new(10 * i as u8, 200, 100));
    }
    pruned.update_inner_occupancy();
    pruned.prune();
    s.put("color_ot", "pruned.ot", &color_ot_bytes(&pruned));
}

fn color_ot_bytes(tree: &ColorOcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_color_ot(tree, &mut out).unwrap();
    out
}

// ---- PCD and LZF ---------------------------------------------------------------------

/// liblzf's format with literal runs and distance-1 back references (byte runs), enough to
/// exercise both kinds of control byte.
fn lzf_compress(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut lit: Vec<u8> = Vec::new();
    let flush = |lit: &mut Vec<u8>, out: &mut Vec<u8>| {
        for chunk in lit.chunks(32) {
            out.push(chunk.len() as u8 - 1);
            out.extend_from_slice(chunk);
        }
        lit.clear();
    };
    let mut i = 0;
    while i < data.len() {
        let mut run = 0;
        while i > 0 && i + run < data.len() && data[i + run] == data[i - 1] && run < 264 {
            run += 1;
        }
        if run >= 3 {
            flush(&mut lit, &mut out);
            let len = run - 2;
            if len < 7 {
                out.push((len as u8) << 5);
            } else {
                out.push(7 << 5);
                out.push((len - 7) as u8);
            }
            out.push(0); // distance 1
            i += run;
        } else {
            lit.push(data[i]);
            i += 1;
        }
    }
    flush(&mut lit, &mut out);
    out
}

fn pcd_header(fields: &str, size: &str, ty: &str, count: &str, n: usize, encoding: &str) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\n\
         TYPE {ty}\nCOUNT {count}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 1 1 0 0 0\nPOINTS {n}\n\
         DATA {encoding}\n"
    )
}

fn pcd(s: &mut Seeds) {
    let pts = scene_points(12, 0.0);
    // ascii, with a NaN point and an extra field
    let mut a = pcd_header(
        "x y z intensity",
        "4 4 4 4",
        "F F F F",
        "1 1 1 1",
        pts.len() + 1,
        "ascii",
    );
    for (i, p) in pts.iter().enumerate() {
        a.push_str(&format!("{} {} {} {}\n", p.x, p.y, p.z, i));
    }
    a.push_str("nan nan nan 0\n");
    s.put("pcd", "ascii.pcd", a.as_bytes());
    // binary, f32 xyz + u8 rgb padding
    let mut b = pcd_header(
        "x y z rgb",
        "4 4 4 4",
        "F F F U",
        "1 1 1 1",
        pts.len(),
        "binary",
    )
    .into_bytes();
    for (i, p) in pts.iter().enumerate() {
        for c in [p.x, p.y, p.z] {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.extend_from_slice(&(i as u32 * 0x010203).to_le_bytes());
    }
    s.put("pcd", "binary.pcd", &b);
    // binary, f64 xyz
    let mut d = pcd_header("x y z", "8 8 8", "F F F", "1 1 1", pts.len(), "binary").into_bytes();
    for p in &pts {
        for c in [p.x, p.y, p.z] {
            d.extend_from_slice(&f64::from(c).to_le_bytes());
        }
    }
    s.put("pcd", "binary-f64.pcd", &d);
    // organised: a 10 x 8 depth image seen by a pinhole camera (focal length 10 pixels,
    // principal point (4.5, 3.5)), one pixel invalid; the reader fits that camera to it
    let mut o = b"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n\
        SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 10\nHEIGHT 8\nVIEWPOINT 0 0 0 1 0 0 0\n\
        POINTS 80\nDATA binary\n"
        .to_vec();
    for v in 0..8u8 {
        for u in 0..10u8 {
            let z = 1.0 + 0.05 * f32::from((u * 3 + v * 5) % 7);
            let p = if (u, v) == (7, 2) {
                [f32::NAN; 3]
            } else {
                let (a, b) = ((f32::from(u) - 4.5) / 10.0, (f32::from(v) - 3.5) / 10.0);
                [a * z, b * z, z]
            };
            for c in p {
                o.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    s.put("pcd", "organised.pcd", &o);
    // binary_compressed: field-major, LZF
    let mut raw = Vec::new();
    for k in 0..3 {
        for p in &pts {
            raw.extend_from_slice(&p[k].to_le_bytes());
        }
    }
    for _ in &pts {
        raw.extend_from_slice(&[0, 0, 0, 0]); // an all-zero padding field: compresses as a run
    }
    let comp = lzf_compress(&raw);
    let mut c = pcd_header(
        "x y z _",
        "4 4 4 4",
        "F F F U",
        "1 1 1 1",
        pts.len(),
        "binary_compressed",
    )
    .into_bytes();
    c.extend_from_slice(&(comp.len() as u32).to_le_bytes());
    c.extend_from_slice(&(raw.len() as u32).to_le_bytes());
    c.extend_from_slice(&comp);
    s.put("pcd", "binary-compressed.pcd", &c);
    // the LZF target: u16 output length, then the stream
    for (name, data) in [
        ("runs", &raw[..]),
        (
            "text",
            &b"abcabcabcaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaxyz"[..],
        ),
    ] {
        let comp = lzf_compress(data);
        let mut l = (data.len() as u16).to_le_bytes().to_vec();
        l.extend_from_slice(&comp);
        s.put("lzf", &format!("{name}.lzf"), &l);
    }
}

// ---- PLY -----------------------------------------------------------------------------

fn ply(s: &mut Seeds) {
    let pts = scene_points(10, 0.5);
    let mut a = Vec::new();
    write_ply(&mut a, &pts, PlyEncoding::Ascii).unwrap();
    s.put("ply", "ascii.ply", &a);
    let mut b = Vec::new();
    write_ply(&mut b, &pts, PlyEncoding::BinaryLittleEndian).unwrap();
    s.put("ply", "binary-le.ply", &b);
    // doubles, extra properties and a face list after the vertices
    let mut be = format!(
        "ply\nformat binary_little_endian 1.0\ncomment hand-made\nelement vertex {}\n\
         property uchar red\nproperty double x\nproperty double y\nproperty double z\n\
         property short s\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n",
        pts.len()
    )
    .into_bytes();
    for (i, p) in pts.iter().enumerate() {
        be.push(i as u8);
        for c in [p.x, p.y, p.z] {
            be.extend_from_slice(&f64::from(c).to_le_bytes());
        }
        be.extend_from_slice(&(i as i16).to_le_bytes());
    }
    be.push(3);
    for v in [0i32, 1, 2] {
        be.extend_from_slice(&v.to_le_bytes());
    }
    s.put("ply", "binary-le-doubles.ply", &be);
    // big endian is refused with a clear error: one seed keeps that path covered
    s.put(
        "ply",
        "binary-be.ply",
        b"ply\nformat binary_big_endian 1.0\nelement vertex 0\nend_header\n",
    );
    let faces_first =
        "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n\
                       element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                       end_header\n3 0 1 2\n0 0 0\n1 0 0\n0 1 0\n";
    s.put("ply", "faces-first.ply", faces_first.as_bytes());
}

// ---- VTK and the trajectory CSV -------------------------------------------------------

fn vtk(s: &mut Seeds) {
    let pts = scene_points(9, 0.1);
    let mut v = String::from("# vtk DataFile Version 3.0\nscan\nASCII\nDATASET POLYDATA\n");
    v.push_str(&format!("POINTS {} float\n", pts.len()));
    for (i, p) in pts.iter().enumerate() {
        // three points per line, then one per line
        let sep = if i < 6 && i % 3 != 2 { " " } else { "\n" };
        v.push_str(&format!("{} {} {}{sep}", p.x, p.y, p.z));
    }
    v.push_str(&format!("VERTICES {} {}\n", pts.len(), 2 * pts.len()));
    for i in 0..pts.len() {
        v.push_str(&format!("1 {i}\n"));
    }
    s.put("vtk", "polydata.vtk", v.as_bytes());
    let grid =
        "# vtk DataFile Version 2.0\ngrid\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 double\n\
                1.5 2.5 -0.5\n1e-3 2E2 3\nCELLS 0 0\n";
    s.put("vtk", "grid.vtk", grid.as_bytes());
    let csv = "header.stamp.sec,header.stamp.nanosec,pose.pose.position.x,pose.pose.position.y,\
               pose.pose.position.z,pose.pose.orientation.x,pose.pose.orientation.y,\
               pose.pose.orientation.z,pose.pose.orientation.w\n\
               1700000000,5000,1.0,2.0,0.5,0,0,0,1\n1700000001,999999999,1.5,2.0,0.5,0,0,0.7071068,0.7071068\n";
    s.put("vtk", "trajectory.csv", csv.as_bytes());
    s.put("vtk", "scan-name.txt", b"scan_1700000000_000005000.vtk");
}

// ---- binvox ---------------------------------------------------------------------------

fn binvox(s: &mut Seeds) {
    use octoquant_formats::binvox::write_binvox;
    // a 4 x 5 x 6 grid: a diagonal slab of voxels, a run of value 2
    let cells: Vec<u8> = (0..120)
        .map(|j| match j {
            0..=9 => 2,
            _ if (j / 30) == (j % 6) / 2 => 1,
            _ => 0,
        })
        .collect();
    s.put(
        "binvox",
        "slab.binvox",
        &write_binvox([4, 5, 6], [-0.5, 0.25, 1.0], 1.5, &cells),
    );
    // 300 cells in one line: runs split at 255
    s.put(
        "binvox",
        "line.binvox",
        &write_binvox([300, 1, 1], [0.0; 3], 3.0, &[1; 300]),
    );
    // an unknown header line and header words in another order
    let mut odd =
        b"#binvox 1\nbbox 0 0 0 1 1 1\nscale 0.1\ntranslate 1 2 3\ndim 2 2 2\ndata\n".to_vec();
    odd.extend_from_slice(&[0, 3, 1, 5]);
    s.put("binvox", "header-order.binvox", &odd);
}

// ---- .graph and .frames --------------------------------------------------------------

fn frames_of(n: usize) -> Vec<Frame> {
    (0..n)
        .map(|i| {
            Frame::new_f32(
                Point3::new(0.1 * i as f32, 0.0, 1.0),
                scene_points(6 + i, i as f32 * 0.1),
            )
        })
        .collect()
}

fn graph_and_frames(s: &mut Seeds) {
    for n in [0usize, 1, 3] {
        let frames = frames_of(n);
        let mut g = Vec::new();
        write_graph(&mut g, &graph_from_frames(&frames)).unwrap();
        s.put("graph", &format!("{n}-nodes.graph"), &g);
        let mut f = Vec::new();
        write_frames(&mut f, &frames).unwrap();
        s.put("frames", &format!("{n}-frames.frames"), &f);
    }
    // version 2: stamps, colours and a depth camera (one frame with all, one with a stamp)
    let mut full = frames_of(2);
    let n = full[0].points.len();
    full[0].stamp = Some(1.5);
    full[0].colors = Some((0..n).map(|k| Color::new(k as u8, 9, 200)).collect());
    full[0].camera = Some(CameraPixels {
        camera: PinholeCamera {
            width: 8,
            height: 6,
            fx: 4.0,
            fy: 4.5,
            cx: 3.5,
            cy: 2.5,
            rotation: Rotation3::from_euler_angles(0.1, 0.2, 0.3),
        },
        pixels: (0..n as u32).map(|k| k * 5 % 48).collect(),
    });
    full[1].stamp = Some(2.0);
    let mut f = Vec::new();
    write_frames(&mut f, &full).unwrap();
    s.put("frames", "v2-stamps-colours-camera.frames", &f);
}

// ---- text, CARMEN, TUM ---------------------------------------------------------------

fn text(s: &mut Seeds) {
    let mut list = String::from("# x y z\n");
    for p in scene_points(8, 0.0) {
        list.push_str(&format!("{} {} {}\n", p.x, p.y, p.z));
    }
    list.push_str("nan inf -inf\n1 2 3");
    s.put("text", "points.txt", list.as_bytes());
    let log =
        "NODE 0 0 1 0 0 0\n1 0 0\n0 1 0\n 9 9 9\nNODE 1.5 0 1 0.1 -0.2 1.5707963\n2 0 0\n\n# end\n";
    s.put("text", "nodes.log", log.as_bytes());
    let origin = "origin 0 0 1\n1 1 1\n2 2 2\norigin 1 0 1\n3 3 3\n";
    s.put("text", "origin.txt", origin.as_bytes());
}

fn carmen(s: &mut Seeds) {
    let flaser = "# CARMEN log\nPARAM robot_front_laser_max 50.0 nohost 0\n\
                  PARAM laser_front_laser_resolution 1.0 nohost 0\n\
                  FLASER 5 1.0 2.0 81.9 0.5 3.0 1.0 2.0 0.1 1.0 2.0 0.1 1000.5 host 1000.6\n\
                  ODOM 1.0 2.0 0.1 0 0 0 1000.7 host 1000.7\n";
    s.put("carmen", "flaser.log", flaser.as_bytes());
    let robot = "ROBOTLASER1 0 -1.5707963 3.1415927 0.7853982 81.9 0.01 0 5 1.0 2.0 nan 0.5 3.0 \
                 0 0.2 0.3 0.05 0.1 0.2 0.05 0 0 0 0 0 1000.5 host 1000.6\n\
                 ROBOTLASER1 0 -1.0 2.0 0.5 10.0 0.01 0 5 1 2 3 4 5 2 7 8 0 0 0 0 0 0 0 0 0 0 0 1 h 1\n";
    s.put("carmen", "robotlaser.log", robot.as_bytes());
}

fn tum(s: &mut Seeds) {
    let assoc = "# timestamp depth tx ty tz qx qy qz qw\n\
                 1305031102.175304 depth/1305031102.160407.png 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n\
                 1305031102.211214 depth/1305031102.226738.png 1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n";
    s.put("tum_assoc", "associations.txt", assoc.as_bytes());
    s.put(
        "tum_assoc",
        "bad-quaternion.txt",
        b"1 d.png 0 0 0 0 0 0 0\n",
    );
    for (name, w, h) in [("depth-8x6", 8u32, 6u32), ("depth-3x1", 3, 1)] {
        let mut png_bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut png_bytes, w, h);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Sixteen);
            let mut wr = enc.write_header().unwrap();
            let mut data = Vec::new();
            for i in 0..w * h {
                let depth: u16 = if i % 5 == 0 { 0 } else { 5000 + 37 * i as u16 };
                data.extend_from_slice(&depth.to_be_bytes());
            }
            wr.write_image_data(&data).unwrap();
        }
        s.put("tum_png", &format!("{name}.png"), &png_bytes);
    }
}

// ---- MCAP ----------------------------------------------------------------------------

/// ROS 1 (little-endian, packed) or CDR (header, aligned) serializer.
struct Ser {
    buf: Vec<u8>,
    cdr: bool,
    be: bool,
}

impl Ser {
    fn new(cdr: bool, be: bool) -> Ser {
        let buf = if cdr {
            vec![0, if be { 0 } else { 1 }, 0, 0]
        } else {
            Vec::new()
        };
        Ser { buf, cdr, be }
    }
    fn align(&mut self, n: usize) {
        if self.cdr {
            while (self.buf.len() - 4) % n != 0 {
                self.buf.push(0);
            }
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
        if self.cdr {
            self.u32(s.len() as u32 + 1);
            self.buf.extend_from_slice(s.as_bytes());
            self.buf.push(0);
        } else {
            self.u32(s.len() as u32);
            self.buf.extend_from_slice(s.as_bytes());
        }
    }
    fn header(&mut self, sec: u32, nsec: u32, frame: &str) {
        if !self.cdr {
            self.u32(7); // seq
        }
        self.u32(sec);
        self.u32(nsec);
        self.string(frame);
    }
}

/// A PointCloud2 of `pts` with f32 x, y, z and a trailing intensity, 16-byte points.
fn cloud_message(cdr: bool, be: bool, frame: &str, pts: &[Point3<f32>]) -> Vec<u8> {
    let mut m = Ser::new(cdr, be);
    m.header(100, 250_000_000, frame);
    m.u32(1);
    m.u32(pts.len() as u32);
    m.u32(4);
    for (i, name) in ["x", "y", "z", "intensity"].iter().enumerate() {
        m.string(name);
        m.u32(4 * i as u32);
        m.u8(datatype::FLOAT32);
        m.u32(1);
    }
    m.u8(0); // points little-endian
    m.u32(16);
    m.u32(16 * pts.len() as u32);
    m.u32(16 * pts.len() as u32);
    for p in pts {
        for c in [p.x, p.y, p.z, 1.0] {
            m.buf.extend_from_slice(&c.to_le_bytes());
        }
    }
    m.u8(1);
    m.buf
}

fn tf_message(cdr: bool, be: bool, edges: &[(&str, &str, [f64; 3], [f64; 4])]) -> Vec<u8> {
    let mut m = Ser::new(cdr, be);
    m.u32(edges.len() as u32);
    for (parent, child, t, q) in edges {
        m.header(0, 0, parent);
        m.string(child);
        for v in t.iter().chain(q) {
            m.f64(*v);
        }
    }
    m.buf
}

struct Msg {
    topic: &'static str,
    schema: &'static str,
    encoding: &'static str,
    data: Vec<u8>,
    log_time: u64,
}

fn mcap_file(profile: &str, messages: &[Msg], compression: Option<mcap::Compression>) -> Vec<u8> {
    mcap_file_in_chunks(profile, messages, compression, None, true)
}

/// [`mcap_file`] with chunks of at most `chunk_size` bytes (the writer's default: `None`),
/// with or without the chunks' CRC-32 (0 in the header: not checked). The reader refuses a
/// chunk whose records do not match its CRC, so a mutation inside a chunk that has one
/// stops there: the seeds without CRCs let the fuzzer reach the records' parsing.
fn mcap_file_in_chunks(
    profile: &str,
    messages: &[Msg],
    compression: Option<mcap::Compression>,
    chunk_size: Option<u64>,
    crcs: bool,
) -> Vec<u8> {
    let mut opts = mcap::WriteOptions::new()
        .profile(profile)
        .compression(compression)
        .calculate_chunk_crcs(crcs);
    if chunk_size.is_some() {
        opts = opts.chunk_size(chunk_size);
    }
    let mut w = opts.create(Cursor::new(Vec::new())).unwrap();
    let mut channels: BTreeMap<&str, u16> = BTreeMap::new();
    for (i, m) in messages.iter().enumerate() {
        let id = match channels.get(m.topic) {
            Some(&id) => id,
            None => {
                let enc = if m.encoding == "ros1" {
                    "ros1msg"
                } else {
                    "ros2msg"
                };
                let sid = w.add_schema(m.schema, enc, b"").unwrap();
                let id = w
                    .add_channel(sid, m.topic, m.encoding, &BTreeMap::new())
                    .unwrap();
                channels.insert(m.topic, id);
                id
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: i as u32,
            log_time: m.log_time,
            publish_time: m.log_time,
        };
        w.write_to_known_channel(&header, &m.data).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

fn mcap(s: &mut Seeds) {
    let pts = scene_points(4, 0.0);
    let q90 = [
        0.0,
        0.0,
        std::f64::consts::FRAC_1_SQRT_2,
        std::f64::consts::FRAC_1_SQRT_2,
    ];
    let edges = [
        ("map", "base", [1.0, 2.0, 0.0], q90),
        ("base", "lidar", [0.0, 0.0, 0.5], [0.0, 0.0, 0.0, 1.0]),
    ];
    for (name, cdr, be) in [
        ("ros1", false, false),
        ("cdr-le", true, false),
        ("cdr-be", true, true),
    ] {
        let cloud = cloud_message(cdr, be, "lidar", &pts);
        let tf = tf_message(cdr, be, &edges);
        let mut c = vec![u8::from(cdr)];
        c.extend_from_slice(&cloud);
        s.put("mcap_cloud", &format!("{name}.msg"), &c);
        let mut t = vec![u8::from(cdr)];
        t.extend_from_slice(&tf);
        s.put("mcap_tf", &format!("{name}.msg"), &t);
    }
    let ros2 = |be: bool| {
        vec![
            Msg {
                topic: "/tf_static",
                schema: "tf2_msgs/msg/TFMessage",
                encoding: "cdr",
                data: tf_message(true, be, &edges[..1]),
                log_time: 10,
            },
            Msg {
                topic: "/tf",
                schema: "tf2_msgs/msg/TFMessage",
                encoding: "cdr",
                data: tf_message(true, be, &edges[1..]),
                log_time: 20,
            },
            Msg {
                topic: "/cloud",
                schema: "sensor_msgs/msg/PointCloud2",
                encoding: "cdr",
                data: cloud_message(true, be, "lidar", &pts),
                log_time: 30,
            },
            Msg {
                topic: "/cloud",
                schema: "sensor_msgs/msg/PointCloud2",
                encoding: "cdr",
                data: cloud_message(true, be, "lidar", &pts[..2]),
                log_time: 40,
            },
        ]
    };
    s.put(
        "mcap",
        "ros2-zstd.mcap",
        &mcap_file("ros2", &ros2(false), Some(mcap::Compression::Zstd)),
    );
    s.put(
        "mcap",
        "ros2-be-plain.mcap",
        &mcap_file("ros2", &ros2(true), None),
    );
    // several small chunks with their indexes: a slice jumps over the first ones
    let mut chunked = ros2(false);
    for i in 0..4u64 {
        chunked.push(Msg {
            topic: "/cloud",
            schema: "sensor_msgs/msg/PointCloud2",
            encoding: "cdr",
            data: cloud_message(true, false, "lidar", &pts[..1 + i as usize % 2]),
            log_time: 50 + 10 * i,
        });
    }
    for (name, crcs) in [
        ("ros2-zstd-chunks.mcap", true),
        ("ros2-zstd-chunks-no-crc.mcap", false),
    ] {
        let zstd = Some(mcap::Compression::Zstd);
        let file = mcap_file_in_chunks("ros2", &chunked, zstd, Some(200), crcs);
        s.put("mcap", name, &file);
    }
    s.put(
        "mcap",
        "ros2-be-plain-no-crc.mcap",
        &mcap_file_in_chunks("ros2", &ros2(true), None, None, false),
    );
    let ros1 = vec![
        Msg {
            topic: "/tf_static",
            schema: "tf2_msgs/TFMessage",
            encoding: "ros1",
            data: tf_message(false, false, &edges),
            log_time: 5,
        },
        Msg {
            topic: "/points",
            schema: "sensor_msgs/PointCloud2",
            encoding: "ros1",
            data: cloud_message(false, false, "lidar", &pts),
            log_time: 6,
        },
        Msg {
            topic: "/imu",
            schema: "sensor_msgs/Imu",
            encoding: "ros1",
            data: vec![1, 2, 3],
            log_time: 7,
        },
    ];
    s.put("mcap", "ros1-plain.mcap", &mcap_file("ros1", &ros1, None));
}

// ---- gz / bz2 ------------------------------------------------------------------------

fn source(s: &mut Seeds) {
    let text = b"1 2 3\n4 5 6\n# comment\n7 8 9\n";
    let mut gz = flate2::write::GzEncoder::new(vec![0u8], flate2::Compression::default());
    gz.write_all(text).unwrap();
    let gz = gz.finish().unwrap();
    s.put("source", "points.txt.gz", &gz);
    // two gzip members back to back
    let mut two = gz.clone();
    two.extend_from_slice(&gz[1..]);
    s.put("source", "two-members.txt.gz", &two);
    let mut bz = bzip2::write::BzEncoder::new(vec![1u8], bzip2::Compression::default());
    bz.write_all(text).unwrap();
    s.put("source", "points.txt.bz2", &bz.finish().unwrap());
}

/// The `count_frames` target's seeds: the MCAP, `.frames`, `.graph` and TUM association
/// seeds written above, each behind the byte that picks its file name in the target, and one
/// gzip-wrapped `.frames` file.
fn count_frames(s: &mut Seeds) {
    for (pick, target) in [(0u8, "mcap"), (1, "frames"), (2, "graph"), (3, "tum_assoc")] {
        let dir = s.out.join(target);
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        for name in names {
            let mut data = vec![pick];
            data.extend(std::fs::read(dir.join(&name)).unwrap());
            s.put(
                "count_frames",
                &format!("{target}-{}", name.to_string_lossy()),
                &data,
            );
        }
    }
    let frames = std::fs::read(s.out.join("frames/3-frames.frames")).unwrap();
    let mut gz = flate2::write::GzEncoder::new(vec![4u8], flate2::Compression::default());
    gz.write_all(&frames).unwrap();
    s.put(
        "count_frames",
        "frames-3-frames.frames.gz",
        &gz.finish().unwrap(),
    );
}

// ---- octree operation sequences -------------------------------------------------------

fn octree_ops(s: &mut Seeds) {
    random_seeds(s, "octree_ops", 0x2545_f491_4f6c_dd1d, &[16, 64, 256, 1024]);
}

fn stamped_ops(s: &mut Seeds) {
    random_seeds(
        s,
        "stamped_ops",
        0x5851_f42d_4c95_7f2d,
        &[16, 64, 256, 1024],
    );
}

fn frame_pairs(s: &mut Seeds) {
    random_seeds(
        s,
        "frame_pairs",
        0x9e37_79b9_7f4a_7c15,
        &[64, 256, 1024, 4096],
    );
}

fn scan_sets(s: &mut Seeds) {
    random_seeds(
        s,
        "scan_sets",
        0x2f6b_8a1c_5d3e_9047,
        &[64, 256, 1024, 4096],
    );
}

fn color_point_clouds(s: &mut Seeds) {
    random_seeds(
        s,
        "color_point_clouds",
        0xd1b5_4a32_d192_ed03,
        &[64, 256, 1024, 4096],
    );
}

fn color_passes(s: &mut Seeds) {
    random_seeds(
        s,
        "color_passes",
        0x2545_f491_4f6c_dd1d,
        &[64, 256, 1024, 4096],
    );
}

/// Seeds for a structure-aware target: `arbitrary` reads any bytes, so a few deterministic
/// pseudo-random strings (xorshift from `state`) of the given lengths start its campaign with
/// sequences of a few to a few dozen operations.
fn random_seeds(s: &mut Seeds, target: &str, mut state: u64, lengths: &[usize]) {
    for (i, &len) in lengths.iter().enumerate() {
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 24) as u8
            })
            .collect();
        s.put(target, &format!("random-{i}.bin"), &bytes);
    }
}

// ---- rows files (`--points`, `--rays`) and distance maps ---------------------------------

fn rows(s: &mut Seeds) {
    // the first byte picks the width: 0 -> 3 numbers a row, 1 -> 6
    let files: [(&str, u8, &str); 6] = [
        ("points", 0, "# x y z\n1 2 3\n\n-0.5, 2.25, 1e-3\n4\t5\t6\n"),
        ("rays", 1, "0 0 0 1 0 0\n0.1,0.2,0.3, 0,0,-1\n"),
        ("short-line", 0, "1 2 3\n1 2\n"),
        ("nan", 0, "1 2 3\nnan 0 0\n"),
        ("overflow", 1, "0 0 0 1 0 1e999\n"),
        ("crlf", 0, "1 2 3\r\n4 5 6\r\n"),
    ];
    for (name, width, text) in files {
        let mut bytes = vec![width];
        bytes.extend_from_slice(text.as_bytes());
        s.put("rows", &format!("{name}.txt"), &bytes);
    }
}

fn distance_map(s: &mut Seeds) {
    random_seeds(
        s,
        "distance_map",
        0x9e37_79b9_7f4a_7c15,
        &[32, 128, 512, 2048],
    );
}

/// Tile update buffers (OQTU) at several tile depths, from deterministic pseudo-random
/// sorted codes inside each tile, and tile directory indexes, written by the tiles crate's
/// own encoder and index writer (each read back here).
fn tiles(s: &mut Seeds) {
    use octoquant_tiles::{
        read_index, write_index, Tile, TileFrame, TileIndex, TileUpdates, INDEX_FILE,
    };
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    for (i, depth) in [0u8, 3, 8, 12, 16].into_iter().enumerate() {
        let index = next() & ((1u64 << (3 * depth as u32)) - 1);
        let tile = Tile::new(depth, index).unwrap();
        let base = tile.min_key().morton();
        let span = 1u64 << (48 - 3 * depth as u32);
        let mut lists = TileUpdates::new(tile);
        for f in 0..(1 + i as u64) {
            let mut codes: Vec<u64> = (0..(3 * i + 2)).map(|_| base + next() % span).collect();
            codes.sort_unstable();
            codes.dedup();
            let split = codes.len() / 2;
            lists.frames.push(TileFrame {
                frame: 2 * f + i as u64,
                free: codes[..split].to_vec(),
                occupied: codes[split..].to_vec(),
            });
        }
        let bytes = lists.to_bytes().unwrap();
        assert!(TileUpdates::from_bytes(&bytes).unwrap() == lists);
        // the target's first byte: 0 reads the rest as it is, 1 fixes its checksum first
        for pick in [0u8, 1] {
            let mut seed = vec![pick];
            seed.extend_from_slice(&bytes);
            s.put(
                "tile_lists",
                &format!("depth-{depth:02}-{pick}.oqtu"),
                &seed,
            );
        }
    }
    let dir = std::env::temp_dir().join(format!("octoquant-seedgen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (i, depth) in [0u8, 6, 9].into_iter().enumerate() {
        let tiles = (0..i as u64 * 2)
            .map(|k| {
                let t = Tile::new(depth, k * 5 % (1u64 << (3 * depth as u32))).unwrap();
                (t, octoquant_tiles::tile_file_name(t))
            })
            .collect::<std::collections::BTreeMap<_, _>>()
            .into_iter()
            .collect();
        let index = TileIndex {
            resolution: [0.1, 0.05, 0.2][i],
            params: octoquant_octree::OccupancyParams::default(),
            tile_depth: depth,
            tiles,
        };
        write_index(&dir, &index).unwrap();
        assert!(read_index(&dir).unwrap() == index);
        let bytes = std::fs::read(dir.join(INDEX_FILE)).unwrap();
        s.put("tile_index", &format!("depth-{depth:02}.index"), &bytes);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
