//! MCAP bags (ROS 1 and ROS 2 PointCloud2 posed by tf): `list_topics` and `read_mcap` on an
//! `.mcap` file; and the frame stream after `skip_frames` over the first clouds (a
//! distributed task's slice, which jumps over chunks where the file's indexes allow), which
//! must give the whole stream's items after them (frames bit for bit, errors word for word)
//! as far as the whole stream reads without an error, and fail to open exactly when it does.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::mcap::{list_topics, read_mcap, McapOptions};
use octoquant_formats::{frame_stream, Frame, ReadOptions};
use octoquant_fuzz::with_file;
use std::path::Path;

/// A stream item, comparable: every coordinate's bits and the stamp's, or the error's text.
type Item = Result<(Vec<u32>, Option<u64>), String>;

fn item(r: Result<Frame, octoquant_formats::FormatError>) -> Item {
    r.map(|f| {
        let coords = std::iter::once(&f.origin)
            .chain(&f.points)
            .flat_map(|p| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()])
            .collect();
        (coords, f.stamp.map(f64::to_bits))
    })
    .map_err(|e| e.to_string())
}

/// The items after skipping `k` (the skip's error as the only item when it fails), with how
/// many the skip passed; or the opening error.
fn after_skip(path: &Path, k: usize) -> Result<(usize, Vec<Item>), String> {
    let mut s = frame_stream(path, &ReadOptions::default()).map_err(|e| e.to_string())?;
    match s.skip_frames(k) {
        Ok(passed) => Ok((passed, s.map(item).collect())),
        Err(e) => Ok((0, vec![Err(e.to_string())])),
    }
}

fuzz_target!(|data: &[u8]| {
    with_file("input.mcap", data, |path| {
        let _ = list_topics(path);
        let _ = read_mcap(path, &McapOptions::default());
        // a slice: skip a few clouds (how many from the input's last byte), read the rest
        let k = data.last().map_or(0, |&b| usize::from(b % 8));
        let whole = after_skip(path, 0);
        let sliced = after_skip(path, k);
        match (&whole, &sliced) {
            (Ok((_, all)), Ok((passed, rest))) => {
                let good = all.iter().take_while(|i| i.is_ok()).count();
                if k <= good {
                    assert_eq!(*passed, k, "skip_frames passed a wrong count");
                    assert!(
                        rest[..] == all[k..],
                        "skipping then reading gave other items"
                    );
                }
            }
            (Err(a), Err(b)) => assert_eq!(a, b, "opening failed otherwise"),
            (Ok(_), Err(e)) | (Err(e), Ok(_)) => panic!("one opening of two failed: {e}"),
        }
    });
});
