//! PCD v0.7 (ascii, binary, binary_compressed with LZF) through the real entry point
//! `read_pcd` on a `.pcd` file, with the viewpoint applied or as origin only (by the
//! input length's parity, so each input reads once), with its colour field (`rgb`/`rgba`)
//! decoded or not (by the length's second bit).
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::pcd::{read_pcd_with, PcdOptions, ViewpointUse};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("input.pcd", data, |path| {
        let viewpoint = if data.len().is_multiple_of(2) {
            ViewpointUse::Apply
        } else {
            ViewpointUse::OriginOnly
        };
        let colors = data.len() & 2 != 0;
        let _ = read_pcd_with(path, &PcdOptions { viewpoint }, colors);
    });
});
