//! The online grid density reducer paper's experiment, in kind (issue 27): a terrestrial scan
//! with the paper's scanner settings and OctoMap's `scan.dat`, reduced with 0.07 m cells;
//! the points after the grid stage and after the output stage, and the density (points per
//! square metre of surface) near and far from the scanner, before and after.
//!
//! `cargo run --release --example reducer_experiment -- OUT_DIR [SCAN_DAT]`
//!
//! * The simulated scan: the built-in city (seed 0, 6 x 6 blocks), one station 1.5 m above
//!   the road 150 m along the city's route, the Riegl LMS-Z620 settings of the paper
//!   ([`TerrestrialScanner::riegl_lms_z620`]: 0.075° steps, 360° x 80°, 2-2000 m), 1 cm range
//!   noise, beams that hit nothing dropped.
//! * `SCAN_DAT` (default `$OCTOQUANT_DATA/lidar3d/octomap_scan_dat/scan.dat.bz2`), all its
//!   frames merged (it is one scan, read with the sensor at the origin); a point's range is to
//!   its own frame's origin.
//!
//! Density at a point: the points of the same stage within 0.2 m of it, divided by
//! pi * 0.2^2 (the area of a disc of that radius on a locally flat surface). Per range bin
//! (0.5-1 m, 1-2 m, ... doubling) it is measured at up to 4000 points of the bin spread evenly
//! over it, and the median and the 10th and 90th percentiles are reported.
//!
//! Writes `OUT_DIR/counts.csv` (points per stage) and `OUT_DIR/density.csv` (density per range
//! bin and stage), and prints both as Markdown tables; `python/benches/reducer_density_plot.py`
//! draws the PNG from `density.csv`.

use nalgebra::Point3;
use octoquant::formats::{read_frames, ReadOptions};
use octoquant::scene::{
    scan_terrestrial, City, CityOptions, MissPolicy, ScanOptions, TerrestrialScanner,
};
use octoquant_density::{DensityGrid, GridSpec};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

const CELL: f64 = 0.07;
const RADIUS: f64 = 0.2;
const SAMPLES: usize = 4000;

/// Points of one stage with their ranges.
struct Stage {
    name: &'static str,
    points: Vec<[f64; 3]>,
    ranges: Vec<f64>,
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(out_dir) = args.first().map(PathBuf::from) else {
        eprintln!("usage: reducer_experiment OUT_DIR [SCAN_DAT]");
        std::process::exit(2);
    };
    let scan_dat = args.get(1).map(PathBuf::from).or_else(|| {
        std::env::var_os("OCTOQUANT_DATA")
            .map(|d| PathBuf::from(d).join("lidar3d/octomap_scan_dat/scan.dat.bz2"))
    });
    std::fs::create_dir_all(&out_dir).expect("cannot create OUT_DIR");
    let mut counts =
        String::from("source,input,grid_stage,output_stage,seconds_grid,seconds_output\n");
    let mut density =
        String::from("source,stage,range_lo,range_hi,points,sampled,p10,median,p90\n");

    // The simulated terrestrial scan.
    let city = City::generate(&CityOptions::default()).expect("the default city");
    let scene = city.scene();
    let at = *city.route(150.0).last().expect("a route has a start");
    let z = scene.ground_height(at[0], at[1]).unwrap_or(0.0) + 1.5;
    let station = Point3::new(at[0], at[1], z);
    let scanner = TerrestrialScanner::riegl_lms_z620(vec![station]);
    let options = ScanOptions {
        misses: MissPolicy::Drop,
        ..ScanOptions::default()
    };
    let t = Instant::now();
    let (frames, stats) = scan_terrestrial(&scene, &scanner, &options).expect("a valid scanner");
    eprintln!(
        "city scan from {station:?}: {} beams, {} returns, {:.1} s",
        stats[0].rays,
        stats[0].hits,
        t.elapsed().as_secs_f64()
    );
    let sources = {
        let mut s = vec![("simulated Riegl scan (city)", frames)];
        if let Some(path) = scan_dat.filter(|p| p.exists()) {
            let frames = read_frames(&path, &ReadOptions::default()).expect("scan.dat reads");
            s.push(("OctoMap scan.dat", frames));
        } else {
            eprintln!("no scan.dat (give its path or set OCTOQUANT_DATA): simulated scan only");
        }
        s
    };

    for (source, frames) in sources {
        let mut input = Stage {
            name: "input",
            points: Vec::new(),
            ranges: Vec::new(),
        };
        for f in &frames {
            let o = f.origin.cast::<f64>();
            for p in &f.points {
                let q = [f64::from(p.x), f64::from(p.y), f64::from(p.z)];
                input.ranges.push(
                    ((q[0] - o.x).powi(2) + (q[1] - o.y).powi(2) + (q[2] - o.z).powi(2)).sqrt(),
                );
                input.points.push(q);
            }
        }
        // The range of each input point, to carry over to the stages' subsets.
        let range_of: HashMap<[u64; 3], f64> = input
            .points
            .iter()
            .zip(&input.ranges)
            .map(|(p, r)| (p.map(f64::to_bits), *r))
            .collect();
        let t = Instant::now();
        let mut grid = DensityGrid::streaming(GridSpec::cubic(CELL).expect("a valid cell"));
        grid.extend_rewalk(input.points.iter().copied());
        let grid_points = grid.selected_points();
        let seconds_grid = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let (out, _) = grid.output_cycle();
        let seconds_output = t.elapsed().as_secs_f64();
        let stage = |name, points: Vec<[f64; 3]>| Stage {
            name,
            ranges: points
                .iter()
                .map(|p| range_of[&p.map(f64::to_bits)])
                .collect(),
            points,
        };
        let stages = [
            input,
            stage("grid stage", grid_points),
            stage("output stage", out),
        ];
        writeln!(
            counts,
            "{source},{},{},{},{seconds_grid:.3},{seconds_output:.3}",
            stages[0].points.len(),
            stages[1].points.len(),
            stages[2].points.len()
        )
        .unwrap();
        for s in &stages {
            for row in density_by_range(s) {
                writeln!(density, "{source},{},{row}", s.name).unwrap();
            }
        }
    }
    std::fs::write(out_dir.join("counts.csv"), &counts).expect("write counts.csv");
    std::fs::write(out_dir.join("density.csv"), &density).expect("write density.csv");
    print!("{counts}\n{density}");
}

/// `range_lo,range_hi,points,sampled,p10,median,p90` for each doubling range bin from 0.5 m
/// that holds points.
fn density_by_range(s: &Stage) -> Vec<String> {
    // Hash grid of cell RADIUS over the stage's points.
    let key = |p: &[f64; 3]| p.map(|v| (v / RADIUS).floor() as i64);
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (k, p) in s.points.iter().enumerate() {
        cells.entry(key(p)).or_default().push(k as u32);
    }
    let count_near = |q: &[f64; 3]| {
        let c = key(q);
        let mut n = 0usize;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(v) = cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        n += v
                            .iter()
                            .filter(|&&k| {
                                let p = &s.points[k as usize];
                                (p[0] - q[0]).powi(2)
                                    + (p[1] - q[1]).powi(2)
                                    + (p[2] - q[2]).powi(2)
                                    <= RADIUS * RADIUS
                            })
                            .count();
                    }
                }
            }
        }
        n
    };
    let area = std::f64::consts::PI * RADIUS * RADIUS;
    let mut rows = Vec::new();
    let mut lo = 0.5;
    while lo < 4096.0 {
        let hi = 2.0 * lo;
        let members: Vec<usize> = (0..s.points.len())
            .filter(|&k| s.ranges[k] >= lo && s.ranges[k] < hi)
            .collect();
        if !members.is_empty() {
            let step = members.len().div_ceil(SAMPLES);
            let mut d: Vec<f64> = members
                .iter()
                .step_by(step)
                .map(|&k| count_near(&s.points[k]) as f64 / area)
                .collect();
            d.sort_by(f64::total_cmp);
            let q = |f: f64| d[((d.len() - 1) as f64 * f).round() as usize];
            rows.push(format!(
                "{lo},{hi},{},{},{:.1},{:.1},{:.1}",
                members.len(),
                d.len(),
                q(0.1),
                q(0.5),
                q(0.9)
            ));
        }
        lo = hi;
    }
    rows
}
