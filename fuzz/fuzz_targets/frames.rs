//! `.frames` (the exchange format with the C++ reference program): `parse_frames` on any
//! bytes (the in-memory function `read_frames_file` calls), a write/read/write byte round
//! trip, and the streaming reader `frames_file_stream` on the same bytes as a file, which must
//! give the same frames, and fail exactly when `parse_frames` fails; also after passing over
//! the first frames with `skip_frames` (a distributed task's slice), which must give the
//! remaining frames, or the stream's error.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::frames::{frames_file_stream, parse_frames, write_frames};
use octoquant_formats::FormatError;
use octoquant_fuzz::with_file;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("input.frames");
    let whole = parse_frames(path, data);
    let streamed = with_file("input.frames", data, |file| {
        frames_file_stream(file).and_then(|s| s.collect::<Result<Vec<_>, _>>())
    });
    // a slice: skip a few frames (how many from the input's last byte), read the rest
    let k = data.last().map_or(0, |&b| usize::from(b % 8));
    let sliced: Result<_, FormatError> = with_file("input.frames", data, |file| {
        let mut s = frames_file_stream(file)?;
        let passed = s.skip_frames(k)?;
        Ok((passed, s.collect::<Result<Vec<_>, _>>()?))
    });
    match (&streamed, &sliced) {
        (Ok(a), Ok((passed, rest))) => {
            assert_eq!(*passed, k.min(a.len()), "skip_frames passed a wrong count");
            let (mut wa, mut wb) = (Vec::new(), Vec::new());
            write_frames(&mut wa, &a[*passed..]).unwrap();
            write_frames(&mut wb, rest).unwrap();
            assert!(wa == wb, "skipping then reading gave other frames");
        }
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "skipping failed otherwise"),
        (Ok(_), Err(e)) => panic!("a slice failed where the stream did not: {e}"),
        (Err(e), Ok(_)) => panic!("a slice read a file the stream refuses: {e}"),
    }
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
