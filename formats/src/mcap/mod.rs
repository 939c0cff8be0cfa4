//! `sensor_msgs/PointCloud2` from MCAP files (ROS 1 and ROS 2 recordings), with the sensor
//! pose from `/tf_static` and `/tf`. One file per part: `cdr.rs` (the ROS 1 and CDR
//! serializations), `pointcloud2.rs`, `tf.rs` and `reader.rs` (the file and its topics).
//!
//! - [`read_mcap`] / [`read_mcap_frames`]: every cloud of one topic as a
//!   [`Frame`](crate::Frame) in a fixed frame, with per-cloud [`CloudStats`]; [`list_topics`]
//!   names what a file holds.
//! - [`decode_point_cloud2`]: one message, in either encoding, into a [`PointCloud2`]
//!   whose [`PointCloud2::points_f32`] extracts `x y z` from any field layout.
//!
//! **Encodings.** `ros1` (little-endian, packed, strings as `u32` length + bytes) and `cdr`
//! (ROS 2: a 4-byte encapsulation header selecting little or big endian, then each primitive
//! aligned to its size relative to the end of that header; strings carry a NUL). The point
//! bytes follow the message's own `is_bigendian`, `point_step`, `row_step` and field offsets;
//! `x`, `y`, `z` may be `FLOAT32` or `FLOAT64`.
//!
//! **Invalid points.** Drivers store missing returns as NaN or as exactly (0, 0, 0) (the
//! Ouster driver does, even with `is_dense` set); both are skipped and counted.
//!
//! **Poses.** Each cloud is expressed in [`McapOptions::fixed_frame`] by composing the
//! transforms of `tf2_msgs/TFMessage` messages on `/tf_static` (always valid) and `/tf` (the
//! latest at or before the cloud's log time, else the first after) along the chain between
//! the two frames, in either direction. Without a fixed frame, the root of the cloud frame's
//! transform tree is used; without any transform, the cloud's own frame (identity). The
//! sensor origin is the cloud frame's origin carried through the same chain; then
//! [`McapOptions::sensor_pose`] maps the fixed frame to the world.
//!
//! The file is read by seeking, one chunk in memory at a time ([`mcap_frames`] yields one
//! cloud at a time after a first pass that collects the transforms; its
//! [`McapFrames::skip_clouds`] passes whole chunks unread where the summary's chunk indexes
//! and the message index records place the clouds, and checks the clouds read after such a
//! jump against what the first pass saw of them); chunks may be
//! uncompressed or zstd-compressed (lz4 is not built in). A compressed chunk whose declared
//! size passes the [`DecompressionLimit`](crate::DecompressionLimit) is refused before it is
//! allocated, and a tf chain is composed over at most 256 links, so the work per cloud is
//! bounded.

mod cdr;
mod pointcloud2;
mod reader;
mod tf;

pub use cdr::{DecodeError, Encoding};
pub use pointcloud2::{datatype, decode_point_cloud2, CloudStats, PointCloud2, PointField};
pub use reader::{
    announced_clouds, list_topics, mcap_frames, read_mcap, read_mcap_frames, McapFrames,
    McapOptions, TopicInfo,
};
pub use tf::{decode_tf_message, Transform};
