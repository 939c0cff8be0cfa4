//! Memory and speed of the two storages on a long stream (BENCHMARKS.md, the density reducer's
//! storage section).
//!
//! `cargo run --release -p octoquant-density --example stream_memory -- STORAGE FEED [N]`
//!
//! * `STORAGE`: `one-node` ([`DensityGrid::streaming`]) or `all-members` ([`DensityGrid::new`]).
//! * `FEED`: `points` (one [`DensityGrid::insert`] per point) or `batches` (batches of 65536
//!   points through [`DensityGrid::extend`]).
//! * `N`: stream length, 10,000,000 by default.
//!
//! The stream is generated, not read: a terrestrial-scan-like cloud of `N` points drawn on the
//! floor, the walls and the ceiling of a 12 m x 12 m x 3 m room around the origin, rounded to
//! `f32` (as every file's points are), in batches that are made and dropped one at a time, so
//! that the process's peak resident memory is the store's plus one batch. Cell 0.07 m (the
//! paper's). One process per storage and feed: the peak (`VmHWM` of `/proc/self/status`) is
//! the process's own. Prints one JSON line.

use octoquant_density::{DensityGrid, GridSpec};
use std::time::Instant;

const BATCH: usize = 65_536;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: stream_memory one-node|all-members points|batches [N]";
    if args.len() < 2 || args.len() > 3 {
        eprintln!("{usage}");
        std::process::exit(2);
    }
    let n: u64 = match args.get(2).map(|s| s.parse()) {
        None => 10_000_000,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("N: {e}; {usage}");
            std::process::exit(2);
        }
    };
    let spec = GridSpec::<3>::cubic(0.07).expect("a valid cell size");
    let mut grid = match args[0].as_str() {
        "one-node" => DensityGrid::streaming(spec),
        "all-members" => DensityGrid::new(spec),
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let batches = match args[1].as_str() {
        "points" => false,
        "batches" => true,
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let rss_before = peak_rss_kib();
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let mut made = 0u64;
    let mut input_seconds = 0.0;
    let mut batch = Vec::with_capacity(BATCH);
    while made < n {
        batch.clear();
        let k = (n - made).min(BATCH as u64);
        for _ in 0..k {
            batch.push(room_point(&mut rng));
        }
        made += k;
        let t = Instant::now();
        if batches {
            grid.extend_rewalk(batch.iter().copied());
        } else {
            for p in &batch {
                grid.insert(*p);
            }
        }
        input_seconds += t.elapsed().as_secs_f64();
    }
    let t = Instant::now();
    let (out, cycle) = grid.output_cycle();
    let output_seconds = t.elapsed().as_secs_f64();
    let c = grid.counts();
    println!(
        "{{\"storage\":\"{}\",\"feed\":\"{}\",\"points\":{n},\"cells\":{},\"stored\":{},\"discarded\":{},\"output\":{},\"eliminated\":{},\"input_seconds\":{input_seconds:.3},\"output_seconds\":{output_seconds:.3},\"peak_rss_mib_before\":{},\"peak_rss_mib\":{}}}",
        args[0],
        args[1],
        grid.len(),
        grid.point_count(),
        c.discarded,
        out.len(),
        cycle.eliminated,
        mib(rss_before),
        mib(peak_rss_kib()),
    );
}

/// `VmHWM` (peak resident set) in KiB, where `/proc` has it.
fn peak_rss_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn mib(kib: Option<u64>) -> String {
    kib.map_or("null".to_string(), |k| format!("{:.1}", k as f64 / 1024.0))
}

fn uniform(rng: &mut u64) -> f64 {
    *rng = rng
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*rng >> 11) as f64 / (1u64 << 53) as f64
}

/// A point on the floor (half), a wall (four, 40 %) or the ceiling (10 %) of the room, with
/// 5 mm of noise across the surface, rounded to `f32`.
fn room_point(rng: &mut u64) -> [f64; 3] {
    let (a, b, noise) = (uniform(rng), uniform(rng), 0.005 * (uniform(rng) - 0.5));
    let s = uniform(rng);
    let h = 12.0 * a - 6.0;
    let p = if s < 0.5 {
        [h, 12.0 * b - 6.0, noise]
    } else if s < 0.9 {
        let side = if s < 0.7 { -6.0 } else { 6.0 };
        if ((s * 10.0) as u64).is_multiple_of(2) {
            [side + noise, h, 3.0 * b]
        } else {
            [h, side + noise, 3.0 * b]
        }
    } else {
        [h, 12.0 * b - 6.0, 3.0 + noise]
    };
    p.map(|v| f64::from(v as f32))
}
