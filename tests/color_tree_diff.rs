//! `ColorOcTree` against the real OctoMap: random sequences of occupancy and colour operations,
//! and real coloured points, applied to both must give byte-identical `.ot` files; OctoMap's
//! files must read and rewrite identically, in both directions.

use crate::common::{self, first_diff};
use octoquant::formats::pcd::{lzf_decompress, read_pcd_cloud};
use octoquant::octree::io::{read_color_ot, write_color_ot};
use octoquant::octree::{
    Color, ColorOcTree, InnerNodes, Key, OccupancyParams, OctreeError, Update,
};
use proptest::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Which colour operation.
#[derive(Debug, Clone, Copy)]
enum ColorOp {
    Set,
    Average,
    Integrate,
}

/// One operation applied to both trees.
#[derive(Debug, Clone)]
enum Op {
    Update {
        key: Key,
        hit: bool,
        repeat: u8,
        lazy: bool,
    },
    Set {
        key: Key,
        bits: u32,
        lazy: bool,
    },
    Color {
        op: ColorOp,
        key: Key,
        color: Color,
    },
    Delete {
        key: Key,
    },
    Prune,
    Expand,
    MaxLikelihood,
    Inner,
    /// Node surgery on one node (`expandNode`, `pruneNode`, `createNodeChild`,
    /// `deleteNodeChild`).
    Surgery(common::Surgery),
    /// Several operations in a row.
    Many(Vec<Op>),
}

#[derive(Debug, Clone)]
struct Case {
    res: f64,
    params: Option<[f64; 5]>,
    ops: Vec<Op>,
}

fn key_strategy(base: Key) -> impl Strategy<Value = Key> {
    let near = move |w: u16| {
        (0..w, 0..w, 0..w).prop_map(move |(x, y, z)| {
            Key::new(
                base.x().wrapping_add(x),
                base.y().wrapping_add(y),
                base.z().wrapping_add(z),
            )
        })
    };
    prop_oneof![
        // clustered, so octants fill up and prune (with colours to merge)
        6 => near(4),
        3 => near(16),
        1 => any::<[u16; 3]>().prop_map(Key),
    ]
}

fn color_strategy() -> impl Strategy<Value = Color> {
    prop_oneof![
        // white is "no colour" in OctoMap; near-white is a colour
        1 => Just(Color::WHITE),
        1 => Just(Color::new(255, 255, 254)),
        1 => Just(Color::new(0, 0, 0)),
        6 => any::<[u8; 3]>().prop_map(|[r, g, b]| Color::new(r, g, b)),
    ]
}

fn op_strategy(base: Key) -> impl Strategy<Value = Op> {
    let k = move || key_strategy(base);
    let cop = prop_oneof![
        Just(ColorOp::Set),
        Just(ColorOp::Average),
        Just(ColorOp::Integrate)
    ];
    prop_oneof![
        30 => (k(), any::<bool>(), 1u8..10, prop::bool::weighted(0.2))
            .prop_map(|(key, hit, repeat, lazy)| Op::Update { key, hit, repeat, lazy }),
        // the eight voxels of one depth-15 node, five times: octants reach a clamp together
        // and prune with whatever colours they hold
        6 => (k(), any::<bool>(), prop::bool::weighted(0.2)).prop_flat_map(|(key, hit, lazy)| {
            let ops: Vec<Op> = (0..8u16)
                .map(|i| Op::Update {
                    key: Key::new(
                        key.x() & !1 | (i & 1),
                        key.y() & !1 | (i >> 1 & 1),
                        key.z() & !1 | (i >> 2 & 1),
                    ),
                    hit,
                    repeat: 5,
                    lazy,
                })
                .collect();
            Just(Op::Many(ops))
        }),
        4 => (k(), -4.0f32..4.0, prop::bool::weighted(0.2))
            .prop_map(|(key, v, lazy)| Op::Set { key, bits: v.to_bits(), lazy }),
        25 => (cop, k(), color_strategy()).prop_map(|(op, key, color)| Op::Color { op, key, color }),
        2 => k().prop_map(|key| Op::Delete { key }),
        2 => Just(Op::Prune),
        1 => Just(Op::Expand),
        1 => Just(Op::MaxLikelihood),
        2 => Just(Op::Inner),
        10 => common::surgery_strategy(k()).prop_map(Op::Surgery),
    ]
}

fn case_strategy() -> impl Strategy<Value = Case> {
    let res = prop_oneof![
        Just(0.1),
        Just(0.05),
        Just(0.01f32 as f64),
        Just(0.123456789)
    ];
    let params = prop::option::weighted(
        0.3,
        (
            0.51f64..0.95,
            0.05f64..0.49,
            0.01f64..0.4,
            0.6f64..0.99,
            0.3f64..0.7,
        ),
    )
    .prop_map(|p| p.map(|(h, m, lo, hi, t)| [h, m, lo, hi, t]));
    let base = prop_oneof![
        Just(Key::new(32768, 32768, 32768)),
        Just(Key::new(32766, 32765, 32767)),
        any::<[u16; 3]>().prop_map(Key),
    ];
    (res, params, base).prop_flat_map(|(res, params, base)| {
        prop::collection::vec(op_strategy(base), 1..200).prop_map(move |mut ops| {
            // a delete can leave a childless root that the next update expands into coarse
            // leaves; a later expand() would then create billions of nodes
            if ops.iter().any(|o| matches!(o, Op::Delete { .. })) {
                ops.retain(|o| !matches!(o, Op::Expand));
            }
            Case { res, params, ops }
        })
    })
}

fn apply_case(case: &Case) -> ColorOcTree {
    let mut tree = ColorOcTree::new(case.res).unwrap();
    if let Some([h, m, lo, hi, t]) = case.params {
        tree.set_params(OccupancyParams::from_probabilities(h, m, lo, hi, t).unwrap());
    }
    apply_ops(&mut tree, &case.ops);
    tree
}

fn apply_ops(tree: &mut ColorOcTree, ops: &[Op]) {
    for op in ops {
        match *op {
            Op::Many(ref ops) => apply_ops(tree, ops),
            Op::Update {
                key,
                hit,
                repeat,
                lazy,
            } => {
                let u = if hit { Update::Hit } else { Update::Miss };
                for _ in 0..repeat {
                    tree.update_node(key, u, InnerNodes::from_lazy(lazy));
                }
            }
            Op::Set { key, bits, lazy } => {
                tree.set_node_value(key, f32::from_bits(bits), InnerNodes::from_lazy(lazy))
                    .unwrap();
            }
            Op::Color { op, key, color } => {
                match op {
                    ColorOp::Set => tree.set_node_color(key, color),
                    ColorOp::Average => tree.average_node_color(key, color),
                    ColorOp::Integrate => tree.integrate_node_color(key, color),
                };
            }
            Op::Delete { key } => {
                tree.delete_node(key, 16);
            }
            Op::Prune => tree.prune(),
            Op::Expand => tree.expand(),
            Op::MaxLikelihood => tree.to_max_likelihood(),
            Op::Inner => tree.update_inner_occupancy(),
            Op::Surgery(ref c) => c.apply(tree, 0),
        }
    }
}

fn script_for(case: &Case) -> String {
    let mut s = String::new();
    writeln!(s, "tree {:.17e}", case.res).unwrap();
    if let Some([h, m, lo, hi, t]) = case.params {
        writeln!(s, "params {h:.17e} {m:.17e} {lo:.17e} {hi:.17e} {t:.17e}").unwrap();
    }
    script_ops(&mut s, &case.ops);
    s
}

fn script_ops(s: &mut String, ops: &[Op]) {
    for op in ops {
        match *op {
            Op::Many(ref ops) => script_ops(s, ops),
            Op::Update {
                key,
                hit,
                repeat,
                lazy,
            } => {
                for _ in 0..repeat {
                    let c = if hit { "hit" } else { "miss" };
                    writeln!(s, "{c} {} {} {} {}", key.x(), key.y(), key.z(), lazy as u8).unwrap();
                }
            }
            Op::Set { key, bits, lazy } => writeln!(
                s,
                "set {} {} {} {bits:08x} {}",
                key.x(),
                key.y(),
                key.z(),
                lazy as u8
            )
            .unwrap(),
            Op::Color { op, key, color } => {
                let c = match op {
                    ColorOp::Set => "color",
                    ColorOp::Average => "avgcolor",
                    ColorOp::Integrate => "intcolor",
                };
                writeln!(
                    s,
                    "{c} {} {} {} {} {} {}",
                    key.x(),
                    key.y(),
                    key.z(),
                    color.r,
                    color.g,
                    color.b
                )
                .unwrap()
            }
            Op::Delete { key } => {
                writeln!(s, "delete {} {} {} 16", key.x(), key.y(), key.z()).unwrap()
            }
            Op::Prune => s.push_str("prune\n"),
            Op::Expand => s.push_str("expand\n"),
            Op::MaxLikelihood => s.push_str("ml\n"),
            Op::Inner => s.push_str("inner\n"),
            Op::Surgery(ref c) => s.push_str(&c.line()),
        }
    }
}

/// OctoMap 1.9.7 aborts on this assertion when a node emptied by `deleteNode` is later
/// destroyed; such cases have no reference answer.
const OCTOMAP_DELETE_ABORT: &str = "Assertion `children == NULL' failed";

/// Run a colour script ending in `write_ot ref.ot` with the reference program and return the
/// file; `None` when OctoMap hit its known delete abort.
fn try_reference(refprog: &Path, script: &str, dir: &Path) -> Option<Vec<u8>> {
    let out_path = dir.join("ref.ot");
    let _ = std::fs::remove_file(&out_path);
    let sp = dir.join("ops.txt");
    std::fs::write(&sp, format!("{script}write_ot {}\n", out_path.display())).unwrap();
    let out = Command::new(refprog)
        .arg("color-script")
        .arg(&sp)
        .output()
        .expect("run reference program");
    if !out.status.success() && String::from_utf8_lossy(&out.stderr).contains(OCTOMAP_DELETE_ABORT)
    {
        return None;
    }
    assert!(
        out.status.success(),
        "reference program failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(std::fs::read(out_path).unwrap())
}

fn color_ot(tree: &ColorOcTree) -> Vec<u8> {
    let mut v = Vec::new();
    write_color_ot(tree, &mut v).unwrap();
    v
}

#[test]
fn random_color_sequences_match_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch("color_tree_diff_random");
    let compared = std::cell::Cell::new(0usize);
    let colored = std::cell::Cell::new(0usize);
    let aborted = std::cell::Cell::new(0usize);
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 200,
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&case_strategy(), |case| {
            let tree = apply_case(&case);
            let ot = color_ot(&tree);
            let Some(rot) = try_reference(&refprog, &script_for(&case), &dir) else {
                aborted.set(aborted.get() + 1);
                return Ok(());
            };
            compared.set(compared.get() + 1);
            if tree.num_colored_nodes() > 0 {
                colored.set(colored.get() + 1);
            }
            prop_assert!(ot == rot, ".ot differs: {}", first_diff(&ot, &rot));
            // our reader takes OctoMap's file back to the same bytes
            let back = read_color_ot(&rot[..]).unwrap();
            prop_assert!(color_ot(&back) == rot);
            Ok(())
        })
        .unwrap();
    assert!(
        compared.get() >= 4 * aborted.get() && compared.get() >= 120,
        "compared {} cases, reference aborted on {}",
        compared.get(),
        aborted.get()
    );
    assert!(
        colored.get() * 2 >= compared.get(),
        "only {} of {} compared trees had a colour",
        colored.get(),
        compared.get()
    );
}

/// The coloured points of PCL's table scene (x y z and the packed `rgba`, NaN pixels dropped).
fn table_scene_points(path: &Path) -> Vec<([f32; 3], Color)> {
    let cloud = read_pcd_cloud(path).unwrap();
    let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["x", "y", "z", "rgba"], "{}", path.display());
    // binary_compressed: after the DATA line, u32 compressed size, u32 raw size, LZF data,
    // field-major (all x, all y, all z, all rgba)
    let bytes = std::fs::read(path).unwrap();
    let tag = b"DATA binary_compressed\n";
    let at = bytes
        .windows(tag.len())
        .position(|w| w == tag)
        .expect("a binary_compressed PCD")
        + tag.len();
    let word = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    let (packed, raw) = (word(at), word(at + 4));
    let data = lzf_decompress(&bytes[at + 8..at + 8 + packed], raw).unwrap();
    let n = cloud.points.len();
    assert_eq!(data.len(), 16 * n);
    let field = |f: usize, i: usize| {
        let o = 4 * (f * n + i);
        [data[o], data[o + 1], data[o + 2], data[o + 3]]
    };
    let mut out = Vec::new();
    for (i, p) in cloud.points.iter().enumerate() {
        let xyz = [0, 1, 2].map(|f| f32::from_le_bytes(field(f, i)));
        if xyz.iter().any(|v| v.is_nan()) {
            continue;
        }
        assert_eq!(f64::from(xyz[0]), p.x);
        // PCL packs rgba as 0xAARRGGBB: little-endian bytes b, g, r, a
        let [b, g, r, _a] = field(3, i);
        out.push((xyz, Color::new(r, g, b)));
    }
    out
}

#[test]
fn real_colored_points_match_octomap() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some(pcd) = common::data_file(
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ) else {
        return;
    };
    let points = table_scene_points(&pcd);
    assert_eq!(points.len(), 209_280);
    let dir = common::scratch("color_tree_diff_real");
    let mut file = Vec::with_capacity(4 + 16 * points.len());
    file.extend_from_slice(&(points.len() as u32).to_le_bytes());
    for (p, c) in &points {
        for v in p {
            file.extend_from_slice(&v.to_le_bytes());
        }
        file.extend_from_slice(&[c.r, c.g, c.b, 0]);
    }
    let pts = dir.join("points.bin");
    std::fs::write(&pts, file).unwrap();

    for (res, lazy) in [(0.01, false), (0.005, true)] {
        let mut tree = ColorOcTree::new(res).unwrap();
        let inner = InnerNodes::from_lazy(lazy);
        for (p, c) in &points {
            let pt = nalgebra::Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
            let Ok(key) = tree.converter().point_to_key_checked(&pt) else {
                continue;
            };
            tree.update_node(key, Update::Hit, inner);
            tree.integrate_node_color(key, *c);
        }
        tree.update_inner_occupancy();
        let stage1 = color_ot(&tree);
        tree.to_max_likelihood();
        tree.prune();
        let stage2 = color_ot(&tree);
        assert!(
            tree.num_colored_nodes() > 10_000,
            "{} coloured nodes",
            tree.num_colored_nodes()
        );

        let script = format!(
            "tree {res:.17e}\npoints {} {}\ninner\nwrite_ot {}\nml\nprune\n",
            pts.display(),
            lazy as u8,
            dir.join("stage1.ot").display()
        );
        let rot2 = try_reference(&refprog, &script, &dir).expect("no delete here");
        let rot1 = std::fs::read(dir.join("stage1.ot")).unwrap();
        assert!(
            stage1 == rot1,
            "res {res}: .ot after the points differs: {}",
            first_diff(&stage1, &rot1)
        );
        assert!(
            stage2 == rot2,
            "res {res}: .ot after ml + prune differs: {}",
            first_diff(&stage2, &rot2)
        );

        // OctoMap reads our file and writes it back unchanged
        let ours = dir.join("ours.ot");
        std::fs::write(&ours, &stage2).unwrap();
        let script = format!("read_ot {}\n", ours.display());
        let again = try_reference(&refprog, &script, &dir).unwrap();
        assert!(again == stage2, "{}", first_diff(&again, &stage2));
    }
}

#[test]
fn color_ot_rejects_plain_trees_and_damage() {
    let mut t = ColorOcTree::new(0.1).unwrap();
    t.update_node(Key::new(5, 5, 5), Update::Hit, InnerNodes::Refresh);
    t.set_node_color(Key::new(5, 5, 5), Color::new(1, 2, 3));
    let bytes = color_ot(&t);
    // every truncation is an error, never a panic or a partial tree
    for cut in 0..bytes.len() {
        assert!(read_color_ot(&bytes[..cut]).is_err(), "cut at {cut}");
    }
    // a plain OcTree file is a different tree type
    let tag = b"id ColorOcTree";
    let at = bytes.windows(tag.len()).position(|w| w == tag).unwrap();
    let plain = [&bytes[..at], b"id OcTree", &bytes[at + tag.len()..]].concat();
    match read_color_ot(&plain[..]) {
        Err(OctreeError::WrongTreeType { id, expected }) => {
            assert_eq!((id.as_str(), expected), ("OcTree", "ColorOcTree"))
        }
        other => panic!("{other:?}"),
    }
    // and a plain reader refuses a colour file
    let err = octoquant::octree::io::read_ot(&bytes[..])
        .unwrap_err()
        .to_string();
    assert!(err.contains("ColorOcTree"), "{err}");
}

/// Write `frames` for the reference program: the `.frames` file and the colour side file
/// (`u32` frame count, per frame `u32` n and n × `r g b`).
fn write_colored_frames(dir: &Path, frames: &[octoquant::Frame]) -> (PathBuf, PathBuf) {
    let fp = dir.join("scans.frames");
    octoquant::formats::frames::write_frames_file(&fp, frames).unwrap();
    let mut c = Vec::new();
    c.extend_from_slice(&(frames.len() as u32).to_le_bytes());
    for f in frames {
        let colors = f.colors.as_ref().expect("coloured frames");
        c.extend_from_slice(&(colors.len() as u32).to_le_bytes());
        for col in colors {
            c.extend_from_slice(&col.to_array());
        }
    }
    let cp = dir.join("scans.colors");
    std::fs::write(&cp, c).unwrap();
    (fp, cp)
}

/// Coloured scans inserted as octomap_server's colour server does (colours merged before each
/// scan's updates, then the scan, then prune), by `ColorMapper` and by liboctomap's
/// `ColorOcTree` in the reference program: the `.ot` bytes are equal, for both merge rules,
/// without and with octomap_server's maximum range `max_range` (which must cut some rays).
fn check_colored_scans(name: &str, frames: &[octoquant::Frame], res: f64, max_range: f64) {
    let beyond = frames
        .iter()
        .flat_map(|f| {
            f.points
                .iter()
                .map(move |p| (p - f.origin).cast::<f64>().norm())
        })
        .filter(|d| *d > max_range)
        .count();
    let points: usize = frames.iter().map(|f| f.points.len()).sum();
    assert!(
        beyond > 1000 && beyond < points / 2,
        "{name}: {beyond} of {points} points beyond {max_range} m"
    );
    for range in [None, Some(max_range)] {
        check_colored_scans_with(name, frames, res, range);
    }
}

fn check_colored_scans_with(
    name: &str,
    frames: &[octoquant::Frame],
    res: f64,
    max_range: Option<f64>,
) {
    use octoquant::color_map::{ColorMapper, ColorMerge};
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let dir = common::scratch(name);
    let (fp, cp) = write_colored_frames(&dir, frames);
    for merge in [ColorMerge::Average, ColorMerge::Integrate] {
        let options = octoquant::MapperOptions {
            resolution: res,
            max_range,
            ..octoquant::MapperOptions::default()
        };
        let mut mapper = ColorMapper::new(options, merge).unwrap();
        for f in frames {
            mapper.insert(f).unwrap();
        }
        let tree = mapper.into_tree();
        // the cut rays colour nothing
        let least = if max_range.is_some() { 500 } else { 1000 };
        assert!(
            tree.num_colored_nodes() > least,
            "{name} {merge:?} max range {max_range:?}: {} coloured nodes",
            tree.num_colored_nodes()
        );
        let ours = color_ot(&tree);
        let script = format!(
            "tree {res:.17e}\ncolorscan {} {} {} {:.17e}\n",
            fp.display(),
            cp.display(),
            merge.name(),
            max_range.unwrap_or(-1.0)
        );
        let theirs = try_reference(&refprog, &script, &dir).expect("no delete here");
        assert!(
            ours == theirs,
            "{name} {merge:?} max range {max_range:?}: .ot differs from octomap_server's: {}",
            first_diff(&ours, &theirs)
        );
    }
}

/// The first four TUM RGB-D frames (every second pixel) with the colours of their registered
/// RGB images; `None` without the data.
fn tum_colored_frames() -> Option<Vec<octoquant::Frame>> {
    let assoc = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")?;
    let mut options = octoquant::formats::ReadOptions {
        colors: true,
        ..octoquant::formats::ReadOptions::default()
    };
    options.tum.pixel_step = 2;
    let frames = octoquant::formats::frame_stream(&assoc, &options)
        .unwrap()
        .take(4)
        .collect::<Result<_, _>>()
        .unwrap();
    Some(frames)
}

/// Four TUM RGB-D frames (every second pixel) with the colours of their registered RGB images.
#[test]
fn tum_rgbd_colored_scans_match_octomap_server() {
    let Some(frames) = tum_colored_frames() else {
        return;
    };
    check_colored_scans("color_scans_tum", &frames, 0.05, 4.0);
}

/// OctoMap's `insertPointCloud` on a `ColorOcTree` that already holds colours (two TUM frames
/// inserted as octomap_server's colour server does), then two more frames by
/// `color_map::insert_point_cloud` and by liboctomap's `ColorOcTree::insertPointCloud` in the
/// reference program: the `.ot` bytes are equal, plainly, with a maximum range that cuts
/// rays, lazily (no inner-node upkeep) and with `discretize`. The colours move with the
/// structure only, so they are equal only when every miss and hit comes in OctoMap's
/// `KeySet` order: in Morton order the colours of this case differ (checked below).
#[test]
fn tum_point_clouds_into_a_coloured_tree_match_octomap() {
    use octoquant::color_map::{insert_point_cloud, ColorMapper, ColorMerge};
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some(frames) = tum_colored_frames() else {
        return;
    };
    // the coloured frames go in this many times, so that many voxels reach the clamp and
    // the plain frames' updates prune (and expand again) nodes with coloured children
    const REPEAT: usize = 4;
    let dir = common::scratch("color_tree_point_clouds");
    let (fp, cp) = write_colored_frames(&dir, &frames[..2]);
    let plain: Vec<octoquant::Frame> = frames[2..]
        .iter()
        .map(|f| octoquant::Frame {
            colors: None,
            ..f.clone()
        })
        .collect();
    let pp = dir.join("plain.frames");
    octoquant::formats::frames::write_frames_file(&pp, &plain).unwrap();
    let coloured = || {
        let options = octoquant::MapperOptions {
            resolution: 0.05,
            ..octoquant::MapperOptions::default()
        };
        let mut mapper = ColorMapper::new(options, ColorMerge::Average).unwrap();
        for _ in 0..REPEAT {
            for f in &frames[..2] {
                mapper.insert(f).unwrap();
            }
        }
        mapper.into_tree()
    };
    let base = coloured();
    assert!(
        base.num_colored_nodes() > 1000,
        "{}",
        base.num_colored_nodes()
    );
    for (max_range, lazy, discretize) in [
        (None, false, false),
        (Some(2.5), false, false),
        (None, true, false),
        (None, false, true),
    ] {
        let mut tree = base.clone();
        let mut counts = (0, 0);
        for f in &plain {
            let (free, occupied) = insert_point_cloud(
                &mut tree,
                &f.points,
                &f.origin,
                max_range,
                InnerNodes::from_lazy(lazy),
                discretize,
            );
            counts = (counts.0 + free, counts.1 + occupied);
        }
        assert!(counts.0 > 10_000 && counts.1 > 1000, "{counts:?}");
        let ours = color_ot(&tree);
        let mut options = String::new();
        if let Some(m) = max_range {
            write!(options, " maxrange {m:.17e}").unwrap();
        }
        if lazy {
            options.push_str(" lazy");
        }
        if discretize {
            options.push_str(" discretize");
        }
        let scan = format!("colorscan {} {} average\n", fp.display(), cp.display());
        let script = format!(
            "tree 5e-2\n{}insert {}{options}\n",
            scan.repeat(REPEAT),
            pp.display()
        );
        let theirs = try_reference(&refprog, &script, &dir).expect("no delete here");
        assert!(
            ours == theirs,
            "max range {max_range:?}, lazy {lazy}, discretize {discretize}: .ot differs from \
             OctoMap's: {}",
            first_diff(&ours, &theirs)
        );
        if (max_range, lazy, discretize) == (None, false, false) {
            // the same updates in Morton order: same occupancy, other colours
            let mut sorted = base.clone();
            for f in &plain {
                let mut update = octoquant::raycast::ScanUpdate::new();
                octoquant::raycast::compute_scan_update_f32(
                    sorted.converter(),
                    &f.points,
                    &f.origin,
                    &octoquant::raycast::InsertOptions::default(),
                    &mut update,
                );
                for (keys, u) in [
                    (update.free().to_vec(), Update::Miss),
                    (update.occupied().to_vec(), Update::Hit),
                ] {
                    for k in keys {
                        sorted.update_node(k, u, InnerNodes::Refresh);
                    }
                }
            }
            assert!(
                color_ot(&sorted) != ours,
                "the update order does not change this case's colours"
            );
        }
    }
}

/// The rays of a colour scan are walked in stretches on the rayon threads, and
/// `insert_stream` walks a frame's rays while the frame before goes into the tree; the map
/// depends on neither: one thread and three, frame by frame or streamed, give the same `.ot`
/// bytes, with cut rays (a maximum range) and without, and the map is not empty.
#[test]
fn colored_scans_are_the_same_on_any_thread_count() {
    use octoquant::color_map::{ColorMapper, ColorMerge};
    let Some(frames) = tum_colored_frames() else {
        return;
    };
    for max_range in [None, Some(4.0)] {
        let build = |threads: usize, stream: bool| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let options = octoquant::MapperOptions {
                    resolution: 0.05,
                    max_range,
                    ..octoquant::MapperOptions::default()
                };
                let mut mapper = ColorMapper::new(options, ColorMerge::Average).unwrap();
                if stream {
                    let frames = frames
                        .iter()
                        .map(Ok::<_, octoquant::color_map::ColorMapError>);
                    mapper.insert_stream(frames, |_, _| Ok(())).unwrap();
                } else {
                    for f in &frames {
                        mapper.insert(f).unwrap();
                    }
                }
                mapper.into_tree()
            })
        };
        let one = build(1, false);
        assert!(one.num_colored_nodes() > 500, "{}", one.num_colored_nodes());
        for (threads, stream) in [(3, false), (1, true), (3, true)] {
            assert!(
                color_ot(&one) == color_ot(&build(threads, stream)),
                "max range {max_range:?}: {threads} threads, streamed {stream}, differ from one thread"
            );
        }
    }
}

/// octoquant's z band filter with `ColorMapper` equals octomap_server's insertion of the
/// frames filtered here by hand (points and their colours kept together), on the TUM frames.
#[test]
fn tum_rgbd_colored_scans_with_a_z_band_match_octomap_server_on_the_band() {
    use octoquant::color_map::{ColorMapper, ColorMerge};
    let Some(frames) = tum_colored_frames() else {
        return;
    };
    let Some(refprog) = common::reference_program() else {
        return;
    };
    // the band between the quartiles of the heights
    let mut z: Vec<f32> = frames
        .iter()
        .flat_map(|f| f.points.iter().map(|p| p.z))
        .filter(|z| z.is_finite())
        .collect();
    z.sort_by(f32::total_cmp);
    let (lo, hi) = (z[z.len() / 4], z[3 * z.len() / 4]);
    let inside =
        |p: &nalgebra::Point3<f32>| p.iter().all(|v| v.is_finite()) && p.z >= lo && p.z <= hi;
    let by_hand: Vec<octoquant::Frame> = frames
        .iter()
        .map(|f| {
            let colors = f.colors.as_ref().unwrap();
            let keep: Vec<usize> = (0..f.points.len())
                .filter(|&i| inside(&f.points[i]))
                .collect();
            octoquant::Frame {
                colors: Some(keep.iter().map(|&i| colors[i]).collect()),
                ..octoquant::Frame::new_f32(f.origin, keep.iter().map(|&i| f.points[i]).collect())
            }
        })
        .collect();
    let dir = common::scratch("color_scans_z_band");
    let (fp, cp) = write_colored_frames(&dir, &by_hand);
    let mut mapper = ColorMapper::new(
        octoquant::MapperOptions {
            resolution: 0.05,
            filters: octoquant::filters::PointFilters {
                z_min: Some(f64::from(lo)),
                z_max: Some(f64::from(hi)),
                ..Default::default()
            },
            ..octoquant::MapperOptions::default()
        },
        ColorMerge::Average,
    )
    .unwrap();
    let mut dropped = 0;
    for f in &frames {
        dropped += mapper.insert(f).unwrap().dropped.z_band;
    }
    let total: usize = frames.iter().map(|f| f.points.len()).sum();
    let kept: usize = by_hand.iter().map(|f| f.points.len()).sum();
    assert!(
        kept > total / 4 && dropped > total / 4,
        "{kept} kept, {dropped} dropped of {total}"
    );
    let tree = mapper.into_tree();
    assert!(
        tree.num_colored_nodes() > 500,
        "{}",
        tree.num_colored_nodes()
    );
    let ours = color_ot(&tree);
    let script = format!(
        "tree {:.17e}\ncolorscan {} {} average\n",
        0.05,
        fp.display(),
        cp.display()
    );
    let theirs = try_reference(&refprog, &script, &dir).expect("no delete here");
    assert!(
        ours == theirs,
        ".ot differs: {}",
        first_diff(&ours, &theirs)
    );
}

/// PCL's textured table scene seen three times from three nearby origins (the first sighting
/// gives no colour in octomap_server; the later ones merge into existing voxels).
#[test]
fn table_scene_colored_scans_match_octomap_server() {
    let Some(pcd) = common::data_file(
        "pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd",
    ) else {
        return;
    };
    let options = octoquant::formats::ReadOptions {
        colors: true,
        ..octoquant::formats::ReadOptions::default()
    };
    let base = octoquant::formats::read_frames(&pcd, &options)
        .unwrap()
        .remove(0);
    let frames: Vec<octoquant::Frame> = [0.0f32, 0.013, -0.021]
        .iter()
        .map(|&dx| octoquant::Frame {
            origin: nalgebra::Point3::new(dx, -dx, 0.0),
            ..base.clone()
        })
        .collect();
    check_colored_scans("color_scans_table", &frames, 0.02, 1.3);
}

/// Run the reference program's `mode` on `script` (no trailing write); fails on error.
fn run_reference(refprog: &Path, mode: &str, script: &str, dir: &Path) {
    let sp = dir.join("cli_ops.txt");
    std::fs::write(&sp, script).unwrap();
    let out = Command::new(refprog).arg(mode).arg(&sp).output().unwrap();
    assert!(
        out.status.success(),
        "reference program failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn octoquant_cli(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

/// `map --color` writes the tree `ColorMapper` builds from the same frames; `.bt` and
/// colourless inputs are refused with a clear error; `info`, `convert`, `export` and `render`
/// take the coloured map: the `.bt` conversion equals liboctomap's `writeBinary` of the same
/// ColorOcTree, the exports carry each leaf's colour.
#[test]
fn map_color_and_the_tools_on_a_colored_map() {
    use octoquant::color_map::{ColorMapper, ColorMerge};
    let Some(assoc) = common::data_file("rgbd/tum_fr2_pioneer_slam2_subset/my_association.txt")
    else {
        return;
    };
    let dir = common::scratch("color_cli");
    let a = assoc.to_str().unwrap();
    let run = |args: &[&str]| octoquant_cli(&dir, args);
    let o = run(&[
        "map",
        a,
        "--pixel-step",
        "4",
        "--res",
        "0.1",
        "--color",
        "--color-merge",
        "integrate",
        "-q",
        "-o",
        "m.ot",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cli = std::fs::read(dir.join("m.ot")).unwrap();
    let mut options = octoquant::formats::ReadOptions {
        colors: true,
        ..octoquant::formats::ReadOptions::default()
    };
    options.tum.pixel_step = 4;
    let mut mapper = ColorMapper::new(
        octoquant::MapperOptions {
            resolution: 0.1,
            ..octoquant::MapperOptions::default()
        },
        ColorMerge::Integrate,
    )
    .unwrap();
    for f in octoquant::formats::frame_stream(&assoc, &options).unwrap() {
        mapper.insert(&f.unwrap()).unwrap();
    }
    let tree = mapper.into_tree();
    assert!(tree.num_colored_nodes() > 1000);
    assert!(
        cli == color_ot(&tree),
        "{}",
        first_diff(&cli, &color_ot(&tree))
    );

    // refusals: a .bt output, an input without colour
    let o = run(&["map", a, "--color", "-o", "m.bt"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains(".ot"), "{e}");
    assert!(!dir.join("m.bt").exists());
    let ply = dir.join("plain.ply");
    octoquant::formats::ply::write_ply_file(
        &ply,
        &[nalgebra::Point3::new(1.0f32, 0.0, 0.0)],
        octoquant::formats::ply::PlyEncoding::Ascii,
    )
    .unwrap();
    let o = run(&["map", "plain.ply", "--color", "-o", "p.ot"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("no colours"), "{e}");

    // info names the type
    let o = run(&["info", "m.ot", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["type"], "ColorOcTree");
    assert_eq!(j["colored_nodes"], tree.num_colored_nodes());

    // convert: .ot keeps the colours, .bt is OctoMap's writeBinary of the ColorOcTree
    let o = run(&["convert", "m.ot", "again.ot"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(dir.join("again.ot")).unwrap() == cli);
    let o = run(&["convert", "m.ot", "m_conv.bt"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    if let Some(refprog) = common::reference_program() {
        run_reference(
            &refprog,
            "color-script",
            &format!(
                "read_ot {}\nwrite_bt {}\n",
                dir.join("m.ot").display(),
                dir.join("ref.bt").display()
            ),
            &dir,
        );
        let ours = std::fs::read(dir.join("m_conv.bt")).unwrap();
        let theirs = std::fs::read(dir.join("ref.bt")).unwrap();
        assert!(ours == theirs, "{}", first_diff(&ours, &theirs));
    }
    // that .bt (id ColorOcTree) reads back as occupancy, as OctoMap's readBinary reads it
    let o = run(&["info", "m_conv.bt", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // export: each occupied leaf's vertex carries its colour (height colour when unset)
    let o = run(&["export", "m.ot", "-o", "m.ply"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(dir.join("m.ply")).unwrap();
    let (pts, cols) =
        octoquant::formats::ply::parse_ply_colored(Path::new("m.ply"), &bytes, true).unwrap();
    let cols = cols.expect("coloured vertices");
    let conv = tree.converter();
    let mut matched = 0;
    for (p, c) in pts.iter().zip(&cols) {
        let key = conv.point_to_key(&p.cast::<f64>()).unwrap();
        let node = tree.node_color(key).unwrap();
        if node.is_set() {
            assert_eq!(*c, node, "vertex {p:?}");
            matched += 1;
        }
    }
    assert!(matched > 500, "{matched} coloured vertices");
    let o = run(&["export", "m.ot", "-o", "m.pcd"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let back = octoquant::formats::read_frames(
        &dir.join("m.pcd"),
        &octoquant::formats::ReadOptions {
            colors: true,
            ..octoquant::formats::ReadOptions::default()
        },
    )
    .unwrap();
    let pcols = back[0].colors.as_ref().expect("rgb field");
    for (p, c) in back[0].points.iter().zip(pcols) {
        let key = conv.point_to_key(&p.cast::<f64>()).unwrap();
        assert_eq!(*c, tree.node_color(key).unwrap(), "voxel {p:?}");
    }

    // render draws voxel colours: another picture than the occupancy's
    let o = run(&["render", "m.ot", "-o", "c.png", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&["render", "m_conv.bt", "-o", "h.png"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(dir.join("c.png")).unwrap() != std::fs::read(dir.join("h.png")).unwrap());
}

/// `info` and `convert` take an OcTreeStamped `.ot`: the `.bt` conversion equals liboctomap's
/// `writeBinary` of the tree it reads.
#[test]
fn info_and_convert_take_a_stamped_tree() {
    use octoquant::octree::io::write_stamped_ot;
    use octoquant::octree::StampedOcTree;
    let dir = common::scratch("stamped_cli");
    let mut t = StampedOcTree::new(0.1).unwrap();
    let mut seed = 7u64;
    for i in 0..4000u32 {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let r = (seed >> 33) as u16;
        let k = Key::new(
            32768 + (r & 15),
            32768 + ((r >> 4) & 15),
            32768 + ((r >> 8) & 7),
        );
        let u = if r >> 15 == 0 {
            Update::Hit
        } else {
            Update::Miss
        };
        t.update_node_at(k, u, InnerNodes::Refresh, 100 + i / 500);
    }
    let mut bytes = Vec::new();
    write_stamped_ot(&t, &mut bytes).unwrap();
    std::fs::write(dir.join("s.ot"), &bytes).unwrap();
    let o = octoquant_cli(&dir, &["info", "s.ot", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["type"], "OcTreeStamped");
    assert_eq!(j["nodes"], t.size());
    let o = octoquant_cli(&dir, &["convert", "s.ot", "s2.ot"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(dir.join("s2.ot")).unwrap() == bytes);
    let o = octoquant_cli(&dir, &["convert", "s.ot", "s.bt"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let Some(refprog) = common::reference_program() else {
        return;
    };
    run_reference(
        &refprog,
        "stamped-script",
        &format!(
            "read_ot {}\nwrite_bt {}\n",
            dir.join("s.ot").display(),
            dir.join("ref.bt").display()
        ),
        &dir,
    );
    let ours = std::fs::read(dir.join("s.bt")).unwrap();
    let theirs = std::fs::read(dir.join("ref.bt")).unwrap();
    assert!(ours == theirs, "{}", first_diff(&ours, &theirs));
}
