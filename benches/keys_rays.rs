//! Key conversion and ray keys (OctoMap's coordToKey and computeRayKeys).

mod common;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use octoquant::KeyConverter;
use octoquant_raycast::{compute_ray_keys_f32, KeyRay};
use std::hint::black_box;

fn keys(c: &mut Criterion) {
    let frame = common::scan_frame();
    let conv = KeyConverter::new(0.1).unwrap();
    let mut g = c.benchmark_group("keys");
    g.throughput(Throughput::Elements(frame.points.len() as u64));
    g.bench_function("coord_to_key/scan_dat", |b| {
        b.iter(|| {
            let mut acc = 0u64;
            for p in &frame.points {
                if let Some(k) = conv.point_to_key(&p.cast()) {
                    acc = acc.wrapping_add(k.morton());
                }
            }
            black_box(acc)
        })
    });
    g.finish();
}

fn rays(c: &mut Criterion) {
    let frame = common::scan_frame();
    let mut g = c.benchmark_group("rays");
    g.sample_size(10);
    for res in [0.1, 0.2] {
        let conv = KeyConverter::new(res).unwrap();
        g.throughput(Throughput::Elements(frame.points.len() as u64));
        g.bench_function(format!("dda/scan_dat/{res}"), |b| {
            let mut ray = KeyRay::new();
            b.iter(|| {
                let mut n = 0usize;
                for p in &frame.points {
                    compute_ray_keys_f32(&conv, &frame.origin, p, &mut ray);
                    n += ray.len();
                }
                black_box(n)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, keys, rays);
criterion_main!(benches);
