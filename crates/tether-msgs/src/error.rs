//! What can go wrong when decoding or encoding a message.

use tether_core::Stamp;
use thiserror::Error;

/// Why one message could not be decoded, from a ROS 1 bag or a CDR payload. The
/// recording itself may be fine: the caller skips the message and counts it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DecodeError {
    /// The connection (ROS 1) or channel (MCAP) carries another type than the decoder
    /// reads.
    #[error("message is a {found}{}, not a {expected}", md5_note(.found_md5.as_deref()))]
    WrongType {
        /// Type the decoder reads.
        expected: &'static str,
        /// Type of the connection, or schema name of the channel.
        found: String,
        /// MD5 sum of a ROS 1 connection's definition (ROS 2 types have none).
        found_md5: Option<String>,
    },
    /// The connection names the right type but a different definition (MD5 sum).
    #[error(
        "message type {msg_type} has md5 {found}, expected {expected}: the definition differs \
         from the one this decoder reads"
    )]
    WrongDefinition {
        /// The type name.
        msg_type: &'static str,
        /// MD5 sum the decoder reads.
        expected: &'static str,
        /// MD5 sum of the connection.
        found: String,
    },
    /// The channel's message encoding is not CDR.
    #[error("message encoding is {found:?}; ROS 2 messages are \"cdr\"")]
    WrongEncoding {
        /// The channel's `message_encoding`.
        found: String,
    },
    /// The CDR encapsulation is not plain CDR (e.g. a parameter list, XCDR2).
    #[error(
        "CDR encapsulation kind {kind:02x?} is not supported; ROS 2 writes 00 01 (little-endian)"
    )]
    Encapsulation {
        /// The first two header bytes.
        kind: [u8; 2],
    },
    /// The payload ends inside a field.
    #[error(
        "message ends inside field `{field}`: it needs {needed} bytes at byte {at}, {available} remain"
    )]
    Truncated {
        /// Field being read.
        field: &'static str,
        /// Offset in the payload.
        at: usize,
        /// Bytes the field needs.
        needed: u64,
        /// Bytes left.
        available: usize,
    },
    /// Bytes are left over after the last field.
    #[error("{extra} bytes left over after the last field: is the message type right?")]
    TrailingBytes {
        /// Bytes left over.
        extra: usize,
    },
    /// A string field is not UTF-8.
    #[error("field `{field}` is not UTF-8 text")]
    NotUtf8 {
        /// Field being read.
        field: &'static str,
    },
    /// A field holds a value the message cannot have.
    #[error("field `{field}` is invalid: {problem}")]
    BadValue {
        /// Field being read.
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The decoded scan header cannot describe a scan.
    #[error("laser scan is invalid: {0}")]
    Scan(#[from] tether_core::ScanError),
}

/// ` (md5 SUM)` after a ROS 1 type name; nothing for a ROS 2 one.
fn md5_note(md5: Option<&str>) -> String {
    md5.map(|sum| format!(" (md5 {sum})")).unwrap_or_default()
}

/// Why a message cannot be serialised.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EncodeError {
    /// A stamp outside what `builtin_interfaces/Time` (`int32` seconds) holds.
    #[error("field `{field}`: stamp {stamp} does not fit ROS 2 time (int32 seconds)")]
    StampOutOfRange {
        /// Field being written.
        field: &'static str,
        /// The stamp.
        stamp: Stamp,
    },
    /// A sequence or string longer than a `u32` length can state.
    #[error("field `{field}` has {len} elements, more than CDR's u32 length holds")]
    TooLong {
        /// Field being written.
        field: &'static str,
        /// Its length.
        len: usize,
    },
    /// A string with a NUL byte inside.
    #[error("field `{field}` contains a NUL byte, which a CDR string cannot hold")]
    NulInString {
        /// Field being written.
        field: &'static str,
    },
}
