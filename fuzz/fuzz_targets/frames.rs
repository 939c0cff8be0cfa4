//! `.frames` (the exchange format with the C++ reference program): `parse_frames` on any
//! bytes (the in-memory function `read_frames_file` calls), a write/read/write byte round
//! trip, and the streaming reader `frames_file_stream` on the same bytes as a file, which must
//! give the same frames, and fail exactly when `parse_frames` fails.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::frames::{frames_file_stream, parse_frames, write_frames};
use octoquant_fuzz::with_file;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.frames");
    let whole = parse_frames(path, data);
    let streamed = with_file("input.frames", data, |file| {
        frames_file_stream(file).and_then(|s| s.collect::<Result<Vec<_>, _>>())
    });
    match (&whole, &streamed) {
        // Compared as written bytes: NaN coordinates are never `==`.
        (Ok(a), Ok(b)) => {
            let (mut wa, mut wb) = (Vec::new(), Vec::new());
            write_frames(&mut wa, a).unwrap();
            write_frames(&mut wb, b).unwrap();
            assert!(wa == wb, "the stream read other frames than parse_frames");
        }
        (Err(_), Err(_)) => {}
        (Ok(_), Err(e)) => panic!("the stream failed where parse_frames did not: {e}"),
        (Err(e), Ok(_)) => panic!("the stream read a file parse_frames refuses: {e}"),
    }
    let Ok(frames) = whole else {
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
