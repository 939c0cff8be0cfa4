//! Names for nodes that survive the tree's restructuring: a node is its depth and its smallest
//! voxel key. The side tables of the tree types that carry more than occupancy per node
//! (`ColorOcTree`'s colours, `OcTreeStamped`'s time stamps) are keyed by it.

use crate::key::Key;
use crate::key_hasher::KeyHashing;

/// The side table's key for a node: its depth and smallest voxel key.
pub(crate) type NodeId = (u8, Key);

/// The id of the node at `depth` containing `key`.
#[inline]
pub(crate) fn node_id(key: Key, depth: u8) -> NodeId {
    (depth, key.min_at_depth(depth))
}

/// The id of child `i` of the node `id`.
#[inline]
pub(crate) fn child_id(id: NodeId, i: usize) -> NodeId {
    let (depth, mut k) = id;
    let half = 1u16 << (15 - depth);
    for a in 0..3 {
        if i >> a & 1 == 1 {
            k.0[a] |= half;
        }
    }
    (depth + 1, k)
}

/// The side tables' map from node ids to payloads, hashed by [`crate::key_hasher::KeyHasher`].
pub(crate) type NodeMap<P> = std::collections::HashMap<NodeId, P, KeyHashing>;
