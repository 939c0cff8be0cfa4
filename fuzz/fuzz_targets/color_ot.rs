//! `.ot` of type `ColorOcTree` (OctoMap's colour tree: log-odds plus an RGB byte triple per
//! node): `read_color_ot` on any bytes. A tree that reads must have a well-formed occupancy
//! tree, every node found by a search of a leaf must report a colour, and writing it, reading
//! that back and writing again must give the same bytes. Then a few colour operations on the
//! tree that was read (set, average, integrate, prune, max-likelihood) must keep it readable
//! and round-tripping.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_octree::io::{read_color_ot, write_color_ot};
use octoquant_octree::validate::check_well_formed;
use octoquant_octree::{Color, ColorOcTree, InnerNodes, TREE_DEPTH};

fn bytes_of(tree: &ColorOcTree) -> Vec<u8> {
    let mut out = Vec::new();
    write_color_ot(tree, &mut out).unwrap();
    out
}

fn round_trip(tree: &ColorOcTree, what: &str) {
    let first = bytes_of(tree);
    let again = read_color_ot(first.as_slice())
        .unwrap_or_else(|e| panic!("our own ColorOcTree .ot ({what}) does not read back: {e}"));
    assert_eq!(again.size(), tree.size(), "node count after {what}");
    assert!(
        first == bytes_of(&again),
        "ColorOcTree .ot write/read/write is not a byte round trip ({what})"
    );
}

fuzz_target!(|data: &[u8]| {
    let Ok(mut tree) = read_color_ot(data) else {
        return;
    };
    if let Err(e) = check_well_formed(tree.occupancy(), InnerNodes::Defer) {
        panic!("read_color_ot gave a malformed occupancy tree: {e}");
    }
    round_trip(&tree, "read");
    // A few leaves get colour operations, with a colour taken from the input's last bytes.
    let tail = data.len().saturating_sub(3);
    let c = |i: usize| data.get(tail + i).copied().unwrap_or(0);
    let colour = Color::new(c(0), c(1), c(2));
    let keys: Vec<_> = tree
        .occupancy()
        .leaves()
        .filter(|l| l.depth == TREE_DEPTH)
        .map(|l| l.key)
        .take(8)
        .collect();
    for (i, key) in keys.into_iter().enumerate() {
        let now = match i % 3 {
            0 => tree.set_node_color(key, colour),
            1 => tree.average_node_color(key, colour),
            _ => tree.integrate_node_color(key, colour),
        };
        assert!(now.is_some(), "a colour update missed a voxel that exists");
        assert_eq!(
            tree.node_color(key),
            now,
            "the colour read back is not the one set"
        );
        if i % 3 == 0 {
            assert_eq!(now, Some(colour), "set_node_color did not set the colour");
        }
    }
    tree.update_inner_occupancy();
    round_trip(&tree, "colour updates");
    tree.prune();
    round_trip(&tree, "prune");
    tree.to_max_likelihood();
    round_trip(&tree, "max-likelihood");
});
