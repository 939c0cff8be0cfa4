//! `octoquant segment LOG [--scan N | --all] [--eps-theta A] [--eps-dist D] [--min-points K]
//! [--split-eps E] [--split-min-points K] [--split-spacing-factor F] [--resegment RMS
//! [--resegment-eps E]] [--png OUT.png] [--json]`: line segments of 2D laser scans from a CARMEN log.

use super::{json_path, print_json};
use anyhow::{bail, Context, Result};
use octoquant::formats::carmen::{CarmenReader, LaserScan};
use octoquant::output::{check_output, write_atomic};
use octoquant_segment::{
    segment_scan, Line, LineParams, Resegment, SegmentError, Segmentation, NOISE,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct Args {
    /// CARMEN log with FLASER or ROBOTLASER1 lines (.gz/.bz2 read transparently).
    log: PathBuf,
    /// Index of the scan to segment (0-based, in file order).
    #[arg(long, default_value_t = 0, conflicts_with = "all")]
    scan: usize,
    /// Segment every scan and print per-scan statistics (lines, milliseconds).
    #[arg(long)]
    all: bool,
    /// Neighbourhood radius of the local-angle clustering, degrees.
    #[arg(long, default_value_t = 2.0)]
    eps_theta: f64,
    /// Neighbourhood radius of the distance clustering, metres.
    #[arg(long, default_value_t = 0.05)]
    eps_dist: f64,
    /// Core-point threshold of the angle, distance and re-segmentation clusterings, and the
    /// smallest line reported.
    #[arg(long, default_value_t = 5)]
    min_points: usize,
    /// Collinear lines separation: points of one line farther apart than this along it
    /// (metres) make separate lines, so a wall broken by a doorway gives two; `inf` turns the
    /// step off.
    #[arg(long, default_value_t = LineParams::default().split_eps)]
    split_eps: f64,
    /// Core-point threshold of the collinear lines separation.
    #[arg(long, default_value_t = LineParams::default().split_min_points)]
    split_min_points: usize,
    /// The separation's epsilon grows to this many times the median spacing of a line's
    /// points when that is larger than --split-eps (far walls); 0 keeps it fixed.
    #[arg(long, default_value_t = LineParams::default().split_spacing_factor)]
    split_spacing_factor: f64,
    /// Re-segment a cluster whose fitted line leaves an rms residual above this (metres) with
    /// the stricter --resegment-eps, to separate close parallel features (off by default).
    #[arg(long, value_name = "MAX_RMS")]
    resegment: Option<f64>,
    /// Distance epsilon of the re-segmentation, metres.
    #[arg(long, default_value_t = Resegment::default().eps, requires = "resegment")]
    resegment_eps: f64,
    /// Draw the scan (points coloured by line, fitted lines) to this PNG file.
    #[arg(long, conflicts_with = "all")]
    png: Option<PathBuf>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
}

/// A parameter the library refused, named as the command-line option that set it (with the
/// value as given there: `--eps-theta` in degrees, not the library's radians).
fn option_error(a: &Args, e: SegmentError) -> anyhow::Error {
    let SegmentError::InvalidParameter { name, reason, .. } = &e else {
        return anyhow::Error::new(e).context("invalid segmentation parameters");
    };
    let (option, value) = match *name {
        "eps_theta" => ("--eps-theta", format!("{:?}", a.eps_theta)),
        "eps_dist" => ("--eps-dist", format!("{:?}", a.eps_dist)),
        "min_points_theta" | "min_points_dist" | "min_line_points" | "resegment.min_points" => {
            ("--min-points", a.min_points.to_string())
        }
        "split_eps" => ("--split-eps", format!("{:?}", a.split_eps)),
        "split_min_points" => ("--split-min-points", a.split_min_points.to_string()),
        "split_spacing_factor" => (
            "--split-spacing-factor",
            format!("{:?}", a.split_spacing_factor),
        ),
        "resegment.max_rms" => (
            "--resegment",
            format!("{:?}", a.resegment.unwrap_or(f64::NAN)),
        ),
        "resegment.eps" => ("--resegment-eps", format!("{:?}", a.resegment_eps)),
        _ => return anyhow::Error::new(e).context("invalid segmentation parameters"),
    };
    anyhow::anyhow!("{option} {value}: {reason}")
}

pub fn run(a: &Args) -> Result<()> {
    let params = LineParams {
        eps_theta: a.eps_theta.to_radians(),
        eps_dist: a.eps_dist,
        min_points_theta: a.min_points,
        min_points_dist: a.min_points,
        min_line_points: a.min_points,
        split_eps: a.split_eps,
        split_min_points: a.split_min_points,
        split_spacing_factor: a.split_spacing_factor,
        resegment: a.resegment.map(|max_rms| Resegment {
            max_rms,
            eps: a.resegment_eps,
            min_points: a.min_points,
        }),
        ..LineParams::default()
    };
    if let Err(e) = params.validate() {
        return Err(option_error(a, e));
    }
    if let Some(png) = &a.png {
        check_output(png, &["png"], std::slice::from_ref(&a.log))?;
    }
    let mut reader = CarmenReader::open(&a.log)?;
    if a.all {
        return run_all(a, &mut reader, &params);
    }
    let mut index = 0;
    let scan = loop {
        match reader.next_scan()? {
            Some(s) if index == a.scan => break s,
            Some(_) => index += 1,
            None => bail!(
                "{}: scan {} requested but the log has {index} scans",
                a.log.display(),
                a.scan
            ),
        }
    };
    let mut points = Vec::new();
    scan.laser_points(&mut points);
    let mut seg = Segmentation::new();
    let t = Instant::now();
    segment_scan(&points, &params, &mut seg)
        .with_context(|| format!("{}: line {}", a.log.display(), scan.line))?;
    let ms = t.elapsed().as_secs_f64() * 1e3;
    if let Some(png) = &a.png {
        draw_png(png, &points, &seg)?;
    }
    print_scan(a, &scan, &points, &seg, ms)
}

fn print_scan(
    a: &Args,
    scan: &LaserScan,
    points: &[[f64; 2]],
    seg: &Segmentation,
    ms: f64,
) -> Result<()> {
    let inliers = seg.labels().iter().filter(|&&l| l != NOISE).count();
    if a.json {
        let lines: Vec<serde_json::Value> = seg
            .lines()
            .iter()
            .map(|l| {
                serde_json::json!({
                    "normal_angle": l.normal_angle,
                    "distance": l.distance,
                    "start": l.start,
                    "end": l.end,
                    "points": l.n_points,
                    "length": l.length(),
                    "rms_residual": l.rms_residual,
                    "max_residual": l.max_residual,
                })
            })
            .collect();
        print_json(&serde_json::json!({
            "file": json_path(&a.log),
            "scan": a.scan,
            "line": scan.line,
            "kind": format!("{:?}", scan.kind),
            "readings": scan.ranges.len(),
            "valid": points.len(),
            "on_lines": inliers,
            "laser_pose": [scan.laser_pose.x, scan.laser_pose.y, scan.laser_pose.theta],
            "ms": ms,
            "lines": lines,
        }))?;
        return Ok(());
    }
    outln!("file:        {}", a.log.display())?;
    outln!(
        "scan:        {} ({:?}, line {})",
        a.scan,
        scan.kind,
        scan.line
    )?;
    let p = scan.laser_pose;
    outln!("laser pose:  ({:.3}, {:.3}, {:.4} rad)", p.x, p.y, p.theta)?;
    outln!(
        "readings:    {} ({} valid, {} on lines)",
        scan.ranges.len(),
        points.len(),
        inliers
    )?;
    outln!("time:        {ms:.3} ms")?;
    outln!("lines:       {}", seg.lines().len())?;
    for (k, l) in seg.lines().iter().enumerate() {
        outln!("  {k:3}: {}", describe(l))?;
    }
    Ok(())
}

fn describe(l: &Line) -> String {
    format!(
        "normal {:7.2} deg, distance {:6.3} m, {:3} points, length {:6.3} m, rms {:.4} m",
        l.normal_angle.to_degrees(),
        l.distance,
        l.n_points,
        l.length(),
        l.rms_residual
    )
}

/// Median, 95th percentile and maximum of `v` (sorted in place); zeros when empty.
fn stats(v: &mut [f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    v.sort_unstable_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.95), v[v.len() - 1])
}

fn run_all(a: &Args, reader: &mut CarmenReader, params: &LineParams) -> Result<()> {
    let mut seg = Segmentation::new();
    let mut points = Vec::new();
    let (mut lines, mut ms) = (Vec::new(), Vec::new());
    let mut inliers = 0usize;
    let mut valid = 0usize;
    while let Some(scan) = reader.next_scan()? {
        scan.laser_points(&mut points);
        let t = Instant::now();
        segment_scan(&points, params, &mut seg)
            .with_context(|| format!("{}: line {}", a.log.display(), scan.line))?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        lines.push(seg.lines().len() as f64);
        valid += points.len();
        inliers += seg.labels().iter().filter(|&&l| l != NOISE).count();
    }
    let n = lines.len();
    let mean_lines = lines.iter().sum::<f64>() / n.max(1) as f64;
    let total_ms: f64 = ms.iter().sum();
    let (l50, l95, lmax) = stats(&mut lines);
    let (m50, m95, mmax) = stats(&mut ms);
    let on_lines = inliers as f64 / valid.max(1) as f64;
    if a.json {
        print_json(&serde_json::json!({
            "file": json_path(&a.log),
            "scans": n,
            "lines_per_scan": {"mean": mean_lines, "median": l50, "p95": l95, "max": lmax},
            "ms_per_scan": {"median": m50, "p95": m95, "max": mmax},
            "total_ms": total_ms,
            "fraction_on_lines": on_lines,
        }))?;
    } else {
        outln!("file:            {}", a.log.display())?;
        outln!("scans:           {n}")?;
        outln!("lines per scan:  mean {mean_lines:.2}, median {l50}, p95 {l95}, max {lmax}")?;
        outln!("ms per scan:     median {m50:.4}, p95 {m95:.4}, max {mmax:.4}")?;
        outln!("total:           {total_ms:.1} ms segmenting")?;
        outln!("points on lines: {:.1} %", 100.0 * on_lines)?;
    }
    Ok(())
}

const SIZE: u32 = 900;

/// Distinct colours for lines (Okabe-Ito and Tableau-like hues).
const PALETTE: [[u8; 3]; 10] = [
    [230, 159, 0],
    [86, 180, 233],
    [0, 158, 115],
    [213, 94, 0],
    [0, 114, 178],
    [204, 121, 167],
    [148, 103, 189],
    [140, 86, 75],
    [188, 189, 34],
    [23, 190, 207],
];

struct Canvas {
    rgb: Vec<u8>,
    scale: f64,
    min: [f64; 2],
}

impl Canvas {
    /// A white canvas whose frame fits `points` and the origin with a margin, x right, y up.
    fn fit(points: &[[f64; 2]]) -> Self {
        let (mut lo, mut hi) = ([0.0f64, 0.0f64], [0.0f64, 0.0f64]);
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0) * 1.08;
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        Canvas {
            rgb: vec![255; (SIZE * SIZE * 3) as usize],
            scale: f64::from(SIZE) / span,
            min: [centre[0] - span / 2.0, centre[1] - span / 2.0],
        }
    }

    fn pixel(&self, p: [f64; 2]) -> (f64, f64) {
        (
            (p[0] - self.min[0]) * self.scale,
            f64::from(SIZE) - (p[1] - self.min[1]) * self.scale,
        )
    }

    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if (0..i64::from(SIZE)).contains(&x) && (0..i64::from(SIZE)).contains(&y) {
            let i = ((y as u32 * SIZE + x as u32) * 3) as usize;
            self.rgb[i..i + 3].copy_from_slice(&c);
        }
    }

    fn dot(&mut self, p: [f64; 2], r: i64, c: [u8; 3]) {
        let (x, y) = self.pixel(p);
        let (x, y) = (x.round() as i64, y.round() as i64);
        for dy in -r..=r {
            for dx in -r..=r {
                self.put(x + dx, y + dy, c);
            }
        }
    }

    fn segment(&mut self, a: [f64; 2], b: [f64; 2], c: [u8; 3]) {
        let (ax, ay) = self.pixel(a);
        let (bx, by) = self.pixel(b);
        let steps = (bx - ax).abs().max((by - ay).abs()).ceil().clamp(1.0, 1e5) as usize;
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let (x, y) = (ax + (bx - ax) * t, ay + (by - ay) * t);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)] {
                self.put(x.round() as i64 + dx, y.round() as i64 + dy, c);
            }
        }
    }
}

/// Points (grey when on no line) and fitted lines, laser at the origin (black cross), to `path`.
fn draw_png(path: &Path, points: &[[f64; 2]], seg: &Segmentation) -> Result<()> {
    let mut cv = Canvas::fit(points);
    // A grid of 1, 10 or 100 m, whichever draws at most about 40 lines across.
    let span = f64::from(SIZE) / cv.scale;
    let step = [1.0, 10.0, 100.0, 1000.0]
        .into_iter()
        .find(|&s| span / s <= 40.0)
        .unwrap_or(1e4);
    let grid = [230, 230, 230];
    let (x0, x1) = (
        (cv.min[0] / step).floor() as i64,
        ((cv.min[0] + span) / step).ceil() as i64,
    );
    let (y0, y1) = (
        (cv.min[1] / step).floor() as i64,
        ((cv.min[1] + span) / step).ceil() as i64,
    );
    let (gy0, gy1) = (y0 as f64 * step, y1 as f64 * step);
    let (gx0, gx1) = (x0 as f64 * step, x1 as f64 * step);
    for gx in x0..=x1 {
        cv.segment([gx as f64 * step, gy0], [gx as f64 * step, gy1], grid);
    }
    for gy in y0..=y1 {
        cv.segment([gx0, gy as f64 * step], [gx1, gy as f64 * step], grid);
    }
    for (i, p) in points.iter().enumerate() {
        match seg.labels()[i] {
            NOISE => cv.dot(*p, 1, [150, 150, 150]),
            l => cv.dot(*p, 2, PALETTE[l as usize % PALETTE.len()]),
        }
    }
    for (k, l) in seg.lines().iter().enumerate() {
        let c = PALETTE[k % PALETTE.len()].map(|v| (u16::from(v) * 3 / 5) as u8);
        cv.segment(l.start, l.end, c);
    }
    cv.segment([-0.2, 0.0], [0.2, 0.0], [0, 0, 0]);
    cv.segment([0.0, -0.2], [0.0, 0.2], [0, 0, 0]);
    cv.segment([0.0, 0.0], [0.5, 0.0], [200, 0, 0]);
    write_atomic(path, |w| {
        let mut enc = png::Encoder::new(w, SIZE, SIZE);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().map_err(std::io::Error::other)?;
        wr.write_image_data(&cv.rgb)
            .map_err(std::io::Error::other)?;
        wr.finish().map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}
