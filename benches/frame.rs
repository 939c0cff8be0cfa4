//! Whole frames through the pipeline, and the quantization pre-pass alone.

mod common;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use octoquant::pipeline::{InsertMode, Mapper, MapperOptions};
use octoquant::KeyConverter;
use octoquant_quantize::{quantize_endpoints, QuantizeOptions};
use std::hint::black_box;

fn quantize(c: &mut Criterion) {
    let frame = common::scan_frame();
    let mut g = c.benchmark_group("quantize");
    g.throughput(Throughput::Elements(frame.points.len() as u64));
    for res in [0.05, 0.1, 0.2] {
        let conv = KeyConverter::new(res).unwrap();
        g.bench_function(format!("voxel_keys/scan_dat/{res}"), |b| {
            let mut out = Vec::new();
            b.iter(|| {
                black_box(quantize_endpoints(
                    &conv,
                    &frame.points,
                    &QuantizeOptions::default(),
                    &mut out,
                ))
            })
        });
    }
    g.finish();
}

fn whole_frame(c: &mut Criterion) {
    let frame = common::scan_frame();
    let mut g = c.benchmark_group("frame");
    g.sample_size(10);
    g.throughput(Throughput::Elements(frame.points.len() as u64));
    for (name, mode) in [
        ("exact", InsertMode::Exact),
        ("quantized", InsertMode::Quantized),
    ] {
        g.bench_function(format!("{name}/scan_dat/0.1"), |b| {
            b.iter(|| {
                let mut m = Mapper::new(MapperOptions {
                    resolution: 0.1,
                    mode,
                    ..MapperOptions::default()
                })
                .unwrap();
                m.insert(&frame);
                black_box(m.tree().size())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, quantize, whole_frame);
criterion_main!(benches);
