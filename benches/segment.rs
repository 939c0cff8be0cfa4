//! Issue 6: DBSCAN1D (Meglicki) against two general DBSCANs on the same 1D data:
//! petal-clustering 0.12 (ball tree radius queries, neighbourhoods computed on rayon's default
//! pool, so on both cores) and linfa-clustering 0.8 (k-d tree). Run time against N (should be
//! linear) and against epsilon (should be flat).
//!
//! Data: N points uniform in [0, N) (density 1 per unit), sorted; min_points = 4. Before timing,
//! each case checks that the general implementation finds the same number of clusters and of
//! noise points as DBSCAN1D.
//!
//! petal gets the points in a shuffled order (`petal_dbscan`): its ball tree splits nodes by a
//! quickselect that takes the last element as pivot, which is quadratic on sorted input
//! (`petal_dbscan_sorted`, timed only up to 10k points). petal also departs from DBSCAN in one
//! detail: it drops a cluster left with fewer than `min_points` members once earlier clusters
//! have taken the border points it shares with them; its expected counts are derived from
//! DBSCAN1D's result and petal's visiting order ([`petal_expected`]). petal takes 12 to 14 s
//! per run at 1M points, so against epsilon it runs on 10k points only. linfa's DBSCAN grows
//! quadratically on this data (280 ms at 10k points, ~160 s at 100k on the reference machine),
//! so it is timed only up to 30k points.
//! Run: `cargo bench --bench segment` (figures in BENCHMARKS.md).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use linfa::prelude::*;
use linfa_clustering::Dbscan;
use ndarray::Array2;
use octoquant_segment::{dbscan1d, BorderPolicy, Clustering, Dbscan1dParams};
use petal_clustering::Fit;
use petal_neighbors::distance::Euclidean;
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

/// A fixed pseudo-random permutation of `0..n` (Fisher-Yates, splitmix64).
fn permutation(n: usize, seed: u64) -> Vec<usize> {
    let mut state = seed;
    let mut p: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        p.swap(i, ((z ^ (z >> 31)) % (i as u64 + 1)) as usize);
    }
    p
}

fn ours(x: &[f64], eps: f64, out: &mut Clustering) {
    let p = Dbscan1dParams::new(eps, MIN_POINTS).expect("params");
    dbscan1d(x, &p, out).expect("dbscan1d");
}

/// linfa's DBSCAN: (number of clusters, number of noise points).
fn linfa(x: &Array2<f64>, eps: f64) -> (usize, usize) {
    let labels = Dbscan::params(MIN_POINTS)
        .tolerance(eps)
        .transform(x)
        .expect("linfa params");
    let clusters = labels.iter().flatten().max().map_or(0, |m| m + 1);
    let noise = labels.iter().filter(|l| l.is_none()).count();
    (clusters, noise)
}

/// petal's DBSCAN: (number of clusters, number of noise points).
fn petal(x: &Array2<f64>, eps: f64) -> (usize, usize) {
    let (clusters, noise) =
        petal_clustering::Dbscan::new(eps, MIN_POINTS, Euclidean::default()).fit(x, None);
    (clusters.len(), noise.len())
}

/// DBSCAN1D's (number of clusters, number of noise points); linfa must match it exactly.
fn expected(x: &[f64], eps: f64) -> (usize, usize) {
    let mut out = Clustering::new();
    ours(x, eps, &mut out);
    (out.n_clusters(), out.noise_count())
}

/// What petal must report when it visits sorted point `i` at position `rank[i]`: DBSCAN's
/// clusters, each border point given to the first-discovered cluster that reaches it (the
/// first in visiting order to hold a core point), minus the clusters then left with fewer
/// than `min_points` members, whose points petal reports as noise.
fn petal_expected(x: &[f64], eps: f64, rank: &[usize]) -> (usize, usize) {
    let p = Dbscan1dParams::new(eps, MIN_POINTS)
        .expect("params")
        .with_border(BorderPolicy::All);
    let mut out = Clustering::new();
    dbscan1d(x, &p, &mut out).expect("dbscan1d");
    let mut found = vec![usize::MAX; out.n_clusters()];
    for i in (0..x.len()).filter(|&i| out.is_core(i)) {
        let c = out.labels()[i] as usize;
        found[c] = found[c].min(rank[i]);
    }
    let mut size = vec![0usize; out.n_clusters()];
    for i in 0..x.len() {
        let Some(a) = out.label(i) else { continue };
        let c = match out.second_label(i) {
            Some(b) if found[b as usize] < found[a as usize] => b,
            _ => a,
        };
        size[c as usize] += 1;
    }
    let kept: Vec<usize> = size.into_iter().filter(|&s| s >= MIN_POINTS).collect();
    (kept.len(), x.len() - kept.iter().sum::<usize>())
}

/// Points sorted, in the order given to petal: (column, rank of each sorted point).
fn petal_input(x: &[f64], shuffle: bool) -> (Array2<f64>, Vec<usize>) {
    let order = if shuffle {
        permutation(x.len(), 66)
    } else {
        (0..x.len()).collect()
    };
    let mut rank = vec![0; x.len()];
    for (k, &i) in order.iter().enumerate() {
        rank[i] = k;
    }
    let col = Array2::from_shape_fn((x.len(), 1), |(k, _)| x[order[k]]);
    (col, rank)
}

fn column(x: &[f64]) -> Array2<f64> {
    Array2::from_shape_vec((x.len(), 1), x.to_vec()).expect("shape")
}

/// Check, then time, petal on `x` (shuffled or sorted) under `id`.
fn bench_petal(
    g: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
    id: BenchmarkId,
    x: &[f64],
    eps: f64,
    shuffle: bool,
) {
    let (col, rank) = petal_input(x, shuffle);
    assert_eq!(
        petal(&col, eps),
        petal_expected(x, eps, &rank),
        "petal n={} eps={eps}",
        x.len()
    );
    g.bench_with_input(id, &col, |b, col| b.iter(|| petal(black_box(col), eps)));
}

/// Check, then time, linfa on `x` under `id`.
fn bench_linfa(
    g: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
    id: BenchmarkId,
    x: &[f64],
    eps: f64,
) {
    let col = column(x);
    assert_eq!(
        linfa(&col, eps),
        expected(x, eps),
        "linfa n={} eps={eps}",
        x.len()
    );
    g.bench_with_input(id, &col, |b, col| b.iter(|| linfa(black_box(col), eps)));
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
        bench_petal(&mut g, BenchmarkId::new("petal_dbscan", n), &x, eps, true);
        if n <= 10_000 {
            let id = BenchmarkId::new("petal_dbscan_sorted", n);
            bench_petal(&mut g, id, &x, eps, false);
        }
        if n <= 30_000 {
            bench_linfa(&mut g, BenchmarkId::new("linfa_dbscan", n), &x, eps);
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
    for eps in [0.01, 0.1, 1.0, 10.0, 100.0] {
        let mut out = Clustering::new();
        g.bench_with_input(BenchmarkId::new("dbscan1d_1M", eps), &big, |b, x| {
            b.iter(|| ours(black_box(x), eps, &mut out))
        });
        g.bench_with_input(BenchmarkId::new("dbscan1d_10k", eps), &small, |b, x| {
            b.iter(|| ours(black_box(x), eps, &mut out))
        });
        bench_petal(
            &mut g,
            BenchmarkId::new("petal_dbscan_10k", eps),
            &small,
            eps,
            true,
        );
        // linfa is quadratic here: it runs on 10k points and stops at eps = 10.
        if eps <= 10.0 {
            bench_linfa(
                &mut g,
                BenchmarkId::new("linfa_dbscan_10k", eps),
                &small,
                eps,
            );
        }
    }
    g.finish();
}

criterion_group!(benches, vs_n, vs_eps);
criterion_main!(benches);
