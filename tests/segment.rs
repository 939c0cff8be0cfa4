//! Issue 6: CARMEN logs read completely and every scan segments into lines.
//!
//! Prints lines per scan and milliseconds per scan for each log (`--nocapture` to see them);
//! asserts only outcomes (scan counts, lines found, residuals), never wall-clock time.

use crate::common;
use octoquant::formats::carmen::{read_carmen_file, CarmenReader, ScanKind};
use octoquant_segment::{segment_scan, LineParams, Segmentation, NOISE};
use std::time::Instant;

struct Summary {
    scans: usize,
    kinds_ok: bool,
    median_lines: usize,
    scans_with_lines: usize,
    median_rms: f64,
    fraction_on_lines: f64,
}

/// Segment every scan of `rel` with the default parameters; print the figures.
fn segment_log(rel: &str, kind: ScanKind) -> Option<Summary> {
    let path = common::data_file(rel)?;
    let mut reader = CarmenReader::open(&path).expect("open log");
    let params = LineParams::default();
    let mut seg = Segmentation::new();
    let mut points = Vec::new();
    let (mut lines, mut ms, mut rms) = (Vec::new(), Vec::new(), Vec::new());
    let (mut valid, mut on_lines) = (0usize, 0usize);
    let mut kinds_ok = true;
    while let Some(scan) = reader.next_scan().expect("read scan") {
        kinds_ok &= scan.kind == kind;
        scan.laser_points(&mut points);
        let t = Instant::now();
        segment_scan(&points, &params, &mut seg)
            .unwrap_or_else(|e| panic!("{rel} line {}: {e}", scan.line));
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        lines.push(seg.lines().len());
        valid += points.len();
        on_lines += seg.labels().iter().filter(|&&l| l != NOISE).count();
        for (k, l) in seg.lines().iter().enumerate() {
            assert_eq!(seg.line_members(k).len(), l.n_points);
            rms.push(l.rms_residual);
        }
    }
    let scans = lines.len();
    assert!(scans > 0, "{rel}: no scans");
    let scans_with_lines = lines.iter().filter(|&&n| n > 0).count();
    lines.sort_unstable();
    ms.sort_unstable_by(f64::total_cmp);
    rms.sort_unstable_by(f64::total_cmp);
    let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    eprintln!(
        "{rel}: {scans} scans; lines/scan mean {:.2} median {} p95 {} max {}; \
         ms/scan median {:.4} p95 {:.4} max {:.4}; {:.1} % of valid points on lines",
        lines.iter().sum::<usize>() as f64 / scans as f64,
        lines[scans / 2],
        lines[(scans - 1) * 95 / 100],
        lines[scans - 1],
        q(&ms, 0.5),
        q(&ms, 0.95),
        ms[ms.len() - 1],
        100.0 * on_lines as f64 / valid as f64
    );
    Some(Summary {
        scans,
        kinds_ok,
        median_lines: lines[scans / 2],
        scans_with_lines,
        median_rms: if rms.is_empty() {
            f64::INFINITY
        } else {
            q(&rms, 0.5)
        },
        fraction_on_lines: on_lines as f64 / valid as f64,
    })
}

#[test]
fn issue_6_intel_clf_every_scan_segments() {
    let Some(s) = segment_log("laser2d/radish_clf/intel.clf.bz2", ScanKind::Flaser) else {
        return;
    };
    assert_eq!(s.scans, 13_631);
    assert!(s.kinds_ok);
    assert!(s.median_lines >= 3, "median lines {}", s.median_lines);
    assert!(s.scans_with_lines as f64 > 0.98 * s.scans as f64);
    assert!(s.median_rms < 0.01, "median rms {}", s.median_rms);
    assert!(s.fraction_on_lines > 0.5, "{}", s.fraction_on_lines);
}

#[test]
fn issue_6_fr_clinic_robotlaser1_every_scan_segments() {
    let Some(s) = segment_log(
        "laser2d/radish_clf/fr-clinic_robotlaser.clf.bz2",
        ScanKind::RobotLaser1,
    ) else {
        return;
    };
    assert_eq!(s.scans, 6_917);
    assert!(s.kinds_ok);
    // A cluttered hospital with long ranges: fewer, but real, lines.
    assert!(s.median_lines >= 1, "median lines {}", s.median_lines);
    assert!(s.scans_with_lines as f64 > 0.8 * s.scans as f64);
    assert!(s.median_rms < 0.03, "median rms {}", s.median_rms);
}

#[test]
fn issue_6_intel_corrected_every_scan_segments() {
    let Some(s) = segment_log(
        "laser2d/ple_corrected_carmen/intel-corrected.log.gz",
        ScanKind::Flaser,
    ) else {
        return;
    };
    assert_eq!(s.scans, 910);
    assert!(s.kinds_ok);
    assert!(s.median_lines >= 3, "median lines {}", s.median_lines);
    assert!(s.median_rms < 0.01, "median rms {}", s.median_rms);
}

#[test]
fn issue_6_carmen_poses_and_invalid_readings() {
    let Some(fr) = common::data_file("laser2d/radish_clf/fr-clinic_robotlaser.clf.bz2") else {
        return;
    };
    let Some(corr) = common::data_file("laser2d/ple_corrected_carmen/intel-corrected.log.gz")
    else {
        return;
    };
    let scans = read_carmen_file(&fr).expect("fr-clinic");
    let mut starts: Vec<i64> = Vec::new();
    for s in &scans {
        // Laser = robot pose + 0.22 m along the heading; 181 or 180 beams at 1 degree.
        let (sn, cs) = s.robot_pose.theta.sin_cos();
        let dx = s.laser_pose.x - (s.robot_pose.x + 0.22 * cs);
        let dy = s.laser_pose.y - (s.robot_pose.y + 0.22 * sn);
        assert!(
            dx.hypot(dy) < 2e-3,
            "line {}: laser offset {dx} {dy}",
            s.line
        );
        assert!(s.ranges.len() == 181 || s.ranges.len() == 180);
        assert!((s.angular_resolution - 1f64.to_radians()).abs() < 1e-5);
        assert!(s
            .ranges
            .iter()
            .enumerate()
            .all(|(i, &r)| s.is_valid(i) == (r < 81.89)));
        let k = (s.start_angle * 1e4).round() as i64;
        if !starts.contains(&k) {
            starts.push(k);
        }
    }
    starts.sort_unstable();
    assert_eq!(
        starts,
        vec![-15708, -15664, -15621, -15577],
        "interlaced start angles"
    );
    let corr = read_carmen_file(&corr).expect("intel-corrected");
    let no_return: usize = corr.iter().map(|s| s.ranges.len() - s.valid_count()).sum();
    assert!(no_return > 0, "81.83 readings must be flagged");
    for s in &corr {
        assert_eq!(s.laser_pose, s.robot_pose);
        assert_eq!(s.ranges.len(), 180);
        assert!(s
            .ranges
            .iter()
            .enumerate()
            .all(|(i, &r)| s.is_valid(i) == (r > 0.0 && r < 81.82)));
    }
}
