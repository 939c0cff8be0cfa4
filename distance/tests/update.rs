//! Incremental updates (`DistanceMap::update` after new measurements) against a map
//! regenerated from scratch on the changed tree.

use nalgebra::Point3;
use octoquant_distance::{DistanceMap, DistanceOptions};
use octoquant_octree::{InnerNodes, Key, OcTree, Update};
use proptest::prelude::*;

const BASE: u16 = 32762;

fn apply(tree: &mut OcTree, n: u16, ops: &[(u16, u16, u16, u8)]) {
    for &(x, y, z, op) in ops {
        let key = Key::new(BASE + x % n, BASE + y % n, BASE + z % n);
        let u = match op {
            0 => Update::Hit,
            1 => Update::Miss,
            2 => Update::LogOdds(3.0),
            _ => Update::LogOdds(-3.0),
        };
        tree.update_node(key, u, InnerNodes::Refresh);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn update_equals_regenerating(
        n in 4u16..12,
        first in prop::collection::vec((0u16..12, 0u16..12, 0u16..12, 0u8..4), 0..250),
        rounds in prop::collection::vec(prop::collection::vec((0u16..12, 0u16..12, 0u16..12, 0u8..4), 0..60), 1..4),
        max_voxels in 0.0f32..8.0,
        unknown_occupied in any::<bool>(),
    ) {
        let mut tree = OcTree::new(0.1).unwrap();
        apply(&mut tree, n, &first);
        let c = |k: u16| (f64::from(k) - 32768.0 + 0.5) * 0.1;
        let opts = DistanceOptions {
            max_dist: max_voxels * 0.1,
            bbx_min: Point3::new(c(BASE + 1), c(BASE), c(BASE)),
            bbx_max: Point3::new(c(BASE + n - 1), c(BASE + n - 2), c(BASE + n - 1)),
            unknown_occupied,
        };
        let mut map = DistanceMap::new(&tree, &opts).unwrap();
        tree.enable_change_detection(true);
        for ops in &rounds {
            apply(&mut tree, n, ops);
            map.update(&mut tree, true).unwrap();
            prop_assert_eq!(tree.num_changes_detected(), 0);
            prop_assert!(map.check_consistency(&tree));
            let fresh = DistanceMap::new(&tree, &opts).unwrap();
            for x in BASE..BASE + n {
                for y in BASE..BASE + n {
                    for z in BASE..BASE + n {
                        let p = Point3::new(c(x), c(y), c(z));
                        prop_assert_eq!(
                            map.squared_distance_in_cells(&p).unwrap(),
                            fresh.squared_distance_in_cells(&p).unwrap(),
                            "voxel {} {} {}", x, y, z
                        );
                        prop_assert_eq!(map.distance(&p).unwrap(), fresh.distance(&p).unwrap());
                    }
                }
            }
        }
    }
}
