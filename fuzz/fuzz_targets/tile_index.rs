//! The index of a directory of spilled tiles (`tiles.index`, written by distributed and
//! out-of-core builds, read by `octoquant join`): `read_index` on any bytes as the index
//! file. An index that reads must name tiles of its depth in strictly increasing order with
//! plain file names, and writing it and reading that back must give the same index.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant::tiles::{read_index, write_index};
use octoquant_fuzz::scratch_subdir;

fuzz_target!(|data: &[u8]| {
    let dir = scratch_subdir("tile_index");
    std::fs::write(dir.join("tiles.index"), data).expect("cannot write the scratch index");
    let Ok(index) = read_index(&dir) else {
        return;
    };
    assert!(index.resolution.is_finite() && index.resolution > 0.0);
    assert!(index.tile_depth <= 16);
    for w in index.tiles.windows(2) {
        assert!(w[0].0 < w[1].0, "index tiles out of order");
    }
    for (tile, name) in &index.tiles {
        assert_eq!(tile.depth(), index.tile_depth, "a tile of another depth");
        assert!(!name.is_empty() && !name.contains(['/', '\\']) && !name.starts_with('.'));
        assert!(
            !name.chars().any(char::is_control),
            "a file name with a control character"
        );
    }
    let out = scratch_subdir("tile_index_again");
    write_index(&out, &index).unwrap_or_else(|e| panic!("an index that reads does not write: {e}"));
    let back = read_index(&out).unwrap_or_else(|e| panic!("our own index does not read back: {e}"));
    assert!(
        back == index,
        "the tile index does not survive a write/read round trip"
    );
});
