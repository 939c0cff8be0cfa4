//! Issue 6: DBSCAN1D (Meglicki) against a general DBSCAN (linfa-clustering 0.8, k-d tree
//! neighbour queries) on the same sorted 1D data: run time against N (should be linear) and
//! against epsilon (should be flat).
//!
//! Data: N points uniform in [0, N) (density 1 per unit), sorted; min_points = 4. Before timing,
//! each case checks that both implementations find the same clusters and the same noise.
//! linfa's DBSCAN grows quadratically on this data (280 ms at 10k points, ~160 s at 100k on
//! the reference machine), so it is timed only up to 30k points; DBSCAN1D runs up to 1M.
//! Run: `cargo bench --bench segment` (figures in BENCHMARKS.md).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use linfa::prelude::*;
use linfa_clustering::Dbscan;
use ndarray::Array2;
use octoquant_segment::{dbscan1d, Clustering, Dbscan1dParams, NOISE};
use std::hint::black_box;
use std::time::Duration;

const MIN_POINTS: usize = 4;

/// `n` sorted values uniform in [0, n), from a fixed seed (splitmix64).
fn data(n: usize, seed: u64) -> Vec<f64> {
    let mut state = seed;
    let mut x: Vec<f64> = (0..n)
        .map(|_| {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * n as f64
        })
        .collect();
    x.sort_unstable_by(f64::total_cmp);
    x
}

fn ours(x: &[f64], eps: f64, out: &mut Clustering) {
    let p = Dbscan1dParams::new(eps, MIN_POINTS).expect("params");
    dbscan1d(x, &p, out).expect("dbscan1d");
}

fn general(x: &Array2<f64>, eps: f64) -> ndarray::Array1<Option<usize>> {
    Dbscan::params(MIN_POINTS)
        .tolerance(eps)
        .transform(x)
        .expect("linfa params")
}

/// Both must agree on the number of clusters and of noise points (core points decide both;
/// border points are assigned identically up to cluster numbering).
fn check_same(x: &[f64], col: &Array2<f64>, eps: f64) {
    let mut out = Clustering::new();
    ours(x, eps, &mut out);
    let labels = general(col, eps);
    let clusters = labels.iter().flatten().max().map_or(0, |m| m + 1);
    let noise = labels.iter().filter(|l| l.is_none()).count();
    let our_noise = out.labels().iter().filter(|&&l| l == NOISE).count();
    assert_eq!(
        (out.n_clusters(), our_noise),
        (clusters, noise),
        "n={} eps={eps}",
        x.len()
    );
}

fn column(x: &[f64]) -> Array2<f64> {
    Array2::from_shape_vec((x.len(), 1), x.to_vec()).expect("shape")
}

fn vs_n(c: &mut Criterion) {
    let mut g = c.benchmark_group("segment/n");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let eps = 0.5;
    for n in [1_000usize, 3_000, 10_000, 30_000, 100_000, 1_000_000] {
        let x = data(n, 6);
        g.throughput(Throughput::Elements(n as u64));
        let mut out = Clustering::new();
        g.bench_with_input(BenchmarkId::new("dbscan1d", n), &x, |b, x| {
            b.iter(|| ours(black_box(x), eps, &mut out))
        });
        if n <= 30_000 {
            let col = column(&x);
            check_same(&x, &col, eps);
            g.bench_with_input(BenchmarkId::new("linfa_dbscan", n), &col, |b, col| {
                b.iter(|| general(black_box(col), eps))
            });
        }
    }
    g.finish();
}

fn vs_eps(c: &mut Criterion) {
    let mut g = c.benchmark_group("segment/eps");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let big = data(1_000_000, 7);
    let small = data(10_000, 7);
    let small_col = column(&small);
    for eps in [0.01, 0.1, 1.0, 10.0, 100.0] {
        let mut out = Clustering::new();
        g.bench_with_input(BenchmarkId::new("dbscan1d_1M", eps), &big, |b, x| {
            b.iter(|| ours(black_box(x), eps, &mut out))
        });
        // The general DBSCAN is quadratic here: it runs on 10k points and stops at eps = 10.
        if eps <= 10.0 {
            check_same(&small, &small_col, eps);
            g.bench_with_input(BenchmarkId::new("dbscan1d_10k", eps), &small, |b, x| {
                b.iter(|| ours(black_box(x), eps, &mut out))
            });
            g.bench_with_input(
                BenchmarkId::new("linfa_dbscan_10k", eps),
                &small_col,
                |b, col| b.iter(|| general(black_box(col), eps)),
            );
        }
    }
    g.finish();
}

criterion_group!(benches, vs_n, vs_eps);
criterion_main!(benches);
