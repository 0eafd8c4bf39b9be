//! MCAP files of ROS 2 messages (profile `ros2`, schemas `ros2msg`, messages `cdr`),
//! what `ros2 bag record` writes by default and Foxglove opens.
//!
//! - [`McapFile`] reads a file: header and summary on opening, then the messages in
//!   file order ([`McapFile::messages`]) or decoded ([`McapFile::decoded`]). Chunks may
//!   be uncompressed, zstd (decoded by the pure-Rust `ruzstd`) or lz4 (frame format,
//!   `lz4_flex`), and their CRCs are checked.
//!   A file without summary or footer (a recorder killed mid-run, a copy cut off) is
//!   read by a linear scan up to the cut ([`McapFile::salvaged`], [`Messages::cut`]),
//!   the records of an uncompressed chunk the file ends in included, whether its
//!   length was never written (its writer was killed in it) or the copy stops inside
//!   it.
//! - [`McapWriter`] records a run: messages by topic, log time = the message's stamp;
//!   a chunk closes (and the file is flushed) at least every second of log time.
//! - The messages are `tether-msgs`' ([`tether_msgs::Ros2Message`]: `LaserScanMsg`,
//!   `ImageMsg`, `TwistMsg`, `PoseArrayMsg`, `OdometryMsg`, ... with their CDR codec and
//!   full `ros2msg` definitions, which the schemas store).
//!
//! Damage to the structure (a truncated file, a record whose content contradicts the
//! format, a chunk that does not decompress or fails its CRC) is an [`McapError`]
//! naming the byte offset and the kind of record; the messages before it are
//! delivered. Damage to one message (an unknown channel, a payload that does not
//! decode, a scan whose header is inconsistent) skips that message and counts it.

mod error;
mod reader;
mod writer;

pub use error::{CutShort, Location, McapError};
pub use reader::{
    BadMessage, Channel, Decoded, MAGIC, McapFile, Message, Messages, RawMessage, Schema,
    SkippedRecord,
};
pub use writer::{MAX_CHUNK_SPAN_NS, McapWriter};
