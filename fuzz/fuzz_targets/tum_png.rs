//! TUM 16-bit depth PNGs: `read_tum_depth` (decode and back-project with the default
//! intrinsics) on a `.png` file, under a decompression limit with a 1 MiB floor (the default
//! floor, 64 MiB, would let every small PNG claiming a large image decode 64 MiB: the same
//! code paths, at a cost per input the campaign can afford). The same file also goes through
//! the colour image reader `read_color_png` (TUM RGB images).
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::source::{with_decompression_limit, DecompressionLimit};
use octoquant_formats::tum::{read_color_png, read_tum_depth, TumOptions};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    let limit = DecompressionLimit {
        min_bytes: 1 << 20,
        ..DecompressionLimit::DEFAULT
    };
    with_decompression_limit(limit, || {
        with_file("depth.png", data, |path| {
            let _ = read_tum_depth(path, &TumOptions::default());
            if let Ok(img) = read_color_png(path) {
                assert_eq!(img.data.len(), img.width as usize * img.height as usize);
            }
        })
    });
});
