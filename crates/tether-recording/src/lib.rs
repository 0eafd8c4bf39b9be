//! tether's recordings: the containers its runs are read from and written to.
//!
//! - [`rosbag`]: a reader of ROS 1 bags (format 2.0: bag header, connection, chunk,
//!   chunk info and index records; chunks uncompressed, bz2 or lz4) that yields the
//!   messages of chosen topics in the order they were recorded, with decoders of
//!   `sensor_msgs/LaserScan` into [`tether_core::LaserScan`] and of
//!   `geometry_msgs/PoseArray` (design section 9); and a writer of them.
//! - [`mcap`]: MCAP files of ROS 2 CDR messages (profile `ros2`), read and written;
//!   files that Foxglove, `ros2 bag` and Python `rosbags` read.
//!
//! The messages in them, and their two wire formats, are `tether-msgs`' (one definition
//! of each type): this crate knows the containers, not the messages.
//!
//! - [`samples`]: a robot's recording, bag or MCAP, read as one stream of samples in
//!   log order (laser scans, grey camera frames, odometry, labels), with the checks of
//!   its topics' types and the counted skips of what does not decode: what `tether
//!   track`, `replay`, `eval-track` and `legs` read.
//! - [`sniff`]: which kind of recording a file is, from its first bytes, and what any
//!   other file looks like.
//! - [`limits`]: the caps on what a file can make a reader allocate (a chunk's
//!   uncompressed size and its ratio to the stored size), checked before allocating.
//!
//! Everything here reads data from outside, so nothing here panics on it: a damaged
//! file gives an error that names the byte offset and the record, a message that
//! cannot be decoded is skipped and counted while the good ones keep coming.
//!
//! Dependencies point one way (STYLE.md): this crate depends on `tether-core`,
//! `tether-msgs` and (for the camera frames of [`samples`]) `tether-image` only.

pub mod inspect;
pub mod limits;
pub mod mcap;
pub mod rosbag;
pub mod samples;
mod skips;
pub mod sniff;

pub use skips::{CutShort, Location};
