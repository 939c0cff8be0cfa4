//! TUM 16-bit depth PNGs: `read_tum_depth` (decode and back-project with the default
//! intrinsics) on a `.png` file, under a decompression limit with a 1 MiB floor (the default
//! floor, 64 MiB, would let every small PNG claiming a large image decode 64 MiB: the same
//! code paths, at a cost per input the campaign can afford).
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::source::{with_decompression_limit, DecompressionLimit};
use octoquant_formats::tum::{read_tum_depth, TumOptions};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    let limit = DecompressionLimit {
        min_bytes: 1 << 20,
        ..DecompressionLimit::DEFAULT
    };
    with_decompression_limit(limit, || {
        with_file("depth.png", data, |path| {
            let _ = read_tum_depth(path, &TumOptions::default());
        })
    });
});
