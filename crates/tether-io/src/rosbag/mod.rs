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
//! chosen topics ([`LaserScanMsg`], [`PoseArrayMsg`], or any [`RosMessage`]).
//!
//! Damage to the structure (a truncated file, a record whose header contradicts the
//! format, a chunk that does not decompress) is a [`BagError`] naming the byte offset
//! and the kind of record. Damage to one message (an unknown connection, a payload that
//! does not decode, a scan whose header is inconsistent) skips that message and counts
//! it; the good messages keep coming.

mod dataset;
mod error;
mod msg;
mod reader;
mod record;
#[cfg(test)]
pub(crate) mod testbag;

pub use crate::mcap::{CompressedImageMsg, ImageMsg, OdometryMsg};
pub use dataset::{LabelledScan, LabelledScans, ScanSet, read_labelled_scans, read_scans};
pub use error::{BagError, DecodeError, Location};
pub use msg::{Header, LaserScanMsg, Pose3, PoseArrayMsg, RawLaserScan, RosMessage};
pub use reader::{
    BadMessage, Bag, BagMessage, ChunkInfo, Connection, Decoded, Messages, RawMessage,
    SkippedRecord,
};
