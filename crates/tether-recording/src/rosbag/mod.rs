//! ROS 1 bags, format 2.0 (the format `rosbag record` writes).
//!
//! A bag is the line `#ROSBAG V2.0\n` and a sequence of records (see the record layer's
//! docs): a bag header pointing at the index; chunks, each holding connection and
//! message data records, compressed with `none`, `bz2` or `lz4` (roslz4 writes the LZ4
//! *frame* format) and followed by index data records; and, from `index_pos` to the
//! end, one connection record per connection and one chunk info record per chunk.
//!
//! [`Bag::open`] reads the header and the index; [`Bag::messages`] walks the chunks in
//! file order and yields [`RawMessage`]s; [`Bag::decoded`] decodes the messages of
//! chosen topics (`tether-msgs`' `LaserScanMsg`, `PoseArrayMsg`, or any
//! [`RosMessage`](tether_msgs::RosMessage)).
//!
//! [`BagWriter`] writes bags in the same format (uncompressed chunks, indexed), with
//! each connection's full message definition and the MD5 sum computed from it
//! ([`tether_msgs::definition_md5`]); [`RosMessageOut`](tether_msgs::RosMessageOut) is what a message type needs to be written
//! (LaserScan, PoseArray, Odometry, leg_tracker's Person and PersonArray).
//! [`Bag::open_salvaging`] reads a bag whose index is missing or cut off by walking its
//! records, up to where the file was cut ([`Messages::cut`] says where). A compressed
//! chunk's claimed size is checked against [`crate::limits`] before it is inflated.
//!
//! Damage to the structure (a truncated file, a record whose header contradicts the
//! format, a chunk that does not decompress) is a [`BagError`] naming the byte offset
//! and the kind of record. Damage to one message (an unknown connection, a payload that
//! does not decode, a scan whose header is inconsistent) skips that message and counts
//! it; the good messages keep coming.

mod dataset;
mod error;
mod reader;
mod record;
#[cfg(test)]
pub(crate) mod testbag;
mod writer;

pub use dataset::{LabelledScan, LabelledScans, ScanSet, read_labelled_scans, read_scans};
pub use error::{BagError, CutShort, Location};
pub use reader::{
    BadMessage, Bag, BagMessage, ChunkInfo, Connection, Decoded, Messages, RawMessage,
    SkippedRecord,
};
pub use writer::{BagWriteError, BagWriter, ConnectionId, DEFAULT_CHUNK_BYTES};
