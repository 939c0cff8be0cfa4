//! Peers in the benchmark: `octoquant bench --peer NAME=PROGRAM` runs a peer program (Bonxai's
//! ProbabilisticMap, tools/bonxai-peer) on the same frames and reports it beside the modes.

use crate::common;
use std::path::PathBuf;
use std::process::Command;

/// The Bonxai peer program from `OCTOQUANT_BONXAI` (built by `.ci/run` with
/// tools/bonxai-peer/build.sh); required under CI.
fn bonxai_peer() -> Option<PathBuf> {
    match std::env::var_os("OCTOQUANT_BONXAI").map(PathBuf::from) {
        Some(p) if p.is_file() => Some(p),
        _ => common::skip("OCTOQUANT_BONXAI naming the built tools/bonxai-peer program"),
    }
}

#[test]
fn bench_times_a_peer_on_the_same_frames() {
    let Some(scan) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let Some(peer) = bonxai_peer() else {
        return;
    };
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("bench")
        .arg(&scan)
        .args([
            "--res",
            "0.2",
            "--frames",
            "2",
            "--threads",
            "1",
            "--repeat",
            "2",
            "--json",
        ])
        .arg("--peer")
        .arg(format!("bonxai={}", peer.display()))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = String::from_utf8(o.stdout).unwrap();
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let peers = v["peers"].as_array().unwrap();
    assert_eq!(peers.len(), 1, "{json}");
    assert_eq!(peers[0]["name"], "bonxai");
    let peer_ms = peers[0]["median_ms"].as_f64().unwrap();
    assert!(peer_ms > 0.0, "{json}");
    assert!(peers[0]["memory_bytes"].as_u64().unwrap() > 0, "{json}");
    for run in v["runs"].as_array().unwrap() {
        // the ratio is the peer's median over the mode's
        let ratio = run["speedup_vs_peers"]["bonxai"].as_f64().unwrap();
        let med = run["median_ms"].as_f64().unwrap();
        assert!(
            (ratio - peer_ms / med).abs() <= 1e-3 * ratio.max(1.0),
            "{run}"
        );
    }
}

#[test]
fn bench_names_a_peer_it_cannot_run_and_cleans_up() {
    let Some(scan) = common::data_file("lidar3d/octomap_scan_dat/scan.dat.bz2") else {
        return;
    };
    let child = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("bench")
        .arg(&scan)
        .args([
            "--res",
            "0.4",
            "--frames",
            "1",
            "--threads",
            "1",
            "--repeat",
            "1",
        ])
        .args(["--peer", "ghost=/nonexistent/ghost-peer"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id();
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("ghost") && err.contains("/nonexistent/ghost-peer"),
        "{err}"
    );
    // the bench's scratch directory (named after its pid) held the frames file; it is gone
    let dir = std::env::temp_dir().join(format!("octoquant-bench-{pid}"));
    assert!(!dir.exists(), "{} left behind", dir.display());
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .args(["bench", "--peer", "nameless"])
        .arg(&scan)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("NAME=PROGRAM"));
}
