//! Collision queries against brute force over every leaf (occupied space) and every voxel of
//! the shape's box (unknown counted as occupied), on seeded random trees and shapes.

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use octoquant::parry3d::math::{Pose, Vector};
use octoquant::parry3d::query::intersection_test;
use octoquant::parry3d::shape::{Ball, Capsule, Cuboid, Shape};
use octoquant::query::convert::{point_to_parry, pose_to_parry};
use octoquant::query::{collides, colliding_voxels, occupied_in_bbox, CollisionOptions};
use octoquant::{InnerNodes, Key, OcTree, Update};

/// SplitMix64 for reproducible cases.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// A tree over about [-1, 1]³ at 0.1 m: random hits and misses, plus a fully occupied
/// 0.8 m block (pruned into one leaf) and a free one.
fn random_tree(rng: &mut Rng) -> OcTree {
    let mut tree = OcTree::new(0.1).unwrap();
    for _ in 0..400 {
        let p = Point3::new(rng.f(-1.0, 1.0), rng.f(-1.0, 1.0), rng.f(-1.0, 1.0));
        let k = tree.converter().point_to_key(&p).unwrap();
        let u = if rng.next().is_multiple_of(3) {
            Update::Hit
        } else {
            Update::Miss
        };
        tree.update_node(k, u, InnerNodes::Refresh);
    }
    // 20 updates each reach the clamping bound, so every voxel ends equal and the blocks prune
    for (base, u) in [(32768u16 + 8, Update::Hit), (32768 - 16, Update::Miss)] {
        for _ in 0..20 {
            for x in 0..8 {
                for y in 0..8 {
                    for z in 0..8 {
                        tree.update_node(
                            Key::new(base + x, base + y, 32768 + z),
                            u,
                            InnerNodes::Refresh,
                        );
                    }
                }
            }
        }
    }
    tree
}

fn random_shape(rng: &mut Rng) -> (Box<dyn Shape>, Isometry3<f64>) {
    let shape: Box<dyn Shape> = match rng.next() % 3 {
        0 => Box::new(Ball::new(rng.f(0.03, 0.4) as f32)),
        1 => Box::new(Cuboid::new(Vector::new(
            rng.f(0.02, 0.3) as f32,
            rng.f(0.02, 0.3) as f32,
            rng.f(0.02, 0.3) as f32,
        ))),
        _ => Box::new(Capsule::new_z(
            rng.f(0.05, 0.3) as f32,
            rng.f(0.02, 0.2) as f32,
        )),
    };
    let rot =
        UnitQuaternion::from_euler_angles(rng.f(-3.0, 3.0), rng.f(-3.0, 3.0), rng.f(-3.0, 3.0));
    let t = Vector3::new(rng.f(-1.4, 1.4), rng.f(-1.4, 1.4), rng.f(-1.4, 1.4));
    (shape, Isometry3::from_parts(t.into(), rot))
}

fn cube_touches(center: Point3<f64>, size: f64, shape: &dyn Shape, pose: &Pose) -> bool {
    let h = (size / 2.0) as f32;
    let cube_pose = Pose::from_translation(point_to_parry(&center));
    intersection_test(&cube_pose, &Cuboid::new(Vector::new(h, h, h)), pose, shape)
        .unwrap()
        .intersecting
}

/// Occupied leaves touching the shape, by testing every leaf of the tree.
fn brute_colliding(tree: &OcTree, shape: &dyn Shape, iso: &Isometry3<f64>) -> Vec<Key> {
    let pose = pose_to_parry(iso);
    let conv = tree.converter();
    tree.leaves()
        .filter(|l| tree.params().is_occupied(l.value))
        .filter(|l| {
            cube_touches(
                conv.key_to_point_at_depth(&l.key, l.depth),
                conv.node_size(l.depth),
                shape,
                &pose,
            )
        })
        .map(|l| l.key)
        .collect()
}

/// Whether any occupied-or-unknown voxel (depth 16) of the shape's box touches it.
fn brute_cautious(tree: &OcTree, shape: &dyn Shape, iso: &Isometry3<f64>) -> bool {
    let pose = pose_to_parry(iso);
    let aabb = shape.compute_aabb(&pose);
    let conv = tree.converter();
    let lo = conv
        .point_to_key(&Point3::new(
            aabb.mins.x as f64,
            aabb.mins.y as f64,
            aabb.mins.z as f64,
        ))
        .unwrap();
    let hi = conv
        .point_to_key(&Point3::new(
            aabb.maxs.x as f64,
            aabb.maxs.y as f64,
            aabb.maxs.z as f64,
        ))
        .unwrap();
    for x in lo.x()..=hi.x() {
        for y in lo.y()..=hi.y() {
            for z in lo.z()..=hi.z() {
                let k = Key::new(x, y, z);
                let blocked = tree.is_occupied(k).unwrap_or(true);
                if blocked && cube_touches(conv.key_to_point(&k), conv.resolution(), shape, &pose) {
                    return true;
                }
            }
        }
    }
    false
}

#[test]
fn collision_queries_match_brute_force() {
    let mut rng = Rng(0x5EED_0001);
    let mut outcomes = [0usize; 4];
    for _ in 0..6 {
        let tree = random_tree(&mut rng);
        for i in 0..60 {
            let (shape, mut iso) = random_shape(&mut rng);
            if i % 3 == 0 {
                // inside the free block (x, y in -1.6..-0.8, z in 0..0.8)
                iso.translation.vector =
                    Vector3::new(rng.f(-1.3, -1.1), rng.f(-1.3, -1.1), rng.f(0.3, 0.5));
            }
            let expect = brute_colliding(&tree, shape.as_ref(), &iso);
            let got: Vec<Key> = colliding_voxels(&tree, shape.as_ref(), &iso)
                .unwrap()
                .into_iter()
                .map(|v| v.key)
                .collect();
            assert_eq!(got, expect);
            let hit = collides(&tree, shape.as_ref(), &iso, &CollisionOptions::default()).unwrap();
            assert_eq!(hit, !expect.is_empty());
            outcomes[hit as usize] += 1;

            let cautious = CollisionOptions {
                unknown_is_occupied: true,
            };
            let hit_u = collides(&tree, shape.as_ref(), &iso, &cautious).unwrap();
            assert_eq!(hit_u, brute_cautious(&tree, shape.as_ref(), &iso), "{iso}");
            assert!(hit_u || !hit, "unknown-as-occupied can only add collisions");
            outcomes[2 + hit_u as usize] += 1;
        }
    }
    // both answers occur in both modes, so the comparison is not vacuous
    assert!(outcomes.iter().all(|&n| n >= 10), "{outcomes:?}");
}

#[test]
fn bbox_query_matches_brute_force_key_box() {
    let mut rng = Rng(0x5EED_0002);
    let tree = random_tree(&mut rng);
    let conv = tree.converter();
    let mut nonempty = 0;
    for _ in 0..100 {
        let (shape, iso) = random_shape(&mut rng);
        let aabb = shape.compute_aabb(&pose_to_parry(&iso));
        let lo = conv
            .point_to_key(&Point3::new(
                aabb.mins.x as f64,
                aabb.mins.y as f64,
                aabb.mins.z as f64,
            ))
            .unwrap();
        let hi = conv
            .point_to_key(&Point3::new(
                aabb.maxs.x as f64,
                aabb.maxs.y as f64,
                aabb.maxs.z as f64,
            ))
            .unwrap();
        let expect: Vec<Key> = tree
            .leaves()
            .filter(|l| tree.params().is_occupied(l.value))
            .filter(|l| {
                let (m, w) = (l.min_key(), l.width());
                (0..3).all(|a| (m[a] as u32) <= hi[a] as u32 && m[a] as u32 + w > lo[a] as u32)
            })
            .map(|l| l.key)
            .collect();
        let got: Vec<Key> = occupied_in_bbox(&tree, shape.as_ref(), &iso)
            .unwrap()
            .into_iter()
            .map(|v| v.key)
            .collect();
        assert_eq!(got, expect);
        nonempty += !got.is_empty() as usize;
    }
    assert!(nonempty > 10, "{nonempty}");
}

#[test]
fn pruned_block_collides_as_one_leaf_and_unknown_edges() {
    let mut rng = Rng(3);
    let tree = random_tree(&mut rng);
    // the centre of the pruned occupied block (keys 32776..32783 in x and y)
    let c = tree
        .converter()
        .key_to_point(&Key::new(32780, 32780, 32772));
    let ball = Ball::new(0.05);
    let v = colliding_voxels(&tree, &ball, &Isometry3::translation(c.x, c.y, c.z)).unwrap();
    assert_eq!(v.len(), 1);
    assert_eq!(v[0].depth, 13);
    assert!((v[0].size - 0.8).abs() < 1e-12);

    // far away: free of occupied voxels, but unknown
    let far = Isometry3::translation(50.0, 0.0, 0.0);
    let cautious = CollisionOptions {
        unknown_is_occupied: true,
    };
    assert!(!collides(&tree, &ball, &far, &CollisionOptions::default()).unwrap());
    assert!(collides(&tree, &ball, &far, &cautious).unwrap());
    // an empty tree is all unknown; outside the map counts as unknown
    let empty = OcTree::new(0.1).unwrap();
    assert!(collides(&empty, &ball, &Isometry3::identity(), &cautious).unwrap());
    assert!(!collides(
        &empty,
        &ball,
        &Isometry3::identity(),
        &CollisionOptions::default()
    )
    .unwrap());
    assert!(collides(
        &tree,
        &ball,
        &Isometry3::translation(1e4, 0.0, 0.0),
        &cautious
    )
    .unwrap());
    assert!(
        occupied_in_bbox(&tree, &ball, &Isometry3::translation(1e4, 0.0, 0.0))
            .unwrap()
            .is_empty()
    );
    // a non-finite pose is an error, not a panic
    assert!(collides(
        &tree,
        &ball,
        &Isometry3::translation(f64::NAN, 0.0, 0.0),
        &cautious
    )
    .is_err());
}
