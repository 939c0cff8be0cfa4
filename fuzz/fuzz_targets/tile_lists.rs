//! The tile update lists of distributed building (`OQTU` buffers that Dask ships between
//! ray tasks and tile tasks): `TileUpdates::from_bytes` on any bytes. A buffer that reads
//! must keep the lists' promises (`check`), encode again to a buffer that reads back to the
//! same lists, and apply to a tile tree (clamping, pruning) without a panic, leaving a
//! well-formed tree whose every updated voxel lies in the tile.
//!
//! The buffers end in an FNV-1a checksum, which random mutations almost never satisfy: the
//! first input byte chooses between the rest as it is (the checksum path) and the rest with
//! its last 8 bytes replaced by the checksum of what precedes them, computed here from the
//! FNV-1a definition, so that mutations reach the header, varint and list checks behind it.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant::octree::validate::check_well_formed;
use octoquant::octree::{InnerNodes, OcTree, TREE_DEPTH};
use octoquant::tiles::{apply_tile_updates, TileUpdates};

/// FNV-1a, 64 bits, from its definition (offset basis and prime of the FNV specification).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else {
        return;
    };
    let mut buffer = rest.to_vec();
    if pick & 1 == 1 && buffer.len() >= 8 {
        let body = buffer.len() - 8;
        let sum = fnv1a(&buffer[..body]);
        buffer[body..].copy_from_slice(&sum.to_le_bytes());
    }
    let Ok(lists) = TileUpdates::from_bytes(&buffer) else {
        return;
    };
    if let Err(e) = lists.check() {
        panic!("from_bytes accepted lists that break their invariants: {e}");
    }
    let again = lists
        .to_bytes()
        .unwrap_or_else(|e| panic!("lists that read do not encode: {e}"));
    let back = TileUpdates::from_bytes(&again)
        .unwrap_or_else(|e| panic!("our own tile buffer does not read back: {e}"));
    assert!(
        back == lists,
        "tile lists do not survive an encode/decode round trip"
    );
    // applying is bounded by the input: each code is at least one byte of it
    let mut tree = OcTree::new(0.1).expect("0.1 m is a valid resolution");
    let stats = apply_tile_updates(&mut tree, lists.tile, std::slice::from_ref(&lists))
        .unwrap_or_else(|e| panic!("lists that read do not apply to their own tile: {e}"));
    assert_eq!(stats.frames, lists.frames.len(), "frames applied");
    assert_eq!(
        stats.free + stats.occupied,
        lists.voxel_updates(),
        "voxel updates applied"
    );
    if let Err(e) = check_well_formed(&tree, InnerNodes::Refresh) {
        panic!("applying tile lists gave a malformed tree: {e}");
    }
    for leaf in tree.leaves() {
        let key = leaf.key;
        // a pruned leaf stands for its whole octant: its first voxel must be in the tile
        assert!(
            lists.tile.contains_code(key.morton()),
            "a leaf at depth {} of {TREE_DEPTH} lies outside the tile",
            leaf.depth
        );
    }
});
