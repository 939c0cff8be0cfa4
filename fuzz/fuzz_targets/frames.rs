//! `.frames` (the exchange format with the C++ reference program): `parse_frames` on any
//! bytes (the in-memory function `read_frames_file` calls) and a write/read/write byte
//! round trip.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::frames::{parse_frames, write_frames};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.frames");
    let Ok(frames) = parse_frames(path, data) else {
        return;
    };
    let mut first = Vec::new();
    write_frames(&mut first, &frames).unwrap();
    let again = parse_frames(path, &first).expect("our own .frames output does not read back");
    let mut second = Vec::new();
    write_frames(&mut second, &again).unwrap();
    assert!(
        first == second,
        ".frames write/read/write is not a byte round trip"
    );
});
