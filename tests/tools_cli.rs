//! `octoquant query` and `octoquant export -o OUT.pcd` on a real map (OctoMap's scan.dat at
//! 0.1 m, as graph2tree built it): rays against OctoMap's own `castRay` through the project's
//! reference program, point look-ups against a table of every leaf, and the PCD export read
//! back by our PCD reader against the map's occupied voxels.

use crate::common::{self, scratch};
use nalgebra::Point3;
use octoquant::octree::TREE_DEPTH;
use octoquant::treefile::read_tree_file;
use octoquant::OcTree;
use std::collections::HashMap;
use std::process::Command;

/// SplitMix64: the same rays every run.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [lo, hi), rounded to f32 (so that text round trips are exact).
    fn f(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next() >> 11) as f64 / (1u64 << 53) as f64;
        f64::from((lo + (hi - lo) * u) as f32)
    }
}

fn octoquant(args: &[&dyn AsRef<std::ffi::OsStr>]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn real_map() -> Option<(std::path::PathBuf, OcTree)> {
    let map = common::data_file("octomap_reference/expected/scan_r01.bt")?;
    let tree = read_tree_file(&map).unwrap();
    Some((map, tree))
}

/// Every leaf by (depth, smallest key): what a look-up must find, without descending.
fn leaf_table(tree: &OcTree) -> HashMap<(u8, [u16; 3]), f32> {
    tree.leaves()
        .map(|l| ((l.depth, l.min_key().0), l.value))
        .collect()
}

#[test]
fn query_points_match_a_table_of_every_leaf() {
    let Some((map, tree)) = real_map() else {
        return;
    };
    let dir = scratch("query_points");
    let table = leaf_table(&tree);
    let (lo, hi) = tree.metric_bounds().unwrap();
    let mut rng = Rng(7);
    let mut points: Vec<[f64; 3]> = (0..3000)
        .map(|_| [0, 1, 2].map(|a| rng.f(lo[a] - 1.0, hi[a] + 1.0)))
        .collect();
    // leaf centres and corners too (borders land where OctoMap's float keys put them)
    for l in tree.leaves().step_by(97) {
        let c = tree.converter().key_to_point_at_depth(&l.key, l.depth);
        points.push([c.x, c.y, c.z]);
        let m = tree.converter().key_to_point(&l.min_key());
        let h = tree.resolution() / 2.0;
        points.push([m.x - h, m.y - h, m.z - h]);
    }
    let file = dir.join("points.txt");
    let text: String = points
        .iter()
        .map(|p| format!("{} {} {}\n", p[0], p[1], p[2]))
        .collect();
    std::fs::write(&file, format!("# x y z\n{text}")).unwrap();
    let out = octoquant(&[
        &"query",
        &map,
        &"--points",
        &file,
        &"--at",
        &"0.05",
        &"0.05",
        &"0.05",
    ]);
    let found = out["points"].as_array().unwrap();
    assert_eq!(found.len(), points.len() + 1);
    let mut classes = HashMap::new();
    for (i, q) in found.iter().enumerate() {
        let p = if i == 0 { [0.05; 3] } else { points[i - 1] };
        let pf = Point3::new(p[0] as f32, p[1] as f32, p[2] as f32);
        let want = tree
            .converter()
            .point_to_key(&pf.cast::<f64>())
            .and_then(|k| {
                (0..=TREE_DEPTH).rev().find_map(|d| {
                    let shift = TREE_DEPTH - d;
                    let min = k.0.map(|c| ((u32::from(c) >> shift) << shift) as u16);
                    table.get(&(d, min)).map(|v| (d, *v))
                })
            });
        let class = q["class"].as_str().unwrap();
        *classes.entry(class.to_string()).or_insert(0) += 1;
        match want {
            None => {
                assert_eq!(class, "unknown", "{p:?}: {q}");
                assert!(q["depth"].is_null() && q["probability"].is_null(), "{q}");
            }
            Some((d, v)) => {
                let expected = if tree.params().is_occupied(v) {
                    "occupied"
                } else {
                    "free"
                };
                assert_eq!(class, expected, "{p:?}: {q}");
                assert_eq!(q["depth"].as_u64(), Some(u64::from(d)), "{p:?}: {q}");
                assert_eq!(q["log_odds"].as_f64(), Some(f64::from(v)), "{p:?}: {q}");
                let prob = 1.0 - 1.0 / (1.0 + f64::from(v).exp());
                assert!((q["probability"].as_f64().unwrap() - prob).abs() < 1e-12);
            }
        }
    }
    // all three classes and pruned leaves were seen
    assert!(classes.len() == 3, "{classes:?}");
    assert!(found
        .iter()
        .any(|q| q["depth"].as_u64().is_some_and(|d| d < 16)));
}

#[test]
fn query_rays_match_octomap_cast_ray() {
    let Some(refprog) = common::reference_program() else {
        return;
    };
    let Some((map, tree)) = real_map() else {
        return;
    };
    let dir = scratch("query_rays");
    let (lo, hi) = tree.metric_bounds().unwrap();
    let mut rng = Rng(11);
    let mut rays = Vec::new();
    for i in 0..1500 {
        // most from the scan's origin region (known free space), some from anywhere
        let o = if i % 3 == 0 {
            [0, 1, 2].map(|a| rng.f(lo[a], hi[a]))
        } else {
            [rng.f(-0.5, 0.5), rng.f(-0.5, 0.5), rng.f(-0.2, 0.5)]
        };
        let d = [rng.f(-1.0, 1.0), rng.f(-1.0, 1.0), rng.f(-0.3, 0.3)];
        rays.push((o, d));
    }
    let text: String = rays
        .iter()
        .map(|(o, d)| format!("{} {} {} {} {} {}\n", o[0], o[1], o[2], d[0], d[1], d[2]))
        .collect();
    let file = dir.join("rays.txt");
    std::fs::write(&file, text).unwrap();
    for (ignore_unknown, max_range) in [(false, -1.0), (true, 15.0), (true, -1.0)] {
        // the reference program: u32 n, per ray f32 origin[3], f32 direction[3],
        // u8 ignore_unknown, f64 max_range; back: u8 hit, f32 end[3]
        let mut input = (rays.len() as u32).to_le_bytes().to_vec();
        for (o, d) in &rays {
            for v in o.iter().chain(d) {
                input.extend_from_slice(&(*v as f32).to_le_bytes());
            }
            input.push(u8::from(ignore_unknown));
            input.extend_from_slice(&f64::to_le_bytes(max_range));
        }
        let (inp, outp) = (dir.join("cast.in"), dir.join("cast.out"));
        std::fs::write(&inp, input).unwrap();
        let st = Command::new(&refprog)
            .arg("castray")
            .arg(&map)
            .arg(&inp)
            .arg(&outp)
            .status()
            .unwrap();
        assert!(st.success());
        let theirs = std::fs::read(&outp).unwrap();
        let mr = max_range.to_string();
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
            vec![&"query", &map, &"--rays", &file, &"--max-range", &mr];
        if ignore_unknown {
            args.push(&"--ignore-unknown");
        }
        let ours = octoquant(&args);
        let ours = ours["rays"].as_array().unwrap();
        assert_eq!(ours.len(), rays.len());
        let mut hits = 0;
        for (i, r) in ours.iter().enumerate() {
            let rec = &theirs[i * 13..(i + 1) * 13];
            let hit = rec[0] == 1;
            let end: Vec<f32> = (0..3)
                .map(|a| f32::from_le_bytes(rec[1 + 4 * a..5 + 4 * a].try_into().unwrap()))
                .collect();
            assert_eq!(r["hit"].as_bool(), Some(hit), "ray {i} {:?}: {r}", rays[i]);
            // OctoMap leaves `end` untouched (zero here) when it returns before walking
            let my_end: Vec<f32> = match r["end"].as_array() {
                Some(e) => e.iter().map(|v| v.as_f64().unwrap() as f32).collect(),
                None => vec![0.0; 3],
            };
            assert_eq!(
                my_end.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                end.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "ray {i} {:?}: {r}, OctoMap's end {end:?}",
                rays[i]
            );
            hits += usize::from(hit);
        }
        assert!(hits > 100 && hits < rays.len(), "{hits} hits");
    }
}

#[test]
fn pcd_export_holds_every_occupied_voxel_centre() {
    let Some((map, tree)) = real_map() else {
        return;
    };
    let dir = scratch("export_pcd");
    let out = dir.join("occupied.pcd");
    let summary = octoquant(&[&"export", &map, &"-o", &out]);
    let cloud = octoquant::formats::pcd::read_pcd_cloud(&out).unwrap();
    // the oracle: every voxel of every occupied leaf, block by block
    let mut want: Vec<[u32; 3]> = Vec::new();
    for l in tree.leaves().filter(|l| tree.params().is_occupied(l.value)) {
        let (min, w) = (l.min_key().0, l.width() as u16);
        for dz in 0..w {
            for dy in 0..w {
                for dx in 0..w {
                    let k = octoquant::Key([min[0] + dx, min[1] + dy, min[2] + dz]);
                    let c = tree.converter().key_to_point_f32(&k);
                    want.push([c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]);
                }
            }
        }
    }
    assert!(tree
        .leaves()
        .any(|l| l.depth < 16 && tree.params().is_occupied(l.value)));
    let got: Vec<[u32; 3]> = cloud
        .points
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32].map(f32::to_bits))
        .collect();
    assert_eq!(summary["points"].as_u64(), Some(want.len() as u64));
    assert_eq!((cloud.width, cloud.height), (want.len() as u64, 1));
    // the file lists the leaves' voxels in the tree's order; as sets they are the oracle's
    let (mut g, mut w) = (got.clone(), want.clone());
    g.sort_unstable();
    w.sort_unstable();
    assert_eq!(g, w);
    // and each voxel once, at depth 16: the points are the voxels' exact centres
    g.dedup();
    assert_eq!(g.len(), got.len());
    // the header is octree2pointcloud's
    let text = std::fs::read_to_string(&out).unwrap();
    let n = want.len();
    assert!(text.starts_with(&format!(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\n\
         HEIGHT 1\nVIEWPOINT 0 0 0 0 0 0 1\nPOINTS {n}\nDATA ascii\n"
    )));
    // --free makes no sense for PCD: refused before anything is written
    let bad = dir.join("free.pcd");
    let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args([
            "export".as_ref(),
            map.as_os_str(),
            "-o".as_ref(),
            bad.as_os_str(),
            "--free".as_ref(),
        ])
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(!bad.exists());
}
