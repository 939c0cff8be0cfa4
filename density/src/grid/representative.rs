//! Each cell's representative: the rank of a member under the selection rule, the best of a
//! cell's members, and the local repair that chooses again when a cell changes.

use super::store::{to_u32, DensityGrid};
use crate::selection::{mean, sanitize_score, Rank, Selection};
use crate::spec::{cmp_points, CellIndex, GridSpec};
use std::cmp::Ordering;

impl<const D: usize> DensityGrid<D> {
    /// The rank of `p` in cell `index` under the selection rule; `mean` is the cell's mean for
    /// [`Selection::MeanClosest`] (without it that rule ranks by the centre distance).
    pub(crate) fn rank_of(
        &self,
        p: &[f64; D],
        index: &CellIndex<D>,
        mean: Option<&[f64; D]>,
    ) -> Rank {
        self.rank_near(p, &self.spec.cell_centre(index), mean)
    }

    /// [`Self::rank_of`] with the cell centre `c` already computed (same arithmetic).
    #[inline]
    pub(crate) fn rank_near(&self, p: &[f64; D], c: &[f64; D], mean: Option<&[f64; D]>) -> Rank {
        let centre = self.spec.distance(p, c);
        let primary = match &self.selection {
            Selection::CentreClosest => centre,
            Selection::MeanClosest => match mean {
                Some(m) => self.spec.distance(p, m),
                None => centre,
            },
            Selection::Score(f) => sanitize_score(f(p)),
        };
        Rank { primary, centre }
    }

    /// The best of `members` (all in cell `index`, at least one) under the selection rule, with
    /// its rank; the mean rule takes the mean of `members`.
    pub(crate) fn best_in(&self, index: &CellIndex<D>, members: &[[f64; D]]) -> (usize, Rank) {
        self.best_of(index, members.iter().copied())
    }

    /// [`Self::best_in`] over members given as an iterator (at least one).
    pub(crate) fn best_of<I>(&self, index: &CellIndex<D>, members: I) -> (usize, Rank)
    where
        I: Iterator<Item = [f64; D]> + Clone,
    {
        let c = self.spec.cell_centre(index);
        if let Selection::CentreClosest = self.selection {
            return centre_closest(&c, &self.spec, members);
        }
        let m = self
            .selection
            .needs_members()
            .then(|| mean(members.clone()));
        let mut it = members;
        let Some(first) = it.next() else {
            return (0, self.rank_near(&c, &c, m.as_ref()));
        };
        let mut best = (0, self.rank_near(&first, &c, m.as_ref()));
        let mut best_point = first;
        for (k, p) in it.enumerate() {
            let r = self.rank_near(&p, &c, m.as_ref());
            if r.cmp_with(&p, &best.1, &best_point) == Ordering::Less {
                best = (k + 1, r);
                best_point = p;
            }
        }
        best
    }

    /// The best member of slot `s` under the selection rule, with its rank.
    pub(crate) fn best_member(&self, s: usize) -> (usize, Rank) {
        self.best_of(&self.hot[s].index, self.members_of(s))
    }

    /// Record member `sel` ranked `rank` as the representative of slot `s` (no bookkeeping).
    pub(super) fn choose(&mut self, s: usize, sel: usize, rank: Rank) {
        self.unpack_cells();
        let cell = &mut self.slots[s];
        cell.selected = to_u32(sel);
        cell.rank = rank;
        let at = cell.point_at();
        self.hot[s].point = self.arena().get(at);
    }

    /// Make member `sel` the representative of slot `s`, keeping the distance order.
    pub(super) fn set_selected(&mut self, s: usize, sel: usize, rank: Rank) {
        self.unpack_cells();
        self.generation += 1;
        let index = self.hot[s].index;
        let old = (self.slots[s].rank.centre.to_bits(), index, s as u32);
        let new = (rank.centre.to_bits(), index, s as u32);
        self.choose(s, sel, rank);
        self.hot[s].stamp = self.generation;
        if old != new {
            let (_, by_distance) = self.trees();
            by_distance.remove(&old);
            by_distance.insert(new);
        }
    }

    /// Local repair: choose the representative of slot `s` again from its members.
    /// Returns `true` when the representative changed.
    pub(super) fn reselect(&mut self, s: usize) -> bool {
        let (k, r) = self.best_member(s);
        let cell = self.cell(s);
        let changed = cmp_points(&self.arena().get(cell.start + k), &self.hot[s].point)
            != Ordering::Equal
            || r.centre.to_bits() != cell.rank.centre.to_bits();
        if changed {
            self.set_selected(s, k, r);
        } else {
            // Same point (perhaps a duplicate at another position): keep the rank fresh.
            self.choose(s, k, r);
        }
        changed
    }
}

/// The [`Selection::CentreClosest`] choice among `members` (at least one; cell centre `c`,
/// distances as `spec` measures them): the rank's primary criterion is the centre distance itself, so one
/// comparison of distances, then of coordinates (the same order as `Rank::cmp_with`).
#[inline]
pub(crate) fn centre_closest<const D: usize>(
    c: &[f64; D],
    spec: &GridSpec<D>,
    members: impl Iterator<Item = [f64; D]>,
) -> (usize, Rank) {
    let mut best = (0, f64::INFINITY, *c);
    for (k, p) in members.enumerate() {
        let d = spec.distance(&p, c);
        if k == 0
            || d.total_cmp(&best.1)
                .then_with(|| cmp_points(&p, &best.2))
                .is_lt()
        {
            best = (k, d, p);
        }
    }
    let rank = Rank {
        primary: best.1,
        centre: best.1,
    };
    (best.0, rank)
}
