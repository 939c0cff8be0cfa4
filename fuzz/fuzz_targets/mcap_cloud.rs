//! One `sensor_msgs/PointCloud2` message: the first byte picks the encoding (ROS 1 or CDR),
//! the rest goes to `decode_point_cloud2`, and a decoded cloud extracts its points, also with
//! their `rgb`/`rgba` colours (one per point when the cloud has them).
#![no_main]
use libfuzzer_sys::fuzz_target;
use octoquant_formats::mcap::{decode_point_cloud2, Encoding};

fuzz_target!(|data: &[u8]| {
    let Some((&first, msg)) = data.split_first() else {
        return;
    };
    let encoding = if first & 1 == 0 {
        Encoding::Ros1
    } else {
        Encoding::Cdr
    };
    if let Ok(cloud) = decode_point_cloud2(msg, encoding) {
        let _ = cloud.points_f32();
        if let Ok((points, Some(colors), _)) = cloud.points_colors_f32(true) {
            assert_eq!(colors.len(), points.len());
        }
    }
});
