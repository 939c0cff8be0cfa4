//! `.bt` (OctoMap binary, and the legacy headerless form): `read_bt` and `read_tree` on any
//! bytes. A tree that reads must be well formed, and writing it, reading that back and
//! writing again must give the same bytes.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_octree::io::{read_bt, read_tree, write_bt_const};
use octoquant_octree::validate::check_well_formed;
use octoquant_octree::InnerNodes;

fuzz_target!(|data: &[u8]| {
    let _ = read_tree(data);
    let Ok(tree) = read_bt(data) else { return };
    if let Err(e) = check_well_formed(&tree, InnerNodes::Defer) {
        panic!("read_bt gave a malformed tree: {e}");
    }
    let mut first = Vec::new();
    write_bt_const(&tree, &mut first).unwrap();
    let again = read_bt(first.as_slice()).expect("our own .bt output does not read back");
    let mut second = Vec::new();
    write_bt_const(&again, &mut second).unwrap();
    assert!(
        first == second,
        ".bt write/read/write is not a byte round trip"
    );
});
