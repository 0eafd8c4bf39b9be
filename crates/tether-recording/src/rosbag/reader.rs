//! Reading a bag: its header and index on opening, then its messages in the order they
//! were recorded.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;

use tether_core::Stamp;

use tether_msgs::{DecodeError, RosMessage};

use super::error::{BagError, CutShort, Location};
use super::record::{Fields, MAGIC, Op};
use crate::skips::Skips;
pub use crate::skips::{BadMessage, SkippedRecord};

mod decoded;
pub use decoded::Decoded;

/// One connection of a bag: a topic with its message type, as the recorder saw it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Connection {
    /// Connection id, unique within the bag.
    pub id: u32,
    /// Topic name, e.g. `/scan`.
    pub topic: String,
    /// ROS 1 message type, e.g. `sensor_msgs/LaserScan`.
    pub msg_type: String,
    /// MD5 sum of the message definition (`*` means any).
    pub md5sum: String,
    /// The full message definition text.
    pub message_definition: String,
    /// Node that published, when the recorder noted it.
    pub callerid: Option<String>,
    /// Whether the publisher was latching.
    pub latching: bool,
}

/// The summary of one chunk, from the bag's index.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkInfo {
    /// Offset of the chunk record in the file.
    pub chunk_pos: u64,
    /// Earliest record time of a message in the chunk.
    pub start_time: Stamp,
    /// Latest record time of a message in the chunk.
    pub end_time: Stamp,
    /// Number of messages per connection id in the chunk.
    pub message_counts: Vec<(u32, u32)>,
}

/// A message as stored: its connection, record time and serialised bytes.
#[derive(Debug, Clone)]
pub struct RawMessage {
    /// The connection (topic and type) it was published on.
    pub connection: Arc<Connection>,
    /// Time the recorder received it (not the message's header stamp).
    pub time: Stamp,
    /// Where its record is.
    pub at: Location,
    /// The ROS 1 serialised message.
    pub data: Vec<u8>,
}

impl RawMessage {
    /// Topic name.
    pub fn topic(&self) -> &str {
        &self.connection.topic
    }

    /// Decodes the message as an `M`, checking the connection's type and MD5 sum first.
    pub fn decode<M: RosMessage>(&self) -> Result<M, DecodeError> {
        let c = &self.connection;
        if c.msg_type != M::TYPE {
            return Err(DecodeError::WrongType {
                expected: M::TYPE,
                found: c.msg_type.clone(),
                found_md5: Some(c.md5sum.clone()),
            });
        }
        if c.md5sum != "*" && c.md5sum != M::MD5SUM {
            return Err(DecodeError::WrongDefinition {
                msg_type: M::TYPE,
                expected: M::MD5SUM,
                found: c.md5sum.clone(),
            });
        }
        M::decode(&self.data)
    }
}

/// A decoded message with where and when it was recorded.
#[derive(Debug, Clone)]
pub struct BagMessage<M> {
    /// The connection it was published on.
    pub connection: Arc<Connection>,
    /// Time the recorder received it.
    pub time: Stamp,
    /// Where its record is.
    pub at: Location,
    /// The message.
    pub message: M,
}

/// An open ROS 1 bag (format 2.0).
///
/// Opening reads the bag header and the index (connections and chunk infos) at the end
/// of the file, so a truncated or unindexed bag is refused at once with the offset of
/// the problem. [`Bag::messages`] then walks the chunks in file order.
///
/// ```no_run
/// use tether_msgs::LaserScanMsg;
/// use tether_recording::rosbag::Bag;
/// let mut bag = Bag::open("demo.bag")?;
/// let mut scans = bag.decoded::<LaserScanMsg>(&["/scan"]);
/// for msg in &mut scans {
///     let msg = msg?;
///     println!("{} beams at {}", msg.message.scan.len(), msg.message.scan.stamp);
/// }
/// println!("{} bad messages skipped", scans.bad_count());
/// # Ok::<(), tether_recording::rosbag::BagError>(())
/// ```
#[derive(Debug)]
pub struct Bag<R> {
    reader: R,
    file_len: u64,
    data_start: u64,
    index_pos: u64,
    connections: BTreeMap<u32, Arc<Connection>>,
    chunk_infos: Vec<ChunkInfo>,
    /// Why the index was not used, when the bag is read by walking its records.
    salvaged: Option<String>,
}

impl Bag<BufReader<File>> {
    /// Opens the bag at `path` and reads its header and index.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, BagError> {
        Bag::from_reader(open_buffered(path.as_ref())?)
    }

    /// Opens the bag at `path` like [`Bag::open`], but a bag whose index is missing or
    /// cut off (a recording that was interrupted, a copy cut short) is read by walking
    /// its records from the start instead of being refused; see
    /// [`Bag::from_reader_salvaging`].
    pub fn open_salvaging(path: impl AsRef<Path>) -> Result<Self, BagError> {
        Bag::from_reader_salvaging(open_buffered(path.as_ref())?)
    }
}

/// The file at `path`, buffered for reading records.
fn open_buffered(path: &Path) -> Result<BufReader<File>, BagError> {
    let file = File::open(path).map_err(|source| BagError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(BufReader::with_capacity(1 << 16, file))
}

/// A record's header as found in the file.
struct OuterRecord {
    at: u64,
    op: Op,
    fields: Fields,
    data_at: u64,
    data_len: u64,
}

impl OuterRecord {
    fn end(&self) -> u64 {
        self.data_at + self.data_len
    }

    fn corrupt(&self, problem: impl Into<String>) -> BagError {
        BagError::Corrupt {
            record: self.op.name(),
            at: Location::File(self.at),
            problem: problem.into(),
        }
    }
}

impl<R: Read + Seek> Bag<R> {
    /// Reads the header and index of a bag from any seekable source.
    pub fn from_reader(reader: R) -> Result<Self, BagError> {
        Self::from_reader_with(reader, false)
    }

    /// Like [`Bag::from_reader`], but when the index cannot be used (`index_pos` is 0,
    /// points past the end of the file, or the index section is damaged or cut) the
    /// bag is opened anyway, without chunk infos, and [`Bag::messages`] walks the
    /// records from the start to the end of the file (as `rosbag reindex` does):
    /// connections come from the connection records inside the chunks, and a record cut
    /// by the end of the file ends the walk with a counted skip
    /// ([`Messages::skipped`]) instead of an error. Of an uncompressed chunk that is
    /// cut, the complete records before the cut are still read. [`Bag::salvaged`] says
    /// why the index was not used. The bag header itself must be whole.
    pub fn from_reader_salvaging(reader: R) -> Result<Self, BagError> {
        Self::from_reader_with(reader, true)
    }

    /// Why the index was not used (see [`Bag::from_reader_salvaging`]); `None` when it
    /// was.
    pub fn salvaged(&self) -> Option<&str> {
        self.salvaged.as_deref()
    }

    fn salvage(&mut self, reason: String) {
        self.connections.clear();
        self.chunk_infos.clear();
        self.index_pos = self.file_len;
        self.salvaged = Some(reason);
    }

    fn from_reader_with(mut reader: R, salvage: bool) -> Result<Self, BagError> {
        let file_len = reader
            .seek(SeekFrom::End(0))
            .map_err(|source| BagError::Io {
                at: Location::File(0),
                source,
            })?;
        let mut bag = Bag {
            reader,
            file_len,
            data_start: 0,
            index_pos: 0,
            connections: BTreeMap::new(),
            chunk_infos: Vec::new(),
            salvaged: None,
        };
        let magic_len = MAGIC.len() as u64;
        let head = bag.read_at(0, magic_len.min(file_len))?;
        if head.as_slice() != MAGIC.as_slice() {
            return Err(BagError::NotABag {
                found: String::from_utf8_lossy(&head).into_owned(),
            });
        }
        let header = bag.read_record(magic_len, file_len)?;
        if header.op != Op::BagHeader {
            return Err(header.corrupt("expected the bag header record right after the magic line"));
        }
        let index_pos = header
            .fields
            .u64("index_pos")
            .map_err(|e| header.corrupt(e))?;
        let conn_count = header
            .fields
            .u32("conn_count")
            .map_err(|e| header.corrupt(e))?;
        let chunk_count = header
            .fields
            .u32("chunk_count")
            .map_err(|e| header.corrupt(e))?;
        bag.data_start = header.end();
        if salvage {
            let usable = index_pos != 0 && index_pos <= file_len && index_pos >= bag.data_start;
            if !usable {
                bag.salvage(format!(
                    "index_pos {index_pos} in the bag header does not point into the file \
                     ({file_len} bytes)"
                ));
                return Ok(bag);
            }
            bag.index_pos = index_pos;
            if let Err(e) = bag.read_index(conn_count, chunk_count) {
                bag.salvage(format!("the index is unusable: {e}"));
            }
            return Ok(bag);
        }
        if index_pos == 0 {
            return Err(BagError::NotIndexed { at: header.at });
        }
        if index_pos > file_len {
            return Err(BagError::IndexPastEnd {
                index_pos,
                file_len,
            });
        }
        if index_pos < bag.data_start {
            return Err(header.corrupt(format!(
                "index_pos {index_pos} points inside the bag header (which ends at byte {})",
                bag.data_start
            )));
        }
        bag.index_pos = index_pos;
        bag.read_index(conn_count, chunk_count)?;
        Ok(bag)
    }

    /// Connections by id, from the index (and any met while reading messages).
    pub fn connections(&self) -> impl Iterator<Item = &Connection> {
        self.connections.values().map(|c| c.as_ref())
    }

    /// Chunk summaries from the index, in file order.
    pub fn chunk_infos(&self) -> &[ChunkInfo] {
        &self.chunk_infos
    }

    /// Topic names, sorted, without repeats.
    pub fn topics(&self) -> Vec<&str> {
        let mut topics: Vec<&str> = self.connections().map(|c| c.topic.as_str()).collect();
        topics.sort_unstable();
        topics.dedup();
        topics
    }

    /// Number of messages on `topic` according to the index.
    pub fn message_count(&self, topic: &str) -> u64 {
        self.chunk_infos
            .iter()
            .flat_map(|ci| ci.message_counts.iter())
            .filter(|(conn, _)| self.connections.get(conn).is_some_and(|c| c.topic == topic))
            .map(|&(_, n)| u64::from(n))
            .sum()
    }

    /// Size of the bag in bytes.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// All messages, in the order they are stored in the file (chunk by chunk, and in
    /// each chunk in the order written: the recording order).
    pub fn messages(&mut self) -> Messages<'_, R> {
        let pos = self.data_start;
        Messages {
            bag: self,
            pos,
            chunk: None,
            topics: None,
            done: false,
            skipped: Skips::default(),
            cut: None,
        }
    }

    /// The messages of the given topics decoded as `M`; messages that do not decode
    /// are skipped and counted ([`Decoded::bad_count`]).
    pub fn decoded<M: RosMessage>(&mut self, topics: &[&str]) -> Decoded<'_, R, M> {
        Decoded::new(self.messages().only_topics(topics))
    }

    fn io_error(at: u64) -> impl FnOnce(std::io::Error) -> BagError {
        move |source| BagError::Io {
            at: Location::File(at),
            source,
        }
    }

    /// Reads `len` bytes at `pos`; the caller has checked they are inside the file.
    fn read_at(&mut self, pos: u64, len: u64) -> Result<Vec<u8>, BagError> {
        self.reader
            .seek(SeekFrom::Start(pos))
            .map_err(Self::io_error(pos))?;
        let mut buf = Vec::new();
        (&mut self.reader)
            .take(len)
            .read_to_end(&mut buf)
            .map_err(Self::io_error(pos))?;
        if (buf.len() as u64) < len {
            // The file shrank while we read it.
            return Err(BagError::Truncated {
                record: "record",
                at: Location::File(pos),
                needed: len,
                available: buf.len() as u64,
            });
        }
        Ok(buf)
    }

    /// Reads the framing and header of the record at `at`, which must end by `end`.
    fn read_record(&mut self, at: u64, end: u64) -> Result<OuterRecord, BagError> {
        let available = end.saturating_sub(at);
        let truncated = |record, needed| BagError::Truncated {
            record,
            at: Location::File(at),
            needed,
            available,
        };
        if available < 4 {
            return Err(truncated("record", 4));
        }
        let len_bytes = self.read_at(at, 4)?;
        let header_len = u64::from(u32::from_le_bytes([
            len_bytes[0],
            len_bytes[1],
            len_bytes[2],
            len_bytes[3],
        ]));
        if available < 4 + header_len + 4 {
            return Err(truncated("record", 4 + header_len + 4));
        }
        let mut header = self.read_at(at + 4, header_len + 4)?;
        let data_len_bytes = header.split_off(header_len as usize);
        let fields = Fields::parse(&header).map_err(|problem| BagError::Corrupt {
            record: "record",
            at: Location::File(at),
            problem,
        })?;
        let op = fields.op().map_err(|problem| BagError::Corrupt {
            record: "record",
            at: Location::File(at),
            problem,
        })?;
        let data_len = u64::from(u32::from_le_bytes([
            data_len_bytes[0],
            data_len_bytes[1],
            data_len_bytes[2],
            data_len_bytes[3],
        ]));
        let needed = 4 + header_len + 4 + data_len;
        if available < needed {
            return Err(truncated(op.name(), needed));
        }
        Ok(OuterRecord {
            at,
            op,
            fields,
            data_at: at + 4 + header_len + 4,
            data_len,
        })
    }

    /// The data bytes present of an uncompressed chunk record at `at` that the end of
    /// the file cuts; `None` when the record is not such a chunk or its header is cut.
    fn read_cut_chunk(&mut self, at: u64) -> Result<Option<Vec<u8>>, BagError> {
        let end = self.file_len;
        if end.saturating_sub(at) < 4 {
            return Ok(None);
        }
        let len = self.read_at(at, 4)?;
        let header_len = u64::from(u32::from_le_bytes([len[0], len[1], len[2], len[3]]));
        let data_at = at + 4 + header_len + 4;
        if data_at > end {
            return Ok(None);
        }
        let header = self.read_at(at + 4, header_len)?;
        let Ok(fields) = Fields::parse(&header) else {
            return Ok(None);
        };
        let is_plain_chunk = fields.op().ok() == Some(Op::Chunk)
            && fields.get("compression") == Some(b"none".as_slice());
        if !is_plain_chunk {
            return Ok(None);
        }
        self.read_at(data_at, end - data_at).map(Some)
    }

    /// Reads the connection and chunk info records from `index_pos` to the end.
    fn read_index(&mut self, conn_count: u32, chunk_count: u32) -> Result<(), BagError> {
        let mut pos = self.index_pos;
        let mut connections = 0u32;
        while pos < self.file_len {
            let rec = self.read_record(pos, self.file_len)?;
            match rec.op {
                Op::Connection => {
                    let data = self.read_at(rec.data_at, rec.data_len)?;
                    let conn = parse_connection(&rec.fields, &data).map_err(|e| rec.corrupt(e))?;
                    self.connections.insert(conn.id, Arc::new(conn));
                    connections += 1;
                }
                Op::ChunkInfo => {
                    let data = self.read_at(rec.data_at, rec.data_len)?;
                    let info = parse_chunk_info(&rec.fields, &data).map_err(|e| rec.corrupt(e))?;
                    self.chunk_infos.push(info);
                }
                other => {
                    return Err(rec.corrupt(format!(
                        "a {} in the index section (after index_pos {}), where only \
                         connection and chunk info records belong",
                        other.name(),
                        self.index_pos
                    )));
                }
            }
            pos = rec.end();
        }
        if connections != conn_count || self.chunk_infos.len() as u64 != u64::from(chunk_count) {
            return Err(BagError::Corrupt {
                record: "bag header record",
                at: Location::File(MAGIC.len() as u64),
                problem: format!(
                    "it promises {conn_count} connections and {chunk_count} chunks but the index \
                     at byte {} holds {connections} and {}",
                    self.index_pos,
                    self.chunk_infos.len()
                ),
            });
        }
        for info in &self.chunk_infos {
            if info.chunk_pos < self.data_start || info.chunk_pos >= self.index_pos {
                return Err(BagError::Corrupt {
                    record: "chunk info record",
                    at: Location::File(self.index_pos),
                    problem: format!(
                        "chunk_pos {} lies outside the data section (bytes {}..{})",
                        info.chunk_pos, self.data_start, self.index_pos
                    ),
                });
            }
        }
        Ok(())
    }

    /// Reads and decompresses the chunk record `rec`.
    fn read_chunk(&mut self, rec: &OuterRecord) -> Result<Vec<u8>, BagError> {
        let compression = rec
            .fields
            .string("compression")
            .map_err(|e| rec.corrupt(e))?;
        let size = u64::from(rec.fields.u32("size").map_err(|e| rec.corrupt(e))?);
        if compression != "none" {
            // Checked before anything is read or decompressed: a bomb costs nothing.
            crate::limits::check_chunk_size(size, rec.data_len).map_err(|problem| {
                BagError::Decompress {
                    at: rec.at,
                    compression: compression.clone(),
                    problem,
                }
            })?;
        }
        let stored = self.read_at(rec.data_at, rec.data_len)?;
        let decompress_error = |problem: String| BagError::Decompress {
            at: rec.at,
            compression: compression.clone(),
            problem,
        };
        let data = match compression.as_str() {
            "none" => stored,
            // One byte past the declared size is read so that a longer chunk is caught.
            "bz2" => read_at_most(bzip2::read::BzDecoder::new(stored.as_slice()), size + 1)
                .map_err(|e| decompress_error(e.to_string()))?,
            "lz4" => read_at_most(
                lz4_flex::frame::FrameDecoder::new(stored.as_slice()),
                size + 1,
            )
            .map_err(|e| decompress_error(e.to_string()))?,
            _ => {
                return Err(BagError::UnsupportedCompression {
                    at: rec.at,
                    compression,
                });
            }
        };
        if data.len() as u64 != size {
            return Err(decompress_error(format!(
                "the header promises {size} bytes of records, the data holds {}{}",
                data.len(),
                if data.len() as u64 > size {
                    " or more"
                } else {
                    ""
                }
            )));
        }
        Ok(data)
    }
}

fn parse_connection(fields: &Fields, data: &[u8]) -> Result<Connection, String> {
    let id = fields.u32("conn")?;
    let topic = fields.string("topic")?;
    let inner = Fields::parse(data).map_err(|e| format!("connection data: {e}"))?;
    let msg_type = inner.string("type")?;
    let md5sum = inner.string("md5sum")?;
    let message_definition = inner.string("message_definition")?;
    let callerid = inner
        .get("callerid")
        .map(|v| String::from_utf8_lossy(v).into_owned());
    let latching = inner.get("latching").is_some_and(|v| v == b"1");
    Ok(Connection {
        id,
        topic,
        msg_type,
        md5sum,
        message_definition,
        callerid,
        latching,
    })
}

fn parse_chunk_info(fields: &Fields, data: &[u8]) -> Result<ChunkInfo, String> {
    let ver = fields.u32("ver")?;
    if ver != 1 {
        return Err(format!(
            "chunk info version {ver}, this reader knows version 1"
        ));
    }
    let chunk_pos = fields.u64("chunk_pos")?;
    let start_time = fields.time("start_time")?;
    let end_time = fields.time("end_time")?;
    let count = fields.u32("count")? as usize;
    if data.len() != count.saturating_mul(8) {
        return Err(format!(
            "{count} connections need {} bytes of counts, the record holds {}",
            count.saturating_mul(8),
            data.len()
        ));
    }
    let message_counts = data
        .chunks_exact(8)
        .map(|c| {
            (
                u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                u32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            )
        })
        .collect();
    Ok(ChunkInfo {
        chunk_pos,
        start_time,
        end_time,
        message_counts,
    })
}

/// A decompressed chunk being walked.
struct OpenChunk {
    at: u64,
    data: Vec<u8>,
    pos: usize,
    /// The chunk was cut by the end of the file: its last record may be incomplete.
    cut: bool,
}

/// What an inner record turned out to be.
enum Inner {
    Message(RawMessage),
    Other,
}

/// The messages of a bag in file order; see [`Bag::messages`].
///
/// Yields `Err` once and then stops when the bag turns out to be damaged; message
/// records that cannot be attributed to a connection are skipped and counted
/// ([`Messages::skipped`]).
pub struct Messages<'a, R> {
    bag: &'a mut Bag<R>,
    pos: u64,
    chunk: Option<OpenChunk>,
    topics: Option<Vec<String>>,
    done: bool,
    skipped: Skips<SkippedRecord>,
    cut: Option<CutShort>,
}

impl<R: Read + Seek> Messages<'_, R> {
    /// Keeps only the messages of these topics (the others are not even copied).
    pub fn only_topics(mut self, topics: &[&str]) -> Self {
        self.topics = Some(topics.iter().map(|t| t.to_string()).collect());
        self
    }

    /// Message records skipped so far (the first hundred, with reasons).
    pub fn skipped(&self) -> &[SkippedRecord] {
        self.skipped.kept()
    }

    /// Number of message records skipped so far.
    pub fn skipped_count(&self) -> usize {
        self.skipped.count()
    }

    /// Where the walk stopped because the file ends inside a record (only a bag opened
    /// with [`Bag::from_reader_salvaging`] is walked up to such a cut; a strictly
    /// opened bag gives an error instead). `None` while the walk has met no cut.
    pub fn cut(&self) -> Option<&CutShort> {
        self.cut.as_ref()
    }

    fn wanted(&self, topic: &str) -> bool {
        self.topics
            .as_ref()
            .is_none_or(|ts| ts.iter().any(|t| t == topic))
    }

    fn skip(&mut self, at: Location, reason: String) {
        self.skipped.record(SkippedRecord { at, reason });
    }

    /// Turns a message record's header and data into a message, or skips it.
    fn message(&mut self, fields: &Fields, at: Location, data: &[u8]) -> Inner {
        let conn = match fields.u32("conn") {
            Ok(c) => c,
            Err(e) => {
                self.skip(at, e);
                return Inner::Other;
            }
        };
        let time = match fields.time("time") {
            Ok(t) => t,
            Err(e) => {
                self.skip(at, e);
                return Inner::Other;
            }
        };
        let Some(connection) = self.bag.connections.get(&conn).cloned() else {
            self.skip(
                at,
                format!("message refers to connection {conn}, which the bag never defines"),
            );
            return Inner::Other;
        };
        if !self.wanted(&connection.topic) {
            return Inner::Other;
        }
        Inner::Message(RawMessage {
            connection,
            time,
            at,
            data: data.to_vec(),
        })
    }

    /// Registers a connection record met in the data section.
    fn connection(&mut self, fields: &Fields, data: &[u8], at: Location) -> Result<(), BagError> {
        let conn = parse_connection(fields, data).map_err(|problem| BagError::Corrupt {
            record: "connection record",
            at,
            problem,
        })?;
        if let Some(known) = self.bag.connections.get(&conn.id) {
            if known.topic != conn.topic || known.msg_type != conn.msg_type {
                return Err(BagError::Corrupt {
                    record: "connection record",
                    at,
                    problem: format!(
                        "connection {} is {} ({}) here but {} ({}) in the index",
                        conn.id, conn.topic, conn.msg_type, known.topic, known.msg_type
                    ),
                });
            }
        } else {
            self.bag.connections.insert(conn.id, Arc::new(conn));
        }
        Ok(())
    }

    /// The next record of the open chunk, if any is left.
    fn next_in_chunk(&mut self) -> Option<Result<Inner, BagError>> {
        let chunk = self.chunk.as_mut()?;
        if chunk.pos >= chunk.data.len() {
            self.chunk = None;
            return Some(Ok(Inner::Other));
        }
        let (chunk_at, start) = (chunk.at, chunk.pos);
        let at = Location::InChunk {
            chunk: chunk_at,
            offset: start as u64,
        };
        let parsed = parse_inner_record(&chunk.data, start, at);
        let (op, fields, data_range) = match parsed {
            Ok(p) => p,
            // The cut itself was counted when the chunk was opened.
            Err(BagError::Truncated { .. }) if chunk.cut => {
                self.chunk = None;
                return Some(Ok(Inner::Other));
            }
            Err(e) => return Some(Err(e)),
        };
        chunk.pos = data_range.end;
        // Move the data out of the borrow of `self.chunk` before calling &mut methods.
        let data = chunk.data[data_range].to_vec();
        Some(match op {
            Op::MessageData => Ok(self.message(&fields, at, &data)),
            Op::Connection => self.connection(&fields, &data, at).map(|()| Inner::Other),
            other => Err(BagError::Corrupt {
                record: other.name(),
                at,
                problem: "only connection and message data records belong inside a chunk".into(),
            }),
        })
    }

    /// Reads the next record of the data section.
    fn next_outer(&mut self) -> Result<Option<Inner>, BagError> {
        if self.pos >= self.bag.index_pos {
            return Ok(None);
        }
        let rec = match self.bag.read_record(self.pos, self.bag.index_pos) {
            Ok(rec) => rec,
            Err(BagError::Truncated {
                record,
                needed,
                available,
                ..
            }) if self.bag.salvaged.is_some() => {
                let at = self.pos;
                self.pos = self.bag.index_pos;
                if let Some(data) = self.bag.read_cut_chunk(at)? {
                    self.chunk = Some(OpenChunk {
                        at,
                        data,
                        pos: 0,
                        cut: true,
                    });
                }
                self.cut = Some(CutShort {
                    record,
                    at: Location::File(at),
                    needed,
                    available,
                });
                return Ok(Some(Inner::Other));
            }
            Err(e) => return Err(e),
        };
        self.pos = rec.end();
        match rec.op {
            Op::Chunk => {
                let data = self.bag.read_chunk(&rec)?;
                self.chunk = Some(OpenChunk {
                    at: rec.at,
                    data,
                    pos: 0,
                    cut: false,
                });
                Ok(Some(Inner::Other))
            }
            Op::IndexData => {
                check_index_data(&rec.fields, rec.data_len).map_err(|e| rec.corrupt(e))?;
                Ok(Some(Inner::Other))
            }
            Op::Connection => {
                let data = self.bag.read_at(rec.data_at, rec.data_len)?;
                self.connection(&rec.fields, &data, Location::File(rec.at))?;
                Ok(Some(Inner::Other))
            }
            Op::MessageData => {
                let data = self.bag.read_at(rec.data_at, rec.data_len)?;
                Ok(Some(self.message(
                    &rec.fields,
                    Location::File(rec.at),
                    &data,
                )))
            }
            // Walking a bag whose index was not used: its index section is passed over.
            Op::ChunkInfo if self.bag.salvaged.is_some() => Ok(Some(Inner::Other)),
            Op::BagHeader | Op::ChunkInfo => Err(rec.corrupt(format!(
                "found in the data section (before index_pos {})",
                self.bag.index_pos
            ))),
        }
    }
}

impl<R: Read + Seek> Iterator for Messages<'_, R> {
    type Item = Result<RawMessage, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        while !self.done {
            let step = match self.next_in_chunk() {
                Some(step) => step,
                None => match self.next_outer() {
                    Ok(Some(inner)) => Ok(inner),
                    Ok(None) => {
                        self.done = true;
                        return None;
                    }
                    Err(e) => Err(e),
                },
            };
            match step {
                Ok(Inner::Message(m)) => return Some(Ok(m)),
                Ok(Inner::Other) => {}
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            }
        }
        None
    }
}

/// Splits the record at `start` of a chunk's data into op, fields and data range.
fn parse_inner_record(
    data: &[u8],
    start: usize,
    at: Location,
) -> Result<(Op, Fields, std::ops::Range<usize>), BagError> {
    let available = (data.len() - start) as u64;
    let truncated = |record, needed| BagError::Truncated {
        record,
        at,
        needed,
        available,
    };
    let read_u32 = |pos: usize| -> Option<u64> {
        let b = data.get(pos..pos.checked_add(4)?)?;
        Some(u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
    };
    let header_len = read_u32(start).ok_or_else(|| truncated("record", 4))?;
    let header_end = start as u64 + 4 + header_len;
    if header_end + 4 > data.len() as u64 {
        return Err(truncated("record", 4 + header_len + 4));
    }
    let header_end = header_end as usize;
    let corrupt = |problem| BagError::Corrupt {
        record: "record",
        at,
        problem,
    };
    let fields = Fields::parse(&data[start + 4..header_end]).map_err(corrupt)?;
    let op = fields.op().map_err(corrupt)?;
    let data_len = read_u32(header_end).ok_or_else(|| truncated(op.name(), 4 + header_len + 4))?;
    let data_start = header_end + 4;
    let data_end = data_start as u64 + data_len;
    if data_end > data.len() as u64 {
        return Err(truncated(op.name(), 4 + header_len + 4 + data_len));
    }
    Ok((op, fields, data_start..data_end as usize))
}

/// Checks an index data record's header against its data length.
fn check_index_data(fields: &Fields, data_len: u64) -> Result<(), String> {
    let ver = fields.u32("ver")?;
    if ver != 1 {
        return Err(format!(
            "index data version {ver}, this reader knows version 1"
        ));
    }
    fields.u32("conn")?;
    let count = u64::from(fields.u32("count")?);
    if data_len != count * 12 {
        return Err(format!(
            "{count} entries need {} bytes, the record holds {data_len}",
            count * 12
        ));
    }
    Ok(())
}

/// Everything `reader` gives, but no more than `limit` bytes.
fn read_at_most(reader: impl Read, limit: u64) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    reader.take(limit).read_to_end(&mut out)?;
    Ok(out)
}

#[cfg(test)]
mod tests;
