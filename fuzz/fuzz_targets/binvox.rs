//! binvox voxel grids: `parse_binvox` on any bytes (the in-memory function `read_binvox`
//! calls), a write/read round trip of the cells, and for small grids the import into a tree
//! (binvox2bt's placement, with every option) followed by the inner-node pass and pruning.
#![no_main]
use libfuzzer_sys::fuzz_target;
use nalgebra::{Point3, Vector3};
use octoquant::import::{finish_import, import_binvox, tree_for_binvox, BinvoxImport};
use octoquant_formats::binvox::{parse_binvox, write_binvox};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(grid) = parse_binvox(Path::new("input.binvox"), data) else {
        return;
    };
    let covered: usize = grid.runs.iter().map(|r| usize::from(r.count)).sum();
    assert_eq!(covered, grid.cells(), "the runs cover the grid exactly");
    if grid.cells() > 1 << 16 {
        return;
    }
    let cells: Vec<u8> = grid.cells_iter().map(|(_, v)| v).collect();
    let again = parse_binvox(
        Path::new("again.binvox"),
        &write_binvox(grid.dims, grid.translate, grid.scale, &cells),
    )
    .expect("our own binvox output does not read back");
    assert_eq!(
        (again.dims, again.translate, again.scale),
        (grid.dims, grid.translate, grid.scale)
    );
    assert!(again.cells_iter().map(|(_, v)| v).eq(cells.iter().copied()));
    if grid.cells() > 4096 {
        return;
    }
    let Ok(mut tree) = tree_for_binvox(&grid) else {
        return;
    };
    let last = data.last().copied().unwrap_or(0);
    let options = BinvoxImport {
        mark_free: last & 1 != 0,
        rotate: last & 2 != 0,
        bbx: (last & 4 != 0).then(|| (Point3::new(-1.0, -2.0, -3.0), Point3::new(1.0, 2.0, 3.0))),
        offset: (last & 8 != 0).then(|| Vector3::new(0.5, -0.25, 1e30)),
    };
    let st = import_binvox(&mut tree, &grid, &options);
    assert!(st.hits + st.misses + st.outside_map + st.outside_box <= grid.cells() as u64);
    finish_import(&mut tree);
});
