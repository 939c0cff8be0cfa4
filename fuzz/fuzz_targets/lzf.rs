//! The LZF decompressor of PCD `binary_compressed`: the first two bytes give the expected
//! output length, the rest is the stream. Success must mean exactly that many bytes.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::pcd::lzf_decompress;

fuzz_target!(|data: &[u8]| {
    if data.len() < 2 {
        return;
    }
    let out_len = usize::from(u16::from_le_bytes([data[0], data[1]]));
    if let Ok(out) = lzf_decompress(&data[2..], out_len) {
        assert_eq!(out.len(), out_len);
    }
});
