//! OctoMap ScanGraph `.graph`: `parse_graph` on any bytes (the in-memory function
//! `read_graph` calls), both frame conversions, and a write/read/write byte round trip.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::graph::{graph_to_frames, parse_graph, write_graph, GraphOptions};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.graph");
    let Ok(graph) = parse_graph(path, data) else {
        return;
    };
    for points_global in [false, true] {
        let _ = graph_to_frames(&graph, &GraphOptions { points_global });
    }
    let mut first = Vec::new();
    write_graph(&mut first, &graph).unwrap();
    let again = parse_graph(path, &first).expect("our own .graph output does not read back");
    let mut second = Vec::new();
    write_graph(&mut second, &again).unwrap();
    assert!(
        first == second,
        ".graph write/read/write is not a byte round trip"
    );
});
