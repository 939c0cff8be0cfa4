//! Criterion benchmarks of the online grid density reducer (issue 5) on the real clouds that
//! BENCHMARKS.md compares with PCL's `pcl_voxel_grid`.
//!
//! Ids: `reduce/grid/<cloud>` is the input (grid) stage alone, `reduce/whole/<cloud>` the grid
//! stage plus one output cycle. Both fill the grid with `extend_rewalk`, as `octoquant reduce`
//! does. Data come from `OCTOQUANT_DATA` (or `../shared/data`); a
//! missing cloud is reported and left out.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octoquant::formats::{read_frames, ReadOptions};
use octoquant_density::{DensityGrid, GridSpec};
use std::hint::black_box;
use std::path::PathBuf;

fn data_dir() -> PathBuf {
    match std::env::var_os("OCTOQUANT_DATA") {
        Some(d) => PathBuf::from(d),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
    }
}

/// `(name, cell size, points)` for each cloud that could be read.
fn clouds() -> Vec<(&'static str, f64, Vec<[f64; 3]>)> {
    let d = data_dir();
    let mut out = Vec::new();
    let mut add = |name: &'static str, cell: f64, files: Vec<PathBuf>| {
        let mut pts = Vec::new();
        for f in &files {
            match read_frames(f, &ReadOptions::default()) {
                Ok(frames) => pts.extend(frames.into_iter().flat_map(|fr| {
                    fr.points
                        .into_iter()
                        .map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)])
                })),
                Err(e) => {
                    eprintln!("skipping {name}: {e}");
                    return;
                }
            }
        }
        out.push((name, cell, pts));
    };
    add(
        "table_scene",
        0.01,
        vec![d.join("pcd/pcl_table_scene_mug_stereo_textured/table_scene_mug_stereo_textured.pcd")],
    );
    add(
        "scan_dat",
        0.1,
        vec![d.join("lidar3d/octomap_scan_dat/scan.dat.bz2")],
    );
    let scans = d.join("lidar3d/norlab_icp_mapper_example/scans");
    let mut vtk: Vec<PathBuf> = std::fs::read_dir(&scans)
        .map(|rd| rd.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    vtk.sort();
    add("norlab14", 0.2, vtk);
    out
}

fn bench_reduce(c: &mut Criterion) {
    let clouds = clouds();
    let mut g = c.benchmark_group("reduce");
    g.sample_size(20);
    for (name, cell, pts) in &clouds {
        let spec = GridSpec::cubic(*cell).unwrap();
        g.throughput(Throughput::Elements(pts.len() as u64));
        g.bench_with_input(BenchmarkId::new("grid", name), pts, |b, pts| {
            b.iter(|| {
                let mut grid = DensityGrid::new(spec.clone());
                grid.extend_rewalk(pts.iter().copied());
                black_box(grid.len())
            })
        });
        g.bench_with_input(BenchmarkId::new("whole", name), pts, |b, pts| {
            b.iter(|| {
                let mut grid = DensityGrid::new(spec.clone());
                grid.extend_rewalk(pts.iter().copied());
                black_box(grid.output_cycle().0.len())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_reduce);
criterion_main!(benches);
