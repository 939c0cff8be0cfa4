//! Input and output stages on two threads sharing one store.
//!
//! The store sits behind one `Mutex`. The input thread locks it per point or per batch; the
//! output thread locks it per step of a read cycle, so insertion goes on between steps and
//! whatever arrives during a cycle is deferred to the next one by the cycle's horizon.

use crate::error::DensityError;
use crate::grid::{DensityGrid, InsertOutcome};
use crate::output::{CycleCounts, OutputCycle};
use std::sync::{Arc, Mutex, MutexGuard};

/// A [`DensityGrid`] shared between an input and an output thread (clone the handle).
///
/// For a long stream share [`DensityGrid::streaming`] (the paper's one node per cell, memory
/// growing with the cells); share a [`DensityGrid::new`] when any point may have to be
/// deleted again.
#[derive(Debug, Clone)]
pub struct SharedDensityGrid<const D: usize> {
    inner: Arc<Mutex<DensityGrid<D>>>,
}

impl<const D: usize> SharedDensityGrid<D> {
    /// Share `grid`.
    pub fn new(grid: DensityGrid<D>) -> Self {
        SharedDensityGrid {
            inner: Arc::new(Mutex::new(grid)),
        }
    }

    /// Lock the store. A panic in another holder does not poison it for us: the store's
    /// operations leave it consistent at every return.
    pub fn lock(&self) -> MutexGuard<'_, DensityGrid<D>> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Input stage: insert one point.
    pub fn insert(&self, p: [f64; D]) -> InsertOutcome {
        self.lock().insert(p)
    }

    /// Input stage: insert a batch under one lock; returns how many were rejected.
    pub fn insert_batch(&self, points: &[[f64; D]]) -> u64 {
        self.lock().extend_rewalk(points.iter().copied())
    }

    /// Input stage: delete one point (see [`DensityGrid::remove`]).
    pub fn remove(&self, p: &[f64; D]) -> bool {
        self.lock().remove(p)
    }

    /// Output stage: begin a read cycle.
    pub fn begin_cycle(&self) -> OutputCycle<D> {
        self.lock().begin_cycle()
    }

    /// Output stage: one step of `cycle` under the lock (see [`DensityGrid::step_cycle`]).
    pub fn step_cycle(
        &self,
        cycle: &mut OutputCycle<D>,
        max_cells: usize,
        out: &mut Vec<[f64; D]>,
    ) -> Result<bool, DensityError> {
        self.lock().step_cycle(cycle, max_cells, out)
    }

    /// Output stage: a whole read cycle in steps of `step` cells (at least 1), releasing the
    /// lock between steps so that input continues.
    pub fn run_cycle(&self, step: usize) -> Result<(Vec<[f64; D]>, CycleCounts), DensityError> {
        let mut cycle = self.begin_cycle();
        let mut out = Vec::new();
        while !self.step_cycle(&mut cycle, step.max(1), &mut out)? {}
        Ok((out, cycle.counts()))
    }

    /// The store, when this is the last handle; otherwise the handle back.
    pub fn try_into_inner(self) -> Result<DensityGrid<D>, Self> {
        match Arc::try_unwrap(self.inner) {
            Ok(m) => Ok(m.into_inner().unwrap_or_else(|e| e.into_inner())),
            Err(inner) => Err(SharedDensityGrid { inner }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{reduce, GridSpec};
    use std::sync::mpsc;
    use std::thread;

    fn lattice(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut x = seed | 1;
        (0..n)
            .map(|_| {
                let mut c = [0.0; 2];
                for v in &mut c {
                    x = x
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    *v = ((x >> 33) % 800) as f64 / 16.0;
                }
                c
            })
            .collect()
    }

    /// The input thread inserts while the output thread is in the middle of a cycle (forced by
    /// channels): the new points are deferred to the next cycle, which sees them.
    #[test]
    fn input_thread_inserts_during_an_output_cycle() {
        let spec = GridSpec::with_sizes([1.0, 1.0]).unwrap();
        let shared = SharedDensityGrid::new(DensityGrid::new(spec.clone()));
        let first = lattice(400, 7);
        let second = lattice(400, 8);
        shared.insert_batch(&first);
        let (go_tx, go_rx) = mpsc::channel::<()>();
        let (done_tx, done_rx) = mpsc::channel::<thread::ThreadId>();
        let input = {
            let shared = shared.clone();
            let second = second.clone();
            thread::spawn(move || {
                go_rx.recv().unwrap();
                shared.insert_batch(&second);
                done_tx.send(thread::current().id()).unwrap();
            })
        };
        let mut cycle = shared.begin_cycle();
        let mut out = Vec::new();
        assert!(!shared.step_cycle(&mut cycle, 10, &mut out).unwrap());
        go_tx.send(()).unwrap();
        let input_id = done_rx.recv().unwrap();
        assert_ne!(input_id, thread::current().id());
        while !shared.step_cycle(&mut cycle, 10, &mut out).unwrap() {}
        input.join().unwrap();
        // This cycle reduced what existed when it began, except cells changed meanwhile.
        assert!(cycle.counts().deferred > 0);
        for p in &out {
            assert!(
                first.contains(p),
                "{p:?} came from the batch inserted mid-cycle"
            );
        }
        // The next cycle sees everything and equals a one-thread reduction of all points.
        let (next, counts) = shared.run_cycle(7).unwrap();
        assert_eq!(counts.deferred, 0);
        let all: Vec<_> = first.iter().chain(&second).copied().collect();
        assert_eq!(next, reduce(all, spec).0);
        shared.lock().validate().unwrap();
    }

    /// Free running: one thread inserts in batches while the other runs cycles until the input
    /// ends; every cycle is a valid reduction and the final one equals the one-thread result.
    #[test]
    fn free_running_input_and_output_threads() {
        let spec = GridSpec::with_sizes([0.5, 2.0]).unwrap();
        let shared = SharedDensityGrid::new(DensityGrid::new(spec.clone()));
        let points = lattice(20_000, 11);
        let (done_tx, done_rx) = mpsc::channel::<()>();
        let input = {
            let shared = shared.clone();
            let points = points.clone();
            thread::spawn(move || {
                for chunk in points.chunks(100) {
                    shared.insert_batch(chunk);
                    thread::yield_now();
                }
                done_tx.send(()).unwrap();
            })
        };
        let mut cycles = 0;
        loop {
            let finished_input = done_rx.try_recv().is_ok();
            let (out, _) = shared.run_cycle(50).unwrap();
            cycles += 1;
            for (a, p) in out.iter().enumerate() {
                for q in &out[a + 1..] {
                    assert!(!spec.within_half_cell(p, q), "{p:?} {q:?}");
                }
            }
            if finished_input {
                assert_eq!(out, reduce(points.iter().copied(), spec.clone()).0);
                break;
            }
        }
        input.join().unwrap();
        eprintln!("{cycles} output cycles ran alongside the input thread");
        let grid = shared.try_into_inner().unwrap();
        grid.validate().unwrap();
        assert_eq!(grid.point_count(), 20_000);
    }
}
