//! The checkpoint manifest of `map --checkpoint`/`--resume` (`Checkpoint::load`), on any
//! bytes; a manifest that loads must load its tree without a panic (here the tree file is
//! absent or stale, so that is an error), agree with its own identity, and survive a save and
//! load round trip unchanged (identity, statistics, position).
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant::checkpoint::{Checkpoint, MANIFEST};
use octoquant::octree::OcTree;
use octoquant_fuzz::scratch_subdir;

fuzz_target!(|data: &[u8]| {
    let dir = scratch_subdir("checkpoint");
    std::fs::write(dir.join(MANIFEST), data).expect("cannot write the fuzz manifest");
    let Ok(c) = Checkpoint::load(&dir) else {
        return;
    };
    let _ = c.load_tree();
    c.identity
        .check_same(&c.identity, &dir)
        .expect("a checkpoint's identity differs from itself");
    let again = scratch_subdir("checkpoint-again");
    let tree = OcTree::new(0.1).expect("0.1 m is a valid resolution");
    Checkpoint::save(&again, &tree, &c.stats, c.done_hash, &c.identity)
        .expect("cannot save a checkpoint that loaded");
    let d = Checkpoint::load(&again).expect("a saved checkpoint does not load back");
    assert_eq!(format!("{:?}", d.identity), format!("{:?}", c.identity));
    assert_eq!(format!("{:?}", d.stats), format!("{:?}", c.stats));
    assert_eq!((d.frames_done, d.done_hash), (c.frames_done, c.done_hash));
});
