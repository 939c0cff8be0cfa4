//! The allocator counts what a call allocates: a measurement of nothing would make every
//! bound in the tests that use it pass vacuously.

use octoquant_alloc_count::{measure, serial, CountingAlloc};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

#[test]
fn a_megabyte_shows_in_peak_total_and_calls() {
    let _serial = serial();
    let (v, cost) = measure(|| vec![7u8; 1 << 20]);
    assert_eq!(v.len(), 1 << 20);
    assert!(cost.peak >= 1 << 20 && cost.total >= 1 << 20, "{cost:?}");
    assert!(cost.calls >= 1);
    // freed memory is not live: a second measurement after dropping starts from zero peak
    drop(v);
    let ((), cost) = measure(|| ());
    assert_eq!((cost.peak, cost.total, cost.calls), (0, 0, 0));
}
