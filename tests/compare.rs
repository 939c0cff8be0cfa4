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
