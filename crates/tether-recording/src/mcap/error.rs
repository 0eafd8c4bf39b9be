//! What can go wrong when reading or writing MCAP files and ROS 2 messages, and where.

use std::path::PathBuf;

use tether_core::Stamp;
use tether_msgs::EncodeError;
use thiserror::Error;

pub use crate::skips::{CutShort, Location};

/// Why an MCAP file cannot be read (any further) or written. Reading errors name the
/// place in the file.
///
/// A file that is damaged in one message only does not give this error: such messages
/// are skipped and counted (see [`super::Decoded::bad_messages`]).
#[derive(Debug, Error)]
pub enum McapError {
    /// The file could not be opened, read or created.
    #[error("cannot access MCAP file {path}: {source}")]
    Io {
        /// The path given.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file does not start with the MCAP magic.
    #[error(
        "not an MCAP file: it starts with {found:?}, expected \"\\x89MCAP0\\r\\n\" (a ROS 1 .bag \
         is read by the rosbag reader; a ROS 2 .db3 bag must be converted to MCAP first)"
    )]
    NotMcap {
        /// The first bytes of the file, lossily as text.
        found: String,
    },
    /// A record runs past the end of the file or of its chunk.
    #[error(
        "MCAP file is truncated: the {record} at {at} needs {needed} bytes but only {available} \
         remain; the recording was cut short (an interrupted copy or recorder)"
    )]
    Truncated {
        /// Kind of record being read.
        record: &'static str,
        /// Where the record starts.
        at: Location,
        /// Bytes the record needs from its start.
        needed: u64,
        /// Bytes left from its start to the end of the file or chunk.
        available: u64,
    },
    /// A record's content contradicts the format.
    #[error("MCAP file is corrupt: {record} at {at}: {problem}")]
    Corrupt {
        /// Kind of record being read.
        record: &'static str,
        /// Where the record starts.
        at: Location,
        /// What is wrong with it.
        problem: String,
    },
    /// A chunk uses a compression this reader does not know.
    #[error(
        "chunk at byte {at} uses compression {compression:?}; this reader knows \"\" (none), \
         \"zstd\" and \"lz4\""
    )]
    UnsupportedCompression {
        /// Offset of the chunk record.
        at: u64,
        /// The `compression` field.
        compression: String,
    },
    /// The MCAP writer failed.
    #[error("cannot write MCAP: {0}")]
    Write(#[from] mcap::McapError),
    /// A message could not be serialised.
    #[error("cannot write a {msg_type} on {topic}: {source}")]
    Encode {
        /// Topic being written.
        topic: String,
        /// Message type.
        msg_type: &'static str,
        /// What was wrong.
        source: EncodeError,
    },
    /// A topic was written with two message types.
    #[error(
        "topic {topic} already carries {existing}; it cannot also carry {new} (use another topic)"
    )]
    TopicTypeConflict {
        /// The topic.
        topic: String,
        /// Type it was first written with.
        existing: &'static str,
        /// Type now written.
        new: &'static str,
    },
    /// A log time before the epoch of the file's clock (MCAP times are unsigned).
    #[error("log time {stamp} on {topic} is negative; MCAP log times count up from 0")]
    NegativeLogTime {
        /// Topic being written.
        topic: String,
        /// The stamp.
        stamp: Stamp,
    },
    /// `write_stamped` was given a message type without a header.
    #[error("{msg_type} has no header stamp; write it with `write` and an explicit log time")]
    NoHeader {
        /// Message type.
        msg_type: &'static str,
    },
}
