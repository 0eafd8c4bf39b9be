//! What can go wrong when reading a bag, and where.

use std::path::PathBuf;

use thiserror::Error;

pub use crate::skips::{CutShort, Location};

/// Why a bag cannot be read (any further). Every variant names the place in the file.
///
/// A bag that is damaged in one message only does not give this error: such messages
/// are skipped and counted (see [`super::Messages::skipped`] and
/// [`super::Decoded::bad_messages`]).
#[derive(Debug, Error)]
pub enum BagError {
    /// The file could not be opened.
    #[error("cannot open bag {path}: {source}")]
    Open {
        /// The path given.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The bag has no connection on the topic asked for.
    #[error("bag {path} has no topic {topic:?}; its topics are: {available}")]
    NoSuchTopic {
        /// The bag.
        path: PathBuf,
        /// The topic asked for.
        topic: String,
        /// The topics it has, comma-separated.
        available: String,
    },
    /// Reading failed for a reason other than the end of the file.
    #[error("cannot read the bag at {at}: {source}")]
    Io {
        /// Where the read started.
        at: Location,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file does not start with `#ROSBAG V2.0\n`.
    #[error(
        "not a ROS 1 bag of format 2.0: the file starts with {found:?}, expected \"#ROSBAG V2.0\" \
         (ROS 2 bags are directories with .db3 or .mcap files; convert them or use an MCAP reader)"
    )]
    NotABag {
        /// The first bytes of the file, lossily as text.
        found: String,
    },
    /// The bag header says there is no index: the recording was not closed cleanly.
    #[error(
        "bag has no index (index_pos = 0 in the bag header at byte {at}): the recording was \
         not closed cleanly; run `rosbag reindex` on it"
    )]
    NotIndexed {
        /// Offset of the bag header record.
        at: u64,
    },
    /// The bag header puts the index past the end of the file: the file was cut short
    /// (an interrupted copy or recording). The chunks before the cut can still be read
    /// with [`super::Bag::open_salvaging`].
    #[error(
        "bag is cut short: its header puts the index at byte {index_pos} but the file has only \
         {file_len} bytes (an interrupted copy or recording); the chunks before the cut can be \
         read by walking the records (`Bag::open_salvaging`, what tether's commands do)"
    )]
    IndexPastEnd {
        /// Where the bag header says the index starts.
        index_pos: u64,
        /// Size of the file.
        file_len: u64,
    },
    /// A record runs past the end of the file or of its chunk.
    #[error(
        "bag is truncated: the {record} at {at} needs {needed} bytes but only {available} \
         remain; the file was cut short (an interrupted copy or recording)"
    )]
    Truncated {
        /// Kind of record being read ("chunk record"; "record" before its kind is known).
        record: &'static str,
        /// Where the record starts.
        at: Location,
        /// Bytes the record needs from its start.
        needed: u64,
        /// Bytes left from its start to the end of the file or chunk.
        available: u64,
    },
    /// A record's content contradicts the format.
    #[error("bag is corrupt: {record} at {at}: {problem}")]
    Corrupt {
        /// Kind of record being read ("chunk record"; "record" before its kind is known).
        record: &'static str,
        /// Where the record starts.
        at: Location,
        /// What is wrong with it.
        problem: String,
    },
    /// A chunk uses a compression this reader does not know.
    #[error(
        "chunk at byte {at} uses compression {compression:?}; this reader knows \"none\", \"bz2\" \
         and \"lz4\""
    )]
    UnsupportedCompression {
        /// Offset of the chunk record.
        at: u64,
        /// The `compression` field.
        compression: String,
    },
    /// A chunk's data does not decompress into what its header promises.
    #[error("bag is corrupt: {compression} chunk at byte {at} does not decompress: {problem}")]
    Decompress {
        /// Offset of the chunk record.
        at: u64,
        /// The `compression` field.
        compression: String,
        /// What the decompressor said.
        problem: String,
    },
}
