//! `octoquant compare` against OctoMap's own `compare_octrees` (Debian octomap-tools) on real
//! maps: the same divergence (the tool prints six significant digits), the same refusal of
//! maps that know different voxels, and class counts that add up.

use crate::common::{self, scratch};
use std::path::{Path, PathBuf};
use std::process::Command;

fn octoquant(args: &[&Path]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("compare")
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

/// `compare_octrees A B`'s KLD, or `None` when it refuses the pair.
fn compare_octrees(a: &Path, b: &Path) -> Option<f64> {
    let out = Command::new("compare_octrees")
        .arg(a)
        .arg(b)
        .output()
        .expect("compare_octrees (apt-get install octomap-tools)");
    let text = String::from_utf8_lossy(&out.stdout);
    let kld = text
        .lines()
        .find_map(|l| l.strip_prefix("KLD: "))
        .map(|v| v.trim().parse::<f64>().unwrap());
    if kld.is_none() {
        assert!(
            !out.status.success(),
            "no KLD but success: {text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    kld
}

/// A map of `frames` at 0.1 m written as .ot (the format compare_octrees reads).
fn map_ot(frames: &Path, extra: &[&str], out: &Path) -> PathBuf {
    let st = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("map")
        .arg(frames)
        .args(["--res", "0.1", "--quiet", "-o"])
        .arg(out.with_extension("bt"))
        .arg("--ot")
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    out.to_path_buf()
}

#[test]
fn kld_and_refusals_match_compare_octrees_on_real_maps() {
    let (Some(sph), Some(sph_ml), Some(frames)) = (
        common::data_file("octomap_reference/expected/sph_r01.ot"),
        common::data_file("octomap_reference/expected/sph_r01_ml.ot"),
        common::data_file("octomap_reference/derived/scan.frames"),
    ) else {
        return;
    };
    let dir = scratch("compare_octrees");
    let plain = map_ot(&frames, &[], &dir.join("plain.ot"));
    let sensor = map_ot(
        &frames,
        &["--sensor", "0.45", "0.8"],
        &dir.join("sensor.ot"),
    );
    let clamped = map_ot(
        &frames,
        &["--clamping", "0.3", "0.8"],
        &dir.join("clamped.ot"),
    );
    let ranged = map_ot(&frames, &["--max-range", "5"], &dir.join("ranged.ot"));
    let mut defined = 0;
    for (a, b) in [
        (&sph, &sph_ml),
        (&sph_ml, &sph),
        (&sph, &sph),
        (&plain, &sensor),
        (&sensor, &clamped),
        (&clamped, &plain),
        (&plain, &ranged),
        (&ranged, &plain),
    ] {
        let ours = octoquant(&[a, b]);
        let theirs = compare_octrees(a, b);
        let what = format!("{} vs {}", a.display(), b.display());
        // the class counts add up, and changed voxels are those not agreeing
        let known = ours["known_in_either"].as_u64().unwrap();
        let agreeing = ours["agreeing"].as_u64().unwrap();
        assert_eq!(
            ours["changed_voxels"].as_u64().unwrap(),
            known - agreeing,
            "{what}"
        );
        match theirs {
            Some(kld) => {
                let mine = ours["kld"]
                    .as_f64()
                    .unwrap_or_else(|| panic!("{what}: {ours}"));
                // the tool prints six significant digits
                assert_eq!(format!("{mine:.5e}"), format!("{kld:.5e}"), "{what}");
                assert_eq!(ours["kld_note"], "compare_octrees' sum, in its order");
                defined += 1;
            }
            None => assert!(ours["kld"].is_null(), "{what}: {ours}"),
        }
    }
    // the sensor-model pairs and the sph pairs are defined, the max-range pairs are not
    assert_eq!(defined, 6);
}

/// `compare --png`: a real pair (the scan with and without a maximum range), every pixel's
/// colour checked against a voxel-by-voxel look-up of its column in both maps.
#[test]
fn png_colours_each_column_by_its_class_pairs() {
    let Some(frames) = common::data_file("octomap_reference/derived/scan.frames") else {
        return;
    };
    let dir = scratch("compare_png");
    let plain = map_ot(&frames, &[], &dir.join("plain.ot"));
    let ranged = map_ot(&frames, &["--max-range", "5"], &dir.join("ranged.ot"));
    let png_path = dir.join("diff.png");
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("compare")
        .args([&plain, &ranged, &png_path])
        .arg("--json")
        .output()
        .unwrap();
    // the third path is not an argument: the picture needs --png
    assert!(!out.status.success());
    let out = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("compare")
        .args([&plain, &ranged])
        .arg("--png")
        .arg(&png_path)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let png = &summary["png"];
    assert_eq!(png["columns_per_pixel"], 1, "{summary}");
    let decoder = png::Decoder::new(std::fs::File::open(&png_path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        (png["width"].as_u64(), png["height"].as_u64()),
        (Some(info.width.into()), Some(info.height.into()))
    );
    // the map sits in `map_area`; title and legend around it
    let area: Vec<u32> = png["map_area"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as u32)
        .collect();
    let (ax, ay, w, h) = (area[0], area[1], area[2], area[3]);
    assert!(
        ax + w < info.width && ay > 0 && ay + h <= info.height,
        "{area:?}"
    );
    let at = |x: u32, y: u32| {
        let i = (y as usize * info.width as usize + x as usize) * 3;
        [buf[i], buf[i + 1], buf[i + 2]]
    };
    let a = octoquant::treefile::read_tree_file(&plain).unwrap();
    let b = octoquant::treefile::read_tree_file(&ranged).unwrap();
    let conv = a.converter().clone();
    let res = a.resolution();
    let origin = [
        png["origin"][0].as_f64().unwrap(),
        png["origin"][1].as_f64().unwrap(),
    ];
    let key_of = |c: f64| {
        conv.point_to_key(&nalgebra::Point3::new(c, 0.0, 0.0))
            .unwrap()[0]
    };
    let (x0, y0) = (key_of(origin[0] + res / 2.0), key_of(origin[1] + res / 2.0));
    // the z keys known anywhere
    let (zlo, zhi) = a
        .leaves()
        .chain(b.leaves())
        .map(|l| (l.min_key()[2], l.min_key()[2] + (l.width() - 1) as u16))
        .fold((u16::MAX, 0), |(lo, hi), (l, h)| (lo.min(l), hi.max(h)));
    use octoquant::compare_image::*;
    let mut seen = std::collections::HashSet::new();
    let mut checked = 0;
    for row in (0..h).step_by(3) {
        for col in (0..w).step_by(3) {
            let got = at(ax + col, ay + row);
            let (kx, ky) = (x0 + col as u16, y0 + (h - 1 - row) as u16);
            let (mut first, mut second, mut both_occ, mut one, mut both_free) =
                (false, false, false, false, false);
            for kz in zlo..=zhi {
                let k = octoquant::Key::new(kx, ky, kz);
                match (a.is_occupied(k), b.is_occupied(k)) {
                    (Some(true), Some(true)) => both_occ = true,
                    (Some(true), _) => first = true,
                    (_, Some(true)) => second = true,
                    (Some(false), Some(false)) => both_free = true,
                    (None, None) => {}
                    _ => one = true,
                }
            }
            let want = if first && second {
                BOTH_CHANGES
            } else if first {
                ONLY_FIRST
            } else if second {
                ONLY_SECOND
            } else if both_occ {
                BOTH_OCCUPIED
            } else if one {
                ONE_KNOWS
            } else if both_free {
                BOTH_FREE
            } else {
                octoquant::render::UNKNOWN_COLOUR
            };
            assert_eq!(got, want, "pixel ({col}, {row}), column key ({kx}, {ky})");
            seen.insert(want);
            checked += 1;
        }
    }
    assert!(checked > 1000, "{checked}");
    // the max range loses far obstacles and keeps near ones: several colours appear
    assert!(
        seen.contains(&ONLY_FIRST) && seen.contains(&BOTH_OCCUPIED),
        "{seen:?}"
    );
    assert!(seen.len() >= 4, "{seen:?}");
    // the legend: every colour's swatch, whole, where the library says it is
    let area = [ax, ay, w, h];
    for (i, (colour, _)) in LEGEND.iter().enumerate() {
        let (sx, sy) = legend_swatch(area, i);
        for (dx, dy) in [(0, 0), (8, 0), (0, 8), (8, 8), (4, 4)] {
            assert_eq!(at(sx + dx, sy + dy), *colour, "legend row {i}");
        }
    }
}
