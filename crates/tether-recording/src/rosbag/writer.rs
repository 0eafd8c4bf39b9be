//! Writing ROS 1 bags (format 2.0), as `rosbag record` writes them uncompressed.
//!
//! Layout: the magic line; a bag header record padded to 4,096 bytes (rewritten at the
//! end with the index position); chunks of connection and message data records
//! (compression `none`), each followed by one index data record (version 1) per
//! connection in it; then the index section: one connection record per connection and
//! one chunk info record (version 1) per chunk. Every chunk carries the connection
//! record of each connection it holds messages of, so that the chunks before a cut
//! still read when a bag is cut short.
//!
//! A connection record names the topic, the type, the MD5 sum and the full message
//! definition ([`RosMessageOut::DEFINITION`]); the MD5 sum is computed from that text
//! ([`super::definition_md5`]), never copied.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use tether_core::{NS_PER_S, Stamp};
use thiserror::Error;

use tether_msgs::{DefinitionError, RosMessageOut, definition_md5};

use super::record::{MAGIC, field};

/// Bytes the bag header record takes, padding included (as rosbag reserves).
const HEADER_RECORD_LEN: usize = 4096;

/// Uncompressed chunk size after which a chunk is closed (rosbag's default, 768 KiB).
pub const DEFAULT_CHUNK_BYTES: usize = 768 * 1024;

/// Why a bag could not be written.
#[derive(Debug, Error)]
pub enum BagWriteError {
    /// The file could not be created.
    #[error("cannot create bag {path}: {source}")]
    Create {
        /// The path given.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// Writing failed.
    #[error("cannot write the bag: {0}")]
    Io(#[from] std::io::Error),
    /// A record time ROS 1 cannot hold (`sec` and `nsec` are `u32`).
    #[error("time {0} is outside what a ROS 1 bag can store (1970 to 2106)")]
    TimeOutOfRange(Stamp),
    /// A message was written on a connection this writer did not open.
    #[error("connection {0} was not added to this bag")]
    UnknownConnection(u32),
    /// A record longer than the format's 4 GiB.
    #[error("a {what} of {len} bytes is longer than a bag record can be")]
    TooLong {
        /// What was being written.
        what: &'static str,
        /// Its length.
        len: usize,
    },
    /// The message definition does not give an MD5 sum.
    #[error("definition of {msg_type}: {source}")]
    Definition {
        /// The message type.
        msg_type: String,
        /// What is wrong with it.
        source: DefinitionError,
    },
}

/// A connection as written.
#[derive(Debug, Clone)]
struct WriterConnection {
    topic: String,
    msg_type: String,
    md5sum: String,
    definition: String,
}

/// A chunk being filled.
#[derive(Debug, Default)]
struct OpenChunk {
    data: Vec<u8>,
    /// Per connection: (record time, offset of the message record in `data`).
    index: BTreeMap<u32, Vec<(Stamp, u32)>>,
    start: Option<Stamp>,
    end: Option<Stamp>,
}

/// What the index section says of a written chunk.
#[derive(Debug, Clone)]
struct WrittenChunk {
    pos: u64,
    start: Stamp,
    end: Stamp,
    counts: Vec<(u32, u32)>,
}

/// A handle on a connection of a [`BagWriter`], for [`BagWriter::write`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ConnectionId(u32);

/// Writes a ROS 1 bag (format 2.0, uncompressed chunks, indexed).
///
/// ```no_run
/// use tether_msgs::{Header, PoseArrayMsg};
/// use tether_recording::rosbag::BagWriter;
/// use tether_core::Stamp;
/// let mut bag = BagWriter::create("out.bag")?;
/// let labels = bag.add_connection::<PoseArrayMsg>("/labels")?;
/// let msg = PoseArrayMsg {
///     header: Header { seq: 0, stamp: Stamp::from_ns(1_000_000_000), frame_id: "laser".into() },
///     poses: vec![],
/// };
/// bag.write(labels, msg.header.stamp, &msg)?;
/// bag.finish()?;
/// # Ok::<(), tether_recording::rosbag::BagWriteError>(())
/// ```
#[derive(Debug)]
pub struct BagWriter<W: Write + Seek> {
    out: W,
    pos: u64,
    connections: Vec<WriterConnection>,
    chunk: OpenChunk,
    chunks: Vec<WrittenChunk>,
    chunk_bytes: usize,
    scratch: Vec<u8>,
}

/// A ROS time as a bag stores it: `sec: u32, nsec: u32`.
pub(super) fn time_bytes(t: Stamp) -> Result<[u8; 8], BagWriteError> {
    let ns = t.ns();
    if ns < 0 || ns / NS_PER_S > i64::from(u32::MAX) {
        return Err(BagWriteError::TimeOutOfRange(t));
    }
    let mut b = [0u8; 8];
    b[..4].copy_from_slice(&((ns / NS_PER_S) as u32).to_le_bytes());
    b[4..].copy_from_slice(&((ns % NS_PER_S) as u32).to_le_bytes());
    Ok(b)
}

fn len_u32(what: &'static str, len: usize) -> Result<u32, BagWriteError> {
    u32::try_from(len).map_err(|_| BagWriteError::TooLong { what, len })
}

/// Appends a record: header length, header, data length, data.
/// The bag header record (`op` 0x03) pointing at the index, padded with spaces to
/// [`HEADER_RECORD_LEN`] bytes as `rosbag record` writes it.
pub(super) fn bag_header_record(
    index_pos: u64,
    conn_count: u32,
    chunk_count: u32,
) -> Result<Vec<u8>, BagWriteError> {
    let mut h = Vec::new();
    field(&mut h, "op", &[0x03]);
    field(&mut h, "index_pos", &index_pos.to_le_bytes());
    field(&mut h, "conn_count", &conn_count.to_le_bytes());
    field(&mut h, "chunk_count", &chunk_count.to_le_bytes());
    let mut header = Vec::with_capacity(HEADER_RECORD_LEN);
    let padding = HEADER_RECORD_LEN - 4 - h.len() - 4;
    record(&mut header, &h, &vec![b' '; padding])?;
    Ok(header)
}

pub(super) fn record(out: &mut Vec<u8>, header: &[u8], data: &[u8]) -> Result<(), BagWriteError> {
    out.extend(len_u32("record header", header.len())?.to_le_bytes());
    out.extend(header);
    out.extend(len_u32("record", data.len())?.to_le_bytes());
    out.extend(data);
    Ok(())
}

impl BagWriter<BufWriter<File>> {
    /// Creates (or truncates) the bag at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, BagWriteError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| BagWriteError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        BagWriter::new(BufWriter::with_capacity(1 << 16, file))
    }
}

impl<W: Write + Seek> BagWriter<W> {
    /// Starts a bag on `out`, which must be empty and at its start: the magic line and
    /// room for the bag header.
    pub fn new(mut out: W) -> Result<Self, BagWriteError> {
        out.write_all(MAGIC)?;
        out.write_all(&[0u8; HEADER_RECORD_LEN])?;
        Ok(BagWriter {
            out,
            pos: (MAGIC.len() + HEADER_RECORD_LEN) as u64,
            connections: Vec::new(),
            chunk: OpenChunk::default(),
            chunks: Vec::new(),
            chunk_bytes: DEFAULT_CHUNK_BYTES,
            scratch: Vec::new(),
        })
    }

    /// Closes a chunk once its records reach `bytes` (at least one message a chunk).
    pub fn with_chunk_bytes(mut self, bytes: usize) -> Self {
        self.chunk_bytes = bytes.max(1);
        self
    }

    /// Adds a connection publishing `M` on `topic`; its MD5 sum is computed from
    /// [`RosMessageOut::DEFINITION`].
    pub fn add_connection<M: RosMessageOut>(
        &mut self,
        topic: &str,
    ) -> Result<ConnectionId, BagWriteError> {
        let md5sum =
            definition_md5(M::TYPE, M::DEFINITION).map_err(|source| BagWriteError::Definition {
                msg_type: M::TYPE.to_string(),
                source,
            })?;
        let id = len_u32("connection table", self.connections.len())?;
        self.connections.push(WriterConnection {
            topic: topic.to_string(),
            msg_type: M::TYPE.to_string(),
            md5sum,
            definition: M::DEFINITION.to_string(),
        });
        Ok(ConnectionId(id))
    }

    fn connection_record(&self, id: u32, out: &mut Vec<u8>) -> Result<(), BagWriteError> {
        let c = &self.connections[id as usize];
        let mut h = Vec::new();
        field(&mut h, "op", &[0x07]);
        field(&mut h, "conn", &id.to_le_bytes());
        field(&mut h, "topic", c.topic.as_bytes());
        let mut d = Vec::new();
        field(&mut d, "topic", c.topic.as_bytes());
        field(&mut d, "type", c.msg_type.as_bytes());
        field(&mut d, "md5sum", c.md5sum.as_bytes());
        field(&mut d, "message_definition", c.definition.as_bytes());
        record(out, &h, &d)
    }

    /// Writes `message` on connection `conn` with record time `time` (when the
    /// recorder received it; bag readers order and index by it).
    pub fn write<M: RosMessageOut>(
        &mut self,
        conn: ConnectionId,
        time: Stamp,
        message: &M,
    ) -> Result<(), BagWriteError> {
        let mut data = std::mem::take(&mut self.scratch);
        data.clear();
        message.encode(&mut data);
        let result = self.write_raw(conn, time, &data);
        self.scratch = data;
        result
    }

    /// Writes an already serialised message.
    pub fn write_raw(
        &mut self,
        conn: ConnectionId,
        time: Stamp,
        data: &[u8],
    ) -> Result<(), BagWriteError> {
        let id = conn.0;
        if id as usize >= self.connections.len() {
            return Err(BagWriteError::UnknownConnection(id));
        }
        let t = time_bytes(time)?;
        if !self.chunk.index.contains_key(&id) {
            let mut rec = Vec::new();
            self.connection_record(id, &mut rec)?;
            self.chunk.data.extend(rec);
        }
        let offset = len_u32("chunk", self.chunk.data.len())?;
        let mut h = Vec::new();
        field(&mut h, "op", &[0x02]);
        field(&mut h, "conn", &id.to_le_bytes());
        field(&mut h, "time", &t);
        record(&mut self.chunk.data, &h, data)?;
        self.chunk.index.entry(id).or_default().push((time, offset));
        self.chunk.start = Some(self.chunk.start.map_or(time, |s| s.min(time)));
        self.chunk.end = Some(self.chunk.end.map_or(time, |e| e.max(time)));
        if self.chunk.data.len() >= self.chunk_bytes {
            self.close_chunk()?;
        }
        Ok(())
    }

    /// Writes the open chunk and its index data records.
    fn close_chunk(&mut self) -> Result<(), BagWriteError> {
        let chunk = std::mem::take(&mut self.chunk);
        let (Some(start), Some(end)) = (chunk.start, chunk.end) else {
            return Ok(());
        };
        let mut out = Vec::with_capacity(chunk.data.len() + 256);
        let mut h = Vec::new();
        field(&mut h, "op", &[0x05]);
        field(&mut h, "compression", b"none");
        field(
            &mut h,
            "size",
            &len_u32("chunk", chunk.data.len())?.to_le_bytes(),
        );
        record(&mut out, &h, &chunk.data)?;
        let mut counts = Vec::new();
        for (conn, entries) in &chunk.index {
            let mut h = Vec::new();
            field(&mut h, "op", &[0x04]);
            field(&mut h, "ver", &1u32.to_le_bytes());
            field(&mut h, "conn", &conn.to_le_bytes());
            let count = len_u32("index", entries.len())?;
            field(&mut h, "count", &count.to_le_bytes());
            let mut d = Vec::with_capacity(entries.len() * 12);
            for (t, off) in entries {
                d.extend(time_bytes(*t)?);
                d.extend(off.to_le_bytes());
            }
            record(&mut out, &h, &d)?;
            counts.push((*conn, count));
        }
        self.out.write_all(&out)?;
        self.chunks.push(WrittenChunk {
            pos: self.pos,
            start,
            end,
            counts,
        });
        self.pos += out.len() as u64;
        Ok(())
    }

    /// Closes the last chunk, writes the index and the bag header, flushes, and gives
    /// the output back.
    pub fn finish(mut self) -> Result<W, BagWriteError> {
        self.close_chunk()?;
        let index_pos = self.pos;
        let mut out = Vec::new();
        for id in 0..self.connections.len() as u32 {
            self.connection_record(id, &mut out)?;
        }
        for c in &self.chunks {
            let mut h = Vec::new();
            field(&mut h, "op", &[0x06]);
            field(&mut h, "ver", &1u32.to_le_bytes());
            field(&mut h, "chunk_pos", &c.pos.to_le_bytes());
            field(&mut h, "start_time", &time_bytes(c.start)?);
            field(&mut h, "end_time", &time_bytes(c.end)?);
            field(
                &mut h,
                "count",
                &len_u32("chunk info", c.counts.len())?.to_le_bytes(),
            );
            let mut d = Vec::new();
            for (conn, n) in &c.counts {
                d.extend(conn.to_le_bytes());
                d.extend(n.to_le_bytes());
            }
            record(&mut out, &h, &d)?;
        }
        self.out.write_all(&out)?;
        let header = bag_header_record(
            index_pos,
            len_u32("connections", self.connections.len())?,
            len_u32("chunks", self.chunks.len())?,
        )?;
        self.out.seek(SeekFrom::Start(MAGIC.len() as u64))?;
        self.out.write_all(&header)?;
        self.out.seek(SeekFrom::End(0))?;
        self.out.flush()?;
        Ok(self.out)
    }
}
