//! `tether info`: what a recording (a ROS 1 bag or an MCAP file) holds, topic by topic:
//! message type, count, rate, the frame ids of the headers and, for laser scans, the
//! scan geometry; and for the whole file its format, size, time span and whether it
//! was read whole.
//!
//! The messages are walked once, in file order; of each message only what is needed is
//! decoded: the frame id of its header (when its type starts with one) and, for the
//! first scan of a scan topic that decodes, the scan itself.
//!
//! A recording cut short (a killed recorder, an interrupted copy) is read up to the
//! cut, as every command reads it, and said to be so. A file whose structure is damaged
//! part way is described up to the damage, then the command fails naming it.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::Context;
use serde_json::{Value, json};
use tether_core::Stamp;
use tether_msgs::RosMessage;
use tether_recording::mcap::{self, McapFile};
use tether_recording::rosbag::Bag;

/// Options of `tether info`.
///
/// `--json` prints one JSON document (pretty-printed) with these fields:
///
/// - `file` (string): the path given.
/// - `format`: `"ros1_bag"` or `"mcap"`; `format_name`: `"ROS 1 bag 2.0"` or `"MCAP"`.
/// - `profile`, `library` (strings, MCAP only, else `null`): the MCAP header's profile
///   (`ros2` for ROS 2 recordings) and the library that wrote the file.
/// - `chunks` (number, ROS 1 bags only, else `null`): chunks listed in the bag's index
///   (0 when the index was not used).
/// - `size_bytes` (number): size of the file.
/// - `start_ns`, `end_ns` (numbers or `null` without messages): earliest and latest log
///   time (the time the recorder received a message; the record time of a ROS 1 bag),
///   nanoseconds since the Unix epoch; `start_utc`, `end_utc` the same as
///   `YYYY-MM-DDTHH:MM:SS.nnnnnnnnnZ`; `duration_s` (number or `null`): end - start.
/// - `messages` (number): messages read, all topics.
/// - `read` (object): how the file was read. `status` is `"whole"` (index or summary
///   used, every record read), `"salvaged"` (no usable index or summary: every record
///   read by walking the file, which is whole), `"cut_short"` (walked up to where the
///   file ends inside a record: what comes before it is counted) or `"damaged"` (the
///   walk stopped at damage to the file's structure; the command then exits non-zero);
///   `whole` (bool): status is `"whole"`; `index_unused` (string or `null`): why the
///   index (bag) or summary (MCAP) was not used; `cut` (string or `null`): where the
///   file is cut short; `error` (string or `null`): the damage that stopped the walk;
///   `unattributed_records` (number): message records on no known connection/channel,
///   skipped.
/// - `topics` (array, sorted by topic name), each an object: `topic`; `type` (the
///   message type as the file names it, e.g. `sensor_msgs/LaserScan` in a ROS 1 bag,
///   `sensor_msgs/msg/LaserScan` in ROS 2 MCAP; several distinct ones joined by `" | "`);
///   `count` (number of messages); `first_ns`, `last_ns` (log times, or `null`);
///   `rate_hz` (`(count - 1) / (last - first)`, `null` with fewer than two messages or no
///   time between them); `has_header` (bool: the type's definition starts with a
///   `std_msgs/Header`); `frame_ids` (array of the first few distinct header frame ids,
///   at most 4); `more_frame_ids` (bool: more distinct ones were seen); `bad_headers`
///   (number of messages whose header did not decode); `scan` (laser scan topics only,
///   else `null`, also `null` when no scan decodes): the first scan that decodes,
///   `beams` (number of ranges), `angle_min_deg`, `angle_max_deg`, `fov_deg`
///   (`angle_max - angle_min`), `angle_increment_deg`, `angle_increment_rad`,
///   `range_min_m`, `range_max_m`, `scan_time_s`, `frame_id`; `bad_scans` (number of
///   scans that did not decode before the first that did).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: a ROS 1 bag (format 2.0) or an MCAP file, told apart by their
    /// first bytes.
    pub recording: PathBuf,
    /// Print one JSON document for scripts instead of the table: file, format,
    /// size_bytes, start_ns, end_ns, duration_s, messages, read {status, ...}, topics
    /// [{topic, type, count, rate_hz, frame_ids, scan, ...}].
    #[arg(long)]
    pub json: bool,
}

/// The first line of a ROS 1 bag of format 2.0.
const BAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Message types of laser scans, in both spellings.
const SCAN_TYPES: &[&str] = &["sensor_msgs/LaserScan", "sensor_msgs/msg/LaserScan"];

/// Distinct frame ids kept per topic.
const MAX_FRAMES: usize = 4;

/// Prints what the recording holds.
pub fn run(args: Args) -> anyhow::Result<()> {
    let info = inspect(&args.recording)?;
    if args.json {
        let doc = serde_json::to_string_pretty(&info.to_json())?;
        tether::outln!("{doc}")?;
    } else {
        print_table(&info)?;
    }
    if let Some(error) = &info.read.error {
        anyhow::bail!(
            "{} is damaged: {error}; what is shown is what comes before the damage",
            args.recording.display()
        );
    }
    Ok(())
}

/// The recording's format.
#[derive(Debug, Clone)]
enum Format {
    Bag { chunks: usize },
    Mcap { profile: String, library: String },
}

/// How the recording was read.
#[derive(Debug, Clone, Default)]
struct ReadState {
    /// Why the index (bag) or summary (MCAP) was not used.
    index_unused: Option<String>,
    /// Where the file ends inside a record.
    cut: Option<String>,
    /// The damage that ended the walk.
    error: Option<String>,
    /// Message records on no known connection or channel.
    unattributed: usize,
}

impl ReadState {
    fn status(&self) -> &'static str {
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
struct ScanGeometry {
    beams: usize,
    angle_min_rad: f64,
    angle_max_rad: f64,
    angle_increment_rad: f64,
    range_min_m: f64,
    range_max_m: f64,
    scan_time_s: f64,
    frame_id: String,
}

impl ScanGeometry {
    /// The geometry of a scan as either recording holds it (ROS 1 or CDR, decoded to
    /// the same raw form).
    fn of(m: &tether_msgs::RawLaserScan) -> Self {
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

    fn fov_deg(&self) -> f64 {
        (self.angle_max_rad - self.angle_min_rad).to_degrees()
    }

    fn to_json(&self) -> Value {
        json!({
            "beams": self.beams,
            "angle_min_deg": finite(self.angle_min_rad.to_degrees()),
            "angle_max_deg": finite(self.angle_max_rad.to_degrees()),
            "fov_deg": finite(self.fov_deg()),
            "angle_increment_deg": finite(self.angle_increment_rad.to_degrees()),
            "angle_increment_rad": finite(self.angle_increment_rad),
            "range_min_m": finite(self.range_min_m),
            "range_max_m": finite(self.range_max_m),
            "scan_time_s": finite(self.scan_time_s),
            "frame_id": self.frame_id,
        })
    }
}

/// A float for JSON: NaN and infinities (which JSON cannot hold) become `null`.
fn finite(x: f64) -> Value {
    if x.is_finite() { json!(x) } else { Value::Null }
}

/// What one topic holds.
#[derive(Debug, Clone, Default)]
struct TopicInfo {
    /// Distinct message types, in the order met.
    types: Vec<String>,
    count: u64,
    first: Option<Stamp>,
    last: Option<Stamp>,
    has_header: bool,
    frames: Vec<String>,
    more_frames: bool,
    bad_headers: u64,
    /// Whether any of its types is a laser scan.
    is_scan: bool,
    scan: Option<ScanGeometry>,
    bad_scans: u64,
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

    fn rate_hz(&self) -> Option<f64> {
        let span = self.last?.secs_since(self.first?);
        (self.count >= 2 && span > 0.0).then(|| (self.count - 1) as f64 / span)
    }

    fn type_name(&self) -> String {
        self.types.join(" | ")
    }
}

/// Everything `tether info` says about a recording.
#[derive(Debug, Clone)]
struct Info {
    path: PathBuf,
    format: Format,
    size: u64,
    topics: BTreeMap<String, TopicInfo>,
    read: ReadState,
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

    fn messages(&self) -> u64 {
        self.topics.values().map(|t| t.count).sum()
    }

    fn start(&self) -> Option<Stamp> {
        self.topics.values().filter_map(|t| t.first).min()
    }

    fn end(&self) -> Option<Stamp> {
        self.topics.values().filter_map(|t| t.last).max()
    }

    fn duration_s(&self) -> Option<f64> {
        Some(self.end()?.secs_since(self.start()?))
    }

    fn format_name(&self) -> &'static str {
        match self.format {
            Format::Bag { .. } => "ROS 1 bag 2.0",
            Format::Mcap { .. } => "MCAP",
        }
    }

    fn to_json(&self) -> Value {
        let (format, profile, library, chunks) = match &self.format {
            Format::Bag { chunks } => ("ros1_bag", None, None, Some(*chunks)),
            Format::Mcap { profile, library } => {
                ("mcap", Some(profile.as_str()), Some(library.as_str()), None)
            }
        };
        let topics: Vec<Value> = self
            .topics
            .iter()
            .map(|(name, t)| {
                json!({
                    "topic": name,
                    "type": t.type_name(),
                    "count": t.count,
                    "first_ns": t.first.map(Stamp::ns),
                    "last_ns": t.last.map(Stamp::ns),
                    "rate_hz": t.rate_hz(),
                    "has_header": t.has_header,
                    "frame_ids": t.frames,
                    "more_frame_ids": t.more_frames,
                    "bad_headers": t.bad_headers,
                    "scan": t.scan.as_ref().map(ScanGeometry::to_json),
                    "bad_scans": t.bad_scans,
                })
            })
            .collect();
        json!({
            "file": self.path.display().to_string(),
            "format": format,
            "format_name": self.format_name(),
            "profile": profile,
            "library": library,
            "chunks": chunks,
            "size_bytes": self.size,
            "start_ns": self.start().map(Stamp::ns),
            "end_ns": self.end().map(Stamp::ns),
            "start_utc": self.start().map(utc),
            "end_utc": self.end().map(utc),
            "duration_s": self.duration_s(),
            "messages": self.messages(),
            "read": {
                "status": self.read.status(),
                "whole": self.read.status() == "whole",
                "index_unused": self.read.index_unused,
                "cut": self.read.cut,
                "error": self.read.error,
                "unattributed_records": self.read.unattributed,
            },
            "topics": topics,
        })
    }
}

/// Reads the recording at `path` and gathers what it holds.
fn inspect(path: &Path) -> anyhow::Result<Info> {
    let meta =
        std::fs::metadata(path).with_context(|| format!("cannot open {}", path.display()))?;
    if meta.is_dir() {
        anyhow::bail!("{}", folder_refusal(path));
    }
    let mut head = Vec::with_capacity(64);
    std::fs::File::open(path)
        .and_then(|f| f.take(64).read_to_end(&mut head))
        .with_context(|| format!("cannot read {}", path.display()))?;
    let info = if head.starts_with(mcap::MAGIC) {
        read_mcap(path, meta.len())?
    } else if head.starts_with(BAG_MAGIC) {
        read_bag(path, meta.len())?
    } else {
        anyhow::bail!(
            "{} is not a ROS 1 bag or MCAP file: {}",
            path.display(),
            describe(&head, meta.len())
        );
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

/// Why a folder is refused, with the recording it may hold (a ROS 2 bag folder).
fn folder_refusal(path: &Path) -> String {
    let mut inside: Vec<String> = std::fs::read_dir(path)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".mcap") || n.ends_with(".bag") || n.ends_with(".db3"))
                .collect()
        })
        .unwrap_or_default();
    inside.sort();
    if inside.is_empty() {
        format!("{} is a folder, not a recording file", path.display())
    } else {
        format!(
            "{} is a folder, not a recording file; it holds {}: give one of them",
            path.display(),
            inside.join(", ")
        )
    }
}

/// What a file that is neither format starts with, and what it may be.
fn describe(head: &[u8], len: u64) -> String {
    if head.is_empty() {
        return "it is empty (0 bytes)".to_owned();
    }
    let known: &[(&[u8], &str)] = &[
        (
            b"#ROSBAG V",
            "a ROS bag of another format version; tether reads 2.0",
        ),
        (
            b"SQLite format 3\0",
            "a SQLite database (a ROS 2 .db3 bag? convert it to MCAP: \
             `ros2 bag convert` or `rosbags-convert`)",
        ),
        (&mcap::MAGIC[..5], "an MCAP magic of another version"),
        (b"\x89PNG\r\n\x1a\n", "a PNG image"),
        (b"\xff\xd8\xff", "a JPEG image"),
        (b"\x1f\x8b", "gzip data (decompress it first)"),
        (b"BZh", "bzip2 data (decompress it first)"),
        (b"\x28\xb5\x2f\xfd", "zstd data (decompress it first)"),
        (b"\x04\x22\x4d\x18", "LZ4 frame data (decompress it first)"),
        (b"PK\x03\x04", "a zip archive"),
        (b"\x7fELF", "an ELF executable"),
        (b"%PDF", "a PDF document"),
    ];
    let what = known
        .iter()
        .find(|(magic, _)| head.starts_with(magic))
        .map(|(_, what)| *what);
    let shown = &head[..head.len().min(16)];
    let text = std::str::from_utf8(shown).ok().filter(|s| {
        s.chars()
            .all(|c| !c.is_control() || c == '\n' || c == '\r' || c == '\t')
    });
    let bytes = match text {
        Some(t) => format!("{t:?}"),
        None => {
            let hex: Vec<String> = shown.iter().map(|b| format!("{b:02x}")).collect();
            format!("the bytes {}", hex.join(" "))
        }
    };
    let what = what.unwrap_or(if text.is_some() {
        "text"
    } else {
        "no format tether knows"
    });
    format!(
        "it starts with {bytes} ({what}; {len} bytes); a ROS 1 bag starts with \
         \"#ROSBAG V2.0\\n\", an MCAP file with \"\\x89MCAP0\\r\\n\""
    )
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

/// A time as `YYYY-MM-DDTHH:MM:SS.nnnnnnnnnZ` (UTC, proleptic Gregorian calendar).
fn utc(t: Stamp) -> String {
    let ns = t.ns();
    let secs = ns.div_euclid(1_000_000_000);
    let frac = ns.rem_euclid(1_000_000_000);
    let days = secs.div_euclid(86_400);
    let of_day = secs.rem_euclid(86_400);
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}.{frac:09}Z",
        of_day / 3600,
        of_day % 3600 / 60,
        of_day % 60
    )
}

/// A size in bytes for people.
fn human_size(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut value = bytes as f64;
    let mut unit = "";
    for u in UNITS {
        if value < 1024.0 {
            break;
        }
        value /= 1024.0;
        unit = u;
    }
    format!("{value:.1} {unit} ({bytes} bytes)")
}

/// The frame ids of a topic, for the table.
fn frames_text(t: &TopicInfo) -> String {
    if !t.has_header {
        return "-".to_owned();
    }
    if t.frames.is_empty() {
        return "?".to_owned();
    }
    let mut text = t
        .frames
        .iter()
        .map(|f| {
            if f.is_empty() || f.contains([' ', ',', '"']) {
                format!("{f:?}")
            } else {
                f.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(", ");
    if t.more_frames {
        text.push_str(", ...");
    }
    text
}

fn print_table(info: &Info) -> anyhow::Result<()> {
    let mut format = info.format_name().to_owned();
    match &info.format {
        Format::Bag { chunks } if info.read.index_unused.is_none() => format.push_str(&format!(
            ", {chunks} chunk{} in its index",
            if *chunks == 1 { "" } else { "s" }
        )),
        Format::Bag { .. } => {}
        Format::Mcap { profile, library } => {
            let profile = if profile.is_empty() { "none" } else { profile };
            format.push_str(&format!(", profile {profile}, written by {library:?}"));
        }
    }
    tether::outln!("file      {}", info.path.display())?;
    tether::outln!("format    {format}")?;
    tether::outln!("size      {}", human_size(info.size))?;
    let read = match info.read.status() {
        "whole" => "whole (through its index)".to_owned(),
        "salvaged" => format!(
            "salvaged: every record walked ({})",
            info.read.index_unused.as_deref().unwrap_or("")
        ),
        "cut_short" => format!(
            "cut short, read up to the cut: {}",
            info.read.cut.as_deref().unwrap_or("")
        ),
        _ => format!(
            "damaged, read up to the damage: {}",
            info.read.error.as_deref().unwrap_or("")
        ),
    };
    let read = if matches!(info.format, Format::Mcap { .. }) {
        read.replace("its index", "its summary")
    } else {
        read
    };
    tether::outln!("read      {read}")?;
    if info.read.unattributed > 0 {
        tether::outln!(
            "          {} message records on no known connection skipped",
            info.read.unattributed
        )?;
    }
    match (info.start(), info.end(), info.duration_s()) {
        (Some(start), Some(end), Some(duration)) => {
            tether::outln!("start     {} (Unix time {})", utc(start), secs_text(start))?;
            tether::outln!("end       {} (Unix time {})", utc(end), secs_text(end))?;
            tether::outln!("duration  {duration:.3} s")?;
        }
        _ => tether::outln!("span      no messages")?,
    }
    let topics = info.topics.len();
    tether::outln!(
        "messages  {} on {topics} topic{}",
        info.messages(),
        if topics == 1 { "" } else { "s" }
    )?;
    tether::outln!()?;
    let rows: Vec<[String; 5]> = info
        .topics
        .iter()
        .map(|(name, t)| {
            [
                name.clone(),
                t.type_name(),
                t.count.to_string(),
                t.rate_hz().map_or("-".to_owned(), |r| format!("{r:.2}")),
                frames_text(t),
            ]
        })
        .collect();
    let heading = ["topic", "type", "messages", "rate Hz", "frame ids"];
    let mut widths = heading.map(str::len);
    for row in &rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(cell.chars().count());
        }
    }
    let line = |cells: [&str; 5]| {
        format!(
            "{:<w0$}  {:<w1$}  {:>w2$}  {:>w3$}  {}",
            cells[0],
            cells[1],
            cells[2],
            cells[3],
            cells[4],
            w0 = widths[0],
            w1 = widths[1],
            w2 = widths[2],
            w3 = widths[3],
        )
    };
    tether::outln!("{}", line(heading))?;
    for row in &rows {
        tether::outln!("{}", line([&row[0], &row[1], &row[2], &row[3], &row[4]]))?;
    }
    let scans: Vec<(&String, &TopicInfo)> = info.topics.iter().filter(|(_, t)| t.is_scan).collect();
    if !scans.is_empty() {
        tether::outln!()?;
    }
    for (name, t) in scans {
        match &t.scan {
            Some(s) => tether::outln!(
                "{name}: {} beams, field of view {:.2} deg ({:.2} to {:.2}), increment {:.4} deg \
                 ({:.6} rad), ranges {} to {} m, scan time {} s",
                s.beams,
                s.fov_deg(),
                s.angle_min_rad.to_degrees(),
                s.angle_max_rad.to_degrees(),
                s.angle_increment_rad.to_degrees(),
                s.angle_increment_rad,
                round_text(s.range_min_m),
                round_text(s.range_max_m),
                round_text(s.scan_time_s),
            )?,
            None => tether::outln!("{name}: no scan decodes ({} tried)", t.bad_scans)?,
        }
    }
    Ok(())
}

/// A time as seconds since the Unix epoch, to the nanosecond.
fn secs_text(t: Stamp) -> String {
    let text = t.to_string();
    text.strip_suffix('s').unwrap_or(&text).to_owned()
}

/// A value stored as `f32`, shown with the digits that `f32` holds (0.02, not
/// 0.019999999552965164).
fn round_text(x: f64) -> String {
    format!("{}", x as f32)
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

    #[test]
    fn times_print_in_utc() {
        assert_eq!(utc(Stamp::from_ns(0)), "1970-01-01T00:00:00.000000000Z");
        assert_eq!(
            utc(Stamp::from_ns(1_403_201_183_687_882_605)),
            "2014-06-19T18:06:23.687882605Z"
        );
        assert_eq!(
            utc(Stamp::from_ns(951_782_400_000_000_001)),
            "2000-02-29T00:00:00.000000001Z"
        );
    }

    #[test]
    fn other_files_are_named() {
        assert!(describe(b"", 0).contains("empty"));
        assert!(describe(b"SQLite format 3\0xyz", 100).contains("SQLite"));
        assert!(describe(b"hello world\n", 12).contains("\"hello world\\n\" (text"));
        assert!(describe(&[0, 1, 2, 250], 4).contains("00 01 02 fa"));
    }
}
