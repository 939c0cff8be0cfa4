//! Structure-aware: a small fuzzed tree (updates in a 16³ block), a fuzzed distance map over
//! it (box corners near the block, or wild: NaN, infinite, outside the map; any maximum
//! distance, unknown space free or occupied), then rounds of fuzzed updates taken in with
//! `DistanceMap::update`. Never a panic; a map that builds is consistent with its tree
//! (`check_consistency`), every voxel's squared distance lies between the exact (brute-force)
//! one and the clamp, with its closest obstacle at exactly that distance, and after every
//! update the distances equal those of a map regenerated from the changed tree.
#![no_main]
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use nalgebra::Point3;
use octoquant::distance::{DistanceMap, DistanceOptions};
use octoquant_octree::{InnerNodes, Key, OcTree, Update};

/// Centre of the block the tree and the box live in.
const BASE: u16 = 32760;

#[derive(Arbitrary, Debug, Clone, Copy)]
enum Corner {
    /// Voxel offsets from `BASE` (each taken modulo 16).
    Near(u8, u8, u8),
    /// Any coordinate; used only when it cannot make a large box (non-finite, or beyond the
    /// map), otherwise it falls back to the block's corner.
    Wild(f64, f64, f64),
}

#[derive(Arbitrary, Debug, Clone, Copy)]
struct Op {
    x: u8,
    y: u8,
    z: u8,
    kind: u8,
}

#[derive(Arbitrary, Debug)]
struct Input {
    resolution: u8,
    first: Vec<Op>,
    min: Corner,
    max: Corner,
    max_dist: f32,
    unknown_occupied: bool,
    rounds: Vec<Vec<Op>>,
}

fn apply(tree: &mut OcTree, ops: &[Op]) {
    for op in ops.iter().take(300) {
        let key = Key::new(
            BASE + u16::from(op.x % 16),
            BASE + u16::from(op.y % 16),
            BASE + u16::from(op.z % 16),
        );
        let u = match op.kind % 4 {
            0 => Update::Hit,
            1 => Update::Miss,
            2 => Update::LogOdds(3.0),
            _ => Update::LogOdds(-3.0),
        };
        tree.update_node(key, u, InnerNodes::Refresh);
    }
}

fn corner(c: Corner, tree: &OcTree) -> Point3<f64> {
    let conv = tree.converter();
    let near = |x: u8, y: u8, z: u8| {
        let k = Key::new(
            BASE + u16::from(x % 16),
            BASE + u16::from(y % 16),
            BASE + u16::from(z % 16),
        );
        conv.key_to_point(&k)
    };
    match c {
        Corner::Near(x, y, z) => near(x, y, z),
        Corner::Wild(x, y, z) => {
            let p = Point3::new(x, y, z);
            let harmless = p.iter().any(|v| !v.is_finite()) || conv.point_to_key(&p).is_none();
            if harmless {
                p
            } else {
                near(0, 0, 0)
            }
        }
    }
}

/// Check a built map against its tree and a brute force over the box.
fn check(map: &DistanceMap, tree: &OcTree, unknown_occupied: bool) {
    assert!(map.check_consistency(tree));
    let (lo, hi) = (map.min_key(), map.max_key());
    let m2 = map.max_sq_cells();
    let mut obstacles = Vec::new();
    let keys = |f: &mut dyn FnMut(Key)| {
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    f(Key::new(x, y, z));
                }
            }
        }
    };
    keys(&mut |k| {
        if tree.is_occupied(k).unwrap_or(unknown_occupied) {
            obstacles.push(k);
        }
    });
    let sq = |a: Key, b: Key| -> i64 {
        (0..3)
            .map(|i| (i64::from(a[i]) - i64::from(b[i])).pow(2))
            .sum()
    };
    let conv = tree.converter();
    keys(&mut |k| {
        let p = conv.key_to_point(&k);
        let s = map.squared_distance_in_cells(&p).unwrap();
        let exact = obstacles
            .iter()
            .map(|&o| sq(k, o))
            .min()
            .unwrap_or(i64::MAX);
        assert!((0..=m2).contains(&s), "{s} outside 0..={m2}");
        assert!(
            i64::from(s) >= exact.min(i64::from(m2)),
            "{s} below exact {exact}"
        );
        let (d, o) = map.distance_and_closest_obstacle(&p).unwrap();
        assert_eq!(d, map.distance(&p).unwrap());
        assert!(d >= 0.0);
        match o {
            Some(o) => {
                let ok = conv.point_to_key(&o).unwrap();
                assert!(
                    obstacles.contains(&ok),
                    "closest obstacle {ok:?} is not one"
                );
                assert_eq!(i64::from(s), sq(k, ok).min(i64::from(m2)));
            }
            None => assert_eq!(s, m2),
        }
    });
}

fuzz_target!(|input: Input| {
    let res = [0.1, 0.05, 1.0, 0.3][usize::from(input.resolution % 4)];
    let mut tree = OcTree::new(res).unwrap();
    apply(&mut tree, &input.first);
    let opts = DistanceOptions {
        max_dist: input.max_dist,
        bbx_min: corner(input.min, &tree),
        bbx_max: corner(input.max, &tree),
        unknown_occupied: input.unknown_occupied,
    };
    let Ok(mut map) = DistanceMap::new(&tree, &opts) else {
        return;
    };
    check(&map, &tree, input.unknown_occupied);
    tree.enable_change_detection(true);
    for ops in input.rounds.iter().take(4) {
        apply(&mut tree, ops);
        map.update(&mut tree, true).unwrap();
        assert_eq!(tree.num_changes_detected(), 0);
        check(&map, &tree, input.unknown_occupied);
        let fresh = DistanceMap::new(&tree, &opts).unwrap();
        let (lo, hi) = (map.min_key(), map.max_key());
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let k = Key::new(x, y, z);
                    assert_eq!(map.distance_at_key(k), fresh.distance_at_key(k), "{k:?}");
                }
            }
        }
    }
});
