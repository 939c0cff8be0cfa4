//! `.ot` (OctoMap full tree with log-odds): `read_ot` and `read_tree` on any bytes. A tree
//! that reads must be well formed, and writing it, reading that back and writing again must
//! give the same bytes.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_octree::io::{read_ot, read_tree, write_ot};
use octoquant_octree::validate::check_well_formed;
use octoquant_octree::InnerNodes;

fuzz_target!(|data: &[u8]| {
    let _ = read_tree(data);
    let Ok(tree) = read_ot(data) else { return };
    if let Err(e) = check_well_formed(&tree, InnerNodes::Defer) {
        panic!("read_ot gave a malformed tree: {e}");
    }
    let mut first = Vec::new();
    write_ot(&tree, &mut first).unwrap();
    let again = read_ot(first.as_slice()).expect("our own .ot output does not read back");
    let mut second = Vec::new();
    write_ot(&again, &mut second).unwrap();
    assert!(
        first == second,
        ".ot write/read/write is not a byte round trip"
    );
});
