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

use super::error::{CutShort, DecodeError, Location, McapError};
use super::msgs::{Ros2Message, from_cdr, type_matches};
use crate::skips::Skips;

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

/// A message record that was skipped because it cannot be attributed to a channel or
/// its times do not fit.
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
/// use tether_io::mcap::{McapFile, LaserScanMsg};
/// let file = McapFile::open("run.mcap")?;
/// let mut scans = file.decoded::<LaserScanMsg>(&["/scan"]);
/// for msg in &mut scans {
///     let msg = msg?;
///     println!("{} beams at {}", msg.message.scan.len(), msg.message.scan.stamp);
/// }
/// println!("{} bad messages skipped", scans.bad_count());
/// # Ok::<(), tether_io::mcap::McapError>(())
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

/// A bounded reader over one record's body, naming the record in its errors.
struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    record: &'static str,
    at: Location,
}

impl<'a> Body<'a> {
    fn corrupt(&self, problem: impl Into<String>) -> McapError {
        McapError::Corrupt {
            record: self.record,
            at: self.at,
            problem: problem.into(),
        }
    }

    fn take(&mut self, field: &str, n: u64) -> Result<&'a [u8], McapError> {
        let left = self.data.len() - self.pos;
        if n > left as u64 {
            return Err(self.corrupt(format!(
                "field `{field}` needs {n} bytes at byte {} of the body, {left} remain",
                self.pos
            )));
        }
        let out = &self.data[self.pos..self.pos + n as usize];
        self.pos += n as usize;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], McapError> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(field, N as u64)?);
        Ok(out)
    }

    fn u16(&mut self, field: &str) -> Result<u16, McapError> {
        self.array(field).map(u16::from_le_bytes)
    }

    fn u32(&mut self, field: &str) -> Result<u32, McapError> {
        self.array(field).map(u32::from_le_bytes)
    }

    fn u64(&mut self, field: &str) -> Result<u64, McapError> {
        self.array(field).map(u64::from_le_bytes)
    }

    fn bytes(&mut self, field: &str) -> Result<&'a [u8], McapError> {
        let n = self.u32(field)?;
        self.take(field, u64::from(n))
    }

    fn string(&mut self, field: &str) -> Result<String, McapError> {
        let b = self.bytes(field)?;
        String::from_utf8(b.to_vec()).map_err(|_| self.corrupt(format!("`{field}` is not UTF-8")))
    }

    fn map(&mut self, field: &str) -> Result<BTreeMap<String, String>, McapError> {
        let n = self.u32(field)?;
        let inner = self.take(field, u64::from(n))?;
        let mut sub = Body {
            data: inner,
            pos: 0,
            record: self.record,
            at: self.at,
        };
        let mut out = BTreeMap::new();
        while sub.pos < inner.len() {
            let k = sub.string(field)?;
            let v = sub.string(field)?;
            out.insert(k, v);
        }
        Ok(out)
    }

    fn rest(&mut self) -> &'a [u8] {
        let out = &self.data[self.pos..];
        self.pos = self.data.len();
        out
    }
}

/// One record found in a buffer: opcode and body range.
struct Record {
    op: u8,
    body: std::ops::Range<usize>,
}

/// Reads the record starting at `pos` of `buf`; `at` maps a position to a location.
fn record_at(buf: &[u8], pos: usize, at: impl Fn(usize) -> Location) -> Result<Record, McapError> {
    let available = (buf.len() - pos) as u64;
    if available < 9 {
        return Err(McapError::Truncated {
            record: "record",
            at: at(pos),
            needed: 9,
            available,
        });
    }
    let op = buf[pos];
    let mut len = [0u8; 8];
    len.copy_from_slice(&buf[pos + 1..pos + 9]);
    let len = u64::from_le_bytes(len);
    if len > available - 9 {
        return Err(McapError::Truncated {
            record: op::name(op),
            at: at(pos),
            needed: len.saturating_add(9),
            available,
        });
    }
    let start = pos + 9;
    Ok(Record {
        op,
        body: start..start + len as usize,
    })
}

fn parse_schema(body: &mut Body<'_>) -> Result<Option<Schema>, McapError> {
    let id = body.u16("id")?;
    let name = body.string("name")?;
    let encoding = body.string("encoding")?;
    let data = body.bytes("data")?.to_vec();
    // Schema id 0 is reserved ("no schema"); such a record is ignored.
    Ok((id != 0).then_some(Schema {
        id,
        name,
        encoding,
        data,
    }))
}

fn parse_channel(
    body: &mut Body<'_>,
    schemas: &BTreeMap<u16, Arc<Schema>>,
) -> Result<Channel, McapError> {
    let id = body.u16("id")?;
    let schema_id = body.u16("schema_id")?;
    let topic = body.string("topic")?;
    let message_encoding = body.string("message_encoding")?;
    let metadata = body.map("metadata")?;
    let schema = match schema_id {
        0 => None,
        id => Some(schemas.get(&id).cloned().ok_or_else(|| {
            body.corrupt(format!(
                "channel {topic:?} refers to schema {id}, which no earlier record defines"
            ))
        })?),
    };
    Ok(Channel {
        id,
        topic,
        message_encoding,
        schema,
        metadata,
    })
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

fn parse_statistics(body: &mut Body<'_>) -> Result<BTreeMap<u16, u64>, McapError> {
    body.u64("message_count")?;
    body.u16("schema_count")?;
    body.u32("channel_count")?;
    body.u32("attachment_count")?;
    body.u32("metadata_count")?;
    body.u32("chunk_count")?;
    body.u64("message_start_time")?;
    body.u64("message_end_time")?;
    let n = body.u32("channel_message_counts")?;
    let raw = body.take("channel_message_counts", u64::from(n))?;
    let mut out = BTreeMap::new();
    for entry in raw.chunks_exact(10) {
        let id = u16::from_le_bytes([entry[0], entry[1]]);
        let mut c = [0u8; 8];
        c.copy_from_slice(&entry[2..]);
        out.insert(id, u64::from_le_bytes(c));
    }
    Ok(out)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap::{McapWriter, RawLaserScan, TwistMsg, to_cdr};
    use tether_core::LaserScan;

    /// A recording of 40 scans and 40 commands, in chunks of about 8 KiB.
    fn recording() -> Vec<u8> {
        let mut w = McapWriter::with_chunk_size(std::io::Cursor::new(Vec::new()), 8 << 10).unwrap();
        for k in 0..40i64 {
            let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
            let ranges = (0..682)
                .map(|i| 0.5 + ((i + k) % 50) as f32 * 0.1)
                .collect();
            let scan =
                LaserScan::new(t, "laser", -2.0862, 0.006_135_923, 0.02, 5.6, ranges).unwrap();
            w.write_stamped("/scan", &crate::mcap::LaserScanMsg::new(scan, 0.0, 0.1))
                .unwrap();
            w.write("/cmd_vel", t, &TwistMsg::unicycle(0.1, k as f64))
                .unwrap();
        }
        w.finish().unwrap().into_inner()
    }

    #[test]
    fn reads_what_the_writer_wrote_and_agrees_with_the_mcap_crate() {
        let bytes = recording();
        let file = McapFile::from_bytes(bytes.clone()).unwrap();
        assert_eq!(file.topics(), ["/cmd_vel", "/scan"]);
        assert_eq!(file.message_count("/scan"), 40);
        let ours: Vec<RawMessage> = file.messages().map(|m| m.unwrap()).collect();
        // The `mcap` crate's own reader (uncompressed chunks need no feature).
        let theirs: Vec<_> = mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| m.unwrap())
            .collect();
        assert_eq!(ours.len(), 80);
        assert_eq!(ours.len(), theirs.len());
        for (a, b) in ours.iter().zip(&theirs) {
            assert_eq!(a.topic(), b.channel.topic);
            assert_eq!(a.log_time.ns() as u64, b.log_time);
            assert_eq!(a.data, b.data.as_ref());
        }
        let twists: Vec<_> = file
            .decoded::<TwistMsg>(&["/cmd_vel"])
            .map(|m| m.unwrap().message.w_radps())
            .collect();
        assert_eq!(twists, (0..40).map(f64::from).collect::<Vec<_>>());
    }

    /// The chunk records of a file (start, end) and, for each, how many messages the
    /// full file has in it.
    fn chunks_of(bytes: &[u8]) -> Vec<(u64, u64, usize)> {
        let file = McapFile::from_bytes(bytes.to_vec()).unwrap();
        let in_chunks: Vec<u64> = file
            .messages()
            .map(|m| match m.unwrap().at {
                Location::InChunk { chunk, .. } => chunk,
                Location::File(at) => panic!("message outside a chunk at {at}"),
            })
            .collect();
        let mut out = Vec::new();
        let mut pos = MAGIC.len();
        while pos + 9 <= bytes.len() {
            let len = u64::from_le_bytes(bytes[pos + 1..pos + 9].try_into().unwrap());
            let end = pos as u64 + 9 + len;
            if bytes[pos] == op::CHUNK {
                let n = in_chunks.iter().filter(|&&c| c == pos as u64).count();
                out.push((pos as u64, end, n));
            }
            if bytes[pos] == op::DATA_END {
                break;
            }
            pos = end as usize;
        }
        out
    }

    /// Reads a prefix of a file: the messages it gives (never an error) and the cut.
    fn read_prefix(bytes: &[u8], cut: usize) -> Option<(usize, Option<CutShort>)> {
        let file = McapFile::from_bytes(bytes[..cut].to_vec()).ok()?;
        let mut messages = file.messages();
        let mut n = 0;
        for m in &mut messages {
            match m {
                Ok(_) => n += 1,
                Err(e) => panic!("a prefix of {cut} bytes gives an error: {e}"),
            }
        }
        Some((n, messages.cut().copied()))
    }

    /// Messages in the chunks that end by `cut`.
    fn complete_before(chunks: &[(u64, u64, usize)], cut: usize) -> usize {
        chunks
            .iter()
            .filter(|c| c.1 <= cut as u64)
            .map(|c| c.2)
            .sum()
    }

    #[test]
    fn every_prefix_gives_the_messages_of_the_chunks_complete_before_it() {
        let bytes = recording();
        let chunks = chunks_of(&bytes);
        assert!(chunks.len() >= 4, "{} chunks", chunks.len());
        let full: usize = chunks.iter().map(|c| c.2).sum();
        assert_eq!(full, 80);
        let header_end = {
            let len = u64::from_le_bytes(bytes[9..17].try_into().unwrap());
            17 + len as usize
        };
        for cut in (0..=bytes.len())
            .step_by(97)
            .chain([bytes.len() - 1, bytes.len()])
        {
            let Some((n, cut_at)) = read_prefix(&bytes, cut) else {
                assert!(
                    cut < header_end,
                    "only a cut in the magic or header may refuse"
                );
                continue;
            };
            assert_eq!(n, complete_before(&chunks, cut), "cut at {cut}");
            if let Some(c) = cut_at {
                assert!(
                    matches!(c.at, Location::File(at) if (at as usize) < cut),
                    "{c}"
                );
            }
        }
        // Cut inside the second chunk: the walk says where it stopped.
        let cut = ((chunks[1].0 + chunks[1].1) / 2) as usize;
        let file = McapFile::from_bytes(bytes[..cut].to_vec()).unwrap();
        assert!(file.salvaged().unwrap().contains("footer"));
        assert_eq!(
            file.topics(),
            ["/cmd_vel", "/scan"],
            "channels found in chunks"
        );
        let mut messages = file.messages();
        assert_eq!((&mut messages).count(), chunks[0].2);
        let c = messages.cut().unwrap();
        assert_eq!(
            (c.record, c.at),
            ("chunk record", Location::File(chunks[1].0))
        );
        assert!(McapFile::from_bytes(bytes).unwrap().salvaged().is_none());
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        #[test]
        fn any_prefix_reads_without_error(fraction in 0.0..1.0f64) {
            let bytes = recording();
            let chunks = chunks_of(&bytes);
            let cut = (bytes.len() as f64 * fraction) as usize;
            if let Some((n, _)) = read_prefix(&bytes, cut) {
                proptest::prop_assert_eq!(n, complete_before(&chunks, cut));
            }
        }
    }

    /// A writer target that can be looked at while the writer still holds it.
    #[derive(Clone, Default)]
    struct Shared(std::rc::Rc<std::cell::RefCell<std::io::Cursor<Vec<u8>>>>);

    impl std::io::Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.borrow_mut().write(buf)
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl std::io::Seek for Shared {
        fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
            self.0.borrow_mut().seek(pos)
        }
    }

    #[test]
    fn an_unfinished_recording_holds_every_second_closed_before() {
        let target = Shared::default();
        let mut w = McapWriter::new(target.clone()).unwrap();
        // 3.5 s of 10 Hz scans of 100 beams: far less than a 1 MiB chunk.
        for k in 0..35i64 {
            let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
            let scan = LaserScan::new(t, "laser", -1.0, 0.02, 0.02, 5.6, vec![1.5; 100]).unwrap();
            w.write_stamped("/scan", &crate::mcap::LaserScanMsg::new(scan, 0.0, 0.1))
                .unwrap();
        }
        // The process dies here: what is in the file is all there is.
        let bytes = target.0.borrow().get_ref().clone();
        let file = McapFile::from_bytes(bytes).unwrap();
        assert_eq!(file.topics(), ["/scan"]);
        let mut scans = file.decoded::<crate::mcap::LaserScanMsg>(&["/scan"]);
        let stamps: Vec<i64> = (&mut scans)
            .map(|m| m.unwrap().message.scan.stamp.ns())
            .collect();
        // Chunks closed at 2 s, 3 s and 4 s of log time: 1.0 to 3.9 s are in the file.
        assert_eq!(stamps.len(), 30);
        assert_eq!(stamps[29], 3_900_000_000);
        assert!(scans.cut().unwrap().to_string().contains("never written"));
        w.finish().unwrap();
        // Finished, every scan is there.
        let bytes = target.0.borrow().get_ref().clone();
        assert_eq!(
            McapFile::from_bytes(bytes).unwrap().message_count("/scan"),
            35
        );
    }

    #[test]
    fn a_streaming_recording_cut_anywhere_holds_every_message_written_before() {
        let target = Shared::default();
        let mut w = McapWriter::streaming(target.clone()).unwrap();
        let mut ends = Vec::new();
        for k in 0..35i64 {
            let t = Stamp::from_ns(1_000_000_000 + k * 100_000_000);
            let scan = LaserScan::new(t, "laser", -1.0, 0.02, 0.02, 5.6, vec![1.5; 100]).unwrap();
            w.write_stamped("/scan", &crate::mcap::LaserScanMsg::new(scan, 0.0, 0.1))
                .unwrap();
            ends.push(target.0.borrow().get_ref().len());
        }
        // The process dies here; any prefix of what it wrote is read up to its last
        // complete message, in order.
        let bytes = target.0.borrow().get_ref().clone();
        for cut in (ends[0]..=bytes.len()).step_by(53).chain([bytes.len()]) {
            let file = McapFile::from_bytes(bytes[..cut].to_vec()).unwrap();
            let stamps: Vec<i64> = file
                .decoded::<crate::mcap::LaserScanMsg>(&["/scan"])
                .map(|m| m.unwrap().message.scan.stamp.ns())
                .collect();
            let complete = ends.iter().filter(|&&e| e <= cut).count();
            assert_eq!(stamps.len(), complete, "cut at {cut}");
            assert!(stamps.windows(2).all(|p| p[0] < p[1]));
        }
        w.finish().unwrap();
        let bytes = target.0.borrow().get_ref().clone();
        let file = McapFile::from_bytes(bytes).unwrap();
        assert!(file.salvaged().is_none());
        assert_eq!(file.message_count("/scan"), 35);
    }

    /// An MCAP file of a header and one chunk record with these fields.
    fn one_chunk(compression: &str, uncompressed_size: u64, records: &[u8]) -> Vec<u8> {
        fn string(out: &mut Vec<u8>, s: &str) {
            out.extend((s.len() as u32).to_le_bytes());
            out.extend(s.as_bytes());
        }
        let mut out = MAGIC.to_vec();
        let mut header = Vec::new();
        string(&mut header, "ros2");
        string(&mut header, "test");
        out.push(op::HEADER);
        out.extend((header.len() as u64).to_le_bytes());
        out.extend(header);
        let mut chunk = Vec::new();
        chunk.extend(0u64.to_le_bytes());
        chunk.extend(0u64.to_le_bytes());
        chunk.extend(uncompressed_size.to_le_bytes());
        chunk.extend(0u32.to_le_bytes());
        string(&mut chunk, compression);
        chunk.extend((records.len() as u64).to_le_bytes());
        chunk.extend(records);
        out.push(op::CHUNK);
        out.extend((chunk.len() as u64).to_le_bytes());
        out.extend(chunk);
        out
    }

    #[test]
    fn a_decompression_bomb_is_refused_before_anything_is_allocated() {
        for compression in ["lz4", "zstd"] {
            // 200 MiB claimed from 100 bytes: refused by the ratio; 1 TiB by the size cap.
            for (claim, cap) in [(200u64 << 20, "decompression bomb"), (1 << 40, "256 MiB")] {
                let file = McapFile::from_bytes(one_chunk(compression, claim, &[7; 100])).unwrap();
                let err = file.messages().next().unwrap().unwrap_err();
                assert!(err.to_string().contains(cap), "{compression}: {err}");
                assert!(err.to_string().contains("chunk record at byte 33"), "{err}");
            }
        }
        // An honest small chunk of zeros in lz4 (255:1) still reads.
        // Zeros are records of opcode 0 and length 0 (9 bytes each): no messages.
        let records = vec![0u8; 9 << 17];
        let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
        std::io::Write::write_all(&mut e, &records).unwrap();
        let stored = e.finish().unwrap();
        assert!(stored.len() * 200 < records.len());
        let file = McapFile::from_bytes(one_chunk("lz4", 9 << 17, &stored)).unwrap();
        assert_eq!(file.messages().filter(Result::is_err).count(), 0);
    }

    #[test]
    fn a_damaged_chunk_fails_its_crc() {
        let mut bytes = recording();
        // A byte in the middle of the first chunk's records.
        let first = chunks_of(&bytes)[0];
        let at = ((first.0 + first.1) / 2) as usize;
        bytes[at] ^= 0x55;
        let file = McapFile::from_bytes(bytes).unwrap();
        let err = file.messages().find_map(Result::err).expect("an error");
        assert!(err.to_string().contains("CRC-32"), "{err}");
    }

    #[test]
    fn bad_messages_are_skipped_and_counted() {
        let mut w = McapWriter::new(std::io::Cursor::new(Vec::new())).unwrap();
        let good = RawLaserScan {
            header: crate::mcap::Header::new(Stamp::from_ns(5), "laser"),
            angle_min: -1.0,
            angle_max: 1.0,
            angle_increment: 0.5,
            time_increment: 0.0,
            scan_time: 0.1,
            range_min: 0.02,
            range_max: 5.6,
            ranges: vec![1.0; 5],
            intensities: vec![],
        };
        let mut bad = good.clone();
        bad.angle_max = 3.0; // says 9 beams, carries 5
        for m in [&good, &bad, &good] {
            w.write_stamped("/scan", m).unwrap();
        }
        let bytes = w.finish().unwrap().into_inner();
        let file = McapFile::from_bytes(bytes).unwrap();
        let mut scans = file.decoded::<crate::mcap::LaserScanMsg>(&["/scan"]);
        let read: Vec<_> = scans.by_ref().map(|m| m.unwrap()).collect();
        assert_eq!(read.len(), 2);
        assert_eq!(scans.bad_count(), 1);
        assert!(matches!(
            scans.bad_messages()[0].error,
            DecodeError::Scan(_)
        ));
        let mut wrong = file.decoded::<TwistMsg>(&["/scan"]);
        assert_eq!(wrong.by_ref().count(), 0);
        assert!(matches!(
            wrong.bad_messages()[0].error,
            DecodeError::WrongType { .. }
        ));
        assert!(to_cdr(&good).is_ok());
    }

    #[test]
    fn refuses_other_files() {
        assert!(matches!(
            McapFile::from_bytes(b"#ROSBAG V2.0\n".to_vec()),
            Err(McapError::NotMcap { .. })
        ));
        assert!(McapFile::from_bytes(Vec::new()).is_err());
    }

    /// Opens `bytes` and, if they open, walks every message and decodes every topic as
    /// a scan: an error or a result, never a panic; a walk gives at most one error, as
    /// its last item (what the `mcap_file` fuzz target checks).
    fn open_and_walk(bytes: Vec<u8>) -> Result<usize, McapError> {
        let file = McapFile::from_bytes(bytes)?;
        let _ = (file.salvaged(), file.profile(), file.library());
        let topics: Vec<String> = file.topics().iter().map(|t| t.to_string()).collect();
        let mut n = 0;
        let mut messages = file.messages();
        let mut last_error = None;
        for m in &mut messages {
            assert!(
                last_error.is_none(),
                "a message after the error {last_error:?}"
            );
            match m {
                Ok(_) => n += 1,
                Err(e) => last_error = Some(e),
            }
        }
        if let Some(c) = messages.cut() {
            let _ = c.to_string();
        }
        let names: Vec<&str> = topics.iter().map(String::as_str).collect();
        let mut scans = file.decoded::<crate::mcap::LaserScanMsg>(&names);
        for m in &mut scans {
            let _ = m.map(|m| m.message);
        }
        let _ = (scans.bad_count(), scans.skipped().len());
        match last_error {
            Some(e) => Err(e),
            None => Ok(n),
        }
    }

    /// Records that look like MCAP's: a known or random opcode, a length that is the
    /// body's, or random, or far too large, and a random body (small).
    fn mcap_like_records() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let record = (
            prop_oneof![0x01u8..=0x0F, any::<u8>()],
            prop_oneof![
                Just(None),
                any::<u64>().prop_map(Some),
                (0u64..64).prop_map(Some)
            ],
            proptest::collection::vec(any::<u8>(), 0..96),
        )
            .prop_map(|(op, len, body)| {
                let mut out = vec![op];
                out.extend(len.unwrap_or(body.len() as u64).to_le_bytes());
                out.extend(body);
                out
            });
        (proptest::collection::vec(record, 0..12), any::<bool>()).prop_map(|(records, end)| {
            let mut out = MAGIC.to_vec();
            out.extend(records.concat());
            if end {
                out.extend(MAGIC);
            }
            out
        })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]

        /// Random bytes, alone and after the magic, and MCAP-like records: an error or
        /// a file whose walk ends, never a panic.
        #[test]
        fn random_bytes_give_an_error_or_a_result_never_a_panic(
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..2000),
            after_magic in proptest::prelude::any::<bool>(),
        ) {
            let mut input = if after_magic { MAGIC.to_vec() } else { Vec::new() };
            input.extend(&bytes);
            let _ = open_and_walk(input);
        }

        #[test]
        fn mcap_like_records_give_an_error_or_a_result_never_a_panic(
            bytes in mcap_like_records(),
        ) {
            let _ = open_and_walk(bytes);
        }

        /// A valid recording with bytes changed, inserted or removed anywhere.
        #[test]
        fn a_damaged_recording_gives_an_error_or_a_result_never_a_panic(
            edits in proptest::collection::vec(
                (proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>(), 0u8..3),
                1..8,
            ),
        ) {
            static RECORDING: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
            let mut bytes = RECORDING.get_or_init(recording).clone();
            for (at, byte, op) in edits {
                let i = at.index(bytes.len());
                match op {
                    0 => bytes[i] = byte,
                    1 => bytes.insert(i, byte),
                    _ => {
                        bytes.remove(i);
                    }
                }
            }
            let _ = open_and_walk(bytes);
        }
    }
}
