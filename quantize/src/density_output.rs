//! The output stage: read cycles over the cells in ascending distance, with the
//! minimum-difference check against the 3^D - 1 neighbouring cells.

use crate::density::CellIndex;
use crate::density_grid::DensityGrid;
use crate::density_index::hash_index;
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
        // Entries after the cursor cell (whatever its slot): `u32::MAX` bounds every slot.
        let after = |c: &Option<(u64, CellIndex<D>)>| match c {
            None => Bound::Unbounded,
            Some((d, i)) => Bound::Excluded((*d, *i, u32::MAX)),
        };
        // Walk the distance order while marking cells: disjoint fields of the store.
        let DensityGrid {
            spec,
            lookup,
            hot,
            by_distance,
            neighbours,
            ..
        } = self;
        let (size, offset) = (*spec.size(), *spec.offset());
        let mut last = None;
        let mut probes: Vec<(CellIndex<D>, u64, u64)> = Vec::with_capacity(neighbours.len());
        for &(d, index, slot) in by_distance
            .range((after(&cycle.cursor), Bound::Unbounded))
            .take(max_cells)
        {
            last = Some((d, index));
            let s = slot as usize;
            let cell = &mut hot[s];
            if cell.stamp > cycle.horizon {
                cycle.counts.deferred += 1;
                continue;
            }
            if cell.mark == cycle.id {
                continue;
            }
            cell.mark = cycle.id;
            let p = cell.point;
            out.push(p);
            cycle.counts.emitted += 1;
            // Per axis, only the side the point leans to can hold a point closer than half a
            // cell; a margin keeps this pruning conservative under rounding.
            let mut up = [false; D];
            let mut down = [false; D];
            for a in 0..D {
                let lo = offset[a] + index[a] as f64 * size[a];
                let hi = offset[a] + (index[a] + 1) as f64 * size[a];
                let eps = 1e-9 * (p[a].abs() + offset[a].abs() + hi.abs() + size[a]);
                up[a] = p[a] > hi - 0.5 * size[a] - eps;
                down[a] = p[a] < lo + 0.5 * size[a] + eps;
            }
            // Neighbours that may hold a close point, with their hashes; then their first
            // buckets, all loaded before any is examined, so that the misses overlap.
            probes.clear();
            for off in neighbours.iter() {
                if (0..D).any(|a| (off[a] == 1 && !up[a]) || (off[a] == -1 && !down[a])) {
                    continue;
                }
                let mut n = index;
                for a in 0..D {
                    n[a] += off[a];
                }
                probes.push((n, hash_index(&n), 0));
            }
            for pr in probes.iter_mut() {
                pr.2 = lookup.first_bucket(pr.1);
            }
            for &(n, h, e) in probes.iter() {
                let ns = {
                    let hot = &*hot;
                    match lookup.find_from(h, e, |c| hot[c as usize].index == n) {
                        Some(c) => c as usize,
                        None => continue,
                    }
                };
                let nc = &mut hot[ns];
                if nc.stamp > cycle.horizon || nc.mark == cycle.id {
                    continue;
                }
                if spec.within_half_cell(&p, &nc.point) {
                    nc.mark = cycle.id;
                    cycle.counts.eliminated += 1;
                }
            }
        }
        if last.is_some() {
            cycle.cursor = last;
        }
        cycle.finished = self
            .by_distance
            .range((after(&cycle.cursor), Bound::Unbounded))
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
