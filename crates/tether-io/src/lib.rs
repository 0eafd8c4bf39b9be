//! tether's recorded data and, later, its sensor links.
//!
//! - [`rosbag`]: a reader of ROS 1 bags (format 2.0: bag header, connection, chunk,
//!   chunk info and index records; chunks uncompressed, bz2 or lz4) that yields the
//!   messages of chosen topics in the order they were recorded, with decoders of
//!   `sensor_msgs/LaserScan` into [`tether_core::LaserScan`] and of
//!   `geometry_msgs/PoseArray` (SPEC section 9).
//!
//! Everything here reads data from outside, so nothing here panics on it: a damaged
//! file gives an error that names the byte offset and the record, and a message that
//! cannot be decoded is skipped and counted while the good ones keep coming.
//!
//! Dependencies point one way (STYLE.md): this crate depends on `tether-core` only.

pub mod rosbag;
