//! What the container readers share: where a record sits in a chunked file, and the
//! counted log of what they skipped.

use std::fmt;

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
}
