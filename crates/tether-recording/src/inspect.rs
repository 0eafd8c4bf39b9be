//! What a recording (a ROS 1 bag or an MCAP file) holds, topic by topic: message type,
//! count, times, the frame ids of the headers and, for laser scans, the scan geometry;
//! and for the whole file its format, size and whether it was read whole. What `tether
//! info` prints.
//!
//! The messages are walked once, in file order; of each message only what is needed is
//! decoded: the frame id of its header (when its type starts with one) and, for the
//! first scan of a scan topic that decodes, the scan itself.
//!
//! A recording cut short (a killed recorder, an interrupted copy) is read up to the
//! cut, as every command reads it, and said to be so. A file whose structure is damaged
//! part way is described up to the damage ([`ReadState::error`]).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use anyhow::Context;
use tether_core::Stamp;
use tether_msgs::RosMessage;

use crate::mcap::{self, McapFile};
use crate::rosbag::Bag;
use crate::sniff::{Kind, sniff};

/// Message types of laser scans, in both spellings.
pub const SCAN_TYPES: &[&str] = &["sensor_msgs/LaserScan", "sensor_msgs/msg/LaserScan"];

/// Distinct frame ids kept per topic.
pub const MAX_FRAMES: usize = 4;

/// The recording's format.
#[derive(Debug, Clone)]
pub enum Format {
    /// A ROS 1 bag: chunks listed in its index (0 when the index was not used).
    Bag {
        /// Chunks.
        chunks: usize,
    },
    /// An MCAP file: its header's profile and the library that wrote it.
    Mcap {
        /// Profile (`ros2` for ROS 2 recordings).
        profile: String,
        /// Writer library.
        library: String,
    },
}

/// How the recording was read.
#[derive(Debug, Clone, Default)]
pub struct ReadState {
    /// Why the index (bag) or summary (MCAP) was not used.
    pub index_unused: Option<String>,
    /// Where the file ends inside a record.
    pub cut: Option<String>,
    /// The damage that ended the walk.
    pub error: Option<String>,
    /// Message records on no known connection or channel.
    pub unattributed: usize,
}

impl ReadState {
    /// `whole`, `salvaged` (no usable index or summary: walked), `cut_short` or `damaged`.
    pub fn status(&self) -> &'static str {
        if self.error.is_some() {
            "damaged"
        } else if self.cut.is_some() {
            "cut_short"
        } else if self.index_unused.is_some() {
            "salvaged"
        } else {
            "whole"
        }
    }
}

/// A laser scan's geometry, as its message states it.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanGeometry {
    /// Number of ranges.
    pub beams: usize,
    /// First beam's angle, rad.
    pub angle_min_rad: f64,
    /// Last beam's angle, rad.
    pub angle_max_rad: f64,
    /// Angle between beams, rad.
    pub angle_increment_rad: f64,
    /// Shortest valid range, m.
    pub range_min_m: f64,
    /// Longest valid range, m.
    pub range_max_m: f64,
    /// Time between scans, s.
    pub scan_time_s: f64,
    /// The header's frame id.
    pub frame_id: String,
}

impl ScanGeometry {
    /// The geometry of a scan as either recording holds it (ROS 1 or CDR, decoded to
    /// the same raw form).
    pub fn of(m: &tether_msgs::RawLaserScan) -> Self {
        ScanGeometry {
            beams: m.ranges.len(),
            angle_min_rad: f64::from(m.angle_min),
            angle_max_rad: f64::from(m.angle_max),
            angle_increment_rad: f64::from(m.angle_increment),
            range_min_m: f64::from(m.range_min),
            range_max_m: f64::from(m.range_max),
            scan_time_s: f64::from(m.scan_time),
            frame_id: m.header.frame_id.clone(),
        }
    }

    /// `angle_max - angle_min`, degrees.
    pub fn fov_deg(&self) -> f64 {
        (self.angle_max_rad - self.angle_min_rad).to_degrees()
    }
}

/// What one topic holds.
#[derive(Debug, Clone, Default)]
pub struct TopicInfo {
    /// Distinct message types, in the order met.
    pub types: Vec<String>,
    /// Messages.
    pub count: u64,
    /// Earliest log time.
    pub first: Option<Stamp>,
    /// Latest log time.
    pub last: Option<Stamp>,
    /// Whether the type's definition starts with a `std_msgs/Header`.
    pub has_header: bool,
    /// The first few distinct header frame ids (at most [`MAX_FRAMES`]).
    pub frames: Vec<String>,
    /// More distinct frame ids were seen.
    pub more_frames: bool,
    /// Messages whose header did not decode.
    pub bad_headers: u64,
    /// Whether any of its types is a laser scan.
    pub is_scan: bool,
    /// The first scan that decodes (scan topics).
    pub scan: Option<ScanGeometry>,
    /// Scans that did not decode before the first that did.
    pub bad_scans: u64,
}

impl TopicInfo {
    fn add_type(&mut self, msg_type: &str) {
        if !self.types.iter().any(|t| t == msg_type) {
            self.types.push(msg_type.to_owned());
        }
        self.is_scan |= SCAN_TYPES.contains(&msg_type);
    }

    fn add_time(&mut self, t: Stamp) {
        self.count += 1;
        self.first = Some(self.first.map_or(t, |f| f.min(t)));
        self.last = Some(self.last.map_or(t, |l| l.max(t)));
    }

    fn add_frame(&mut self, frame: Option<String>) {
        match frame {
            None => self.bad_headers += 1,
            Some(f) if self.frames.contains(&f) => {}
            Some(f) if self.frames.len() < MAX_FRAMES => self.frames.push(f),
            Some(_) => self.more_frames = true,
        }
    }

    /// `(count - 1) / (last - first)`; `None` with fewer than two messages or no time
    /// between them.
    pub fn rate_hz(&self) -> Option<f64> {
        let span = self.last?.secs_since(self.first?);
        (self.count >= 2 && span > 0.0).then(|| (self.count - 1) as f64 / span)
    }

    /// The message types, joined by ` | `.
    pub fn type_name(&self) -> String {
        self.types.join(" | ")
    }
}

/// Everything `tether info` says about a recording.
#[derive(Debug, Clone)]
pub struct Info {
    /// The path given.
    pub path: PathBuf,
    /// Bag or MCAP.
    pub format: Format,
    /// Size of the file, bytes.
    pub size: u64,
    /// Every topic, by name.
    pub topics: BTreeMap<String, TopicInfo>,
    /// How the file was read.
    pub read: ReadState,
}

impl Info {
    fn new(path: &Path, format: Format, size: u64) -> Self {
        Info {
            path: path.to_path_buf(),
            format,
            size,
            topics: BTreeMap::new(),
            read: ReadState::default(),
        }
    }

    fn topic(&mut self, topic: &str) -> &mut TopicInfo {
        self.topics.entry(topic.to_owned()).or_default()
    }

    /// Messages read, all topics.
    pub fn messages(&self) -> u64 {
        self.topics.values().map(|t| t.count).sum()
    }

    /// Earliest log time.
    pub fn start(&self) -> Option<Stamp> {
        self.topics.values().filter_map(|t| t.first).min()
    }

    /// Latest log time.
    pub fn end(&self) -> Option<Stamp> {
        self.topics.values().filter_map(|t| t.last).max()
    }

    /// End - start, s.
    pub fn duration_s(&self) -> Option<f64> {
        Some(self.end()?.secs_since(self.start()?))
    }

    /// `ROS 1 bag 2.0` or `MCAP`.
    pub fn format_name(&self) -> &'static str {
        match self.format {
            Format::Bag { .. } => "ROS 1 bag 2.0",
            Format::Mcap { .. } => "MCAP",
        }
    }
}

/// Reads the recording at `path` and gathers what it holds.
pub fn inspect(path: &Path) -> anyhow::Result<Info> {
    let size = std::fs::metadata(path)
        .with_context(|| format!("cannot open {}", path.display()))?
        .len();
    let info = match sniff(path)? {
        Kind::Mcap => read_mcap(path, size)?,
        Kind::Ros1Bag => read_bag(path, size)?,
    };
    if info.messages() == 0 {
        let why = info.read.error.as_deref().or(info.read.cut.as_deref());
        if let Some(why) = why {
            anyhow::bail!(
                "{} holds nothing readable: {why}; no message comes before that",
                path.display()
            );
        }
    }
    Ok(info)
}

/// Whether a message definition's first field is a `std_msgs/Header` (ROS 1 `.msg` or
/// ROS 2 `ros2msg` text): comments, blank lines and constants are passed over.
fn starts_with_header(definition: &str) -> bool {
    for line in definition.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if line.starts_with("===") {
            return false;
        }
        let mut words = line.split_whitespace();
        let (Some(ty), Some(name)) = (words.next(), words.next()) else {
            return false;
        };
        if name.contains('=') || line.contains('=') {
            // A constant, not a field.
            continue;
        }
        return matches!(ty, "Header" | "std_msgs/Header" | "std_msgs/msg/Header");
    }
    false
}

/// The frame id of a ROS 1 serialised message that starts with a header (`uint32 seq`,
/// `time stamp`, `string frame_id`).
fn ros1_frame_id(data: &[u8]) -> Option<String> {
    let len_bytes: [u8; 4] = data.get(12..16)?.try_into().ok()?;
    let len = u32::from_le_bytes(len_bytes) as usize;
    let bytes = data.get(16..16usize.checked_add(len)?)?;
    Some(String::from_utf8_lossy(bytes).into_owned())
}

/// The frame id of a CDR message that starts with a header (after the encapsulation:
/// `int32 sec`, `uint32 nanosec`, `string frame_id`).
fn cdr_frame_id(data: &[u8]) -> Option<String> {
    let mut r = tether_msgs::cdr::CdrReader::new(data).ok()?;
    r.i32("header.stamp.sec").ok()?;
    r.u32("header.stamp.nanosec").ok()?;
    r.string("header.frame_id").ok()
}

/// How the messages of a connection or channel are serialised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Ros1,
    Cdr,
    Other,
}

/// How to read one connection's or channel's messages.
#[derive(Debug, Clone, Copy)]
struct Reading {
    encoding: Encoding,
    has_header: bool,
    is_scan: bool,
}

/// Counts one message and reads what is wanted of it.
fn add_message(
    info: &mut Info,
    topic: &str,
    msg_type: &str,
    reading: Reading,
    t: Stamp,
    data: &[u8],
) {
    let entry = info.topic(topic);
    entry.add_type(msg_type);
    entry.add_time(t);
    entry.has_header |= reading.has_header;
    if reading.has_header {
        let frame = match reading.encoding {
            Encoding::Ros1 => ros1_frame_id(data),
            Encoding::Cdr => cdr_frame_id(data),
            Encoding::Other => return,
        };
        entry.add_frame(frame);
    }
    if reading.is_scan && entry.scan.is_none() {
        let scan = match reading.encoding {
            Encoding::Ros1 => tether_msgs::RawLaserScan::decode(data)
                .ok()
                .map(|m| ScanGeometry::of(&m)),
            Encoding::Cdr => tether_msgs::from_cdr::<tether_msgs::RawLaserScan>(data)
                .ok()
                .map(|m| ScanGeometry::of(&m)),
            Encoding::Other => None,
        };
        match scan {
            Some(s) => entry.scan = Some(s),
            None => entry.bad_scans += 1,
        }
    }
}

/// Adds each of `messages` to `info` with `add`, up to the first that does not read (its
/// error is kept).
fn add_messages<R, E: std::fmt::Display>(
    info: &mut Info,
    messages: impl Iterator<Item = Result<R, E>>,
    mut add: impl FnMut(&mut Info, R),
) {
    for m in messages {
        match m {
            Ok(raw) => add(info, raw),
            Err(e) => {
                info.read.error = Some(e.to_string());
                break;
            }
        }
    }
}

fn read_bag(path: &Path, size: u64) -> anyhow::Result<Info> {
    let mut bag =
        Bag::open_salvaging(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut info = Info::new(
        path,
        Format::Bag {
            chunks: bag.chunk_infos().len(),
        },
        size,
    );
    info.read.index_unused = bag.salvaged().map(str::to_owned);
    let mut readings: HashMap<u32, Reading> = HashMap::new();
    let mut messages = bag.messages();
    add_messages(&mut info, &mut messages, |info, raw| {
        let c = &raw.connection;
        let reading = *readings.entry(c.id).or_insert_with(|| {
            let is_scan = SCAN_TYPES.contains(&c.msg_type.as_str());
            Reading {
                encoding: Encoding::Ros1,
                has_header: is_scan || starts_with_header(&c.message_definition),
                is_scan,
            }
        });
        add_message(info, &c.topic, &c.msg_type, reading, raw.time, &raw.data);
    });
    info.read.cut = messages.cut().map(ToString::to_string);
    info.read.unattributed = messages.skipped_count();
    drop(messages);
    // Connections without messages are topics too.
    for c in bag.connections() {
        info.topic(&c.topic).add_type(&c.msg_type);
    }
    Ok(info)
}

fn read_mcap(path: &Path, size: u64) -> anyhow::Result<Info> {
    let file = McapFile::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut info = Info::new(
        path,
        Format::Mcap {
            profile: file.profile().to_owned(),
            library: file.library().to_owned(),
        },
        size,
    );
    info.read.index_unused = file.salvaged().map(str::to_owned);
    let mut readings: HashMap<u16, Reading> = HashMap::new();
    let mut messages = file.messages();
    add_messages(&mut info, &mut messages, |info, raw| {
        let ch = &raw.channel;
        let reading = *readings.entry(ch.id).or_insert_with(|| channel_reading(ch));
        add_message(
            info,
            &ch.topic,
            ch.type_name(),
            reading,
            raw.log_time,
            &raw.data,
        );
    });
    info.read.cut = messages.cut().map(ToString::to_string);
    info.read.unattributed = messages.skipped_count();
    for ch in file.channels() {
        info.topic(&ch.topic).add_type(ch.type_name());
    }
    Ok(info)
}

/// How an MCAP channel's messages are read: CDR (ROS 2) or ROS 1 serialisation, with a
/// header when the schema's text definition starts with one.
fn channel_reading(ch: &mcap::Channel) -> Reading {
    let encoding = match ch.message_encoding.as_str() {
        "cdr" => Encoding::Cdr,
        "ros1" => Encoding::Ros1,
        _ => Encoding::Other,
    };
    let is_scan = SCAN_TYPES.contains(&ch.type_name()) && encoding != Encoding::Other;
    let text_definition = ch.schema.as_ref().is_some_and(|s| {
        matches!(s.encoding.as_str(), "ros2msg" | "ros1msg")
            && starts_with_header(&String::from_utf8_lossy(&s.data))
    });
    Reading {
        encoding,
        has_header: encoding != Encoding::Other && (is_scan || text_definition),
        is_scan,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_found_in_definitions() {
        assert!(starts_with_header(
            "# comment\n\nHeader header\nfloat32 angle_min\n"
        ));
        assert!(starts_with_header(
            "uint8 FOO=1  # a constant\nstd_msgs/msg/Header header\n"
        ));
        assert!(!starts_with_header(
            "Marker[] markers\n===\nMSG: x\nHeader header\n"
        ));
        assert!(!starts_with_header(
            "geometry_msgs/TransformStamped[] transforms\n"
        ));
        assert!(!starts_with_header(""));
    }

    #[test]
    fn frame_ids_come_out_of_both_serialisations() {
        let mut ros1 = vec![0u8; 12];
        ros1.extend(5u32.to_le_bytes());
        ros1.extend(b"laser");
        ros1.extend([1, 2, 3]);
        assert_eq!(ros1_frame_id(&ros1).as_deref(), Some("laser"));
        assert_eq!(ros1_frame_id(&ros1[..18]), None);
        let mut cdr = tether_msgs::cdr::CDR_LE_HEADER.to_vec();
        cdr.extend(7i32.to_le_bytes());
        cdr.extend(9u32.to_le_bytes());
        cdr.extend(6u32.to_le_bytes());
        cdr.extend(b"laser\0");
        assert_eq!(cdr_frame_id(&cdr).as_deref(), Some("laser"));
    }
}
