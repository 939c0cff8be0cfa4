//! Unit tests of the density reducer: geometry, the 2D worked example, selection rules,
//! deletion and read cycles.

use crate::output::for_each_lean_neighbour;
use crate::{
    CentreDistance, DensityError, DensityGrid, GridSpec, InsertOutcome, Selection, Storage,
};

fn grid_8_17() -> GridSpec<2> {
    GridSpec::with_sizes([8.0, 17.0]).unwrap()
}

/// The paper's worked 2D example (its Table 1): six points and the cell indexes it prints.
///
/// The text says the cells are 8 wide on X and 17 on Y, but the printed indexes come out only
/// with 17 on X and 8 on Y (offset 0): a = (floor(212.3 / 17), floor(588.2 / 8)) = (12, 73),
/// and so on for all six. With 8 x 17 none of them match (a would be (26, 34)), and no offset
/// fixes that, so the table is the paper's data and 17 x 8 the reading it supports.
const PAPER_POINTS: [(char, [f64; 2], [i64; 2]); 6] = [
    ('a', [212.3, 588.2], [12, 73]),
    ('b', [217.6, 563.1], [12, 70]),
    ('c', [224.5, 570.2], [13, 71]),
    ('d', [232.6, 573.3], [13, 71]),
    ('e', [263.8, 583.3], [15, 72]),
    ('f', [266.7, 587.4], [15, 73]),
];

#[test]
fn paper_example_cell_indexes_need_17_by_8() {
    let g = GridSpec::with_sizes([17.0, 8.0]).unwrap();
    for (name, p, want) in PAPER_POINTS {
        assert_eq!(g.cell_index(&p), Some(want), "point {name}");
    }
    // The text's 8 x 17 reading matches none of the printed indexes.
    let text = GridSpec::with_sizes([8.0, 17.0]).unwrap();
    for (name, p, want) in PAPER_POINTS {
        assert_ne!(text.cell_index(&p), Some(want), "point {name} under 8 x 17");
    }
}

/// The paper's Figure 2 story on the 17 x 8 grid: c and d share cell (13, 71), whose centre is
/// (229.5, 572); d is 3.36 m from it, c 5.31 m, so d is kept. Its Figure 3 story (e and f
/// "close", e dropped) holds only under the text's 8 x 17 reading: on 17 x 8 their y difference
/// 4.1 is not below half a cell (4), so both are kept, and nothing else is close either.
#[test]
fn paper_example_keeps_d_over_c_and_both_e_and_f() {
    let mut g = DensityGrid::new(GridSpec::with_sizes([17.0, 8.0]).unwrap());
    for (_, p, _) in PAPER_POINTS {
        g.insert(p);
    }
    g.validate().unwrap();
    assert_eq!(g.len(), 5);
    assert_eq!(g.get(&[13, 71]).unwrap().point(), [232.6, 573.3]);
    // Euclidean distance in metres (Eq. 3), squared: 3.1^2 + 1.3^2.
    let d = g.get(&[13, 71]).unwrap().distance();
    assert!((d - (3.1f64.powi(2) + 1.3f64.powi(2))).abs() < 1e-9, "{d}");
    let (out, counts) = g.output_cycle();
    assert_eq!(counts.eliminated, 0);
    let mut kept: Vec<_> = out.clone();
    kept.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let want: Vec<[f64; 2]> = PAPER_POINTS
        .iter()
        .filter(|(name, _, _)| *name != 'c')
        .map(|(_, p, _)| *p)
        .collect();
    assert_eq!(kept, want);
    // On the text's 8 x 17 grid e and f are within half a cell on both axes (2.9 < 4,
    // 4.1 < 8.5), in neighbouring cells, and one of them is eliminated.
    let mut text = DensityGrid::new(GridSpec::with_sizes([8.0, 17.0]).unwrap());
    text.insert([263.8, 583.3]);
    text.insert([266.7, 587.4]);
    let (out, counts) = text.output_cycle();
    assert_eq!((out.len(), counts.eliminated), (1, 1));
}

/// The cell index formula `floor((x - offset) / size)` at its edges: a coordinate on a cell's
/// lower edge belongs to that cell, negative coordinates round down (floor, not truncation).
#[test]
fn cell_index_edges() {
    let g = grid_8_17();
    let cases: [([f64; 2], [i64; 2]); 10] = [
        ([0.0, 0.0], [0, 0]),
        ([7.999, 16.999], [0, 0]),
        ([8.0, 17.0], [1, 1]),
        ([3.0, 20.0], [0, 1]),
        ([12.0, 5.0], [1, 0]),
        ([23.5, 33.9], [2, 1]),
        ([24.0, 34.0], [3, 2]),
        ([-0.5, 5.0], [-1, 0]),
        ([-8.0, -17.0], [-1, -1]),
        ([-8.01, -17.01], [-2, -2]),
    ];
    for (p, want) in cases {
        assert_eq!(g.cell_index(&p), Some(want), "point {p:?}");
    }
    assert_eq!(g.cell_centre(&[0, 0]), [4.0, 8.5]);
    assert_eq!(g.cell_centre(&[-1, 2]), [-4.0, 42.5]);
    // Offsets shift the grid: with offset (2, -3) the point (1, -3) is in cell (-1, 0).
    let shifted = GridSpec::new([8.0, 17.0], [2.0, -3.0]).unwrap();
    assert_eq!(shifted.cell_index(&[1.0, -3.0]), Some([-1, 0]));
    assert_eq!(shifted.cell_index(&[10.0, 14.0]), Some([1, 1]));
}

/// The two centre distances differ only on cells of unequal sizes: in a 17 x 8 cell, a point
/// 4 m off the centre along X is farther in metres than one 3 m off along Y (16 against 9,
/// squared), but nearer in cell units (4/17 = 0.24 of a cell against 3/8 = 0.375).
#[test]
fn centre_distance_metrics_differ_on_unequal_cells() {
    let centre = [8.5, 4.0];
    let along_x = [centre[0] + 4.0, centre[1]];
    let along_y = [centre[0], centre[1] + 3.0];
    let metres = GridSpec::with_sizes([17.0, 8.0]).unwrap();
    assert_eq!(metres.centre_distance_metric(), CentreDistance::Euclidean);
    assert_eq!(metres.centre_distance(&along_x, &[0, 0]), 16.0);
    assert_eq!(metres.centre_distance(&along_y, &[0, 0]), 9.0);
    let units = metres
        .clone()
        .with_centre_distance(CentreDistance::CellUnits);
    assert!(units.centre_distance(&along_x, &[0, 0]) < units.centre_distance(&along_y, &[0, 0]));
    let keep = |spec: GridSpec<2>| {
        let mut g = DensityGrid::new(spec);
        g.insert(along_x);
        g.insert(along_y);
        g.get(&[0, 0]).unwrap().point()
    };
    assert_eq!(keep(metres), along_y);
    assert_eq!(keep(units), along_x);
}

/// A hand-made run on an 8 x 17 grid in cell units ([`CentreDistance::CellUnits`]), every
/// step computed by hand.
///
/// Points (x, y) -> cell, squared distance to the centre in cell units:
/// a (4, 9)    -> (0,0), centre (4, 8.5):    (0/8)^2 + (0.5/17)^2   = 0.000865
/// b (1, 2)    -> (0,0), far from the centre: loses to a
/// c (9, 10)   -> (1,0), centre (12, 8.5):   (3/8)^2 + (1.5/17)^2   = 0.148
/// d (20, 8.5) -> (2,0), centre (20, 8.5):   0
/// e (4, 30)   -> (0,1), centre (4, 25.5):   (4.5/17)^2             = 0.070
/// f (40, 40)  -> (5,2): no neighbour.
/// Order: d, a, e, c, f. d emits; its neighbour c is 11 away in x (>= 4): kept.
/// a emits; c is 5 away in x (>= 4): kept; e is 21 away in y (>= 8.5): kept.
/// e emits; c emits (no close neighbour left); f emits. The rest of the run is commented
/// step by step below.
#[test]
fn hand_made_run_in_cell_units() {
    let mut g = DensityGrid::new(grid_8_17().with_centre_distance(CentreDistance::CellUnits));
    assert_eq!(g.insert([4.0, 9.0]), InsertOutcome::NewCell);
    assert_eq!(g.insert([1.0, 2.0]), InsertOutcome::Member);
    assert_eq!(g.insert([9.0, 10.0]), InsertOutcome::NewCell);
    assert_eq!(g.insert([20.0, 8.5]), InsertOutcome::NewCell);
    assert_eq!(g.insert([4.0, 30.0]), InsertOutcome::NewCell);
    assert_eq!(g.insert([40.0, 40.0]), InsertOutcome::NewCell);
    g.validate().unwrap();
    assert_eq!(g.len(), 5);
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [4.0, 9.0]);
    assert_eq!(g.get(&[0, 0]).unwrap().len(), 2);
    let order: Vec<_> = g.cells_by_distance().map(|c| c.index()).collect();
    assert_eq!(order, vec![[2, 0], [0, 0], [0, 1], [1, 0], [5, 2]]);
    let (out, counts) = g.output_cycle();
    assert_eq!(
        out,
        vec![
            [20.0, 8.5],
            [4.0, 9.0],
            [4.0, 30.0],
            [9.0, 10.0],
            [40.0, 40.0]
        ]
    );
    assert_eq!(counts.eliminated, 0);

    // A point in cell (1,0) within half a cell of a on both axes, but farther from the
    // centre than c: c stays, nothing changes.
    assert_eq!(g.insert([8.5, 9.0]), InsertOutcome::Member);
    // Now a point that beats c and is within half a cell of a: |11-4| = 7 >= 4, kept.
    assert_eq!(g.insert([11.0, 9.5]), InsertOutcome::Selected);
    // (7, 8.5) joins cell (0,0) (distance (3/8)^2 = 0.14 > a's 0.000865, so a stays). Delete a:
    // (7, 8.5) beats b and takes over, and it is 4 from h in x: exactly half a cell, not
    // closer, so both are kept; the check is strict.
    assert_eq!(g.insert([7.0, 8.5]), InsertOutcome::Member);
    assert!(g.remove(&[4.0, 9.0]));
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [7.0, 8.5]);
    g.validate().unwrap();
    let (out, counts) = g.output_cycle();
    assert_eq!(counts.eliminated, 0);
    assert_eq!(out.len(), 5);
    // A point at (7.5, 9) would be within half a cell of h (3.5 < 4, 0.5 < 8.5).
    g.insert([7.5, 9.0]);
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [7.0, 8.5]);
    assert!(g.remove(&[7.0, 8.5]));
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [7.5, 9.0]);
    // h (11, 9.5): distance (1/8)^2 + (1/17)^2 = 0.019; (7.5, 9): (3.5/8)^2 + .. = 0.19.
    // h is visited first and eliminates (7.5, 9).
    let (out, counts) = g.output_cycle();
    assert_eq!(counts.eliminated, 1);
    assert!(out.contains(&[11.0, 9.5]));
    assert!(!out.contains(&[7.5, 9.0]));
    assert_eq!(out.len(), 4);
}

#[test]
fn invalid_specs_are_errors() {
    assert_eq!(
        GridSpec::<2>::with_sizes([1.0, 0.0]),
        Err(DensityError::InvalidCellSize {
            axis: 1,
            value: 0.0
        })
    );
    assert!(GridSpec::<1>::with_sizes([f64::NAN]).is_err());
    assert!(GridSpec::<1>::with_sizes([-1.0]).is_err());
    assert!(GridSpec::<1>::new([1.0], [f64::INFINITY]).is_err());
    assert_eq!(GridSpec::<0>::with_sizes([]), Err(DensityError::NoAxes));
}

#[test]
fn non_finite_and_far_points_are_rejected_and_counted() {
    let mut g = DensityGrid::new(GridSpec::<3>::cubic(0.1).unwrap());
    assert_eq!(g.insert([f64::NAN, 0.0, 0.0]), InsertOutcome::Rejected);
    assert_eq!(g.insert([0.0, f64::INFINITY, 0.0]), InsertOutcome::Rejected);
    assert_eq!(g.insert([0.0, 0.0, 1e300]), InsertOutcome::Rejected);
    assert_eq!(g.insert([0.0, 0.0, 1e15]), InsertOutcome::Rejected); // index 1e16 > 2^53
    assert_eq!(g.insert([0.0, 0.0, 1e14]), InsertOutcome::NewCell);
    assert_eq!(g.counts().rejected, 4);
    assert_eq!(g.counts().inserted, 1);
    assert!(!g.remove(&[f64::NAN, 0.0, 0.0]));
    g.validate().unwrap();
}

/// All offsets in {-1, 0, 1}^D except zero, in lexicographic order (the brute-force list).
fn all_offsets<const D: usize>() -> Vec<[i64; D]> {
    let total = 3usize.pow(D as u32);
    let mut out = Vec::new();
    for n in 0..total {
        let mut o = [0i64; D];
        let mut r = n;
        for k in (0..D).rev() {
            o[k] = (r % 3) as i64 - 1;
            r /= 3;
        }
        if o.iter().any(|&v| v != 0) {
            out.push(o);
        }
    }
    out
}

/// The lean-neighbour enumeration equals filtering all 3^D - 1 offsets, order included, for
/// every combination of leaning sides.
fn check_lean_neighbours<const D: usize>() {
    let index: [i64; D] = std::array::from_fn(|a| 10 * a as i64 - 7);
    let all = all_offsets::<D>();
    assert_eq!(all.len(), 3usize.pow(D as u32) - 1);
    for mask in 0..(1u32 << (2 * D)) {
        let up: [bool; D] = std::array::from_fn(|a| mask >> a & 1 == 1);
        let down: [bool; D] = std::array::from_fn(|a| mask >> (D + a) & 1 == 1);
        let want: Vec<[i64; D]> = all
            .iter()
            .filter(|o| (0..D).all(|a| (o[a] != 1 || up[a]) && (o[a] != -1 || down[a])))
            .map(|o| std::array::from_fn(|a| index[a] + o[a]))
            .collect();
        let mut got = Vec::new();
        for_each_lean_neighbour(&index, &up, &down, |n| got.push(n));
        assert_eq!(got, want, "up {up:?} down {down:?}");
    }
}

#[test]
fn lean_neighbours_match_the_filtered_3_pow_d_list() {
    check_lean_neighbours::<1>();
    check_lean_neighbours::<2>();
    check_lean_neighbours::<3>();
    check_lean_neighbours::<4>();
}

#[test]
fn mean_and_score_selection() {
    let spec = GridSpec::<1>::cubic(10.0).unwrap();
    // Members 1, 2, 9: centre 5 -> 2 (closest to the centre); mean 4 -> 2; score -x -> 9.
    let pts = [[1.0], [2.0], [9.0]];
    let mut centre = DensityGrid::new(spec.clone());
    let mut mean = DensityGrid::with_selection(spec.clone(), Selection::MeanClosest);
    let mut score = DensityGrid::with_selection(spec.clone(), Selection::score(|p| -p[0]));
    for p in pts {
        centre.insert(p);
        mean.insert(p);
        score.insert(p);
    }
    assert_eq!(centre.get(&[0]).unwrap().point(), [2.0]);
    assert_eq!(score.get(&[0]).unwrap().point(), [9.0]);
    assert_eq!(mean.get(&[0]).unwrap().point(), [2.0]);
    assert_eq!(mean.get(&[0]).unwrap().mean(), [4.0]);
    // Add 8 and 8.5: mean 5.7 -> 8 is closest (2.3). The centre rule ties |8 - 5| = |2 - 5|
    // and breaks the tie by coordinates -> 2.
    for m in [&mut centre, &mut mean] {
        m.insert([8.0]);
        m.insert([8.5]);
        m.validate().unwrap();
    }
    assert_eq!(mean.get(&[0]).unwrap().point(), [8.0]);
    assert_eq!(centre.get(&[0]).unwrap().point(), [2.0]);
    // Delete 8: mean (1+2+9+8.5)/4 = 5.125 -> 2 (3.125) vs 8.5 (3.375) -> 2.
    assert!(mean.remove(&[8.0]));
    assert_eq!(mean.get(&[0]).unwrap().point(), [2.0]);
    mean.validate().unwrap();
    // A NaN score ranks last, never panics.
    let mut nan = DensityGrid::with_selection(
        spec,
        Selection::score(|p| if p[0] > 5.0 { f64::NAN } else { p[0] }),
    );
    nan.insert([9.0]);
    nan.insert([3.0]);
    assert_eq!(nan.get(&[0]).unwrap().point(), [3.0]);
}

#[test]
fn duplicates_and_deletion() {
    let mut g = DensityGrid::new(GridSpec::<2>::cubic(1.0).unwrap());
    g.insert([0.5, 0.5]);
    g.insert([0.5, 0.5]);
    g.insert([0.2, 0.2]);
    assert_eq!(g.get(&[0, 0]).unwrap().len(), 3);
    assert!(g.remove(&[0.5, 0.5]));
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [0.5, 0.5]);
    assert!(g.remove(&[0.5, 0.5]));
    assert_eq!(g.get(&[0, 0]).unwrap().point(), [0.2, 0.2]);
    assert!(!g.remove(&[0.5, 0.5]));
    assert!(!g.remove(&[7.0, 7.0]));
    g.validate().unwrap();
    assert!(g.remove(&[0.2, 0.2]));
    assert!(g.is_empty());
    g.validate().unwrap();
    assert_eq!(g.counts().removed, 3);
}

/// Points arriving during a read cycle are evaluated in the next cycle, not this one.
#[test]
fn points_added_during_a_cycle_wait_for_the_next() {
    let mut g = DensityGrid::new(GridSpec::<1>::cubic(1.0).unwrap());
    g.insert([0.5]);
    g.insert([10.5]);
    let mut cycle = g.begin_cycle();
    let mut out = Vec::new();
    assert!(!g.step_cycle(&mut cycle, 1, &mut out).unwrap());
    assert_eq!(out, vec![[0.5]]);
    // Two new cells, both after the cursor in distance order.
    g.insert([20.5]);
    g.insert([5.5]);
    while !g.step_cycle(&mut cycle, 1, &mut out).unwrap() {}
    assert_eq!(out, vec![[0.5], [10.5]]);
    assert_eq!(cycle.counts().deferred, 2);
    let (next, counts) = g.output_cycle();
    assert_eq!(next, vec![[0.5], [5.5], [10.5], [20.5]]);
    assert_eq!(counts.deferred, 0);
    // A stale cycle is refused.
    assert!(matches!(
        g.step_cycle(&mut cycle, 1, &mut out),
        Err(DensityError::StaleCycle { .. })
    ));
}

/// Small LCG for the store tests below.
fn lcg(x: &mut u64) -> u64 {
    *x = x
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    *x >> 33
}

/// A batch spread over more cells than 63 bits of packed key can hold goes through the
/// comparison sort; it must give the same store as inserting one point at a time.
#[test]
fn very_wide_batch_matches_single_inserts() {
    let spec = GridSpec::<3>::cubic(1.0).unwrap();
    let far = 4.0e15; // cell indexes near +-2^52 on every axis: 3 x 54 bits
    let mut x = 5;
    let mut pts = Vec::new();
    for k in 0..300 {
        let base = match k % 3 {
            0 => [-far, far, -far],
            1 => [far, -far, far],
            _ => [0.0, 0.0, 0.0],
        };
        pts.push([
            base[0] + (lcg(&mut x) % 8) as f64 * 0.5,
            base[1] + (lcg(&mut x) % 8) as f64 * 0.5,
            base[2] + (lcg(&mut x) % 8) as f64 * 0.5,
        ]);
    }
    pts.push([f64::NAN, 0.0, 0.0]);
    pts.push([0.0, 1e300, 0.0]);
    let mut batch = DensityGrid::new(spec.clone());
    assert_eq!(batch.extend(pts.iter().copied()), 2);
    let mut single = DensityGrid::new(spec);
    for p in pts.iter().rev() {
        single.insert(*p);
    }
    batch.validate().unwrap();
    single.validate().unwrap();
    assert_eq!(batch.state(), single.state());
    assert_eq!(batch.counts(), single.counts());
    assert_eq!(batch.output_cycle(), single.output_cycle());
}

/// Batches into an empty grid go through the one-pass window when every cell lies within
/// 2^20 cells (D = 3) of the first finite point's cell, and through the bounding-box pass when
/// one does not (just past the window's edge, a first point near the index limit, spreads in
/// one and two dimensions); every path must give the store of one-by-one insertion.
#[test]
fn window_and_bounding_box_batches_match_single_inserts() {
    fn check<const D: usize>(spec: GridSpec<D>, pts: &[[f64; D]]) {
        let mut batch = DensityGrid::new(spec.clone());
        let rejected = batch.extend(pts.iter().copied());
        let mut single = DensityGrid::new(spec);
        for p in pts.iter().rev() {
            single.insert(*p);
        }
        batch.validate().unwrap();
        single.validate().unwrap();
        assert_eq!(rejected, single.counts().rejected);
        assert_eq!(batch.state(), single.state());
        assert_eq!(batch.counts(), single.counts());
        assert_eq!(batch.output_cycle(), single.output_cycle());
    }
    let half = (1i64 << 20) as f64;
    let mut x = 11;
    let mut jitter = move || (lcg(&mut x) % 16) as f64 * 0.25;
    for (first, spread) in [
        (0.0, 3.0),
        (0.0, half - 1.0),
        (0.0, half),
        (0.0, half + 0.5),
        (-5.0, 4.0 * half),
        (9.007_199_254e15, 2.0),
        (-8.9e15, 2.0),
    ] {
        let spec = GridSpec::<3>::cubic(1.0).unwrap();
        let mut pts = vec![[f64::NAN, 1.0, 2.0], [first, first, first]];
        for k in 0..200 {
            let far = if k % 7 == 0 { spread } else { 0.0 };
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            pts.push([
                first + sign * far + jitter(),
                first - sign * far + jitter(),
                first + jitter(),
            ]);
        }
        pts.push([f64::INFINITY, 0.0, 0.0]);
        check(spec, &pts);
    }
    // Points on exact window edges at a cell size that is not a power of two.
    let spec = GridSpec::<3>::new([0.3, 0.7, 1.1], [0.05, -0.2, 0.0]).unwrap();
    let e = |i: f64, a: usize| [0.05, -0.2, 0.0][a] + i * [0.3, 0.7, 1.1][a];
    let pts: Vec<[f64; 3]> = [0.0, -half, half - 1.0, half, -half - 1.0]
        .iter()
        .map(|&i| [e(i, 0), e(-i, 1), e(i, 2)])
        .collect();
    check(spec.clone(), &pts[..3]);
    check(spec, &pts);
    for spread in [3.0, 1e9, 1e13] {
        let pts1: Vec<[f64; 1]> = (0..100)
            .map(|k| [(k % 9) as f64 * spread + jitter()])
            .collect();
        check(GridSpec::<1>::cubic(0.5).unwrap(), &pts1);
        let pts2: Vec<[f64; 2]> = (0..100)
            .map(|k| [(k % 5) as f64 * spread, jitter() - (k % 3) as f64 * spread])
            .collect();
        check(GridSpec::<2>::cubic(0.5).unwrap(), &pts2);
    }
}

/// Many single insertions into few cells in turn move spans to the arena's end (and
/// compact it); deleting most points again compacts it; the store stays valid throughout and
/// ends equal to a store that only ever saw the remaining points.
#[test]
fn member_arena_relocation_and_compaction() {
    let spec = GridSpec::<2>::cubic(1.0).unwrap();
    let mut g = DensityGrid::new(spec.clone());
    let mut x = 17;
    let pts: Vec<[f64; 2]> = (0..12_000)
        .map(|_| {
            [
                (lcg(&mut x) % 40) as f64 * 0.25,
                (lcg(&mut x) % 40) as f64 * 0.25,
            ]
        })
        .collect();
    for (k, p) in pts.iter().enumerate() {
        g.insert(*p);
        if k % 1000 == 0 {
            g.validate().unwrap();
        }
    }
    g.validate().unwrap();
    // Arena: all points, plus at most twice that in abandoned spans and spare room.
    assert!(g.points.len() <= 3 * pts.len() + 4096, "{}", g.points.len());
    let (gone, kept) = pts.split_at(11_000);
    for (k, p) in gone.iter().enumerate() {
        assert!(g.remove(p));
        if k % 1000 == 0 {
            g.validate().unwrap();
        }
    }
    g.validate().unwrap();
    assert!(
        g.points.len() <= 2 * kept.len() + 4096,
        "{}",
        g.points.len()
    );
    let mut fresh = DensityGrid::new(spec);
    fresh.extend(kept.iter().copied());
    assert_eq!(g.state(), fresh.state());
    assert_eq!(g.output_cycle(), fresh.output_cycle());
}

/// A grid emptied by deletion is rebuilt by the next batch in one pass (reusing nothing of
/// the old slots), and a batch into a non-empty grid merges run by run.
#[test]
fn batches_into_emptied_and_non_empty_grids() {
    let spec = GridSpec::<2>::with_sizes([0.5, 2.0]).unwrap();
    let mut x = 3;
    let mut cloud = |n: usize| -> Vec<[f64; 2]> {
        (0..n)
            .map(|_| {
                [
                    (lcg(&mut x) % 64) as f64 / 8.0,
                    (lcg(&mut x) % 64) as f64 / 8.0,
                ]
            })
            .collect()
    };
    let (a, b, c) = (cloud(500), cloud(500), cloud(300));
    let mut g = DensityGrid::new(spec.clone());
    g.extend(a.iter().copied());
    let _ = g.output_cycle();
    for p in &a {
        assert!(g.remove(p));
    }
    assert!(g.is_empty());
    g.validate().unwrap();
    g.extend(b.iter().copied());
    g.validate().unwrap();
    g.extend(c.iter().copied());
    g.validate().unwrap();
    let mut fresh = DensityGrid::new(spec);
    for p in b.iter().chain(&c) {
        fresh.insert(*p);
    }
    assert_eq!(g.state(), fresh.state());
    assert_eq!(g.output_cycle(), fresh.output_cycle());
}

/// Batches in one and in four dimensions (key packing over other axis counts, 3^4 - 1 = 80
/// neighbours) agree with one-at-a-time insertion.
#[test]
fn batches_in_one_and_four_dimensions() {
    let mut x = 11;
    let one: Vec<[f64; 1]> = (0..400)
        .map(|_| [(lcg(&mut x) % 1000) as f64 / 7.0 - 60.0])
        .collect();
    let spec1 = GridSpec::<1>::new([1.5], [0.25]).unwrap();
    let mut a = DensityGrid::new(spec1.clone());
    a.extend(one.iter().copied());
    let mut b = DensityGrid::new(spec1);
    for p in &one {
        b.insert(*p);
    }
    a.validate().unwrap();
    assert_eq!(a.state(), b.state());
    assert_eq!(a.output_cycle(), b.output_cycle());

    let four: Vec<[f64; 4]> = (0..600)
        .map(|_| {
            let mut p = [0.0; 4];
            for v in &mut p {
                *v = (lcg(&mut x) % 48) as f64 / 8.0;
            }
            p
        })
        .collect();
    let spec4 = GridSpec::<4>::new([1.0, 0.5, 2.0, 1.0], [0.0, -0.1, 0.3, 0.0]).unwrap();
    let mut a = DensityGrid::new(spec4.clone());
    a.extend(four.iter().copied());
    let mut b = DensityGrid::new(spec4);
    for p in four.iter().rev() {
        b.insert(*p);
    }
    a.validate().unwrap();
    assert_eq!(a.state(), b.state());
    assert_eq!(a.output_cycle(), b.output_cycle());
}

/// The copying and the re-walking batch entry points give the same store.
#[test]
fn extend_and_extend_rewalk_agree() {
    let spec = GridSpec::<3>::new([0.3, 0.2, 0.5], [0.05, 0.0, -1.0]).unwrap();
    let mut x = 29;
    let mut pts: Vec<[f32; 3]> = (0..2000)
        .map(|_| {
            [
                (lcg(&mut x) % 200) as f32 * 0.037 - 3.0,
                (lcg(&mut x) % 200) as f32 * 0.041,
                (lcg(&mut x) % 50) as f32 * 0.11 - 2.0,
            ]
        })
        .collect();
    pts[7] = [f32::NAN, 0.0, 0.0];
    pts[99] = [0.0, f32::INFINITY, 0.0];
    let as_f64 = |p: &[f32; 3]| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])];
    let mut a = DensityGrid::new(spec.clone());
    let mut b = DensityGrid::new(spec);
    assert_eq!(a.extend(pts.iter().map(as_f64)), 2);
    assert_eq!(b.extend_rewalk(pts.iter().map(as_f64)), 2);
    a.validate().unwrap();
    b.validate().unwrap();
    assert_eq!(a.state(), b.state());
    assert_eq!(a.counts(), b.counts());
    // Into non-empty grids too.
    a.extend(pts[..500].iter().map(as_f64));
    b.extend_rewalk(pts[..500].iter().map(as_f64));
    assert_eq!(a.state(), b.state());
    assert_eq!(a.output_cycle(), b.output_cycle());
}

/// A batch into an empty grid leaves the compact orders (no B-tree); a read cycle stepped over
/// it, interrupted by an insertion, a re-ranking insertion and a deletion (each switching to
/// the B-trees), continues from its cursor exactly as on a grid that always had the B-trees.
#[test]
fn compact_orders_switch_to_trees_mid_cycle() {
    let spec = GridSpec::<3>::new([0.5, 0.5, 0.25], [0.1, -0.2, 0.0]).unwrap();
    let mut x = 29;
    let pts: Vec<[f64; 3]> = (0..3000)
        .map(|_| {
            [
                (lcg(&mut x) % 97) as f64 / 13.0,
                (lcg(&mut x) % 89) as f64 / 11.0,
                (lcg(&mut x) % 31) as f64 / 17.0,
            ]
        })
        .collect();
    let mut compact = DensityGrid::new(spec.clone());
    compact.extend(pts.iter().copied());
    assert!(compact.built.is_some() && compact.index.is_empty());
    compact.validate().unwrap();
    let mut trees = DensityGrid::new(spec.clone());
    for p in &pts {
        trees.insert(*p);
    }
    assert!(trees.built.is_none());
    assert_eq!(compact.state(), trees.state());
    assert_eq!(
        compact.selected_points(),
        trees.selected_points(),
        "index order"
    );

    // A point on the centre of an occupied cell re-ranks it; one far away opens a cell; a
    // member of another cell leaves.
    let recentre = spec.cell_centre(&spec.cell_index(&pts[7]).unwrap());
    let changes: [(bool, [f64; 3]); 3] = [
        (true, recentre),
        (true, [40.0, 40.0, 40.0]),
        (false, pts[100]),
    ];
    let mut cycles = Vec::new();
    for g in [&mut compact, &mut trees] {
        let mut cycle = g.begin_cycle();
        let mut out = Vec::new();
        for (k, &(add, p)) in changes.iter().enumerate() {
            assert!(!g.step_cycle(&mut cycle, 150 + 37 * k, &mut out).unwrap());
            if add {
                g.insert(p);
            } else {
                assert!(g.remove(&p));
            }
            g.validate().unwrap();
        }
        while !g.step_cycle(&mut cycle, 200, &mut out).unwrap() {}
        cycles.push((out, cycle.counts(), g.output_cycle()));
    }
    assert!(compact.built.is_none());
    assert_eq!(cycles[0], cycles[1]);
    assert!(cycles[0].1.deferred >= 1);
    assert_eq!(compact.state(), trees.state());
}

/// A batch of `f32`-exact points into an empty grid keeps its members as `f32` (same values
/// back), widens them on the first change, and matches a grid that only ever held `f64`; one
/// point that `f32` cannot hold keeps the whole batch in `f64`.
#[test]
fn narrow_arena_holds_the_same_points() {
    let spec = GridSpec::<3>::cubic(0.25).unwrap();
    let mut x = 41;
    let mut pts: Vec<[f64; 3]> = (0..2000)
        .map(|_| {
            [
                f64::from((lcg(&mut x) % 4001) as f32 * 0.001_3),
                -f64::from((lcg(&mut x) % 999) as f32 / 7.0),
                f64::from((lcg(&mut x) % 77) as f32 * 0.1),
            ]
        })
        .collect();
    pts.push([f64::NAN, 0.0, 0.0]);
    let mut narrow = DensityGrid::new(spec.clone());
    narrow.extend(pts.iter().copied());
    assert!(narrow.narrow.is_some() && narrow.points.is_empty());
    narrow.validate().unwrap();
    let mut wide = DensityGrid::new(spec.clone());
    for p in &pts {
        wide.insert(*p);
    }
    assert!(wide.narrow.is_none());
    assert_eq!(narrow.state(), wide.state());
    let cell = narrow.get(&spec.cell_index(&pts[3]).unwrap()).unwrap();
    assert!(cell.members().any(|m| m == pts[3]));
    assert_eq!(narrow.clone().output_cycle(), wide.clone().output_cycle());

    // The first change widens the arena; the grids stay equal.
    for g in [&mut narrow, &mut wide] {
        assert!(g.remove(&pts[10]));
        g.insert([0.1, -0.2, 0.3]);
        g.validate().unwrap();
    }
    assert!(narrow.narrow.is_none());
    assert_eq!(narrow.state(), wide.state());
    assert_eq!(narrow.output_cycle(), wide.output_cycle());

    // 0.1 is not an f32 value.
    let mut mixed = pts.clone();
    mixed.push([0.1, 0.0, 0.0]);
    let mut g = DensityGrid::new(spec);
    g.extend(mixed.iter().copied());
    assert!(g.narrow.is_none());
    g.validate().unwrap();
}

/// A full grid refuses further points, one by one and in batches alike, and makes room again
/// after deletions; a batch that crosses the limit keeps exactly the points that one-by-one
/// insertion keeps.
#[test]
fn a_full_grid_refuses_points_as_one_by_one_insertion_would() {
    let pts: Vec<[f64; 2]> = (0..15)
        .map(|i| [(i * 5 % 23) as f64 * 3.1, (i * 7 % 11) as f64 * 6.3])
        .collect();
    let mut one = DensityGrid::with_max_points(grid_8_17(), 10);
    let outcomes: Vec<InsertOutcome> = pts.iter().map(|p| one.insert(*p)).collect();
    assert!(outcomes[..10].iter().all(|o| *o != InsertOutcome::Full));
    assert!(outcomes[10..].iter().all(|o| *o == InsertOutcome::Full));
    assert_eq!((one.point_count(), one.counts().rejected), (10, 5));

    let mut batch = DensityGrid::with_max_points(grid_8_17(), 10);
    assert_eq!(batch.extend(pts.iter().copied()), 5);
    assert_eq!(batch.state(), one.state());
    assert_eq!(batch.counts(), one.counts());

    // deletions make room: of the next five, two fit
    for p in &pts[..2] {
        assert!(one.remove(p));
        assert!(batch.remove(p));
    }
    let more: Vec<[f64; 2]> = (0..5).map(|i| [100.0 + i as f64, 40.0]).collect();
    for p in &more {
        one.insert(*p);
    }
    assert_eq!(batch.extend(more.iter().copied()), 3);
    assert_eq!(batch.state(), one.state());
    assert_eq!(one.point_count(), 10);
    one.validate().unwrap();
    batch.validate().unwrap();

    // a batch within the limit takes the batch path and matches a grid without the limit
    let mut roomy = DensityGrid::with_max_points(grid_8_17(), 15);
    roomy.extend(pts.iter().copied());
    let mut plain = DensityGrid::new(grid_8_17());
    pts.iter().for_each(|p| {
        plain.insert(*p);
    });
    assert_eq!(roomy.state(), plain.state());
    assert_eq!(DensityGrid::<3>::MAX_POINTS, (1 << 31) - 1);
}

/// The packed cell records a batch into an empty grid leaves (closest-to-centre rule) against
/// the same grid with its records unpacked: same views, same state, valid, and the same after
/// further insertions, deletions and a read cycle.
mod packed_records {
    use super::*;
    use proptest::prelude::*;

    fn lattice() -> impl Strategy<Value = f64> {
        (-40i32..40).prop_map(|v| f64::from(v) / 8.0)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        #[test]
        fn packed_and_unpacked_records_agree(
            pts in prop::collection::vec([lattice(), lattice(), lattice()], 1..200),
            more in prop::collection::vec([lattice(), lattice(), lattice()], 0..20),
            size in prop_oneof![Just(1.0), Just(0.75), 0.3f64..2.0],
            drop in 0usize..200,
        ) {
            let mut packed = DensityGrid::new(GridSpec::<3>::cubic(size).unwrap());
            packed.extend(pts.iter().copied());
            prop_assert!(packed.packed.is_some());
            let mut plain = packed.clone();
            plain.unpack_cells();
            prop_assert!(plain.packed.is_none());
            packed.validate().unwrap();
            plain.validate().unwrap();
            for (a, b) in packed.cells().zip(plain.cells()) {
                prop_assert_eq!(a.index(), b.index());
                prop_assert_eq!(a.len(), b.len());
                prop_assert_eq!(a.point(), b.point());
                prop_assert_eq!(a.distance().to_bits(), b.distance().to_bits());
                prop_assert_eq!(a.members().collect::<Vec<_>>(), b.members().collect::<Vec<_>>());
            }
            prop_assert_eq!(packed.state(), plain.state());
            // Changes unpack the records first; both grids must stay equal.
            for g in [&mut packed, &mut plain] {
                g.extend(more.iter().copied());
                let _ = g.remove(&pts[drop % pts.len()]);
                g.validate().unwrap();
            }
            prop_assert_eq!(packed.state(), plain.state());
            prop_assert_eq!(packed.output_cycle(), plain.output_cycle());
        }
    }
}

/// The paper's storage on its worked example: one node per cell. Both orders of c and d keep
/// d; deleting c afterwards is a no-op (c was dropped), deleting d removes cell (13, 71) as the
/// paper's deletion rule says (nothing of c is left to take over).
#[test]
fn one_node_storage_on_the_paper_example() {
    let spec = GridSpec::with_sizes([17.0, 8.0]).unwrap();
    let c = PAPER_POINTS[2].1;
    let d = PAPER_POINTS[3].1;
    for order in [[c, d], [d, c]] {
        let mut g = DensityGrid::streaming(spec.clone());
        assert_eq!(g.storage(), Storage::OneNode);
        assert_eq!(g.insert(order[0]), InsertOutcome::NewCell);
        let second = g.insert(order[1]);
        assert_eq!(
            second,
            if order[1] == d {
                InsertOutcome::Selected
            } else {
                InsertOutcome::Member
            }
        );
        let cell = g.get(&[13, 71]).unwrap();
        assert_eq!((cell.point(), cell.len()), (d, 1));
        assert_eq!(cell.members().collect::<Vec<_>>(), vec![d]);
        assert_eq!(g.counts().discarded, 1);
        assert_eq!(g.point_count(), 1);
        assert!(!g.remove(&c));
        assert_eq!(g.get(&[13, 71]).unwrap().point(), d);
        assert!(g.remove(&d));
        assert!(g.is_empty());
        assert!(!g.remove(&d));
        g.validate().unwrap();
        assert_eq!(g.counts().removed, 1);
    }
    // All members: deleting d lets c take over.
    let mut all = DensityGrid::new(spec);
    all.insert(c);
    all.insert(d);
    assert!(all.remove(&d));
    assert_eq!(all.get(&[13, 71]).unwrap().point(), c);
}

/// The one-node store's arena holds one point per cell however many points arrive, in both
/// arena forms (`f32`-exact batches into an empty grid, and `f64` ones), also after points
/// arrive one at a time and in batches into a non-empty grid.
#[test]
fn one_node_arena_grows_with_cells_not_points() {
    let spec = GridSpec::<3>::cubic(1.0).unwrap();
    let mut x = 7u64;
    for exact_f32 in [true, false] {
        let mut g = DensityGrid::streaming(spec.clone());
        for round in 0..4 {
            let pts: Vec<[f64; 3]> = (0..5000)
                .map(|_| {
                    std::array::from_fn(|_| {
                        let v = (lcg(&mut x) % 1000) as f64 / 97.0;
                        if exact_f32 {
                            f64::from(v as f32)
                        } else {
                            v + 1e-12
                        }
                    })
                })
                .collect();
            if round == 2 {
                for p in &pts {
                    g.insert(*p);
                }
            } else {
                g.extend(pts.iter().copied());
            }
            g.validate().unwrap();
            assert_eq!(g.arena().len(), g.len(), "round {round}, f32 {exact_f32}");
            assert_eq!(g.point_count(), g.len() as u64);
            assert_eq!(g.counts().discarded, g.counts().inserted - g.len() as u64);
        }
        assert!(g.counts().inserted >= 20 * g.len() as u64 / 2);
    }
}

/// The mean rule needs every member: the one-node storage refuses it; other rules are fine.
#[test]
fn one_node_storage_refuses_the_mean_rule() {
    let spec = GridSpec::<2>::cubic(1.0).unwrap();
    assert!(matches!(
        DensityGrid::with_storage(spec.clone(), Selection::MeanClosest, Storage::OneNode),
        Err(DensityError::SelectionNeedsMembers)
    ));
    for storage in [Storage::OneNode, Storage::AllMembers] {
        let g =
            DensityGrid::with_storage(spec.clone(), Selection::score(|p| p[0]), storage).unwrap();
        assert_eq!(g.storage(), storage);
    }
    assert!(DensityGrid::with_storage(spec, Selection::MeanClosest, Storage::AllMembers).is_ok());
}
