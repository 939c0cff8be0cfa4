//! Tree updates: one `update_node` per key (OctoMap's loop) against the batched `update_keys`
//! and `update_bricks`, on the free and occupied voxels of a real scan.

mod common;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use octoquant::{InnerNodes, OcTree, Update};
use octoquant_raycast::{compute_update_f32, ScanUpdate};

fn update(c: &mut Criterion) {
    let frame = common::scan_frame();
    let tree = OcTree::new(0.1).unwrap();
    let mut up = ScanUpdate::new();
    compute_update_f32(
        tree.converter(),
        &frame.points,
        &frame.origin,
        None,
        &mut up,
    );
    let n = (up.free().len() + up.occupied().len()) as u64;
    let mut g = c.benchmark_group("update");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    g.bench_function("update_node/scan_dat", |b| {
        b.iter_batched(
            || tree.clone(),
            |mut t| {
                for k in up.free() {
                    t.update_node(*k, Update::Miss, InnerNodes::Refresh);
                }
                for k in up.occupied() {
                    t.update_node(*k, Update::Hit, InnerNodes::Refresh);
                }
                t
            },
            BatchSize::LargeInput,
        )
    });
    g.bench_function("update_keys/scan_dat", |b| {
        b.iter_batched(
            || tree.clone(),
            |mut t| {
                t.update_keys(up.free(), Update::Miss, InnerNodes::Refresh);
                t.update_keys(up.occupied(), Update::Hit, InnerNodes::Refresh);
                t
            },
            BatchSize::LargeInput,
        )
    });
    g.bench_function("update_bricks/scan_dat", |b| {
        b.iter_batched(
            || tree.clone(),
            |mut t| {
                t.update_bricks(up.free_bricks(), Update::Miss, InnerNodes::Refresh);
                t.update_bricks(up.occupied_bricks(), Update::Hit, InnerNodes::Refresh);
                t
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, update);
criterion_main!(benches);
