//! A counting global allocator for the tests that bound the memory and work of readers on
//! hostile input (`formats/tests/bounds.rs`, `octree/tests/bounds.rs`).
//!
//! A test binary installs it with
//! `#[global_allocator] static ALLOC: CountingAlloc = CountingAlloc;` and measures one call
//! with [`measure`] while holding [`serial`]: the counters are process-wide, so a test
//! building its input on another thread would otherwise show in a measurement.
#![deny(missing_docs)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering::Relaxed};
use std::sync::{Mutex, MutexGuard};

/// The system allocator with counters: live bytes, their peak, bytes and calls in all.
pub struct CountingAlloc;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static TOTAL: AtomicU64 = AtomicU64::new(0);
static CALLS: AtomicU64 = AtomicU64::new(0);

fn grew(bytes: usize) {
    let live = LIVE.fetch_add(bytes, Relaxed) + bytes;
    PEAK.fetch_max(live, Relaxed);
    TOTAL.fetch_add(bytes as u64, Relaxed);
    CALLS.fetch_add(1, Relaxed);
}

// SAFETY: every call is forwarded unchanged to the system allocator; only counters are added.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        LIVE.fetch_sub(layout.size(), Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = System.realloc(ptr, layout, new_size);
        if !p.is_null() {
            // counted as the new block coming before the old one goes (the worst case)
            grew(new_size);
            LIVE.fetch_sub(layout.size(), Relaxed);
        }
        p
    }
}

/// What one call cost in allocations (meaningful only with [`CountingAlloc`] installed).
#[derive(Debug, Clone, Copy)]
pub struct Cost {
    /// Most bytes live at once beyond those live before the call.
    pub peak: usize,
    /// Bytes allocated in all (a measure of work: re-reading or quadratic copying shows).
    pub total: u64,
    /// Allocation calls.
    pub calls: u64,
}

/// Run `f` and return its result with what it allocated.
pub fn measure<T>(f: impl FnOnce() -> T) -> (T, Cost) {
    let base = LIVE.load(Relaxed);
    PEAK.store(base, Relaxed);
    let (total0, calls0) = (TOTAL.load(Relaxed), CALLS.load(Relaxed));
    let out = f();
    let cost = Cost {
        peak: PEAK.load(Relaxed).saturating_sub(base),
        total: TOTAL.load(Relaxed) - total0,
        calls: CALLS.load(Relaxed) - calls0,
    };
    (out, cost)
}

static SERIAL: Mutex<()> = Mutex::new(());

/// A lock that makes measuring tests run one at a time (a failed test does not poison it).
pub fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}
