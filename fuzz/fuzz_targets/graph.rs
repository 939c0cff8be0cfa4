//! OctoMap ScanGraph `.graph`: `parse_graph` on any bytes (the in-memory function
//! `read_graph` calls), both frame conversions, and a write/read/write byte round trip; the
//! same bytes as a file through the node-by-node reader `graph_file_stream`, which must give
//! the frames of the whole-file parse and fail exactly when it fails, and a slice of it
//! (`skip_frames` over the first nodes), which must give the remaining frames.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::graph::{
    graph_file_stream, graph_to_frames, parse_graph, write_graph, GraphOptions,
};
use octoquant_formats::{FormatError, Frame};
use octoquant_fuzz::with_file;
use std::path::Path;

/// Every coordinate's bits (NaN is never `==`).
fn bits(frames: &[Frame]) -> Vec<u32> {
    frames
        .iter()
        .flat_map(|f| std::iter::once(&f.origin).chain(&f.points))
        .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
        .collect()
}

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.graph");
    let parsed = parse_graph(path, data);
    let options = GraphOptions {
        points_global: data.first().is_some_and(|b| b & 1 == 1),
    };
    let k = data.last().map_or(0, |&b| usize::from(b % 8));
    let (streamed, sliced) = with_file("input.graph", data, |file| {
        let streamed =
            graph_file_stream(file, &options).and_then(|s| s.collect::<Result<Vec<_>, _>>());
        let sliced: Result<_, FormatError> = graph_file_stream(file, &options).and_then(|mut s| {
            let passed = s.skip_frames(k)?;
            Ok((passed, s.collect::<Result<Vec<_>, _>>()?))
        });
        (streamed, sliced)
    });
    match (&parsed, &streamed) {
        (Ok(g), Ok(frames)) => {
            assert!(
                bits(&graph_to_frames(g, &options)) == bits(frames),
                "the stream read other frames than parse_graph"
            );
            // a stream that reads every node reads every slice
            let (passed, rest) = sliced.expect("a slice failed where the whole stream did not");
            assert_eq!(
                passed,
                k.min(frames.len()),
                "skip_frames passed a wrong count"
            );
            assert!(
                bits(&rest) == bits(&frames[passed..]),
                "a slice gave other frames"
            );
        }
        (Err(_), Err(_)) => {}
        (Ok(_), Err(e)) => panic!("the stream failed where parse_graph did not: {e}"),
        (Err(e), Ok(_)) => panic!("the stream read a file parse_graph refuses: {e}"),
    }
    let Ok(graph) = parsed else {
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
