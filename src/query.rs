//! Collision queries for planners: does a parry3d shape at a pose touch occupied space, and
//! which occupied voxels lie in its bounding box.
//!
//! - [`collides`]: `true` when the shape touches an occupied leaf (or, with
//!   [`CollisionOptions::unknown_is_occupied`], unknown space).
//! - [`colliding_voxels`]: the occupied leaves the shape touches.
//! - [`occupied_in_bbox`]: the occupied leaves overlapping the shape's axis-aligned bounding
//!   box, without the exact shape test (the broad phase, or a local map for a planner).
//!
//! Poses are nalgebra `Isometry3<f64>` like the rest of the crate; parry3d works in `f32`
//! glam types, and [`convert`] is the one place where the two meet. Leaves are tested as
//! cuboids of their own size, so a pruned 8×8×8 block is one test. Touching counts as a
//! collision.
//!
//! ```
//! use nalgebra::{Isometry3, Point3, Vector3};
//! use octoquant::parry3d::shape::Ball;
//! use octoquant::query::{collides, CollisionOptions};
//! use octoquant::{InnerNodes, OcTree, Update};
//!
//! let mut tree = OcTree::new(0.1).unwrap();
//! let key = tree.converter().point_to_key(&Point3::new(1.0, 0.0, 0.0)).unwrap();
//! tree.update_node(key, Update::Hit, InnerNodes::Refresh);
//! let ball = Ball::new(0.3);
//! let near = Isometry3::translation(1.2, 0.0, 0.0);
//! let far = Isometry3::translation(3.0, 0.0, 0.0);
//! let opts = CollisionOptions::default();
//! assert!(collides(&tree, &ball, &near, &opts).unwrap());
//! assert!(!collides(&tree, &ball, &far, &opts).unwrap());
//! // far from the one known voxel, space is unknown
//! let cautious = CollisionOptions { unknown_is_occupied: true };
//! assert!(collides(&tree, &ball, &far, &cautious).unwrap());
//! ```

use nalgebra::{Isometry3, Point3};
use octoquant_octree::{Key, OcTree, TREE_DEPTH};
use parry3d::math::Vector;
use parry3d::query::intersection_test;
use parry3d::shape::{Cuboid, Shape};

/// Conversions between nalgebra (`f64`, the crate's API) and parry3d's glam types (`f32`).
///
/// The only place where the two libraries meet; scene and query code goes through here.
pub mod convert {
    use nalgebra::{Isometry3, Point3, Vector3};
    use parry3d::math::{Pose, Rot3, Vector};

    /// A nalgebra isometry as a parry pose (rounded to `f32`).
    pub fn pose_to_parry(iso: &Isometry3<f64>) -> Pose {
        let q = iso.rotation.quaternion();
        let t = &iso.translation.vector;
        Pose::from_parts(
            Vector::new(t.x as f32, t.y as f32, t.z as f32),
            Rot3::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32).normalize(),
        )
    }

    /// A nalgebra vector as a parry vector (rounded to `f32`).
    pub fn vector_to_parry(v: &Vector3<f64>) -> Vector {
        Vector::new(v.x as f32, v.y as f32, v.z as f32)
    }

    /// A nalgebra point as a parry vector (rounded to `f32`).
    pub fn point_to_parry(p: &Point3<f64>) -> Vector {
        Vector::new(p.x as f32, p.y as f32, p.z as f32)
    }

    /// A parry vector (a point) as a nalgebra point.
    pub fn point_from_parry(v: Vector) -> Point3<f64> {
        Point3::new(v.x as f64, v.y as f64, v.z as f64)
    }
}

use convert::{point_from_parry, point_to_parry, pose_to_parry};

/// Errors from collision queries.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum QueryError {
    /// parry3d has no intersection test between this shape and a cuboid.
    #[error("parry3d cannot test a {shape} shape against a voxel cuboid")]
    Unsupported {
        /// The shape's type, as parry names it.
        shape: String,
    },
    /// The pose or the shape's bounding box is not finite.
    #[error("the shape's pose or bounding box is not finite")]
    NotFinite,
}

/// How [`collides`] treats space the map knows nothing about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CollisionOptions {
    /// Count unknown space (never observed, or outside the map's addressable cube) as
    /// occupied: the cautious choice for planning in a partly explored map.
    pub unknown_is_occupied: bool,
}

/// An occupied leaf returned by a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Voxel {
    /// The leaf's key (OctoMap's iterator convention: a depth-16 key at the cube's centre).
    pub key: Key,
    /// Its depth (16 = one voxel, less for a pruned block).
    pub depth: u8,
    /// Centre of its cube, metres.
    pub center: Point3<f64>,
    /// Edge length of its cube, metres.
    pub size: f64,
    /// Its log-odds.
    pub log_odds: f32,
}

/// The shape's world AABB and the inclusive key box of voxels it overlaps.
struct Footprint {
    min: Point3<f64>,
    max: Point3<f64>,
    /// Key box clamped to the map; `None` when the box misses the map entirely.
    keys: Option<(Key, Key)>,
    /// Whether the box reaches outside the map's addressable cube.
    leaves_map: bool,
}

fn footprint(
    tree: &OcTree,
    shape: &dyn Shape,
    pose: &Isometry3<f64>,
) -> Result<Footprint, QueryError> {
    let ppose = pose_to_parry(pose);
    let aabb = shape.compute_aabb(&ppose);
    let (min, max) = (point_from_parry(aabb.mins), point_from_parry(aabb.maxs));
    if !(min
        .coords
        .iter()
        .chain(max.coords.iter())
        .all(|v| v.is_finite()))
    {
        return Err(QueryError::NotFinite);
    }
    let conv = tree.converter();
    let mut lo = [0u16; 3];
    let mut hi = [0u16; 3];
    let mut leaves_map = false;
    let mut misses = false;
    let half_span = conv.resolution() * 32768.0;
    for a in 0..3 {
        if max[a] < -half_span || min[a] >= half_span {
            misses = true;
        }
        if min[a] < -half_span || max[a] >= half_span {
            leaves_map = true;
        }
        lo[a] = conv
            .coord_to_key_checked(min[a])
            .unwrap_or(if min[a] < 0.0 { 0 } else { u16::MAX });
        hi[a] = conv
            .coord_to_key_checked(max[a])
            .unwrap_or(if max[a] < 0.0 { 0 } else { u16::MAX });
    }
    Ok(Footprint {
        min,
        max,
        keys: (!misses).then_some((Key(lo), Key(hi))),
        leaves_map,
    })
}

/// Whether the cube centred at `center` with edge `size` touches the shape.
///
/// The cube is first clipped to the shape's bounding box: the shape lies inside it, so the
/// answer is the same, and a huge unknown block becomes a small cuboid that `f32` holds
/// precisely.
fn cube_touches(
    center: &Point3<f64>,
    size: f64,
    shape: &dyn Shape,
    shape_pose: &parry3d::math::Pose,
    fp: &Footprint,
) -> Result<bool, QueryError> {
    let h = size / 2.0;
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for a in 0..3 {
        lo[a] = (center[a] - h).max(fp.min[a]);
        hi[a] = (center[a] + h).min(fp.max[a]);
        if lo[a] > hi[a] {
            return Ok(false);
        }
    }
    let half = Vector::new(
        ((hi[0] - lo[0]) / 2.0) as f32,
        ((hi[1] - lo[1]) / 2.0) as f32,
        ((hi[2] - lo[2]) / 2.0) as f32,
    );
    let mid = Point3::new(
        (lo[0] + hi[0]) / 2.0,
        (lo[1] + hi[1]) / 2.0,
        (lo[2] + hi[2]) / 2.0,
    );
    let cube_pose = parry3d::math::Pose::from_translation(point_to_parry(&mid));
    intersection_test(&cube_pose, &Cuboid::new(half), shape_pose, shape)
        .map(|i| i.intersecting)
        .map_err(|_| QueryError::Unsupported {
            shape: format!("{:?}", shape.shape_type()),
        })
}

/// Whether the cube overlaps the metric box `[min, max]` (closed).
fn cube_in_box(center: &Point3<f64>, size: f64, fp: &Footprint) -> bool {
    let h = size / 2.0;
    (0..3).all(|a| center[a] - h <= fp.max[a] && center[a] + h >= fp.min[a])
}

fn voxel_of(tree: &OcTree, key: Key, depth: u8, log_odds: f32) -> Voxel {
    let conv = tree.converter();
    Voxel {
        key,
        depth,
        center: conv.key_to_point_at_depth(&key, depth),
        size: conv.node_size(depth),
        log_odds,
    }
}

/// Occupied leaves whose cubes overlap the voxels spanned by the shape's axis-aligned
/// bounding box at `pose` (the broad phase; no exact shape test), in the tree's pre-order.
pub fn occupied_in_bbox(
    tree: &OcTree,
    shape: &dyn Shape,
    pose: &Isometry3<f64>,
) -> Result<Vec<Voxel>, QueryError> {
    let fp = footprint(tree, shape, pose)?;
    let Some((lo, hi)) = fp.keys else {
        return Ok(Vec::new());
    };
    let params = tree.params();
    Ok(tree
        .leaves_in_bbx(lo, hi)
        .filter(|l| params.is_occupied(l.value))
        .map(|l| voxel_of(tree, l.key, l.depth, l.value))
        .collect())
}

/// Occupied leaves the shape at `pose` touches, in the tree's pre-order.
pub fn colliding_voxels(
    tree: &OcTree,
    shape: &dyn Shape,
    pose: &Isometry3<f64>,
) -> Result<Vec<Voxel>, QueryError> {
    let ppose = pose_to_parry(pose);
    let fp = footprint(tree, shape, pose)?;
    let mut out = Vec::new();
    for v in occupied_in_bbox(tree, shape, pose)? {
        if cube_touches(&v.center, v.size, shape, &ppose, &fp)? {
            out.push(v);
        }
    }
    Ok(out)
}

/// Whether the shape at `pose` touches an occupied leaf, or with
/// [`CollisionOptions::unknown_is_occupied`] unknown space too.
///
/// With unknown counted as occupied, a shape whose bounding box leaves the map's addressable
/// cube (±32768 voxels around the origin) collides, and the search descends the tree so that
/// whole unknown blocks are tested as one cuboid each.
pub fn collides(
    tree: &OcTree,
    shape: &dyn Shape,
    pose: &Isometry3<f64>,
    options: &CollisionOptions,
) -> Result<bool, QueryError> {
    let ppose = pose_to_parry(pose);
    let fp = footprint(tree, shape, pose)?;
    if !options.unknown_is_occupied {
        let Some((lo, hi)) = fp.keys else {
            return Ok(false);
        };
        let conv = tree.converter();
        let params = tree.params();
        for leaf in tree.leaves_in_bbx(lo, hi) {
            if !params.is_occupied(leaf.value) {
                continue;
            }
            let center = conv.key_to_point_at_depth(&leaf.key, leaf.depth);
            let size = conv.node_size(leaf.depth);
            if cube_touches(&center, size, shape, &ppose, &fp)? {
                return Ok(true);
            }
        }
        return Ok(false);
    }
    if fp.leaves_map {
        return Ok(true);
    }
    let Some((lo, hi)) = fp.keys else {
        return Ok(true);
    };
    if tree.is_empty() {
        return Ok(true);
    }
    let walk = Walk {
        tree,
        shape,
        pose: &ppose,
        fp: &fp,
        lo,
        hi,
    };
    for child in 0..8 {
        if walk.node(child_min([0; 3], 0, child), 1)? {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Smallest key of child `i` of the node at `depth` whose smallest key is `min`.
fn child_min(min: [u32; 3], depth: u8, i: usize) -> [u32; 3] {
    let w = 1u32 << (TREE_DEPTH - depth - 1);
    let mut m = min;
    for (a, v) in m.iter_mut().enumerate() {
        if i & (1 << a) != 0 {
            *v += w;
        }
    }
    m
}

/// The descent of [`collides`] with unknown space counted as occupied.
struct Walk<'a> {
    tree: &'a OcTree,
    shape: &'a dyn Shape,
    pose: &'a parry3d::math::Pose,
    fp: &'a Footprint,
    lo: Key,
    hi: Key,
}

impl Walk<'_> {
    /// Whether anything occupied or unknown in the node at `depth` with smallest key `min`
    /// touches the shape.
    fn node(&self, min: [u32; 3], depth: u8) -> Result<bool, QueryError> {
        let w = 1u32 << (TREE_DEPTH - depth);
        let overlaps =
            (0..3).all(|a| min[a] <= self.hi[a] as u32 && min[a] + w > self.lo[a] as u32);
        if !overlaps {
            return Ok(false);
        }
        let key = Key(min.map(|v| v as u16));
        let conv = self.tree.converter();
        let center = conv.key_to_point_at_depth(&key, depth);
        let size = conv.node_size(depth);
        if !cube_in_box(&center, size, self.fp) {
            return Ok(false);
        }
        match self.tree.search(key, depth) {
            None => cube_touches(&center, size, self.shape, self.pose, self.fp),
            Some(info) if !info.has_children => {
                if !self.tree.params().is_occupied(info.value) {
                    return Ok(false);
                }
                // A leaf found above `depth` covers this cube; test the leaf's own cube.
                let c = conv.key_to_point_at_depth(&key, info.depth);
                cube_touches(
                    &c,
                    conv.node_size(info.depth),
                    self.shape,
                    self.pose,
                    self.fp,
                )
            }
            Some(_) => {
                if !cube_touches(&center, size, self.shape, self.pose, self.fp)? {
                    return Ok(false);
                }
                for i in 0..8 {
                    if self.node(child_min(min, depth, i), depth + 1)? {
                        return Ok(true);
                    }
                }
                Ok(false)
            }
        }
    }
}

/// What a map says at one point: OctoMap's `search(point3d)` and `isNodeOccupied`, as
/// `octoquant query` prints it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointOccupancy {
    /// The class: unknown (no node), free or occupied (log-odds against the threshold).
    pub class: octoquant_octree::VoxelClass,
    /// The node found: the voxel, or the pruned leaf above it that covers it.
    pub node: Option<octoquant_octree::NodeInfo>,
}

impl PointOccupancy {
    /// The node's occupancy probability (OctoMap's `getOccupancy`), `None` in unknown space.
    pub fn probability(&self) -> Option<f64> {
        self.node
            .map(|n| octoquant_octree::probability(f64::from(n.value)))
    }
}

/// The node holding `point` and its class, as OctoMap's `search(point3d)` finds it: the
/// coordinates are first narrowed to `f32` (OctoMap's `point3d`, which is what C++ and
/// octomap-python callers pass), so a point on a voxel border lands where OctoMap puts it.
/// Points outside the map, or not finite, are unknown.
pub fn occupancy_at(tree: &OcTree, point: &Point3<f64>) -> PointOccupancy {
    use octoquant_octree::VoxelClass;
    let narrowed = point.map(|c| f64::from(c as f32));
    let node = tree
        .converter()
        .point_to_key_checked(&narrowed)
        .ok()
        .and_then(|k| tree.search(k, TREE_DEPTH));
    let class = match node {
        None => VoxelClass::Unknown,
        Some(n) if tree.params().is_occupied(n.value) => VoxelClass::Occupied,
        Some(_) => VoxelClass::Free,
    };
    PointOccupancy { class, node }
}
