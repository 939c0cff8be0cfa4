//! The member arena: every cell's members in one contiguous span (`Cell::span`), a full span
//! moved to the end of the arena with room to double, and the arena rewritten once abandoned
//! spans make up most of it.
//!
//! Its narrow form: a batch into an empty grid whose points are all exactly representable in `f32` (every
//! cloud read from an `f32` file) stores its members as `[f32; D]`: half the memory to fill and
//! fault in, and the same `f64` values when read back (`f32 -> f64` is exact). The grid keeps
//! that form (field `narrow`, the `f64` arena `points` then empty) until the first change to a
//! cell's members, which widens the arena to `f64` once.

use super::store::{to_u32, DensityGrid};
use std::ops::Range;
use std::slice;

/// A borrowed view of the member arena, in either form.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ArenaRef<'a, const D: usize> {
    Wide(&'a [[f64; D]]),
    Narrow(&'a [[f32; D]]),
}

impl<'a, const D: usize> ArenaRef<'a, D> {
    /// The members at arena positions `range`, as `f64`.
    #[inline]
    pub(crate) fn members(self, range: Range<usize>) -> Members<'a, D> {
        match self {
            ArenaRef::Wide(a) => Members::Wide(a[range].iter()),
            ArenaRef::Narrow(a) => Members::Narrow(a[range].iter()),
        }
    }

    /// The member at arena position `i`, as `f64`.
    #[inline]
    pub(crate) fn get(self, i: usize) -> [f64; D] {
        match self {
            ArenaRef::Wide(a) => a[i],
            ArenaRef::Narrow(a) => widen_point(&a[i]),
        }
    }

    /// Number of arena places.
    pub(crate) fn len(self) -> usize {
        match self {
            ArenaRef::Wide(a) => a.len(),
            ArenaRef::Narrow(a) => a.len(),
        }
    }
}

/// Members of a cell as `f64` points, from either arena form.
#[derive(Debug, Clone)]
pub(crate) enum Members<'a, const D: usize> {
    Wide(slice::Iter<'a, [f64; D]>),
    Narrow(slice::Iter<'a, [f32; D]>),
}

impl<const D: usize> Iterator for Members<'_, D> {
    type Item = [f64; D];

    #[inline]
    fn next(&mut self) -> Option<[f64; D]> {
        match self {
            Members::Wide(it) => it.next().copied(),
            Members::Narrow(it) => it.next().map(widen_point),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        match self {
            Members::Wide(it) => it.size_hint(),
            Members::Narrow(it) => it.size_hint(),
        }
    }
}

impl<const D: usize> ExactSizeIterator for Members<'_, D> {}

/// `p` as `f64` (exact).
#[inline]
pub(crate) fn widen_point<const D: usize>(p: &[f32; D]) -> [f64; D] {
    p.map(f64::from)
}

/// `p` as `f32` when that is exact (same value, bit for bit, back in `f64`).
#[inline]
pub(crate) fn narrow_point<const D: usize>(p: &[f64; D]) -> Option<[f32; D]> {
    let q = p.map(|v| v as f32);
    (0..D)
        .all(|a| f64::from(q[a]).to_bits() == p[a].to_bits())
        .then_some(q)
}

impl<const D: usize> DensityGrid<D> {
    /// The member arena, in its current form.
    #[inline]
    pub(crate) fn arena(&self) -> ArenaRef<'_, D> {
        match &self.narrow {
            Some(n) => ArenaRef::Narrow(n),
            None => ArenaRef::Wide(&self.points),
        }
    }

    /// Switch the arena to `f64` (a no-op when it is already), and the cells' records out of
    /// their packed form: before any change to members.
    pub(crate) fn widen(&mut self) {
        if let Some(n) = self.narrow.take() {
            self.points = n.iter().map(widen_point).collect();
        }
        self.unpack_cells();
    }

    /// The members of slot `s`.
    #[inline]
    pub(crate) fn members_of(&self, s: usize) -> Members<'_, D> {
        self.arena().members(self.cell(s).span())
    }

    /// Append `run` to the members of slot `s`, moving the cell's span to the end of the arena
    /// (with room to double) when it is full.
    pub(crate) fn push_members(&mut self, s: usize, run: &[[f64; D]]) {
        self.widen();
        let (start, len, cap) = {
            let c = &self.slots[s];
            (c.start, c.len as usize, c.cap as usize)
        };
        let need = len + run.len();
        if start + cap == self.points.len() {
            // Last span of the arena: grow in place.
            self.points.truncate(start + len);
            self.points.extend_from_slice(run);
            self.reserved = self.reserved - cap + need;
            let c = &mut self.slots[s];
            c.len = to_u32(need);
            c.cap = c.len;
        } else if need <= cap {
            self.points[start + len..start + need].copy_from_slice(run);
            self.slots[s].len = to_u32(need);
        } else {
            let new_cap = need.max(2 * len);
            let new_start = self.points.len();
            self.points.extend_from_within(start..start + len);
            self.points.extend_from_slice(run);
            let pad = self.points[new_start];
            self.points.resize(new_start + new_cap, pad);
            self.reserved = self.reserved - cap + new_cap;
            let c = &mut self.slots[s];
            c.start = new_start;
            c.len = to_u32(need);
            c.cap = to_u32(new_cap);
        }
    }

    /// Rewrite the arena without abandoned spans and spare room once they make up most of it.
    pub(crate) fn maybe_compact(&mut self) {
        let live = self.point_count() as usize;
        if self.arena().len() <= 2 * live + 4096 {
            return;
        }
        self.widen();
        let mut arena = Vec::with_capacity(live);
        let order: Vec<u32> = self.index_slots().collect();
        for slot in order {
            let c = &mut self.slots[slot as usize];
            let start = arena.len();
            arena.extend_from_slice(&self.points[c.span()]);
            c.start = start;
            c.cap = c.len;
        }
        self.points = arena;
        self.reserved = live;
    }
}
