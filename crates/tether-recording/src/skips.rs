//! What the container readers share: where a record sits in a chunked file, what they
//! skipped, and the counted log of it.

use std::fmt;

use tether_msgs::DecodeError;

/// Where in a chunked recording (a ROS 1 bag or an MCAP file) something was found.
///
/// Records inside a chunk live in the chunk's uncompressed data, so their position is
/// the chunk's offset in the file plus an offset into that data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Location {
    /// This byte offset of the file.
    File(u64),
    /// `offset` bytes into the uncompressed data of the chunk record that starts at
    /// byte `chunk` of the file.
    InChunk {
        /// Offset of the chunk record in the file.
        chunk: u64,
        /// Offset into the chunk's uncompressed data.
        offset: u64,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::File(offset) => write!(f, "byte {offset}"),
            Location::InChunk { chunk, offset } => write!(
                f,
                "byte {offset} of the uncompressed data of the chunk at byte {chunk}"
            ),
        }
    }
}

/// Where the walk over a recording cut short (a killed recorder, an interrupted copy)
/// stopped: the file ends inside this record, and everything complete before it was
/// read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CutShort {
    /// Kind of record the file ends in ("chunk record"; "record" before its kind is
    /// known).
    pub record: &'static str,
    /// Where that record starts.
    pub at: Location,
    /// Bytes the record needs from its start (`u64::MAX`: its length was never
    /// written, as in a chunk the writer had not closed).
    pub needed: u64,
    /// Bytes there are from its start to the end of the file.
    pub available: u64,
}

impl fmt::Display for CutShort {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the file ends inside the {} at {}: {} bytes of it are there",
            self.record, self.at, self.available
        )?;
        if self.needed >= u64::MAX - 16 {
            write!(
                f,
                ", and its length was never written (the writer was stopped in it)"
            )
        } else {
            write!(f, " of the {} it needs", self.needed)
        }
    }
}

/// A message record that was skipped because it cannot be attributed to a connection
/// (ROS 1) or a channel (MCAP), or (MCAP) its times do not fit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedRecord {
    /// Where the record is.
    pub at: Location,
    /// Why it was skipped.
    pub reason: String,
}

/// A message that was skipped because it did not decode.
#[derive(Debug, Clone, PartialEq)]
pub struct BadMessage {
    /// Its topic.
    pub topic: String,
    /// Where its record is.
    pub at: Location,
    /// Why it did not decode.
    pub error: DecodeError,
}

/// How many skipped things are kept with their reasons; all of them are counted.
pub(crate) const KEPT_REASONS: usize = 100;

/// Things a reader skipped: every one counted, the first [`KEPT_REASONS`] kept so that
/// a user can see why without a damaged file filling memory.
#[derive(Debug, Clone)]
pub(crate) struct Skips<T> {
    count: usize,
    kept: Vec<T>,
}

impl<T> Default for Skips<T> {
    fn default() -> Self {
        Skips {
            count: 0,
            kept: Vec::new(),
        }
    }
}

impl<T> Skips<T> {
    /// Counts `item`, and keeps it while fewer than [`KEPT_REASONS`] are kept.
    pub(crate) fn record(&mut self, item: T) {
        self.count += 1;
        if self.kept.len() < KEPT_REASONS {
            self.kept.push(item);
        }
    }

    /// How many were skipped.
    pub(crate) fn count(&self) -> usize {
        self.count
    }

    /// The first ones skipped, at most [`KEPT_REASONS`].
    pub(crate) fn kept(&self) -> &[T] {
        &self.kept
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_all_and_keeps_the_first() {
        let mut skips = Skips::default();
        for i in 0..KEPT_REASONS + 7 {
            skips.record(i);
        }
        assert_eq!(skips.count(), KEPT_REASONS + 7);
        assert_eq!(skips.kept().len(), KEPT_REASONS);
        assert_eq!(skips.kept()[KEPT_REASONS - 1], KEPT_REASONS - 1);
    }

    #[test]
    fn location_names_the_chunk() {
        let at = Location::InChunk {
            chunk: 4117,
            offset: 12,
        };
        assert_eq!(
            at.to_string(),
            "byte 12 of the uncompressed data of the chunk at byte 4117"
        );
        assert_eq!(Location::File(9).to_string(), "byte 9");
    }

    #[test]
    fn a_cut_names_the_record_and_what_is_there() {
        let cut = CutShort {
            record: "chunk record",
            at: Location::File(4109),
            needed: 5000,
            available: 1200,
        };
        assert_eq!(
            cut.to_string(),
            "the file ends inside the chunk record at byte 4109: 1200 bytes of it are there \
             of the 5000 it needs"
        );
        let open = CutShort {
            needed: u64::MAX,
            ..cut
        };
        assert!(open.to_string().contains("never written"), "{open}");
    }
}
