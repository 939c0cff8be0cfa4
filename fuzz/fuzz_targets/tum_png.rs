//! TUM 16-bit depth PNGs: `read_tum_depth` (decode and back-project with the default
//! intrinsics) on a `.png` file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::tum::{read_tum_depth, TumOptions};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("depth.png", data, |path| {
        let _ = read_tum_depth(path, &TumOptions::default());
    });
});
