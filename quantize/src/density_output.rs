//! The output stage: read cycles over the cells in ascending distance, with the
//! minimum-difference check against the 3^D - 1 neighbouring cells.

use crate::density::CellIndex;
use crate::density_grid::DensityGrid;
use crate::error::QuantizeError;
use std::ops::Bound;

/// Counts of one output cycle so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CycleCounts {
    /// Cells whose point was emitted.
    pub emitted: u64,
    /// Cells skipped because a neighbour's emitted point is within half a cell on every axis.
    pub eliminated: u64,
    /// Cells created or changed after the cycle began: left to the next cycle.
    pub deferred: u64,
}

/// One read cycle of the output stage, stepped with [`DensityGrid::step_cycle`].
///
/// The cycle holds its id, the input generation at which it began (cells stamped later are
/// deferred to the next cycle) and a cursor into the distance order, so input may continue
/// between steps. Only the newest cycle of a grid may be stepped.
#[derive(Debug, Clone)]
pub struct OutputCycle<const D: usize> {
    id: u64,
    horizon: u64,
    cursor: Option<(u64, CellIndex<D>)>,
    finished: bool,
    counts: CycleCounts,
}

impl<const D: usize> OutputCycle<D> {
    /// The read-cycle id (1 for the first cycle of a grid).
    pub fn id(&self) -> u64 {
        self.id
    }
    /// `true` once every cell has been visited.
    pub fn is_finished(&self) -> bool {
        self.finished
    }
    /// Counts so far.
    pub fn counts(&self) -> CycleCounts {
        self.counts
    }
}

impl<const D: usize> DensityGrid<D> {
    /// Start a new read cycle; cells created or changed from now on wait for the next one.
    pub fn begin_cycle(&mut self) -> OutputCycle<D> {
        self.cycle += 1;
        OutputCycle {
            id: self.cycle,
            horizon: self.generation,
            cursor: None,
            finished: false,
            counts: CycleCounts::default(),
        }
    }

    /// Visit up to `max_cells` more cells of `cycle` in ascending distance, appending emitted
    /// points to `out`; returns `Ok(true)` when the cycle is finished.
    ///
    /// A visited cell not yet decided in this cycle emits its point; then every neighbouring
    /// cell (3^D - 1) not yet decided whose point is closer than half a cell size on every axis
    /// is eliminated for this cycle. `max_cells == 0` visits nothing.
    pub fn step_cycle(
        &mut self,
        cycle: &mut OutputCycle<D>,
        max_cells: usize,
        out: &mut Vec<[f64; D]>,
    ) -> Result<bool, QuantizeError> {
        if cycle.id != self.cycle {
            return Err(QuantizeError::StaleCycle {
                cycle: cycle.id,
                current: self.cycle,
            });
        }
        if cycle.finished {
            return Ok(true);
        }
        let lower = match &cycle.cursor {
            None => Bound::Unbounded,
            Some(c) => Bound::Excluded(*c),
        };
        // Collect the next keys first: marking neighbours needs `&mut self`.
        let keys: Vec<(u64, CellIndex<D>)> = self
            .by_distance
            .range((lower, Bound::Unbounded))
            .take(max_cells)
            .copied()
            .collect();
        for key in &keys {
            let slot = self.index[&key.1] as usize;
            let cell = &self.slots[slot];
            if cell.stamp > cycle.horizon {
                cycle.counts.deferred += 1;
                continue;
            }
            if cell.mark == cycle.id {
                continue;
            }
            let p = *cell.point();
            let index = cell.index;
            self.slots[slot].mark = cycle.id;
            out.push(p);
            cycle.counts.emitted += 1;
            // Per axis, only the side the point leans to can hold a point closer than half a
            // cell; a margin keeps this pruning conservative under rounding.
            let mut up = [false; D];
            let mut down = [false; D];
            let (size, offset) = (self.spec.size(), self.spec.offset());
            for a in 0..D {
                let lo = offset[a] + index[a] as f64 * size[a];
                let hi = offset[a] + (index[a] + 1) as f64 * size[a];
                let eps = 1e-9 * (p[a].abs() + offset[a].abs() + hi.abs() + size[a]);
                up[a] = p[a] > hi - 0.5 * size[a] - eps;
                down[a] = p[a] < lo + 0.5 * size[a] + eps;
            }
            for k in 0..self.neighbours.len() {
                let off = self.neighbours[k];
                if (0..D).any(|a| (off[a] == 1 && !up[a]) || (off[a] == -1 && !down[a])) {
                    continue;
                }
                let mut n = index;
                for a in 0..D {
                    n[a] += off[a];
                }
                let Some(&ns) = self.index.get(&n) else {
                    continue;
                };
                let nc = &mut self.slots[ns as usize];
                if nc.stamp > cycle.horizon || nc.mark == cycle.id {
                    continue;
                }
                if self.spec.within_half_cell(&p, &nc.members[nc.selected]) {
                    nc.mark = cycle.id;
                    cycle.counts.eliminated += 1;
                }
            }
        }
        if let Some(last) = keys.last() {
            cycle.cursor = Some(*last);
        }
        let lower = match &cycle.cursor {
            None => Bound::Unbounded,
            Some(c) => Bound::Excluded(*c),
        };
        cycle.finished = self
            .by_distance
            .range((lower, Bound::Unbounded))
            .next()
            .is_none();
        Ok(cycle.finished)
    }

    /// Run one complete read cycle and return the emitted points in output order.
    pub fn output_cycle(&mut self) -> (Vec<[f64; D]>, CycleCounts) {
        let mut cycle = self.begin_cycle();
        let mut out = Vec::with_capacity(self.len());
        // A fresh cycle is current and the grid is not shared, so this cannot be stale.
        let _ = self.step_cycle(&mut cycle, usize::MAX, &mut out);
        (out, cycle.counts)
    }
}
