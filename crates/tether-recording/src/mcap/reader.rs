//! Reading an MCAP file: its header and summary on opening, then its messages in file
//! order.
//!
//! MCAP (mcap.dev/spec, format version 0): the magic `\x89MCAP0\r\n`, then records,
//! each an opcode byte, a `u64` little-endian body length and the body; the data
//! section (Header, Schema, Channel, Message, Chunk, Message Index, ... up to Data End),
//! an optional summary section, the Footer (pointing at the summary) and the magic
//! again. A Chunk holds Schema, Channel and Message records, compressed with `""`
//! (none), `"zstd"` or `"lz4"` (the LZ4 frame format), with a CRC-32 of the
//! uncompressed records (0: not computed).

use std::collections::BTreeMap;
use std::io::Read;
use std::marker::PhantomData;
use std::path::Path;
use std::sync::Arc;

use tether_core::Stamp;

use tether_msgs::{DecodeError, Ros2Message, from_cdr, type_matches};

use super::error::{CutShort, Location, McapError};
use crate::skips::Skips;
pub use crate::skips::{BadMessage, SkippedRecord};

/// The magic at both ends of an MCAP file.
pub const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const STATISTICS: u8 = 0x0B;
    pub const DATA_END: u8 = 0x0F;

    pub fn name(op: u8) -> &'static str {
        match op {
            HEADER => "header record",
            FOOTER => "footer record",
            SCHEMA => "schema record",
            CHANNEL => "channel record",
            MESSAGE => "message record",
            CHUNK => "chunk record",
            0x07 => "message index record",
            0x08 => "chunk index record",
            0x09 => "attachment record",
            0x0A => "attachment index record",
            STATISTICS => "statistics record",
            0x0C => "metadata record",
            0x0D => "metadata index record",
            0x0E => "summary offset record",
            DATA_END => "data end record",
            _ => "record",
        }
    }
}

/// A schema: the definition of a message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Schema {
    /// Schema id, unique within the file (never 0).
    pub id: u16,
    /// Type name, e.g. `sensor_msgs/msg/LaserScan`.
    pub name: String,
    /// Encoding of `data`, e.g. `ros2msg`.
    pub encoding: String,
    /// The definition.
    pub data: Vec<u8>,
}

/// A channel: a topic with its message encoding and schema.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Channel {
    /// Channel id, unique within the file.
    pub id: u16,
    /// Topic name, e.g. `/scan`.
    pub topic: String,
    /// Encoding of the messages, `cdr` for ROS 2.
    pub message_encoding: String,
    /// The schema (`None`: schemaless channel).
    pub schema: Option<Arc<Schema>>,
    /// Key-value metadata (rosbag2 stores `offered_qos_profiles` here).
    pub metadata: BTreeMap<String, String>,
}

impl Channel {
    /// The schema's type name, or "" for a schemaless channel.
    pub fn type_name(&self) -> &str {
        self.schema.as_ref().map_or("", |s| s.name.as_str())
    }

    fn check<M: Ros2Message>(&self) -> Result<(), DecodeError> {
        if self.message_encoding != "cdr" {
            return Err(DecodeError::WrongEncoding {
                found: self.message_encoding.clone(),
            });
        }
        if !type_matches::<M>(self.type_name()) {
            return Err(DecodeError::WrongType {
                expected: M::TYPE,
                found: self.type_name().to_owned(),
                found_md5: None,
            });
        }
        Ok(())
    }
}

/// A message as stored.
#[derive(Debug, Clone)]
pub struct RawMessage {
    /// The channel it was published on.
    pub channel: Arc<Channel>,
    /// Sequence number (writer-defined; often 0).
    pub sequence: u32,
    /// Time the recorder received it.
    pub log_time: Stamp,
    /// Time it was published.
    pub publish_time: Stamp,
    /// Where its record is.
    pub at: Location,
    /// The serialised message (CDR for ROS 2).
    pub data: Vec<u8>,
}

impl RawMessage {
    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.channel.topic
    }

    /// Decodes the message as an `M`, checking the channel's encoding and type first.
    pub fn decode<M: Ros2Message>(&self) -> Result<M, DecodeError> {
        self.channel.check::<M>()?;
        from_cdr(&self.data)
    }
}

/// A decoded message with its channel and times.
#[derive(Debug, Clone)]
pub struct Message<M> {
    /// The channel it was published on.
    pub channel: Arc<Channel>,
    /// Time the recorder received it.
    pub log_time: Stamp,
    /// Time it was published.
    pub publish_time: Stamp,
    /// Where its record is.
    pub at: Location,
    /// The message.
    pub message: M,
}

/// An open MCAP file, held in memory.
///
/// Opening checks the magic and the header, and reads the schemas, channels and message
/// counts from the summary section. A file without a usable summary (cut short by a
/// killed recorder, or written without one) is read by a linear scan instead: a first
/// pass over the data section collects the schemas and channels (inside chunks too) and
/// counts the messages, and the walk that delivers the messages ends quietly where the
/// file ends inside a record, with the place in [`Messages::cut`];
/// [`McapFile::salvaged`] says why the summary was not used. [`McapFile::messages`]
/// walks the data section in file order; chunks are decompressed one at a time, their
/// claimed sizes checked against [`crate::limits`] first.
///
/// ```no_run
/// use tether_msgs::LaserScanMsg;
/// use tether_recording::mcap::McapFile;
/// let file = McapFile::open("run.mcap")?;
/// let mut scans = file.decoded::<LaserScanMsg>(&["/scan"]);
/// for msg in &mut scans {
///     let msg = msg?;
///     println!("{} beams at {}", msg.message.scan.len(), msg.message.scan.stamp);
/// }
/// println!("{} bad messages skipped", scans.bad_count());
/// # Ok::<(), tether_recording::mcap::McapError>(())
/// ```
#[derive(Debug)]
pub struct McapFile {
    data: Vec<u8>,
    profile: String,
    library: String,
    /// Offset of the first record after the header record.
    data_start: usize,
    /// End of the data section (the summary's start, or the footer, or the file end).
    data_end: usize,
    schemas: BTreeMap<u16, Arc<Schema>>,
    channels: BTreeMap<u16, Arc<Channel>>,
    message_counts: BTreeMap<u16, u64>,
    /// Why the summary was not used (the file is read by a linear scan).
    salvaged: Option<String>,
}

impl McapFile {
    /// Reads the file at `path` and checks its header.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, McapError> {
        let path = path.as_ref();
        let data = std::fs::read(path).map_err(|source| McapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(data)
    }

    /// Reads an MCAP file held in memory.
    pub fn from_bytes(data: Vec<u8>) -> Result<Self, McapError> {
        if data.len() < MAGIC.len() || &data[..MAGIC.len()] != MAGIC {
            let n = data.len().min(MAGIC.len());
            return Err(McapError::NotMcap {
                found: String::from_utf8_lossy(&data[..n]).into_owned(),
            });
        }
        let header = record_at(&data, MAGIC.len(), |p| Location::File(p as u64))?;
        let at = Location::File(MAGIC.len() as u64);
        let mut body = Body {
            data: &data[header.body.clone()],
            pos: 0,
            record: op::name(header.op),
            at,
        };
        if header.op != op::HEADER {
            return Err(body.corrupt(format!(
                "the first record has opcode {:#04x}, expected the header record (0x01)",
                header.op
            )));
        }
        let profile = body.string("profile")?;
        let library = body.string("library")?;
        let mut file = McapFile {
            data_start: header.body.end,
            data_end: data.len(),
            data,
            profile,
            library,
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            message_counts: BTreeMap::new(),
            salvaged: None,
        };
        if let Err(why) = file.read_summary() {
            file.salvaged = Some(why);
            file.scan_data_section();
        }
        Ok(file)
    }

    /// Why the summary was not used and the file is read by a linear scan (no footer:
    /// the recorder did not finish it; no summary; a damaged one); `None` when the
    /// summary was used.
    pub fn salvaged(&self) -> Option<&str> {
        self.salvaged.as_deref()
    }

    /// Reads the footer and the summary section; `Err(why)` when the file has none (or a
    /// damaged one), in which case nothing is kept from it.
    fn read_summary(&mut self) -> Result<(), String> {
        // Footer record: opcode, length 20, summary_start u64, summary_offset_start u64,
        // summary_crc u32; then the magic.
        const FOOTER_LEN: usize = 1 + 8 + 20;
        let n = self.data.len();
        if n < MAGIC.len() * 2 + FOOTER_LEN || &self.data[n - MAGIC.len()..] != MAGIC {
            return Err(
                "it does not end with a footer and the magic (the recorder did not finish it)"
                    .into(),
            );
        }
        let footer_at = n - MAGIC.len() - FOOTER_LEN;
        let footer = record_at(&self.data, footer_at, |p| Location::File(p as u64))
            .map_err(|e| format!("its footer is unreadable: {e}"))?;
        if footer.op != op::FOOTER || footer.body.len() != 20 {
            return Err(format!("no footer record at byte {footer_at}"));
        }
        let mut start = [0u8; 8];
        start.copy_from_slice(&self.data[footer.body.start..footer.body.start + 8]);
        let summary_start = u64::from_le_bytes(start) as usize;
        if summary_start == 0 {
            return Err("its footer says it has no summary section".into());
        }
        if summary_start < self.data_start || summary_start > footer_at {
            return Err(format!(
                "its footer puts the summary at byte {summary_start}, outside the file's body"
            ));
        }
        let mut schemas = BTreeMap::new();
        let mut channels = BTreeMap::new();
        let mut counts = BTreeMap::new();
        let mut pos = summary_start;
        while pos < footer_at {
            let rec = record_at(&self.data[..footer_at], pos, |p| Location::File(p as u64))
                .map_err(|e| format!("its summary is damaged: {e}"))?;
            let mut body = Body {
                data: &self.data[rec.body.clone()],
                pos: 0,
                record: op::name(rec.op),
                at: Location::File(pos as u64),
            };
            let ok = match rec.op {
                op::SCHEMA => parse_schema(&mut body).map(|s| {
                    if let Some(s) = s {
                        schemas.insert(s.id, Arc::new(s));
                    }
                }),
                op::CHANNEL => parse_channel(&mut body, &schemas).map(|c| {
                    channels.insert(c.id, Arc::new(c));
                }),
                op::STATISTICS => parse_statistics(&mut body).map(|c| counts = c),
                _ => Ok(()),
            };
            if let Err(e) = ok {
                return Err(format!("its summary is damaged: {e}"));
            }
            pos = rec.body.end;
        }
        self.data_end = summary_start;
        self.schemas = schemas;
        self.channels = channels;
        self.message_counts = counts;
        Ok(())
    }

    /// For a file without a summary: one pass over the data section collecting
    /// schemas and channels (inside chunks too) and counting messages. A damaged place
    /// or the cut stops the pass silently; reading the messages reports it.
    fn scan_data_section(&mut self) {
        let mut cursor = Cursor::new(self);
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        while let Some(Ok(found)) = cursor.next_message(self) {
            *counts.entry(found.channel.id).or_default() += 1;
        }
        self.schemas = cursor.schemas;
        self.channels = cursor.channels;
        self.message_counts = counts;
    }

    /// The profile of the header (`ros2` for ROS 2 recordings).
    pub fn profile(&self) -> &str {
        &self.profile
    }

    /// The library that wrote the file.
    pub fn library(&self) -> &str {
        &self.library
    }

    /// The schemas, by id.
    pub fn schemas(&self) -> impl Iterator<Item = &Schema> {
        self.schemas.values().map(|s| s.as_ref())
    }

    /// The channels, by id.
    pub fn channels(&self) -> impl Iterator<Item = &Channel> {
        self.channels.values().map(|c| c.as_ref())
    }

    /// The distinct topic names, sorted.
    pub fn topics(&self) -> Vec<&str> {
        let mut t: Vec<&str> = self.channels.values().map(|c| c.topic.as_str()).collect();
        t.sort_unstable();
        t.dedup();
        t
    }

    /// Number of messages on `topic` according to the summary's statistics (or the
    /// first pass of a file without summary).
    pub fn message_count(&self, topic: &str) -> u64 {
        self.channels
            .values()
            .filter(|c| c.topic == topic)
            .map(|c| self.message_counts.get(&c.id).copied().unwrap_or(0))
            .sum()
    }

    /// Size of the file, bytes.
    pub fn len_bytes(&self) -> usize {
        self.data.len()
    }

    /// All messages in file order. A structural problem ends the iteration with one
    /// error naming its place; a message record on an unknown channel is skipped and
    /// counted ([`Messages::skipped`]). In a file read by a linear scan
    /// ([`McapFile::salvaged`]), a record cut by the end of the file ends the iteration
    /// without an error, the place in [`Messages::cut`].
    pub fn messages(&self) -> Messages<'_> {
        Messages {
            file: self,
            cursor: Cursor::new(self),
        }
    }

    /// The messages on `topics` decoded as `M`, in file order. A message that does not
    /// decode (wrong type or encoding, damaged payload, inconsistent scan) is skipped
    /// and counted; a structural problem ends the iteration with one error.
    pub fn decoded<M: Ros2Message>(&self, topics: &[&str]) -> Decoded<'_, M> {
        Decoded {
            file: self,
            cursor: Cursor::new(self),
            topics: topics.iter().map(|t| (*t).to_owned()).collect(),
            bad: Skips::default(),
            marker: PhantomData,
        }
    }
}

/// A message found by the cursor: its channel, header fields and where its payload is.
struct Found {
    channel: Arc<Channel>,
    sequence: u32,
    log_time: Stamp,
    publish_time: Stamp,
    at: Location,
    in_chunk: bool,
    payload: std::ops::Range<usize>,
}

/// The walk over the data section, shared by the iterators.
struct Cursor {
    pos: usize,
    end: usize,
    /// Decompressed records of the chunk being walked, and the position in them.
    chunk: Vec<u8>,
    chunk_pos: usize,
    /// Offset of the chunk record being walked (`None`: not inside a chunk).
    chunk_at: Option<u64>,
    done: bool,
    schemas: BTreeMap<u16, Arc<Schema>>,
    channels: BTreeMap<u16, Arc<Channel>>,
    skipped: Skips<SkippedRecord>,
    /// The file is read without its summary: a record cut by the end of the file is
    /// where the recording stopped, not damage.
    linear: bool,
    /// Where the walk stopped at such a cut.
    cut: Option<CutShort>,
    /// The chunk being walked runs past the end of the file (never closed, or cut):
    /// its records run to the end of the file, and it needed this many bytes from its
    /// start for all of it ([`open_chunk`]).
    unclosed: Option<u64>,
}

impl Cursor {
    fn new(file: &McapFile) -> Self {
        Cursor {
            pos: file.data_start,
            end: file.data_end,
            chunk: Vec::new(),
            chunk_pos: 0,
            chunk_at: None,
            done: false,
            schemas: file.schemas.clone(),
            channels: file.channels.clone(),
            skipped: Skips::default(),
            linear: file.salvaged.is_some(),
            cut: None,
            unclosed: None,
        }
    }

    fn skip(&mut self, at: Location, reason: String) {
        self.skipped.record(SkippedRecord { at, reason });
    }

    /// The next message, or `None` at the end of the data section. After an error the
    /// cursor is done.
    fn next_message(&mut self, file: &McapFile) -> Option<Result<Found, McapError>> {
        if self.done {
            return None;
        }
        let result = self.advance(file);
        if !matches!(result, Some(Ok(_))) {
            self.done = true;
        }
        result
    }

    fn advance(&mut self, file: &McapFile) -> Option<Result<Found, McapError>> {
        loop {
            // Inside a chunk: walk its records.
            if let Some(chunk_at) = self.chunk_at {
                if self.chunk_pos >= self.chunk.len() {
                    if self.unclosed.is_some() {
                        self.end_unclosed_chunk(None);
                        return None;
                    }
                    self.chunk_at = None;
                    continue;
                }
                let pos = self.chunk_pos;
                let locate = |p: usize| Location::InChunk {
                    chunk: chunk_at,
                    offset: p as u64,
                };
                let rec = match record_at(&self.chunk, pos, locate) {
                    Ok(r) => r,
                    Err(McapError::Truncated {
                        record,
                        at,
                        needed,
                        available,
                    }) if self.unclosed.is_some() => {
                        self.end_unclosed_chunk(Some(CutShort {
                            record,
                            at,
                            needed,
                            available,
                        }));
                        return None;
                    }
                    Err(e) => return Some(Err(e)),
                };
                self.chunk_pos = rec.body.end;
                match self.handle(rec.op, &rec.body, locate(pos), true) {
                    Ok(Some(found)) => return Some(Ok(found)),
                    Ok(None) => continue,
                    Err(e) => return Some(Err(e)),
                }
            }
            if self.pos >= self.end {
                return None;
            }
            let pos = self.pos;
            if self.linear {
                match self.open_unclosed_chunk(file, pos) {
                    Ok(true) => continue,
                    Ok(false) => {}
                    Err(e) => return Some(Err(e)),
                }
            }
            let rec = match record_at(&file.data[..self.end], pos, |p| Location::File(p as u64)) {
                Ok(r) => r,
                Err(McapError::Truncated {
                    record,
                    at,
                    needed,
                    available,
                }) if self.linear => {
                    self.cut = Some(CutShort {
                        record,
                        at,
                        needed,
                        available,
                    });
                    self.pos = self.end;
                    return None;
                }
                Err(e) => return Some(Err(e)),
            };
            self.pos = rec.body.end;
            match rec.op {
                op::DATA_END | op::FOOTER => {
                    self.pos = self.end;
                    return None;
                }
                op::CHUNK => {
                    if let Err(e) = self.open_chunk(&file.data[rec.body.clone()], pos as u64) {
                        return Some(Err(e));
                    }
                }
                other => match self.handle_file(file, other, &rec.body, pos) {
                    Ok(Some(found)) => return Some(Ok(found)),
                    Ok(None) => {}
                    Err(e) => return Some(Err(e)),
                },
            }
        }
    }

    fn handle_file(
        &mut self,
        file: &McapFile,
        op: u8,
        body: &std::ops::Range<usize>,
        pos: usize,
    ) -> Result<Option<Found>, McapError> {
        let at = Location::File(pos as u64);
        if op == op::MESSAGE {
            return self.message(&file.data[body.clone()], body.start, at, false);
        }
        self.handle_record(op, &file.data[body.clone()], at)
            .map(|()| None)
    }

    fn handle(
        &mut self,
        op: u8,
        body: &std::ops::Range<usize>,
        at: Location,
        in_chunk: bool,
    ) -> Result<Option<Found>, McapError> {
        if op == op::MESSAGE {
            let data = std::mem::take(&mut self.chunk);
            let r = self.message(&data[body.clone()], body.start, at, in_chunk);
            self.chunk = data;
            return r;
        }
        let data = std::mem::take(&mut self.chunk);
        let r = self.handle_record(op, &data[body.clone()], at);
        self.chunk = data;
        r.map(|()| None)
    }

    /// Schema and channel records update the maps; other records are ignored.
    fn handle_record(&mut self, op: u8, body: &[u8], at: Location) -> Result<(), McapError> {
        let mut b = Body {
            data: body,
            pos: 0,
            record: op::name(op),
            at,
        };
        match op {
            op::SCHEMA => {
                if let Some(s) = parse_schema(&mut b)? {
                    self.schemas.insert(s.id, Arc::new(s));
                }
            }
            op::CHANNEL => {
                let c = parse_channel(&mut b, &self.schemas)?;
                self.channels.insert(c.id, Arc::new(c));
            }
            op::HEADER => {
                return Err(b.corrupt("a second header record inside the data section"));
            }
            _ => {}
        }
        Ok(())
    }

    fn message(
        &mut self,
        body: &[u8],
        body_start: usize,
        at: Location,
        in_chunk: bool,
    ) -> Result<Option<Found>, McapError> {
        let mut b = Body {
            data: body,
            pos: 0,
            record: "message record",
            at,
        };
        let channel_id = b.u16("channel_id")?;
        let sequence = b.u32("sequence")?;
        let log_time = b.u64("log_time")?;
        let publish_time = b.u64("publish_time")?;
        let payload_start = body_start + b.pos;
        let payload = payload_start..payload_start + b.rest().len();
        let Some(channel) = self.channels.get(&channel_id).cloned() else {
            self.skip(
                at,
                format!("message on channel {channel_id}, which no earlier record defines"),
            );
            return Ok(None);
        };
        let (Ok(log_ns), Ok(publish_ns)) = (i64::try_from(log_time), i64::try_from(publish_time))
        else {
            self.skip(
                at,
                format!("log time {log_time} ns does not fit a signed 64-bit stamp"),
            );
            return Ok(None);
        };
        Ok(Some(Found {
            channel,
            sequence,
            log_time: Stamp::from_ns(log_ns),
            publish_time: Stamp::from_ns(publish_ns),
            at,
            in_chunk,
            payload,
        }))
    }

    /// Decompresses a chunk record's records into the cursor's buffer and checks them.
    fn open_chunk(&mut self, body: &[u8], chunk_at: u64) -> Result<(), McapError> {
        let mut b = Body {
            data: body,
            pos: 0,
            record: "chunk record",
            at: Location::File(chunk_at),
        };
        b.u64("message_start_time")?;
        b.u64("message_end_time")?;
        let uncompressed_size = b.u64("uncompressed_size")?;
        let uncompressed_crc = b.u32("uncompressed_crc")?;
        let compression = b.string("compression")?;
        let records_len = b.u64("records")?;
        let records = b.take("records", records_len)?;
        if !compression.is_empty() {
            // Checked before anything is allocated or decompressed.
            crate::limits::check_chunk_size(uncompressed_size, records_len)
                .map_err(|e| b.corrupt(e))?;
        }
        let Ok(size) = usize::try_from(uncompressed_size) else {
            return Err(b.corrupt(format!(
                "it claims {uncompressed_size} bytes of records, more than this machine addresses"
            )));
        };
        self.chunk.clear();
        match compression.as_str() {
            "" => {
                if records.len() != size {
                    return Err(b.corrupt(format!(
                        "uncompressed chunk holds {} bytes of records but states {size}",
                        records.len()
                    )));
                }
                self.chunk.extend_from_slice(records);
            }
            "zstd" => {
                self.chunk.resize(size, 0);
                let mut decoder = ruzstd::decoding::FrameDecoder::new();
                let written = decoder
                    .decode_all(records, &mut self.chunk)
                    .map_err(|e| b.corrupt(format!("zstd data does not decompress: {e}")))?;
                if written != size {
                    return Err(b.corrupt(format!(
                        "zstd data decompresses to {written} bytes, the record states {size}"
                    )));
                }
            }
            "lz4" => {
                self.chunk.resize(size, 0);
                let mut decoder = lz4_flex::frame::FrameDecoder::new(records);
                decoder.read_exact(&mut self.chunk).map_err(|e| {
                    b.corrupt(format!("lz4 data does not decompress to {size} bytes: {e}"))
                })?;
                let mut extra = [0u8; 1];
                if matches!(decoder.read(&mut extra), Ok(n) if n > 0) {
                    return Err(b.corrupt(format!(
                        "lz4 data decompresses to more than the {size} bytes the record states"
                    )));
                }
            }
            _ => {
                return Err(McapError::UnsupportedCompression {
                    at: chunk_at,
                    compression,
                });
            }
        }
        if uncompressed_crc != 0 {
            let crc = crc32fast::hash(&self.chunk);
            if crc != uncompressed_crc {
                return Err(b.corrupt(format!(
                    "CRC-32 of the records is {crc:#010x}, the record states {uncompressed_crc:#010x}"
                )));
            }
        }
        self.chunk_pos = 0;
        self.chunk_at = Some(chunk_at);
        Ok(())
    }

    fn payload<'a>(&'a self, file: &'a McapFile, found: &Found) -> &'a [u8] {
        if found.in_chunk {
            &self.chunk[found.payload.clone()]
        } else {
            &file.data[found.payload.clone()]
        }
    }
}

/// The messages of a file in file order (see [`McapFile::messages`]).
pub struct Messages<'a> {
    file: &'a McapFile,
    cursor: Cursor,
}

impl Messages<'_> {
    /// Message records skipped so far (the first 100 with reasons).
    pub fn skipped(&self) -> &[SkippedRecord] {
        self.cursor.skipped.kept()
    }

    /// Number of message records skipped so far.
    pub fn skipped_count(&self) -> usize {
        self.cursor.skipped.count()
    }

    /// Where the walk stopped because the file ends inside a record (files read by a
    /// linear scan only, see [`McapFile::salvaged`]); `None` while no cut was met.
    pub fn cut(&self) -> Option<&CutShort> {
        self.cursor.cut.as_ref()
    }
}

impl Iterator for Messages<'_> {
    type Item = Result<RawMessage, McapError>;

    fn next(&mut self) -> Option<Self::Item> {
        let found = match self.cursor.next_message(self.file)? {
            Ok(f) => f,
            Err(e) => return Some(Err(e)),
        };
        let data = self.cursor.payload(self.file, &found).to_vec();
        Some(Ok(RawMessage {
            channel: found.channel,
            sequence: found.sequence,
            log_time: found.log_time,
            publish_time: found.publish_time,
            at: found.at,
            data,
        }))
    }
}

/// The decoded messages of chosen topics (see [`McapFile::decoded`]).
pub struct Decoded<'a, M> {
    file: &'a McapFile,
    cursor: Cursor,
    topics: Vec<String>,
    bad: Skips<BadMessage>,
    marker: PhantomData<M>,
}

impl<M> Decoded<'_, M> {
    /// Messages that did not decode so far (the first 100 with reasons).
    pub fn bad_messages(&self) -> &[BadMessage] {
        self.bad.kept()
    }

    /// Number of messages that did not decode so far.
    pub fn bad_count(&self) -> usize {
        self.bad.count()
    }

    /// Message records skipped so far because no channel defines them.
    pub fn skipped(&self) -> &[SkippedRecord] {
        self.cursor.skipped.kept()
    }

    /// Where the walk stopped at a cut in the file; see [`Messages::cut`].
    pub fn cut(&self) -> Option<&CutShort> {
        self.cursor.cut.as_ref()
    }
}

impl<M: Ros2Message> Iterator for Decoded<'_, M> {
    type Item = Result<Message<M>, McapError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let found = match self.cursor.next_message(self.file)? {
                Ok(f) => f,
                Err(e) => return Some(Err(e)),
            };
            if !self.topics.iter().any(|t| *t == found.channel.topic) {
                continue;
            }
            let decoded = found
                .channel
                .check::<M>()
                .and_then(|()| from_cdr::<M>(self.cursor.payload(self.file, &found)));
            match decoded {
                Ok(message) => {
                    return Some(Ok(Message {
                        channel: found.channel,
                        log_time: found.log_time,
                        publish_time: found.publish_time,
                        at: found.at,
                        message,
                    }));
                }
                Err(error) => {
                    self.bad.record(BadMessage {
                        topic: found.channel.topic.clone(),
                        at: found.at,
                        error,
                    });
                }
            }
        }
    }
}

mod open_chunk;
mod records;

use records::{Body, parse_channel, parse_schema, parse_statistics, record_at};
#[cfg(test)]
mod tests;
