//! MCAP bags (ROS 1 and ROS 2 PointCloud2 posed by tf): `list_topics` and `read_mcap` on an
//! `.mcap` file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::mcap::{list_topics, read_mcap, McapOptions};
use octoquant_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("input.mcap", data, |path| {
        let _ = list_topics(path);
        let _ = read_mcap(path, &McapOptions::default());
    });
});
