//! `input::count_frames`, the frame count `map` reads ahead of a run for its ETA (MCAP
//! summary statistics through `mcap::announced_clouds`, `.frames` and `.graph` headers, TUM
//! association rows), on any bytes. The first byte picks the file name (so the format), the
//! rest is the file. A count is only what the input announces (a damaged file may end
//! earlier), so beyond "no panic" the check is: when the whole `.frames` (plain or gzip) or
//! `.graph` file reads without error, the count announced is the number of frames or nodes
//! read.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::frames::frames_file_stream;
use octoquant_formats::graph::read_graph;
use octoquant_formats::source::with_decompression_limit;
use octoquant_formats::{count_frames, DecompressionLimit, ReadOptions};
use octoquant_fuzz::with_file;

const NAMES: [&str; 5] = [
    "input.mcap",
    "input.frames",
    "input.graph",
    "associations.txt",
    "input.frames.gz",
];

fuzz_target!(|data: &[u8]| {
    let Some((&first, file)) = data.split_first() else {
        return;
    };
    let name = NAMES[usize::from(first) % NAMES.len()];
    let limit = DecompressionLimit {
        min_bytes: 1 << 20,
        ..DecompressionLimit::DEFAULT
    };
    let options = ReadOptions {
        decompression: limit,
        ..ReadOptions::default()
    };
    with_file(name, file, |path| {
        let count = count_frames(path, &options);
        let read = with_decompression_limit(limit, || match name {
            "input.frames" | "input.frames.gz" => frames_file_stream(path)
                .ok()?
                .collect::<Result<Vec<_>, _>>()
                .ok()
                .map(|f| f.len()),
            "input.graph" => read_graph(path).ok().map(|g| g.nodes.len()),
            _ => None,
        });
        if let Some(n) = read {
            assert_eq!(count, Some(n), "{name}: announced count != frames read");
        }
    });
});
