//! tether's recorded data and its sensor links.
//!
//! - [`rosbag`]: a reader of ROS 1 bags (format 2.0: bag header, connection, chunk,
//!   chunk info and index records; chunks uncompressed, bz2 or lz4) that yields the
//!   messages of chosen topics in the order they were recorded, with decoders of
//!   `sensor_msgs/LaserScan` into [`tether_core::LaserScan`] and of
//!   `geometry_msgs/PoseArray` (design section 9).
//! - [`mcap`]: MCAP files of ROS 2 CDR messages (profile `ros2`), read and written:
//!   `LaserScan`, `Image`, `CompressedImage`, `Twist`, `PoseArray`,
//!   `PoseWithCovarianceStamped`, `Odometry`, with conversions to tether's types; files
//!   that Foxglove, `ros2 bag` and Python `rosbags` read.
//! - [`scip`]: the Hokuyo SCIP 2.0 protocol (URG-04LX and siblings): a driver over
//!   serial / USB-ACM or TCP, producing [`tether_core::LaserScan`]s with host time
//!   stamps, and an emulator that speaks the protocol byte for byte, with fault
//!   injection, over a pseudo-terminal or TCP.
//!
//! - [`limits`]: the caps on what a file can make a reader allocate (a chunk's
//!   uncompressed size and its ratio to the stored size), checked before allocating.
//!
//! Everything here reads data from outside, so nothing here panics on it: a damaged
//! file gives an error that names the byte offset and the record, a message that
//! cannot be decoded is skipped and counted while the good ones keep coming, and a
//! damaged sensor reply is dropped, counted and reported while the driver re-syncs.
//!
//! Dependencies point one way (STYLE.md): this crate depends on `tether-core` only.

pub mod limits;
pub mod mcap;
pub mod rosbag;
pub mod scip;
mod skips;

pub use skips::{CutShort, Location};
