//! Issue 6: CARMEN logs read completely and every scan segments into lines. Issue 27: the
//! collinear lines separation (on by default) against the segmentation without it, on the
//! same scans, and the `segment` command's new options on small synthetic logs.
//!
//! Prints lines per scan and milliseconds per scan for each log (`--nocapture` to see them);
//! asserts only outcomes (scan counts, lines found, residuals), never wall-clock time.

use crate::common;
use octoquant::formats::carmen::{read_carmen_file, CarmenReader, ScanKind};
use octoquant_segment::{
    hough_lines, incremental_lines, ransac_lines, segment_scan, split_and_merge, HoughParams,
    IncrementalParams, LineParams, RansacParams, Segmentation, SplitMergeParams, NOISE,
};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

struct Summary {
    scans: usize,
    kinds_ok: bool,
    median_lines: usize,
    scans_with_lines: usize,
    median_rms: f64,
    fraction_on_lines: f64,
}

/// The parameters before the collinear lines separation existed.
fn without_split() -> LineParams {
    LineParams {
        split_eps: f64::INFINITY,
        ..LineParams::default()
    }
}

/// Per-scan figures of one parameter set over a log.
#[derive(Default)]
struct Tally {
    lines: Vec<usize>,
    ms: Vec<f64>,
    rms: Vec<f64>,
    valid: usize,
    on_lines: usize,
}

impl Tally {
    fn add(&mut self, points: &[[f64; 2]], params: &LineParams, seg: &mut Segmentation, at: &str) {
        self.run(points, seg, |p, s| {
            segment_scan(p, params, s).unwrap_or_else(|e| panic!("{at}: {e}"))
        });
    }

    /// Time one extractor on one scan and record its lines.
    fn run(
        &mut self,
        points: &[[f64; 2]],
        seg: &mut Segmentation,
        extract: impl FnOnce(&[[f64; 2]], &mut Segmentation),
    ) {
        let t = Instant::now();
        extract(points, seg);
        self.ms.push(t.elapsed().as_secs_f64() * 1e3);
        self.lines.push(seg.lines().len());
        self.valid += points.len();
        self.on_lines += seg.labels().iter().filter(|&&l| l != NOISE).count();
        for (k, l) in seg.lines().iter().enumerate() {
            assert_eq!(seg.line_members(k).len(), l.n_points);
            self.rms.push(l.rms_residual);
        }
    }

    fn summary(mut self, rel: &str, what: &str, kinds_ok: bool) -> Summary {
        let scans = self.lines.len();
        assert!(scans > 0, "{rel}: no scans");
        let scans_with_lines = self.lines.iter().filter(|&&n| n > 0).count();
        let mean_lines = self.lines.iter().sum::<usize>() as f64 / scans as f64;
        self.lines.sort_unstable();
        self.ms.sort_unstable_by(f64::total_cmp);
        self.rms.sort_unstable_by(f64::total_cmp);
        let q = |v: &[f64], p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
        let lines = &self.lines;
        eprintln!(
            "{rel} ({what}): {scans} scans; lines/scan mean {mean_lines:.2} median {} p95 {} \
             max {}; ms/scan median {:.4} p95 {:.4} max {:.4}; {:.1} % of valid points on lines",
            lines[scans / 2],
            lines[(scans - 1) * 95 / 100],
            lines[scans - 1],
            q(&self.ms, 0.5),
            q(&self.ms, 0.95),
            self.ms[self.ms.len() - 1],
            100.0 * self.on_lines as f64 / self.valid as f64
        );
        Summary {
            scans,
            kinds_ok,
            median_lines: lines[scans / 2],
            scans_with_lines,
            median_rms: if self.rms.is_empty() {
                f64::INFINITY
            } else {
                q(&self.rms, 0.5)
            },
            fraction_on_lines: self.on_lines as f64 / self.valid as f64,
        }
    }
}

/// Segment every scan of `rel` with the default parameters, with the paper's fixed epsilon for
/// the collinear lines separation, and without it; every tenth scan also with split-and-merge,
/// incremental (line tracking), RANSAC and the Hough transform. Print the figures of all; return the default's.
fn segment_log(rel: &str, kind: ScanKind) -> Option<Summary> {
    let path = common::data_file(rel)?;
    let mut reader = CarmenReader::open(&path).expect("open log");
    let default = LineParams::default();
    let fixed = LineParams {
        split_spacing_factor: 0.0,
        ..LineParams::default()
    };
    let whole = without_split();
    let mut seg = Segmentation::new();
    let mut points = Vec::new();
    let mut tallies: [Tally; 7] = Default::default();
    let mut kinds_ok = true;
    let mut index = 0;
    while let Some(scan) = reader.next_scan().expect("read scan") {
        kinds_ok &= scan.kind == kind;
        scan.laser_points(&mut points);
        let at = format!("{rel} line {}", scan.line);
        tallies[0].add(&points, &default, &mut seg, &at);
        tallies[1].add(&points, &fixed, &mut seg, &at);
        tallies[2].add(&points, &whole, &mut seg, &at);
        if index % 10 == 0 {
            tallies[3].run(&points, &mut seg, |p, s| {
                split_and_merge(p, &SplitMergeParams::default(), s).unwrap()
            });
            tallies[4].run(&points, &mut seg, |p, s| {
                ransac_lines(p, &RansacParams::default(), s).unwrap()
            });
            tallies[5].run(&points, &mut seg, |p, s| {
                incremental_lines(p, &IncrementalParams::default(), s)
                    .unwrap_or_else(|e| panic!("{at}: {e}"))
            });
            tallies[6].run(&points, &mut seg, |p, s| {
                hough_lines(p, &HoughParams::default(), s).unwrap_or_else(|e| panic!("{at}: {e}"))
            });
        }
        index += 1;
    }
    let [t_default, t_fixed, t_whole, t_sm, t_ransac, t_inc, t_hough] = tallies;
    t_sm.summary(rel, "split-and-merge, every 10th scan", kinds_ok);
    t_inc.summary(rel, "incremental, every 10th scan", kinds_ok);
    t_ransac.summary(rel, "RANSAC, every 10th scan", kinds_ok);
    t_hough.summary(rel, "Hough, every 10th scan", kinds_ok);
    let before = t_whole.summary(rel, "angular, without collinear separation", kinds_ok);
    let fixed = t_fixed.summary(rel, "angular, fixed 0.5 m separation", kinds_ok);
    let after = t_default.summary(rel, "angular, default", kinds_ok);
    // The separation only cuts lines, and drops the pieces too short to be lines; the spacing
    // factor only widens the epsilon, so it cuts less than the fixed one.
    assert!(fixed.fraction_on_lines <= after.fraction_on_lines);
    assert!(after.fraction_on_lines <= before.fraction_on_lines);
    assert!(
        after.fraction_on_lines > before.fraction_on_lines - 0.03,
        "{rel}: points on lines {} without the separation, {} with",
        before.fraction_on_lines,
        after.fraction_on_lines
    );
    Some(after)
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

/// A one-scan `FLASER` log: 181 beams over 180°, each hitting the nearest of `walls` (segments
/// in the laser frame, x forward) or nothing (the SICK "no return" 81.83).
fn flaser_log(path: &Path, walls: &[[[f64; 2]; 2]]) {
    let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    let ranges: Vec<String> = (0..181)
        .map(|i| {
            let a = (-90.0 + i as f64).to_radians();
            let d = [a.cos(), a.sin()];
            let mut best = 81.83f64;
            for w in walls {
                let e = [w[1][0] - w[0][0], w[1][1] - w[0][1]];
                let den = cross(d, e);
                if den.abs() > 1e-12 {
                    let (r, s) = (cross(w[0], e) / den, cross(w[0], d) / den);
                    if r > 0.0 && (0.0..=1.0).contains(&s) {
                        best = best.min(r);
                    }
                }
            }
            format!("{best:.4}")
        })
        .collect();
    std::fs::write(
        path,
        format!("FLASER 181 {} 0 0 0 0 0 0 1.0 host 1.0\n", ranges.join(" ")),
    )
    .unwrap();
}

fn segment_json(log: &Path, args: &[&str]) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("segment")
        .arg(log)
        .args(args)
        .arg("--json")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn segment_error(log: &Path, args: &[&str]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_octoquant"))
        .arg("segment")
        .arg(log)
        .args(args)
        .output()
        .unwrap();
    assert!(!o.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn issue_27_segment_command_splits_doorways_and_resegments() {
    let dir = common::scratch("segment-issue-27");
    // A wall 2 m ahead, 8 m wide, with a 1 m doorway on the left.
    let door = dir.join("door.log");
    flaser_log(
        &door,
        &[[[2.0, -4.0], [2.0, 0.5]], [[2.0, 1.5], [2.0, 4.0]]],
    );
    let lines = |v: &serde_json::Value| v["lines"].as_array().unwrap().len();
    let v = segment_json(&door, &[]);
    assert_eq!(lines(&v), 2, "{v}");
    // The door jambs: each line ends within a beam spacing of one.
    let mut inner: Vec<f64> = v["lines"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| {
            let (a, b) = (
                l["start"][1].as_f64().unwrap(),
                l["end"][1].as_f64().unwrap(),
            );
            if (a - 1.0).abs() < (b - 1.0).abs() {
                a
            } else {
                b
            }
        })
        .collect();
    inner.sort_by(f64::total_cmp);
    assert!(
        (inner[0] - 0.5).abs() < 0.04 && (inner[1] - 1.5).abs() < 0.04,
        "{inner:?}"
    );
    assert_eq!(lines(&segment_json(&door, &["--split-eps", "inf"])), 1);
    assert_eq!(lines(&segment_json(&door, &["--split-eps", "1.2"])), 1);
    assert_eq!(
        lines(&segment_json(&door, &["--split-spacing-factor", "40"])),
        1,
        "40 spacings of 3.5 cm cover the doorway"
    );
    assert!(segment_error(&door, &["--split-spacing-factor", "nan"])
        .contains("--split-spacing-factor NaN"));
    assert_eq!(
        lines(&segment_json(&door, &["--split-min-points", "50"])),
        0,
        "no piece has 50 points within 0.5 m"
    );
    let v = segment_json(&door, &["--all"]);
    assert_eq!(v["lines_per_scan"]["max"], 2.0, "{v}");
    // Two parallel walls 4.5 cm apart side by side: one line unless re-segmented.
    let step = dir.join("step.log");
    flaser_log(
        &step,
        &[[[2.0, -3.0], [2.0, 0.0]], [[1.955, 0.0], [1.955, 3.0]]],
    );
    assert_eq!(lines(&segment_json(&step, &[])), 1);
    let v = segment_json(&step, &["--resegment", "0.01"]);
    assert_eq!(lines(&v), 2, "{v}");
    let v = segment_json(&step, &["--resegment", "0.01", "--resegment-eps", "0.1"]);
    assert_eq!(
        lines(&v),
        1,
        "an eps above the separation merges them again: {v}"
    );
    // Bad values are named by their options; --resegment-eps alone is refused.
    assert!(segment_error(&door, &["--split-eps=-1"]).contains("--split-eps -1"));
    assert!(segment_error(&door, &["--split-min-points", "0"]).contains("--split-min-points 0"));
    assert!(segment_error(&door, &["--resegment", "nan"]).contains("--resegment NaN"));
    assert!(segment_error(&door, &["--resegment-eps", "0.01"]).contains("--resegment"));
}
