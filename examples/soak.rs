//! Soak test (not in CI): many simulated LiDAR frames into one tree, with the process's
//! resident memory (`VmRSS`, peak `VmHWM` from `/proc/self/status`) measured against the
//! tree's own bytes (`OcTree::memory_usage`) as it goes.
//!
//! `cargo run --release --example soak -- [FRAMES] [EVERY] [RES]` (defaults 10000, 500, 0.2).
//!
//! The frames come from the built-in scene's LiDAR path, driven again and again with a new
//! noise seed and a small sideways offset each pass, generated one pass at a time (so the
//! frames in memory are one pass, not the run). The bound checked at the end: resident memory
//! stays within 1.5 × the tree's bytes plus a fixed buffer (the resident memory before the
//! first frame, plus 64 MiB for one pass of frames and the insertion buffers), and once the
//! tree stops growing (the second half of the run), resident memory stops growing too.
//! Exits 1 when the bound is broken.

use octoquant::pipeline::{Mapper, MapperOptions};
use octoquant::scene::{scan_lidar, ScanOptions, Scene, SpinningLidar};

/// `VmRSS` and `VmHWM` in bytes (0 where `/proc` is missing).
fn rss() -> (usize, usize) {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        s.lines()
            .find_map(|l| l.strip_prefix(name))
            .and_then(|v| v.split_whitespace().next()?.parse::<usize>().ok())
            .map_or(0, |kb| kb * 1024)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn mib(b: usize) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

fn main() {
    let arg = |i: usize, d: f64| {
        std::env::args()
            .nth(i)
            .and_then(|a| a.parse().ok())
            .unwrap_or(d)
    };
    let total = arg(1, 10000.0) as usize;
    let every = (arg(2, 500.0) as usize).max(1);
    let res = arg(3, 0.2);
    let scene = Scene::builtin();
    let base = SpinningLidar {
        columns: 512,
        ..SpinningLidar::builtin_path()
    };
    let mut mapper = match Mapper::new(MapperOptions {
        resolution: res,
        max_range: Some(base.max_range),
        ..MapperOptions::default()
    }) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(2);
        }
    };
    let (baseline, _) = rss();
    let buffer = baseline + (64 << 20);
    println!(
        "soak: {total} frames, {} rays each, resolution {res} m; baseline RSS {:.1} MiB, fixed buffer {:.1} MiB",
        base.rings * base.columns,
        mib(baseline),
        mib(buffer)
    );
    println!(
        "{:>7} {:>12} {:>12} {:>12} {:>10} {:>8}",
        "frames", "tree MiB", "RSS MiB", "peak MiB", "RSS/tree", "bound"
    );
    let mut rows: Vec<(usize, usize, usize, usize)> = Vec::new();
    let mut done = 0;
    let mut pass = 0u64;
    let mut ok = true;
    while done < total {
        // a new pass along the path: new noise, the path shifted sideways by up to ±0.2 m
        let offset = [
            (pass % 5) as f64 * 0.1 - 0.2,
            ((pass / 5) % 5) as f64 * 0.1 - 0.2,
        ];
        let lidar = SpinningLidar {
            path: base
                .path
                .iter()
                .map(|[x, y]| [x + offset[0], y + offset[1]])
                .collect(),
            ..base.clone()
        };
        let options = ScanOptions {
            seed: pass,
            ..ScanOptions::default()
        };
        let frames = match scan_lidar(&scene, &lidar, &options) {
            Ok((f, _)) => f,
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(2);
            }
        };
        pass += 1;
        for f in &frames {
            if done == total {
                break;
            }
            mapper.insert(f);
            done += 1;
            if done % every == 0 || done == total {
                let tree = mapper.tree().memory_usage();
                let (now, peak) = rss();
                let within = (peak as f64) <= 1.5 * tree as f64 + buffer as f64;
                ok &= within;
                println!(
                    "{done:>7} {:>12.1} {:>12.1} {:>12.1} {:>10.2} {:>8}",
                    mib(tree),
                    mib(now),
                    mib(peak),
                    now as f64 / tree.max(1) as f64,
                    if within { "ok" } else { "EXCEEDED" }
                );
                rows.push((done, tree, now, peak));
            }
        }
    }
    // growth per frame over the second half, when the scene is saturated
    let half: Vec<_> = rows.iter().filter(|r| r.0 > total / 2).collect();
    if let (Some(a), Some(b)) = (half.first(), half.last()) {
        if b.0 > a.0 {
            let per = |x: usize, y: usize| (y as f64 - x as f64) / (b.0 - a.0) as f64;
            let rss_growth = per(a.2, b.2);
            let tree_growth = per(a.1, b.1);
            println!(
                "second half (frames {}..{}): RSS {rss_growth:+.0} bytes/frame, tree {tree_growth:+.0} bytes/frame",
                a.0, b.0
            );
            // resident memory may follow the tree, nothing more (1.5x, a page of slack)
            if rss_growth > 1.5 * tree_growth.max(0.0) + 4096.0 {
                println!("resident memory grows faster than the tree");
                ok = false;
            }
        }
    }
    println!(
        "{}",
        if ok {
            "within the bound"
        } else {
            "BOUND EXCEEDED"
        }
    );
    if !ok {
        std::process::exit(1);
    }
}
