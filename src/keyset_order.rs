//! OctoMap's `KeySet` with the iteration order it has under GCC's libstdc++, for code that
//! must visit keys exactly as a C++ program walking a `KeySet` does (octomap_server's
//! `insertScan`).
//!
//! Why it matters: OctoMap's occupancy updates give the same tree in any order, but a
//! `ColorOcTree`'s colours do not. An eager update can prune a node (its colour becomes the
//! children's average) that a later update of the same scan expands again (all children take
//! that average), while the other order never prunes it; so to give octomap_server's colours,
//! the updates must come in its order.
//!
//! With GCC (and not libc++), OctoMap's `OcTreeKey.h` makes `KeySet` a
//! `std::tr1::unordered_set<OcTreeKey, OcTreeKey::KeyHash>`, whose order is that of libstdc++'s
//! TR1 hash table, modelled by [`octoquant_octree::KeyTable`] (its docs give the rules; the
//! same model gives OctoMap's changed-keys order for the distance maps). A scan only inserts,
//! so the set keeps the insertions' history and rebuilds that order once, at the end
//! ([`octoquant_octree::KeySetLog`]).

use nalgebra::Point3;
use octoquant_octree::KeyConverter;
use octoquant_octree::{KeySetLog, KeySetPart};
use octoquant_raycast::{walk_ray_keys_f32, RayWalk};

/// A set of keys that iterates in the order of OctoMap's `KeySet` under libstdc++
/// ([`KeySetLog::order`]).
pub type KeySetOrder = KeySetLog;

/// `set.insert(ray.begin(), ray.end())` after OctoMap's `computeRayKeys(origin, end, ray)`
/// succeeds, as octomap_server adds a ray's voxels, into a stretch of a scan's insertions made
/// apart ([`KeySetPart`], appended to the scan's set in order): the keys go into the set as
/// the ray is walked, and a ray whose keys cannot be computed (an end outside the map, a
/// degenerate walk) adds nothing. Returns whether the keys were computed.
pub fn insert_ray_keys(
    set: &mut KeySetPart,
    conv: &KeyConverter,
    origin: &Point3<f32>,
    end: &Point3<f32>,
) -> bool {
    let mut range = set.range();
    match walk_ray_keys_f32(conv, origin, end, |k| {
        range.key(k);
        true
    }) {
        RayWalk::Complete | RayWalk::SameVoxel => {
            range.finish();
            true
        }
        RayWalk::OutsideMap | RayWalk::Stopped | RayWalk::Degenerate => {
            range.cancel();
            false
        }
    }
}
