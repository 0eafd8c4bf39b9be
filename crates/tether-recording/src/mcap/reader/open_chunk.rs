//! A chunk cut by the end of the file (issue 33). The `mcap` crate, writing to a file it
//! can seek in, starts a chunk with its length and sizes left at `u64::MAX` and fills
//! them in when the chunk closes: a recorder killed before that (tether's chunked live
//! recordings before they streamed) leaves that placeholder with the chunk's records
//! after it, up to where the file ends. A copy cut off inside a closed chunk leaves its
//! records up to the cut too. Read without a summary, such an uncompressed chunk is
//! walked as the rest of the file, up to the cut, as a streamed recording is (its CRC
//! cannot be checked: the chunk is not all there). A compressed one ends the walk at
//! the chunk, as before.

use super::{Body, Cursor, McapFile, op};
use crate::mcap::{CutShort, Location, McapError};

impl Cursor {
    /// Opens, at file offset `pos`, a chunk that runs past the end of the file (its
    /// length never written, or the file cut inside it), if there is one and its records
    /// are uncompressed: its records are then the rest of the file. `Ok(false)`: no
    /// such chunk here (a compressed one is left to the cut, as before).
    pub(super) fn open_unclosed_chunk(
        &mut self,
        file: &McapFile,
        pos: usize,
    ) -> Result<bool, McapError> {
        let data = &file.data[..self.end];
        let Some(len) = data.get(pos + 1..pos + 9) else {
            return Ok(false);
        };
        let mut len_bytes = [0u8; 8];
        len_bytes.copy_from_slice(len);
        // Unclosed, or closed but cut by the end of the file (an interrupted copy): the
        // records that are there are read either way.
        let available = (data.len() - pos - 9) as u64;
        if data[pos] != op::CHUNK || u64::from_le_bytes(len_bytes) <= available {
            return Ok(false);
        }
        let mut b = Body {
            data: &data[pos + 9..],
            pos: 0,
            record: "chunk record",
            at: Location::File(pos as u64),
        };
        // The header as far as it goes; a file cut inside it is a cut, as before.
        let header = (|| {
            b.u64("message_start_time")?;
            b.u64("message_end_time")?;
            b.u64("uncompressed_size")?;
            b.u32("uncompressed_crc")?;
            let compression = b.string("compression")?;
            b.u64("records")?;
            Ok::<_, McapError>(compression)
        })();
        let Ok(compression) = header else {
            return Ok(false);
        };
        if !compression.is_empty() {
            return Ok(false);
        }
        let records = pos + 9 + b.pos;
        self.chunk.clear();
        self.chunk.extend_from_slice(&data[records..]);
        self.chunk_pos = 0;
        self.chunk_at = Some(pos as u64);
        self.unclosed = Some(u64::from_le_bytes(len_bytes).saturating_add(9));
        self.pos = self.end;
        Ok(true)
    }

    /// The end of a cut chunk's records: the cut, at the record the file ends in
    /// (`in_record`: a record of the chunk cut short) or, when the file ends between two
    /// records, at the chunk itself (what it needs: its stated length, `u64::MAX` when
    /// that was never written).
    pub(super) fn end_unclosed_chunk(&mut self, in_record: Option<CutShort>) {
        let (Some(chunk_at), Some(needed)) = (self.chunk_at.take(), self.unclosed.take()) else {
            return;
        };
        self.cut = Some(in_record.unwrap_or(CutShort {
            record: "chunk record",
            at: Location::File(chunk_at),
            needed,
            available: self.end as u64 - chunk_at,
        }));
        self.chunk.clear();
        self.chunk_pos = 0;
    }
}
