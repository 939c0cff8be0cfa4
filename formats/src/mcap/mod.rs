//! `sensor_msgs/PointCloud2` from MCAP files (ROS 1 and ROS 2 recordings), posed by tf.
mod reader;
pub use reader::*;
