//! Property tests of the density reducer against naive definitions.

use octoquant_density::{CentreDistance, DensityGrid, GridSpec, Selection, Storage};
use proptest::prelude::*;
use std::cmp::Ordering;
use std::collections::BTreeMap;

/// Naive cell index, written out again from the definition.
fn naive_index<const D: usize>(p: &[f64; D], size: &[f64; D], off: &[f64; D]) -> [i64; D] {
    let mut i = [0; D];
    for a in 0..D {
        i[a] = ((p[a] - off[a]) / size[a]).floor() as i64;
    }
    i
}

/// Squared distance from `p` to the centre of cell `i`, from the paper's Eq. 3: Euclidean in
/// the input's units (`metres`), or, for the cell-units option, each axis divided by its size.
fn naive_dist<const D: usize>(
    p: &[f64; D],
    i: &[i64; D],
    size: &[f64; D],
    off: &[f64; D],
    metres: bool,
) -> f64 {
    let mut d = 0.0;
    for a in 0..D {
        let c = off[a] + (i[a] as f64 + 0.5) * size[a];
        let t = if metres {
            p[a] - c
        } else {
            (p[a] - c) / size[a]
        };
        d += t * t;
    }
    d
}

fn lex<const D: usize>(a: &[f64; D], b: &[f64; D]) -> Ordering {
    (0..D)
        .map(|k| a[k].total_cmp(&b[k]))
        .find(|o| o.is_ne())
        .unwrap_or(Ordering::Equal)
}

fn close<const D: usize>(a: &[f64; D], b: &[f64; D], size: &[f64; D]) -> bool {
    (0..D).all(|k| (a[k] - b[k]).abs() < 0.5 * size[k])
}

fn neighbours<const D: usize>(a: &[i64; D], b: &[i64; D]) -> bool {
    a != b && (0..D).all(|k| (a[k] - b[k]).abs() <= 1)
}

/// Naive grid stage: every cell's closest-to-centre point (ties by coordinates).
fn naive_grid<const D: usize>(
    pts: &[[f64; D]],
    size: &[f64; D],
    off: &[f64; D],
    metres: bool,
) -> BTreeMap<[i64; D], ([f64; D], f64)> {
    let mut cells: BTreeMap<[i64; D], ([f64; D], f64)> = BTreeMap::new();
    for p in pts {
        let i = naive_index(p, size, off);
        let d = naive_dist(p, &i, size, off, metres);
        let e = cells.entry(i).or_insert((*p, d));
        if d.total_cmp(&e.1).then_with(|| lex(p, &e.0)) == Ordering::Less {
            *e = (*p, d);
        }
    }
    cells
}

/// Naive output stage: cells in (distance, index) order, greedy, O(n^2).
fn naive_output<const D: usize>(
    cells: &BTreeMap<[i64; D], ([f64; D], f64)>,
    size: &[f64; D],
) -> Vec<[f64; D]> {
    let mut order: Vec<_> = cells.iter().map(|(i, (p, d))| (*d, *i, *p)).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut decided: BTreeMap<[i64; D], bool> = BTreeMap::new();
    let mut out = Vec::new();
    for (_, i, p) in &order {
        if decided.contains_key(i) {
            continue;
        }
        decided.insert(*i, true);
        out.push(*p);
        for (_, j, q) in &order {
            if neighbours(i, j) && !decided.contains_key(j) && close(p, q, size) {
                decided.insert(*j, false);
            }
        }
    }
    out
}

/// Coordinates on a 1/8 lattice so that ties, cell edges and exact half-cell gaps occur.
fn coord() -> impl Strategy<Value = f64> {
    (-64i32..64).prop_map(|v| f64::from(v) / 8.0)
}

fn pts2(n: usize) -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec([coord(), coord()], 0..n)
}

fn pts3(n: usize) -> impl Strategy<Value = Vec<[f64; 3]>> {
    prop::collection::vec([coord(), coord(), coord()], 0..n)
}

fn size() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(0.75), Just(2.0), 0.3f64..3.0]
}

fn offset() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), -2.0f64..2.0]
}

fn spec3() -> impl Strategy<Value = ([f64; 3], [f64; 3])> {
    ([size(), size(), size()], [offset(), offset(), offset()])
}

fn spec2() -> impl Strategy<Value = ([f64; 2], [f64; 2])> {
    ([size(), size()], [offset(), offset()])
}

/// Checks every output property of one grid against the naive definitions: the default grid
/// (Euclidean centre distance, `metres`) or the cell-units option.
fn check_reduction<const D: usize>(pts: &[[f64; D]], size: [f64; D], off: [f64; D], metres: bool) {
    let mut spec = GridSpec::new(size, off).unwrap();
    if !metres {
        spec = spec.with_centre_distance(CentreDistance::CellUnits);
    }
    let mut g = DensityGrid::new(spec);
    g.extend(pts.iter().copied());
    g.validate().unwrap();
    let naive = naive_grid(pts, &size, &off, metres);
    // Grid stage: exactly one point per non-empty cell, the naive choice.
    let grid: Vec<_> = g.cells().map(|c| (c.index(), c.point())).collect();
    let want: Vec<_> = naive.iter().map(|(i, (p, _))| (*i, *p)).collect();
    assert_eq!(grid, want);

    let (out, counts) = g.output_cycle();
    assert_eq!(out.len() as u64 + counts.eliminated, g.len() as u64);
    // Subset of the input, one point per cell at most.
    for p in &out {
        assert!(pts.iter().any(|q| lex(p, q).is_eq()), "{p:?} not in input");
    }
    // No two output points within half a cell on every axis (all pairs, not only neighbours).
    for (a, p) in out.iter().enumerate() {
        for q in &out[a + 1..] {
            assert!(!close(p, q, &size), "{p:?} and {q:?} are both output");
        }
    }
    // Every cell is output or eliminated by an output neighbour earlier in distance order.
    let rank = |i: &[i64; D]| (naive[i].1, *i);
    let out_cells: Vec<[i64; D]> = out.iter().map(|p| naive_index(p, &size, &off)).collect();
    for (i, (p, _)) in &naive {
        if out_cells.contains(i) {
            continue;
        }
        let (di, ii) = rank(i);
        let by = out_cells.iter().zip(&out).find(|(j, q)| {
            let (dj, jj) = rank(j);
            neighbours(i, j)
                && close(p, q, &size)
                && dj.total_cmp(&di).then(jj.cmp(&ii)) == Ordering::Less
        });
        assert!(by.is_some(), "cell {i:?} neither output nor eliminated");
    }
    // And the whole output equals the naive greedy reducer, in the same order.
    assert_eq!(out, naive_output(&naive, &size));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn reduction_2d_matches_definitions(pts in pts2(120), (s, o) in spec2()) {
        check_reduction(&pts, s, o, true);
    }

    #[test]
    fn reduction_3d_matches_definitions(pts in pts3(150), (s, o) in spec3()) {
        check_reduction(&pts, s, o, true);
    }

    #[test]
    fn reduction_in_cell_units_matches_definitions(
        pts in pts3(150),
        (s, o) in spec3(),
    ) {
        check_reduction(&pts, s, o, false);
    }

    /// A batch into an empty grid packs cell keys in one pass relative to its first finite
    /// point's cell when every cell lies within 2^20 cells of it (D = 3), else after a
    /// bounding-box pass: with one far point (or a NaN first) either way, a batch gives the
    /// store and the output of one point at a time.
    #[test]
    fn batch_paths_match_single_inserts(
        pts in pts3(150),
        (s, o) in spec3(),
        far_cells in prop_oneof![Just(0.0f64), Just(1048575.0), Just(1048577.0), 1e6f64..1e9],
        at in 0usize..150,
        nan_first in any::<bool>(),
    ) {
        let mut batch_pts = pts.clone();
        if far_cells > 0.0 {
            let far = [o[0] - far_cells * s[0], o[1] + 0.5 * s[1], o[2] + far_cells * s[2]];
            batch_pts.insert(at.min(batch_pts.len()), far);
        }
        if nan_first {
            batch_pts.insert(0, [f64::NAN, 0.0, 1.0]);
        }
        let mut a = DensityGrid::new(GridSpec::new(s, o).unwrap());
        let rejected = a.extend(batch_pts.iter().copied());
        let mut b = DensityGrid::new(GridSpec::new(s, o).unwrap());
        for p in batch_pts.iter().rev() {
            b.insert(*p);
        }
        a.validate().unwrap();
        b.validate().unwrap();
        prop_assert_eq!(rejected, b.counts().rejected);
        prop_assert_eq!(a.state(), b.state());
        prop_assert_eq!(a.output_cycle(), b.output_cycle());
    }

    /// The grid state and the output do not depend on the input order (the paper's input stage
    /// is order independent; our tie-breaks make it exact), for every selection rule.
    #[test]
    fn input_order_does_not_matter(
        pts in pts3(150),
        (s, o) in spec3(),
        seed in any::<u64>(),
        rule in 0..3u8,
    ) {
        let make = || {
            let sel = match rule {
                0 => Selection::CentreClosest,
                1 => Selection::MeanClosest,
                _ => Selection::score(|p: &[f64; 3]| p[2] - 0.5 * p[0]),
            };
            DensityGrid::with_selection(GridSpec::new(s, o).unwrap(), sel)
        };
        let mut shuffled = pts.clone();
        // Fisher-Yates with a fixed LCG from the seed.
        let mut x = seed | 1;
        for k in (1..shuffled.len()).rev() {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            shuffled.swap(k, (x >> 33) as usize % (k + 1));
        }
        let (mut a, mut b) = (make(), make());
        // One batch (sorted by cell inside) against one point at a time in another order.
        a.extend(pts.iter().copied());
        for p in &shuffled {
            b.insert(*p);
        }
        a.validate().unwrap();
        b.validate().unwrap();
        prop_assert_eq!(a.state(), b.state());
        prop_assert_eq!(a.output_cycle(), b.output_cycle());
    }

    /// Inserting extra points and deleting them again (in another order, interleaved with the
    /// kept points) gives the state of never having inserted them.
    #[test]
    fn deletion_restores_the_never_inserted_state(
        keep in pts2(80),
        extra in pts2(80),
        (s, o) in spec2(),
        rule in 0..2u8,
        interleave in any::<bool>(),
    ) {
        let make = || {
            let sel = if rule == 0 {
                Selection::CentreClosest
            } else {
                Selection::score(|p: &[f64; 2]| p[1])
            };
            DensityGrid::with_selection(GridSpec::new(s, o).unwrap(), sel)
        };
        let mut never = make();
        never.extend(keep.iter().copied());
        let mut g = make();
        if interleave {
            for k in 0..keep.len().max(extra.len()) {
                if let Some(p) = extra.get(k) { g.insert(*p); }
                if let Some(p) = keep.get(k) { g.insert(*p); }
            }
        } else {
            g.extend(extra.iter().copied());
            g.extend(keep.iter().copied());
        }
        g.validate().unwrap();
        for p in extra.iter().rev() {
            prop_assert!(g.remove(p));
            g.validate().unwrap();
        }
        prop_assert_eq!(g.state(), never.state());
        prop_assert_eq!(g.len(), never.len());
        prop_assert_eq!(g.point_count(), never.point_count());
        prop_assert_eq!(g.output_cycle(), never.output_cycle());
    }

    /// Output cycles stepped while points keep arriving: each cycle's output stays a valid
    /// reduction of the cells that existed when it began, and later cycles see the new points.
    #[test]
    fn cycles_interleaved_with_input(
        batches in prop::collection::vec(pts2(30), 1..6),
        (s, o) in spec2(),
        step in 1usize..8,
    ) {
        let mut g = DensityGrid::new(GridSpec::new(s, o).unwrap());
        let mut seen: Vec<[f64; 2]> = Vec::new();
        let mut batches = batches.into_iter();
        if let Some(b) = batches.next() {
            seen.extend(&b);
            g.extend(b);
        }
        let mut pending = batches.collect::<Vec<_>>();
        pending.reverse();
        loop {
            let before = naive_grid(&seen, &s, &o, true);
            let mut cycle = g.begin_cycle();
            let mut out = Vec::new();
            let mut arrived = false;
            while !g.step_cycle(&mut cycle, step, &mut out).unwrap() {
                if !arrived {
                    if let Some(b) = pending.pop() {
                        seen.extend(&b);
                        g.extend(b);
                        arrived = true;
                    }
                }
            }
            // Every emitted point was a cell winner when the cycle began (the input after that
            // may only defer cells, never add them), and no two are close.
            let winners: Vec<[f64; 2]> = before.values().map(|v| v.0).collect();
            for p in &out {
                prop_assert!(winners.iter().any(|w| lex(w, p).is_eq()));
            }
            for (a, p) in out.iter().enumerate() {
                for q in &out[a + 1..] {
                    prop_assert!(!close(p, q, &s));
                }
            }
            if pending.is_empty() && !arrived {
                // Quiet cycle: it is the full reduction of everything seen.
                prop_assert_eq!(out, naive_output(&naive_grid(&seen, &s, &o, true), &s));
                break;
            }
            if !arrived {
                // The cycle ended in one step: the next batch arrives between cycles.
                if let Some(b) = pending.pop() {
                    seen.extend(&b);
                    g.extend(b);
                }
            }
        }
        g.validate().unwrap();
    }
}

/// The cells of a grid as `(index, point, distance bits)`, in index order, and the cell indexes
/// in output order: what the read cycles depend on, without the stored members.
type Kept<const D: usize> = (Vec<([i64; D], [f64; D], u64)>, Vec<[i64; D]>);

fn kept<const D: usize>(g: &DensityGrid<D>) -> Kept<D> {
    (
        g.cells()
            .map(|c| (c.index(), c.point(), c.distance().to_bits()))
            .collect(),
        g.cells_by_distance().map(|c| c.index()).collect(),
    )
}

/// Feeds `pts` to `g` in the pieces `cuts` describes: alternately one point at a time and a
/// batch (a batch first when `batch_first`), the piece lengths taken from `cuts` in turn.
fn feed<const D: usize>(
    g: &mut DensityGrid<D>,
    pts: &[[f64; D]],
    cuts: &[usize],
    batch_first: bool,
) {
    let mut at = 0;
    let mut k = 0;
    while at < pts.len() {
        let n = cuts
            .get(k % cuts.len().max(1))
            .copied()
            .unwrap_or(pts.len())
            .max(1);
        let piece = &pts[at..(at + n).min(pts.len())];
        if (k + usize::from(batch_first)) % 2 == 0 {
            for p in piece {
                g.insert(*p);
            }
        } else {
            g.extend(piece.iter().copied());
        }
        at += piece.len();
        k += 1;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// On an insert-only stream, fed in pieces (one by one and in batches, the first batch
    /// possibly into an empty grid), the one-node storage keeps exactly the points of the
    /// all-members storage, and both equal the naive grid and output stages; the one-node
    /// grid stores one point per cell and counts the rest as discarded.
    #[test]
    fn one_node_and_all_members_keep_the_same_points(
        pts in pts3(150),
        (s, o) in spec3(),
        cuts in prop::collection::vec(1usize..40, 1..6),
        batch_first in any::<bool>(),
        score in any::<bool>(),
    ) {
        let make = |storage| {
            let sel = if score {
                Selection::score(|p: &[f64; 3]| p[2] - 0.5 * p[0])
            } else {
                Selection::CentreClosest
            };
            DensityGrid::with_storage(GridSpec::new(s, o).unwrap(), sel, storage).unwrap()
        };
        let (mut one, mut all) = (make(Storage::OneNode), make(Storage::AllMembers));
        feed(&mut one, &pts, &cuts, batch_first);
        feed(&mut all, &pts, &cuts, batch_first);
        one.validate().unwrap();
        all.validate().unwrap();
        prop_assert_eq!(kept(&one), kept(&all));
        prop_assert_eq!(one.point_count(), one.len() as u64);
        prop_assert_eq!(all.point_count(), pts.len() as u64);
        let c = one.counts();
        prop_assert_eq!(c.inserted, pts.len() as u64);
        prop_assert_eq!(c.discarded, pts.len() as u64 - one.len() as u64);
        prop_assert_eq!(all.counts().discarded, 0);
        prop_assert!(one.cells().all(|c| c.len() == 1 && c.members().next() == Some(c.point())));
        let out = one.output_cycle();
        prop_assert_eq!(&out, &all.output_cycle());
        if !score {
            prop_assert_eq!(out.0, naive_output(&naive_grid(&pts, &s, &o, true), &s));
        }
    }

    /// One-node deletion: deleting a cell's kept point removes the cell; deleting any other
    /// point changes nothing and returns `false` (the naive model: a map of kept points).
    #[test]
    fn one_node_deletes_only_kept_points(
        pts in pts2(100),
        (s, o) in spec2(),
        picks in prop::collection::vec(0usize..1000, 0..60),
        cuts in prop::collection::vec(1usize..40, 1..4),
        batch_first in any::<bool>(),
    ) {
        let mut g = DensityGrid::streaming(GridSpec::new(s, o).unwrap());
        feed(&mut g, &pts, &cuts, batch_first);
        let mut model = naive_grid(&pts, &s, &o, true);
        for k in picks {
            let Some(p) = pts.get(k % pts.len().max(1)) else { break };
            let i = naive_index(p, &s, &o);
            let is_kept = model.get(&i).is_some_and(|(q, _)| lex(p, q).is_eq());
            let before = kept(&g);
            let removed = g.remove(p);
            prop_assert_eq!(removed, is_kept, "{:?}", p);
            if is_kept {
                model.remove(&i);
                prop_assert!(g.get(&i).is_none());
            } else {
                prop_assert_eq!(kept(&g), before);
            }
            g.validate().unwrap();
        }
        let cells: Vec<_> = g.cells().map(|c| (c.index(), c.point())).collect();
        let want: Vec<_> = model.iter().map(|(i, (p, _))| (*i, *p)).collect();
        prop_assert_eq!(cells, want);
        prop_assert_eq!(g.output_cycle().0, naive_output(&model, &s));
    }
}
