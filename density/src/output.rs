//! The output stage: read cycles over the cells in ascending distance, with the
//! minimum-difference check against the 3^D - 1 neighbouring cells.

use crate::error::DensityError;
use crate::grid::{distance_slots_after, hash_index, DensityGrid};
use crate::spec::CellIndex;

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
    ) -> Result<bool, DensityError> {
        if cycle.id != self.cycle {
            return Err(DensityError::StaleCycle {
                cycle: cycle.id,
                current: self.cycle,
            });
        }
        if cycle.finished {
            return Ok(true);
        }
        // Walk the distance order while marking cells: disjoint fields of the store.
        let DensityGrid {
            spec,
            lookup,
            hot,
            by_distance,
            built,
            ..
        } = self;
        let (size, offset) = (*spec.size(), *spec.offset());
        let mut last = None;
        let mut probes: Vec<(CellIndex<D>, u64, u64)> = Vec::with_capacity(1 << D);
        for (d, slot) in distance_slots_after(built, by_distance, hot, cycle.cursor).take(max_cells)
        {
            let s = slot as usize;
            let cell = &mut hot[s];
            let index = cell.index;
            last = Some((d, index));
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
            if (0..D).all(|a| up[a] != down[a]) && D < usize::BITS as usize {
                // The usual case, one side per axis: the 2^D - 1 neighbours are the non-empty
                // sets of axes to step along, each toward its side.
                let step: [i64; D] = std::array::from_fn(|a| if up[a] { 1 } else { -1 });
                for set in 1..1usize << D {
                    let mut n = index;
                    for a in 0..D {
                        if set >> (D - 1 - a) & 1 == 1 {
                            n[a] += step[a];
                        }
                    }
                    probes.push((n, hash_index(&n), 0));
                }
            } else {
                for_each_lean_neighbour(&index, &up, &down, |n| {
                    probes.push((n, hash_index(&n), 0));
                });
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
        cycle.finished = self.distance_slots_after(cycle.cursor).next().is_none();
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

/// Calls `f` with every neighbour of cell `index` (offsets in {-1, 0, 1}^D, not all zero) whose
/// offset is 1 only on axes where `up` holds and -1 only where `down` holds, in lexicographic
/// order of the offsets. Costs O(number of such neighbours), not O(3^D).
pub(crate) fn for_each_lean_neighbour<const D: usize>(
    index: &CellIndex<D>,
    up: &[bool; D],
    down: &[bool; D],
    mut f: impl FnMut(CellIndex<D>),
) {
    // Allowed offsets per axis, ascending.
    let mut choice = [[0i64; 3]; D];
    let mut count = [0usize; D];
    for a in 0..D {
        let mut k = 0;
        if down[a] {
            choice[a][k] = -1;
            k += 1;
        }
        choice[a][k] = 0;
        k += 1;
        if up[a] {
            choice[a][k] = 1;
            k += 1;
        }
        count[a] = k;
    }
    // Odometer over the allowed offsets, the last axis fastest.
    let mut pos = [0usize; D];
    loop {
        let mut n = *index;
        let mut zero = true;
        for a in 0..D {
            let o = choice[a][pos[a]];
            n[a] += o;
            zero &= o == 0;
        }
        if !zero {
            f(n);
        }
        let mut a = D;
        loop {
            if a == 0 {
                return;
            }
            a -= 1;
            pos[a] += 1;
            if pos[a] < count[a] {
                break;
            }
            pos[a] = 0;
        }
    }
}
