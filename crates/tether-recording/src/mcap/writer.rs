//! Recording a run as an MCAP file of ROS 2 messages.

use std::collections::BTreeMap;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

use tether_core::Stamp;

use tether_msgs::Ros2Message;
use tether_msgs::cdr::CdrWriter;

use super::error::McapError;

/// Chunk size before compression: about 1 MiB, as `ros2 bag` and the Python writer use.
const CHUNK_BYTES: u64 = 1 << 20;

/// Longest stretch of log time one chunk holds: a message logged this long after the
/// first one of the open chunk closes that chunk first (and flushes the file), so that
/// a recording cut short loses at most about a second. See [`McapWriter::flush`].
pub const MAX_CHUNK_SPAN_NS: u64 = 1_000_000_000;

/// A channel opened by the writer.
#[derive(Debug, Clone, Copy)]
struct OpenChannel {
    id: u16,
    msg_type: &'static str,
    next_sequence: u32,
}

/// Writes ROS 2 messages into an MCAP file with profile `ros2`, schemas in `ros2msg`
/// with full definitions, and `cdr` messages, as `ros2 bag record` does; Foxglove,
/// `ros2 bag`, Python `mcap-ros2-support` and `rosbags` read it.
///
/// One channel per topic, created on its first message. Chunks are stored
/// uncompressed (the `mcap` crate compresses only with its C-backed features, which
/// tether leaves off to keep the build lean), with message and chunk indexes,
/// statistics and CRCs. Each message's log time and publish time are the time given
/// (for messages with a header: its stamp, see [`McapWriter::write_stamped`]).
///
/// A chunk is closed when it reaches its byte size or when it spans
/// [`MAX_CHUNK_SPAN_NS`] of log time, whichever comes first, and the underlying writer
/// is flushed then: a file cut short (a killed recorder, a full disk) holds every
/// message of the chunks closed before the cut, and what reached the file of the one
/// still open, which [`super::McapFile`] reads by a linear scan. The schemas and channels are written in the chunk of their first
/// message. Chunks close on log time only (never on the wall clock), so the same
/// messages always give the same bytes.
///
/// ```no_run
/// use tether_msgs::TwistMsg;
/// use tether_recording::mcap::McapWriter;
/// use tether_core::Stamp;
/// let mut out = McapWriter::create("run.mcap")?;
/// out.write("/cmd_vel", Stamp::from_ns(100_000_000), &TwistMsg::unicycle(0.3, 0.1))?;
/// out.finish()?;
/// # Ok::<(), tether_recording::mcap::McapError>(())
/// ```
pub struct McapWriter<W: Write + Seek> {
    inner: mcap::Writer<W>,
    schemas: HashMap<&'static str, u16>,
    channels: HashMap<String, OpenChannel>,
    scratch: Vec<u8>,
    /// Log time of the first message since the last flush (the open chunk's start).
    chunk_start_ns: Option<u64>,
}

impl McapWriter<BufWriter<File>> {
    /// Creates (or truncates) the file at `path`.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, McapError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| McapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(BufWriter::with_capacity(1 << 16, file))
    }

    /// Creates (or truncates) the file at `path` for a recording of unbounded length:
    /// see [`McapWriter::streaming`].
    pub fn create_streaming(path: impl AsRef<Path>) -> Result<Self, McapError> {
        let path = path.as_ref();
        let file = File::create(path).map_err(|source| McapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::streaming(BufWriter::with_capacity(1 << 16, file))
    }
}

impl<W: Write + Seek> McapWriter<W> {
    /// Starts an MCAP file on `w`, with chunks of about 1 MiB.
    pub fn new(w: W) -> Result<Self, McapError> {
        Self::with_chunk_size(w, CHUNK_BYTES)
    }

    /// Starts an MCAP file on `w` whose chunks hold about `chunk_bytes` of records
    /// (smaller chunks lose less of a recording cut short, and cost more index).
    pub fn with_chunk_size(w: W, chunk_bytes: u64) -> Result<Self, McapError> {
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("tether ", env!("CARGO_PKG_VERSION")))
            .compression(None)
            .chunk_size(Some(chunk_bytes.max(1)));
        Self::with_options(w, options)
    }

    /// Starts an MCAP file on `w` for a recording of unbounded length (a live run):
    /// messages go straight into the data section, without chunks, and the
    /// underlying writer is flushed at least once a second of log time. A chunked
    /// file keeps an index entry per chunk in memory until it is finished (the `mcap`
    /// crate's, several hundred bytes each: 2-3 MB an hour at a chunk a second); this
    /// one keeps nothing that grows. Readers scan it linearly (tether's, `mcap`'s,
    /// Foxglove); the summary still holds the schemas, channels and statistics.
    pub fn streaming(w: W) -> Result<Self, McapError> {
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("tether ", env!("CARGO_PKG_VERSION")))
            .use_chunks(false);
        Self::with_options(w, options)
    }

    fn with_options(w: W, options: mcap::WriteOptions) -> Result<Self, McapError> {
        Ok(McapWriter {
            inner: options.create(w)?,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            scratch: Vec::new(),
            chunk_start_ns: None,
        })
    }

    /// Writes `msg` on `topic` with log and publish time `log_time`.
    pub fn write<M: Ros2Message>(
        &mut self,
        topic: &str,
        log_time: Stamp,
        msg: &M,
    ) -> Result<(), McapError> {
        let log_ns = u64::try_from(log_time.ns()).map_err(|_| McapError::NegativeLogTime {
            topic: topic.to_owned(),
            stamp: log_time,
        })?;
        match self.chunk_start_ns {
            Some(start) if start.abs_diff(log_ns) >= MAX_CHUNK_SPAN_NS => self.flush()?,
            _ => {}
        }
        let channel = self.channel::<M>(topic)?;
        let mut w = CdrWriter::reusing(std::mem::take(&mut self.scratch));
        msg.write_cdr(&mut w).map_err(|source| McapError::Encode {
            topic: topic.to_owned(),
            msg_type: M::TYPE,
            source,
        })?;
        let bytes = w.into_bytes();
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            sequence: channel.next_sequence,
            log_time: log_ns,
            publish_time: log_ns,
        };
        let result = self.inner.write_to_known_channel(&header, &bytes);
        self.scratch = bytes;
        if let Some(c) = self.channels.get_mut(topic) {
            c.next_sequence = c.next_sequence.wrapping_add(1);
        }
        result?;
        self.chunk_start_ns.get_or_insert(log_ns);
        Ok(())
    }

    /// Closes the open chunk (with its message indexes) and flushes the underlying
    /// writer: everything written so far is then readable from the file even if the
    /// program dies before [`McapWriter::finish`]. [`McapWriter::write`] calls it when
    /// the open chunk spans [`MAX_CHUNK_SPAN_NS`] of log time.
    pub fn flush(&mut self) -> Result<(), McapError> {
        self.chunk_start_ns = None;
        Ok(self.inner.flush()?)
    }

    /// Writes a message that has a header, with its header stamp as log time.
    pub fn write_stamped<M: Ros2Message>(&mut self, topic: &str, msg: &M) -> Result<(), McapError> {
        let stamp = msg
            .header_stamp()
            .ok_or(McapError::NoHeader { msg_type: M::TYPE })?;
        self.write(topic, stamp, msg)
    }

    fn channel<M: Ros2Message>(&mut self, topic: &str) -> Result<OpenChannel, McapError> {
        if let Some(c) = self.channels.get(topic) {
            if c.msg_type != M::TYPE {
                return Err(McapError::TopicTypeConflict {
                    topic: topic.to_owned(),
                    existing: c.msg_type,
                    new: M::TYPE,
                });
            }
            return Ok(*c);
        }
        let schema_id = match self.schemas.get(M::TYPE) {
            Some(&id) => id,
            None => {
                let id = self
                    .inner
                    .add_schema(M::TYPE, "ros2msg", M::DEFINITION.as_bytes())?;
                self.schemas.insert(M::TYPE, id);
                id
            }
        };
        let id = self
            .inner
            .add_channel(schema_id, topic, "cdr", &BTreeMap::new())?;
        let c = OpenChannel {
            id,
            msg_type: M::TYPE,
            next_sequence: 0,
        };
        self.channels.insert(topic.to_owned(), c);
        Ok(c)
    }

    /// Writes the summary and footer, flushes, and returns the underlying writer.
    pub fn finish(mut self) -> Result<W, McapError> {
        self.inner.finish()?;
        let mut w = self.inner.into_inner();
        w.flush().map_err(mcap::McapError::from)?;
        Ok(w)
    }
}
