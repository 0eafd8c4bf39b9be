//! MCAP files of ROS 2 messages (profile `ros2`, schemas `ros2msg`, messages `cdr`),
//! what `ros2 bag record` writes by default and Foxglove opens.
//!
//! - [`McapFile`] reads a file: header and summary on opening, then the messages in
//!   file order ([`McapFile::messages`]) or decoded ([`McapFile::decoded`]). Chunks may
//!   be uncompressed, zstd (decoded by the pure-Rust `ruzstd`) or lz4 (frame format,
//!   `lz4_flex`), and their CRCs are checked.
//!   A file without summary or footer (a recorder killed mid-run) is read by a linear
//!   scan up to its last complete chunk ([`McapFile::salvaged`], [`Messages::cut`]).
//! - [`McapWriter`] records a run: messages by topic, log time = the message's stamp;
//!   a chunk closes (and the file is flushed) at least every second of log time.
//! - [`msgs`]: the message types, their CDR layout ([`cdr`]) and full definitions, with
//!   conversions to tether's types: `sensor_msgs/msg/LaserScan` ([`LaserScanMsg`],
//!   a [`tether_core::LaserScan`]), `sensor_msgs/msg/Image` ([`ImageMsg`], mono8, rgb8,
//!   bgr8, to [`tether_core::GrayImage`]), `sensor_msgs/msg/CompressedImage`
//!   ([`CompressedImageMsg`], JPEG or PNG kept as is), `geometry_msgs/msg/Twist`
//!   ([`TwistMsg`]), `geometry_msgs/msg/PoseArray` ([`PoseArrayMsg`]),
//!   `geometry_msgs/msg/PoseWithCovarianceStamped`
//!   ([`PoseWithCovarianceStampedMsg`], to a [`tether_core::Gaussian2`]) and
//!   `nav_msgs/msg/Odometry` ([`OdometryMsg`], to a [`tether_core::Pose2`]).
//!
//! Damage to the structure (a truncated file, a record whose content contradicts the
//! format, a chunk that does not decompress or fails its CRC) is an [`McapError`]
//! naming the byte offset and the kind of record; the messages before it are
//! delivered. Damage to one message (an unknown channel, a payload that does not
//! decode, a scan whose header is inconsistent) skips that message and counts it.

pub mod cdr;
mod error;
pub mod msgs;
mod reader;
mod writer;

pub use error::{CutShort, DecodeError, EncodeError, Location, McapError};
pub use msgs::{
    ClockMsg, ColorRgba, CompressedFormat, CompressedImageMsg, Detection2DArrayMsg, Detection2DMsg,
    Header, ImageMsg, ImageMsgError, LaserScanMsg, MarkerArrayMsg, MarkerMsg, MeshFile,
    ObjectHypothesisMsg, OdometryMsg, PersonArrayMsg, PixelEncoding, Pose3, PoseArrayMsg,
    PoseWithCovarianceStampedMsg, RawLaserScan, Ros2Message, StringMsg, TfMessage,
    TransformStampedMsg, TwistMsg, TwistStampedMsg, from_cdr, to_cdr,
};
pub use reader::{
    BadMessage, Channel, Decoded, MAGIC, McapFile, Message, Messages, RawMessage, Schema,
    SkippedRecord,
};
pub use writer::{MAX_CHUNK_SPAN_NS, McapWriter};
