//! The incremental brushfire of dynamicEDT3D over a dense 3D grid of cells.
//!
//! Every cell remembers the obstacle cell it believes nearest and the squared distance to it
//! in cells, clamped at `max_sq`. New obstacles start a *lower* wave; removed obstacles start
//! a *raise* wave that invalidates the cells that pointed at them and re-queues their
//! neighbours so the lower wave can refill them. Cells are processed smallest squared distance
//! first, first in first out within a distance ([`BucketQueue`]).
//!
//! A lower step from a cell that is not itself an obstacle only looks at neighbours that lie
//! on the far side of it as seen from its obstacle (per axis: the neighbour's offset has the
//! sign of cell − obstacle, or zero). Together with the tie rules below, this is what makes
//! the result equal to dynamicEDT3D's, including the cells where the brushfire's answer is not
//! the exact Euclidean one (see the crate documentation for the bound).

use crate::queue::BucketQueue;

/// Marker of "no obstacle" in a cell's obstacle coordinates (dynamicEDT3D's `INT_MAX`).
pub(crate) const NO_OBSTACLE: i32 = i32::MAX;

/// Where a cell stands in the wavefront bookkeeping.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// Not queued (initial, or after a raise step).
    Idle,
    /// In the open list.
    Queued,
    /// Lowered: its distance is final for this update.
    Settled,
    /// A removed obstacle waiting for its raise step.
    Removed,
}

/// One grid cell.
#[derive(Debug, Clone, Copy)]
struct Cell {
    /// Distance in cells, as a float (only refreshed when real distances are asked for).
    dist: f32,
    /// The obstacle this cell points at, or [`NO_OBSTACLE`] on every axis.
    obstacle: [i32; 3],
    /// Squared distance to `obstacle` in cells, clamped at the grid's `max_sq`.
    sq_dist: i32,
    stage: Stage,
    /// Whether a raise wave has to pass through this cell.
    raise: bool,
}

/// A dense distance grid: sizes, cells and the pending changes.
#[derive(Debug, Clone)]
pub(crate) struct Grid {
    size: [i32; 3],
    cells: Vec<Cell>,
    max_sq: i32,
    /// `sqrt(max_sq)` in double precision, as the far value is computed.
    max_dist: f64,
    open: BucketQueue,
    added: Vec<[i32; 3]>,
    removed: Vec<[i32; 3]>,
}

/// The 26 neighbour offsets in dynamicEDT3D's visiting order: x offset 0, +1, −1 outermost,
/// then y in the same order, then z.
const NEIGHBOURS: [[i32; 3]; 26] = {
    let order = [0, 1, -1];
    let mut out = [[0; 3]; 26];
    let mut n = 0;
    let mut i = 0;
    while i < 3 {
        let mut j = 0;
        while j < 3 {
            let mut k = 0;
            while k < 3 {
                if !(i == 0 && j == 0 && k == 0) {
                    out[n] = [order[i], order[j], order[k]];
                    n += 1;
                }
                k += 1;
            }
            j += 1;
        }
        i += 1;
    }
    out
};

impl Grid {
    /// A grid of `size` cells (each > 0; the caller checked that the product fits `u32`
    /// indices), every cell far (`max_sq`) and without obstacle. `None` when the memory
    /// cannot be had.
    pub(crate) fn new(size: [i32; 3], max_sq: i32) -> Option<Grid> {
        let max_dist = f64::from(max_sq).sqrt();
        let far = Cell {
            dist: max_dist as f32,
            obstacle: [NO_OBSTACLE; 3],
            sq_dist: max_sq,
            stage: Stage::Idle,
            raise: false,
        };
        let n = (size[0] as usize)
            .checked_mul(size[1] as usize)?
            .checked_mul(size[2] as usize)?;
        let mut cells: Vec<Cell> = Vec::new();
        cells.try_reserve_exact(n).ok()?;
        cells.resize(n, far);
        Some(Grid {
            size,
            cells,
            max_sq,
            max_dist,
            open: BucketQueue::default(),
            added: Vec::new(),
            removed: Vec::new(),
        })
    }

    /// Grid size per axis.
    pub(crate) fn size(&self) -> [i32; 3] {
        self.size
    }

    /// The clamp of squared distances, in cells.
    pub(crate) fn max_sq(&self) -> i32 {
        self.max_sq
    }

    /// `sqrt(max_sq)`, the far distance in cells.
    pub(crate) fn max_dist(&self) -> f64 {
        self.max_dist
    }

    /// Whether `p` is inside the grid.
    pub(crate) fn contains(&self, p: [i32; 3]) -> bool {
        (0..3).all(|a| p[a] >= 0 && p[a] < self.size[a])
    }

    #[inline]
    fn index(&self, p: [i32; 3]) -> usize {
        ((p[0] as usize * self.size[1] as usize) + p[1] as usize) * self.size[2] as usize
            + p[2] as usize
    }

    #[inline]
    fn point(&self, i: usize) -> [i32; 3] {
        let sz = self.size[2] as usize;
        let sy = self.size[1] as usize;
        [
            (i / (sy * sz)) as i32,
            ((i / sz) % sy) as i32,
            (i % sz) as i32,
        ]
    }

    /// A cell is an obstacle when it points at itself.
    #[inline]
    fn is_obstacle_cell(&self, p: [i32; 3]) -> bool {
        self.cells[self.index(p)].obstacle == p
    }

    /// Whether `p` (inside the grid) is currently an obstacle.
    pub(crate) fn is_obstacle(&self, p: [i32; 3]) -> bool {
        self.is_obstacle_cell(p)
    }

    /// Distance in cells stored at `p` (inside the grid).
    pub(crate) fn dist(&self, p: [i32; 3]) -> f32 {
        self.cells[self.index(p)].dist
    }

    /// Squared distance in cells stored at `p` (inside the grid).
    pub(crate) fn sq_dist(&self, p: [i32; 3]) -> i32 {
        self.cells[self.index(p)].sq_dist
    }

    /// The obstacle `p` (inside the grid) points at, if any.
    pub(crate) fn obstacle(&self, p: [i32; 3]) -> Option<[i32; 3]> {
        let o = self.cells[self.index(p)].obstacle;
        (o[0] != NO_OBSTACLE).then_some(o)
    }

    /// Make `p` an obstacle that needs no wave: all its neighbours are obstacles too, so it
    /// is settled at distance zero straight away.
    pub(crate) fn settle_obstacle(&mut self, p: [i32; 3]) {
        let i = self.index(p);
        self.cells[i] = Cell {
            dist: 0.0,
            obstacle: p,
            sq_dist: 0,
            stage: Stage::Settled,
            raise: false,
        };
    }

    /// Mark `p` as a new obstacle; the lower wave starts at the next [`Grid::propagate`].
    pub(crate) fn add_obstacle(&mut self, p: [i32; 3]) {
        if self.is_obstacle_cell(p) {
            return;
        }
        self.added.push(p);
        let i = self.index(p);
        self.cells[i].obstacle = p;
    }

    /// Mark the obstacle `p` as removed; the raise wave starts at the next
    /// [`Grid::propagate`].
    pub(crate) fn remove_obstacle(&mut self, p: [i32; 3]) {
        if !self.is_obstacle_cell(p) {
            return;
        }
        self.removed.push(p);
        let i = self.index(p);
        let c = &mut self.cells[i];
        c.obstacle = [NO_OBSTACLE; 3];
        c.stage = Stage::Removed;
    }

    /// Run the pending changes through the grid until the open list is empty. With
    /// `real_dist` false only squared distances are refreshed (the float distances keep
    /// whatever they held), as dynamicEDT3D's `update(false)`.
    pub(crate) fn propagate(&mut self, real_dist: bool) {
        self.commit(real_dist);
        while let Some(i) = self.open.pop() {
            let i = i as usize;
            let c = self.cells[i];
            if c.stage == Stage::Settled {
                continue;
            }
            let p = self.point(i);
            if c.raise {
                self.raise(p, real_dist);
                let c = &mut self.cells[i];
                c.raise = false;
                c.stage = Stage::Idle;
            } else if c.obstacle[0] != NO_OBSTACLE && self.is_obstacle_cell(c.obstacle) {
                self.lower(p, c, real_dist);
            }
        }
    }

    /// Seed the open list with the added obstacles (distance zero) and the removed ones
    /// (raise), in the order they were marked.
    fn commit(&mut self, real_dist: bool) {
        let added = std::mem::take(&mut self.added);
        for p in added {
            let i = self.index(p);
            let c = &mut self.cells[i];
            if c.stage != Stage::Queued {
                if real_dist {
                    c.dist = 0.0;
                }
                c.sq_dist = 0;
                c.obstacle = p;
                c.stage = Stage::Queued;
                self.open.push(0, i as u32);
            }
        }
        let removed = std::mem::take(&mut self.removed);
        for p in removed {
            if self.is_obstacle_cell(p) {
                // removed and added again before this update
                continue;
            }
            let i = self.index(p);
            self.open.push(0, i as u32);
            let c = &mut self.cells[i];
            if real_dist {
                c.dist = self.max_dist as f32;
            }
            c.sq_dist = self.max_sq;
            c.raise = true;
        }
    }

    /// A raise step at `p`: neighbours pointing at an obstacle that no longer exists are
    /// reset and queued for raising; the others are queued to lower into the gap.
    fn raise(&mut self, p: [i32; 3], real_dist: bool) {
        for d in NEIGHBOURS {
            let n = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
            if !self.contains(n) {
                continue;
            }
            let ni = self.index(n);
            let nc = self.cells[ni];
            if nc.obstacle[0] == NO_OBSTACLE || nc.raise {
                continue;
            }
            if !self.is_obstacle_cell(nc.obstacle) {
                self.open.push(nc.sq_dist, ni as u32);
                let c = &mut self.cells[ni];
                c.stage = Stage::Queued;
                c.raise = true;
                c.obstacle = [NO_OBSTACLE; 3];
                if real_dist {
                    c.dist = self.max_dist as f32;
                }
                c.sq_dist = self.max_sq;
            } else if nc.stage != Stage::Queued {
                self.open.push(nc.sq_dist, ni as u32);
                self.cells[ni].stage = Stage::Queued;
            }
        }
    }

    /// A lower step at `p` (holding `c`, whose obstacle exists): offer that obstacle to the
    /// neighbours on the far side of `p`.
    fn lower(&mut self, p: [i32; 3], c: Cell, real_dist: bool) {
        let i = self.index(p);
        self.cells[i].stage = Stage::Settled;
        let away = [
            p[0] - c.obstacle[0],
            p[1] - c.obstacle[1],
            p[2] - c.obstacle[2],
        ];
        for d in NEIGHBOURS {
            // a step against the direction away from the obstacle is never taken
            if (0..3).any(|a| (d[a] > 0 && away[a] < 0) || (d[a] < 0 && away[a] > 0)) {
                continue;
            }
            let n = [p[0] + d[0], p[1] + d[1], p[2] + d[2]];
            if !self.contains(n) {
                continue;
            }
            self.offer(n, c.obstacle, real_dist);
        }
    }

    /// Offer `obstacle` to cell `n`: it is taken when nearer than what `n` holds, or equally
    /// near while `n`'s own obstacle is gone.
    fn offer(&mut self, n: [i32; 3], obstacle: [i32; 3], real_dist: bool) {
        let ni = self.index(n);
        let nc = self.cells[ni];
        if nc.raise {
            return;
        }
        let sq: i64 = (0..3)
            .map(|a| {
                let d = i64::from(n[a]) - i64::from(obstacle[a]);
                d * d
            })
            .sum();
        let sq = sq.min(i64::from(self.max_sq)) as i32;
        let mut take = sq < nc.sq_dist;
        if !take && sq == nc.sq_dist {
            take = nc.obstacle[0] == NO_OBSTACLE || !self.is_obstacle_cell(nc.obstacle);
        }
        if !take {
            return;
        }
        if sq < self.max_sq {
            self.open.push(sq, ni as u32);
        }
        let c = &mut self.cells[ni];
        if sq < self.max_sq {
            c.stage = Stage::Queued;
        }
        if real_dist {
            c.dist = f64::from(sq).sqrt() as f32;
        }
        c.sq_dist = sq;
        c.obstacle = obstacle;
    }
}

#[cfg(test)]
mod tests {
    use super::NEIGHBOURS;

    #[test]
    fn neighbour_order_starts_with_z_then_y_then_x() {
        assert_eq!(NEIGHBOURS[0], [0, 0, 1]);
        assert_eq!(NEIGHBOURS[1], [0, 0, -1]);
        assert_eq!(NEIGHBOURS[2], [0, 1, 0]);
        assert_eq!(NEIGHBOURS[8], [1, 0, 0]);
        assert_eq!(NEIGHBOURS[17], [-1, 0, 0]);
        assert_eq!(NEIGHBOURS[25], [-1, -1, -1]);
        let mut all = NEIGHBOURS.to_vec();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), 26);
    }
}
