//! Reading a robot's recording, ROS 1 bag or MCAP (ROS 2), as one stream of samples in
//! log order: laser scans, camera frames (grey) and odometry. `tether track` and
//! `tether replay` are built on it.
//!
//! Before any sample is delivered, every topic asked for must be in the recording and of
//! a type its stream reads (a scan topic holds `sensor_msgs/LaserScan`, ...): otherwise
//! the reading fails at once, naming the topic's type and the topics that would do.
//!
//! A message that does not decode (damaged payload, an image encoding tether does not
//! read, a scan whose header contradicts its ranges) is skipped and counted, with the
//! first few reasons logged; when not one scan of the scan topic decodes, the reading
//! fails with the first reason. Damage to the file's structure ends the reading with an
//! error naming the place, after the samples before it have been delivered.
//!
//! A recording cut short (a killed recorder, an interrupted copy) is read up to the
//! cut: a ROS 1 bag whose index is missing or cut off chunk by chunk, an MCAP file
//! without footer or summary by a linear scan; one warning says where the reading
//! stopped and how many messages it read. Only a recording with nothing readable before
//! the cut is an error.

use std::path::Path;

use crate::mcap::{self, McapFile};
use crate::rosbag::{self, Bag};
use tether_core::{GrayImage, Laser, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_image::imread::decode_gray;
use tether_msgs::{CompressedImageMsg, ImageMsg, OdometryMsg, Ros2Message, RosMessage};

/// The topics to read; `None` (or no image topic) leaves a stream out.
#[derive(Debug, Clone, Default)]
pub struct Topics {
    /// `sensor_msgs/LaserScan`.
    pub scan: String,
    /// Camera topics, one per camera: `sensor_msgs/Image` (mono8, rgb8, bgr8) or
    /// `sensor_msgs/CompressedImage` (JPEG, PNG). Each frame's header names its camera.
    pub images: Vec<String>,
    /// `nav_msgs/Odometry`: the robot's pose in its odometry frame.
    pub odom: Option<String>,
}

impl Topics {
    fn all(&self) -> Vec<&str> {
        let mut out = vec![self.scan.as_str()];
        out.extend(self.images.iter().map(String::as_str));
        out.extend(self.odom.as_deref());
        out
    }
}

/// One sample of a recording.
#[derive(Debug, Clone)]
pub enum Sample {
    /// A laser scan (stamp and frame from its header).
    Scan(LaserScan),
    /// A camera frame in 8-bit grey, stamped by its header.
    Camera {
        /// Header stamp.
        stamp: Stamp,
        /// Header frame: which camera took it (design 5.7).
        frame_id: String,
        /// The frame.
        image: GrayImage,
    },
    /// The robot's pose in the odometry frame (tether's world frame).
    Odom {
        /// Header stamp.
        stamp: Stamp,
        /// Pose of the robot (`child_frame_id`) in the odometry frame.
        world_from_robot: Pose2<World, Robot>,
    },
}

/// A message of an annotation topic: labelled people or legs in the scan's frame, as
/// `tether eval-track` and `tether eval-legs` read them. Three message types carry
/// labels: `leg_tracker/PersonArray` (each person with an `id`),
/// `geometry_msgs/PoseArray` (positions only, e.g. leg_tracker's
/// `/leg_cluster_positions`) and `leg_tracker/Person` (one person a message, no header:
/// Leigh et al.'s published benchmark recordings, ROS 1 bags only).
#[derive(Debug, Clone, PartialEq)]
pub struct LabelMessage {
    /// Header stamp (zero in leg_tracker's extracted training bags, and for `Person`
    /// messages, which have no header).
    pub stamp: Stamp,
    /// Header frame (empty for `Person` messages: the scan's frame is meant).
    pub frame_id: String,
    /// Each label: its id (PersonArray, Person) or `None` (PoseArray), and its position
    /// on the ground plane of the frame, m.
    pub labels: Vec<(Option<u32>, Point2<Laser>)>,
    /// The message type the labels came in.
    pub source: LabelSource,
}

/// The message type of a label message.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum LabelSource {
    /// `geometry_msgs/PoseArray`: positions without ids, legs or people as the reader
    /// is told.
    PoseArray,
    /// `leg_tracker/PersonArray`: the people of one scan, with ids and a header.
    PersonArray,
    /// `leg_tracker/Person`: one labelled person, no header. **Pairing rule**: every
    /// Person message between scan k and scan k+1 (in log order) belongs to scan k, so
    /// a scan's labels are all the Person messages recorded after it and before the
    /// next scan; Person messages before the first scan belong to none (counted as
    /// unpaired). A scan followed by no Person message is unlabelled (not scored).
    Person,
}

impl LabelMessage {
    fn from_poses<'a>(
        stamp: Stamp,
        frame_id: String,
        source: LabelSource,
        poses: impl Iterator<Item = (Option<u32>, &'a tether_msgs::Pose3)>,
    ) -> Self {
        LabelMessage {
            stamp,
            frame_id,
            source,
            labels: poses
                .map(|(id, p)| (id, Point2::new(p.position_m[0], p.position_m[1])))
                .collect(),
        }
    }
}

/// What a reading read and skipped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadStats {
    /// Messages that did not decode or convert and were skipped.
    pub bad_messages: usize,
    /// Message records that could not be attributed to a topic.
    pub unattributed: usize,
    /// Messages of the topics asked for that were found (decoded or not).
    pub messages: usize,
    /// The recording had no usable index or summary (cut short, or not closed) and was
    /// read by walking its records, up to its end or the cut.
    pub salvaged: bool,
}

/// Message types each stream reads, in both spellings (ROS 1 and ROS 2).
const SCAN_TYPES: &[&str] = &["sensor_msgs/LaserScan", "sensor_msgs/msg/LaserScan"];
const ODOM_TYPES: &[&str] = &["nav_msgs/Odometry", "nav_msgs/msg/Odometry"];
const IMAGE_TYPES: &[&str] = &[
    "sensor_msgs/Image",
    "sensor_msgs/msg/Image",
    "sensor_msgs/CompressedImage",
    "sensor_msgs/msg/CompressedImage",
];
const LABEL_TYPES: &[&str] = &[
    "leg_tracker/PersonArray",
    "leg_tracker/Person",
    "leg_tracker/msg/PersonArray",
    "geometry_msgs/PoseArray",
    "geometry_msgs/msg/PoseArray",
];

/// The first scan that did not decode, and how many scans did.
#[derive(Default)]
struct ScanTally {
    good: usize,
    bad: usize,
    first_bad: Option<String>,
}

/// Logs the first few skipped messages, counts all.
fn skip(
    stats: &mut ReadStats,
    topic: &str,
    at: &dyn std::fmt::Display,
    why: &dyn std::fmt::Display,
) {
    stats.bad_messages += 1;
    if stats.bad_messages <= 10 {
        tracing::warn!("skipping the {topic} message at {at}: {why}");
    } else if stats.bad_messages == 11 {
        tracing::warn!("more messages skipped; the count is reported at the end");
    }
}

/// Refuses a scan whose beams go round more than once or whose directions lie beyond
/// a full turn either way: its sweep from the first beam to the last is longer than
/// `2 pi` plus one increment (a full-circle scanner's last beam may meet its first),
/// or its first or last beam is beyond `+-2 pi` plus one increment. Such a header is
/// damaged or wrong (beams would repeat directions, so one leg would be seen twice);
/// the scan is skipped and counted like any message that does not decode.
fn check_sweep(scan: LaserScan) -> anyhow::Result<LaserScan> {
    use std::f64::consts::TAU;
    let step = scan.angle_increment_rad.abs();
    let first = scan.angle_min_rad;
    let last = scan.angle_rad(scan.len() - 1);
    let sweep = (last - first).abs();
    if sweep > TAU + step + 1e-6 {
        anyhow::bail!(
            "the scan's {} beams sweep {sweep:.3} rad ({first:.3} to {last:.3} by {:.5}), more \
             than a full turn: directions would repeat",
            scan.len(),
            scan.angle_increment_rad
        );
    }
    if first.abs().max(last.abs()) > TAU + step + 1e-6 {
        anyhow::bail!(
            "the scan's beams point from {first:.3} to {last:.3} rad, beyond a full turn \
             (+-2 pi): a damaged header?"
        );
    }
    Ok(scan)
}

/// The same message types come out of both readers.
fn odom_sample(m: OdometryMsg) -> Sample {
    Sample::Odom {
        stamp: m.header.stamp,
        world_from_robot: m.pose.pose2(),
    }
}

fn compressed_sample(m: CompressedImageMsg) -> anyhow::Result<Sample> {
    Ok(Sample::Camera {
        image: decode_gray(&m.data)?,
        stamp: m.header.stamp,
        frame_id: m.header.frame_id,
    })
}

fn raw_sample(m: ImageMsg) -> anyhow::Result<Sample> {
    Ok(Sample::Camera {
        image: m.to_gray()?,
        stamp: m.header.stamp,
        frame_id: m.header.frame_id,
    })
}

/// True for an MCAP file, false for a ROS 1 bag; any other file is refused, saying
/// what it looks like ([`crate::sniff`]: by its first bytes, whatever its name).
fn is_mcap(path: &Path) -> anyhow::Result<bool> {
    Ok(crate::sniff::sniff(path)? == crate::sniff::Kind::Mcap)
}

/// Checks that every topic asked for is in the recording and of a type its stream
/// reads. `present` holds every (topic, message type) of the recording; `cut` says why
/// only part of the recording was looked at, if so.
fn check_topics(
    path: &Path,
    topics: &Topics,
    labels: Option<&str>,
    present: &[(String, String)],
    cut: Option<&str>,
) -> anyhow::Result<()> {
    if let (true, Some(cut)) = (present.is_empty(), cut) {
        anyhow::bail!(
            "{} holds nothing readable: {cut}; no complete chunk comes before that",
            path.display()
        );
    }
    let mut wanted: Vec<(&str, &str, &[&str])> = vec![(&topics.scan, "laser scans", SCAN_TYPES)];
    wanted.extend(topics.odom.as_deref().map(|t| (t, "odometry", ODOM_TYPES)));
    wanted.extend(
        topics
            .images
            .iter()
            .map(|t| (t.as_str(), "camera frames", IMAGE_TYPES)),
    );
    wanted.extend(labels.map(|t| (t, "labels", LABEL_TYPES)));
    let mut names: Vec<&str> = present.iter().map(|(t, _)| t.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    for (topic, what, accepted) in wanted {
        let types: Vec<&str> = present
            .iter()
            .filter(|(t, _)| t == topic)
            .map(|(_, ty)| ty.as_str())
            .collect();
        if types.is_empty() {
            anyhow::bail!(
                "{} has no topic {topic:?}; its topics are: {}{}",
                path.display(),
                names.join(", "),
                cut.map(|c| format!(" (as far as it could be read: {c})"))
                    .unwrap_or_default()
            );
        }
        if !types.iter().any(|ty| accepted.contains(ty)) {
            let mut holding: Vec<&str> = present
                .iter()
                .filter(|(_, ty)| accepted.contains(&ty.as_str()))
                .map(|(t, _)| t.as_str())
                .collect();
            holding.sort_unstable();
            holding.dedup();
            anyhow::bail!(
                "topic {topic:?} of {} holds {}, not {what} ({}); the topics with {what} are: {}",
                path.display(),
                types.join(" and "),
                accepted.join(", "),
                if holding.is_empty() {
                    "none".to_string()
                } else {
                    holding.join(", ")
                }
            );
        }
    }
    Ok(())
}

/// The one warning about a recording read past damage or without its index, or the
/// error when nothing of it could be read.
fn report_salvage(
    path: &Path,
    salvaged: Option<&str>,
    cut: Option<&crate::CutShort>,
    wanted: &[&str],
    messages: usize,
) -> anyhow::Result<()> {
    let Some(why) = salvaged else {
        return Ok(());
    };
    let topics = wanted.join(", ");
    match cut {
        Some(cut) if messages == 0 => anyhow::bail!(
            "{} is cut short and holds no message of {topics} before the cut: {cut}",
            path.display()
        ),
        Some(cut) => tracing::warn!(
            "{} is cut short: {cut}; reading stopped there, after {messages} messages of \
             {topics} (everything complete before the cut)",
            path.display()
        ),
        None => tracing::warn!(
            "{}: {why}; read by walking its records to the end: {messages} messages of {topics}",
            path.display()
        ),
    }
    Ok(())
}

/// Fails when the scan topic had messages but not one of them decoded.
fn check_scans(path: &Path, topic: &str, tally: &ScanTally) -> anyhow::Result<()> {
    if tally.good == 0 && tally.bad > 0 {
        anyhow::bail!(
            "none of the {} messages on {topic:?} in {} is a readable laser scan; the first: {}",
            tally.bad,
            path.display(),
            tally.first_bad.as_deref().unwrap_or("?")
        );
    }
    Ok(())
}

/// When a sample was logged: the time the recorder received it (a live tether run logs
/// each datum when its loop took it), and the log time of the recording's first
/// message (of any topic in an MCAP file; of the topics read in a bag).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LogTimes {
    /// This message's log time.
    pub log: Stamp,
    /// The first message's log time.
    pub first: Stamp,
}

/// What a timed reading calls with each sample.
pub type OnLoggedSample<'a> = dyn FnMut(LogTimes, Sample) -> anyhow::Result<()> + 'a;

/// What a reading calls with each message of a labels topic.
pub type OnLabels<'a> = dyn FnMut(LabelMessage) -> anyhow::Result<()> + 'a;

/// Reads the recording at `path` (MCAP or ROS 1 bag, told apart by their first bytes)
/// and calls `on_sample` with every sample of `topics`, in log order. `on_sample` may
/// stop the reading by returning an error.
pub fn read(
    path: &Path,
    topics: &Topics,
    on_sample: &mut dyn FnMut(Sample) -> anyhow::Result<()>,
) -> anyhow::Result<ReadStats> {
    read_logged(path, topics, None, &mut |_, sample| on_sample(sample))
}

/// Like [`read`], and also hands every message of `labels_topic` (see
/// [`LabelMessage`]) to `on_labels`, in log order among the samples.
pub fn read_with_labels(
    path: &Path,
    topics: &Topics,
    labels_topic: &str,
    on_sample: &mut dyn FnMut(Sample) -> anyhow::Result<()>,
    on_labels: &mut dyn FnMut(LabelMessage) -> anyhow::Result<()>,
) -> anyhow::Result<ReadStats> {
    read_logged(
        path,
        topics,
        Some((labels_topic, on_labels)),
        &mut |_, sample| on_sample(sample),
    )
}

/// Like [`read`] (and [`read_with_labels`] with `labels`), each sample with its
/// [`LogTimes`].
pub fn read_logged(
    path: &Path,
    topics: &Topics,
    labels: Option<(&str, &mut OnLabels<'_>)>,
    on_sample: &mut OnLoggedSample<'_>,
) -> anyhow::Result<ReadStats> {
    let sink = labels.map(|(topic, on_labels)| LabelSink { topic, on_labels });
    if is_mcap(path)? {
        read_mcap(path, topics, on_sample, sink)
    } else {
        read_bag(path, topics, on_sample, sink)
    }
}

/// A stored message of either format, decoded into the sample it stands for.
trait Stored {
    fn topic(&self) -> &str;
    /// When the recorder received it.
    fn log_time(&self) -> Stamp;
    /// Whether the message is a `CompressedImage` (else a camera topic holds `Image`s).
    fn is_compressed(&self) -> bool;
    fn scan(&self) -> anyhow::Result<LaserScan>;
    fn odometry(&self) -> anyhow::Result<OdometryMsg>;
    fn compressed(&self) -> anyhow::Result<CompressedImageMsg>;
    fn image(&self) -> anyhow::Result<ImageMsg>;
    fn labels(&self) -> anyhow::Result<LabelMessage>;

    fn sample(&self, topics: &Topics) -> anyhow::Result<Sample> {
        let topic = self.topic();
        if topic == topics.scan {
            self.scan().and_then(check_sweep).map(Sample::Scan)
        } else if Some(topic) == topics.odom.as_deref() {
            self.odometry().map(odom_sample)
        } else if self.is_compressed() {
            self.compressed().and_then(compressed_sample)
        } else {
            self.image().and_then(raw_sample)
        }
    }
}

impl Stored for mcap::RawMessage {
    fn topic(&self) -> &str {
        self.topic()
    }
    fn log_time(&self) -> Stamp {
        self.log_time
    }
    fn is_compressed(&self) -> bool {
        let name = self.channel.type_name();
        name == <CompressedImageMsg as Ros2Message>::TYPE || name == "sensor_msgs/CompressedImage"
    }
    fn scan(&self) -> anyhow::Result<LaserScan> {
        Ok(self.decode::<tether_msgs::LaserScanMsg>()?.scan)
    }
    fn odometry(&self) -> anyhow::Result<OdometryMsg> {
        Ok(self.decode()?)
    }
    fn compressed(&self) -> anyhow::Result<CompressedImageMsg> {
        Ok(self.decode()?)
    }
    fn image(&self) -> anyhow::Result<ImageMsg> {
        Ok(self.decode()?)
    }
    fn labels(&self) -> anyhow::Result<LabelMessage> {
        let name = self.channel.type_name();
        if name == <tether_msgs::PersonArrayMsg as Ros2Message>::TYPE
            || name == "leg_tracker/PersonArray"
        {
            let m = self.decode::<tether_msgs::PersonArrayMsg>()?;
            Ok(LabelMessage::from_poses(
                m.header.stamp,
                m.header.frame_id,
                LabelSource::PersonArray,
                m.people.iter().map(|p| (Some(p.id), &p.pose)),
            ))
        } else if name == <tether_msgs::PoseArrayMsg as Ros2Message>::TYPE
            || name == "geometry_msgs/PoseArray"
        {
            let m = self.decode::<tether_msgs::PoseArrayMsg>()?;
            Ok(LabelMessage::from_poses(
                m.header.stamp,
                m.header.frame_id,
                LabelSource::PoseArray,
                m.poses.iter().map(|p| (None, p)),
            ))
        } else if name == "leg_tracker/Person" || name == "leg_tracker/msg/Person" {
            anyhow::bail!(
                "labels of type {name} in an MCAP file: tether reads one-person-a-message \
                 labels from ROS 1 bags (Leigh et al.'s benchmark); in MCAP it reads \
                 leg_tracker/msg/PersonArray or geometry_msgs/msg/PoseArray"
            )
        } else {
            anyhow::bail!(
                "labels of type {name}: tether reads leg_tracker/msg/PersonArray or \
                 geometry_msgs/msg/PoseArray"
            )
        }
    }
}

// Parallel to the MCAP impl above on purpose: two wire formats (CDR and ROS 1), each
// decoding with its own message types and type names.
impl Stored for rosbag::RawMessage {
    fn topic(&self) -> &str {
        &self.connection.topic
    }
    fn log_time(&self) -> Stamp {
        self.time
    }
    fn is_compressed(&self) -> bool {
        self.connection.msg_type == <CompressedImageMsg as RosMessage>::TYPE
    }
    fn scan(&self) -> anyhow::Result<LaserScan> {
        Ok(self.decode::<tether_msgs::LaserScanMsg>()?.scan)
    }
    fn odometry(&self) -> anyhow::Result<OdometryMsg> {
        Ok(self.decode()?)
    }
    fn compressed(&self) -> anyhow::Result<CompressedImageMsg> {
        Ok(self.decode()?)
    }
    fn image(&self) -> anyhow::Result<ImageMsg> {
        Ok(self.decode()?)
    }
    fn labels(&self) -> anyhow::Result<LabelMessage> {
        let name = self.connection.msg_type.as_str();
        if name == <tether_msgs::PersonArrayMsg as RosMessage>::TYPE {
            let m = self.decode::<tether_msgs::PersonArrayMsg>()?;
            Ok(LabelMessage::from_poses(
                m.header.stamp,
                m.header.frame_id,
                LabelSource::PersonArray,
                m.people.iter().map(|p| (Some(p.id), &p.pose)),
            ))
        } else if name == <tether_msgs::PoseArrayMsg as RosMessage>::TYPE {
            let m = self.decode::<tether_msgs::PoseArrayMsg>()?;
            Ok(LabelMessage::from_poses(
                m.header.stamp,
                m.header.frame_id,
                LabelSource::PoseArray,
                m.poses.iter().map(|p| (None, p)),
            ))
        } else if name == <tether_msgs::PersonMsg as RosMessage>::TYPE {
            // No header: the frame is the scan's, the stamp unknown (zero).
            let p = self.decode::<tether_msgs::PersonMsg>()?;
            Ok(LabelMessage::from_poses(
                Stamp::from_ns(0),
                String::new(),
                LabelSource::Person,
                std::iter::once((Some(p.id), &p.pose)),
            ))
        } else {
            anyhow::bail!(
                "labels of type {name}: tether reads leg_tracker/PersonArray, \
                 leg_tracker/Person or geometry_msgs/PoseArray"
            )
        }
    }
}

/// Where the messages of an annotation topic go, besides the samples.
struct LabelSink<'a> {
    topic: &'a str,
    on_labels: &'a mut dyn FnMut(LabelMessage) -> anyhow::Result<()>,
}

/// Hands `raw`'s labels to the sink, or skips and counts them.
fn deliver_labels(
    raw: &impl Stored,
    at: &dyn std::fmt::Display,
    sink: &mut LabelSink<'_>,
    stats: &mut ReadStats,
) -> anyhow::Result<()> {
    match raw.labels() {
        Ok(l) => (sink.on_labels)(l),
        Err(e) => {
            skip(stats, raw.topic(), at, &format_args!("{e:#}"));
            Ok(())
        }
    }
}

/// Hands `raw`'s sample to `on_sample`, or skips and counts it.
fn deliver(
    raw: &impl Stored,
    (at, first): (&dyn std::fmt::Display, Stamp),
    topics: &Topics,
    stats: &mut ReadStats,
    scans: &mut ScanTally,
    on_sample: &mut OnLoggedSample<'_>,
) -> anyhow::Result<()> {
    let is_scan = raw.topic() == topics.scan;
    match raw.sample(topics) {
        Ok(s) => {
            if is_scan {
                scans.good += 1;
            }
            let log = raw.log_time();
            on_sample(LogTimes { log, first }, s)
        }
        Err(e) => {
            if is_scan {
                scans.bad += 1;
                scans
                    .first_bad
                    .get_or_insert_with(|| format!("at {at}: {e:#}"));
            }
            skip(stats, raw.topic(), at, &format_args!("{e:#}"));
            Ok(())
        }
    }
}

fn read_mcap(
    path: &Path,
    topics: &Topics,
    on_sample: &mut OnLoggedSample<'_>,
    mut labels: Option<LabelSink<'_>>,
) -> anyhow::Result<ReadStats> {
    let file = McapFile::open(path)?;
    let mut wanted = topics.all();
    wanted.extend(labels.as_ref().map(|l| l.topic));
    let present: Vec<(String, String)> = file
        .channels()
        .map(|c| (c.topic.clone(), c.type_name().to_owned()))
        .collect();
    let why = file
        .salvaged()
        .map(|w| format!("{w}; it was read by a linear scan"));
    check_topics(
        path,
        topics,
        labels.as_ref().map(|l| l.topic),
        &present,
        why.as_deref(),
    )?;
    let mut stats = ReadStats {
        salvaged: why.is_some(),
        ..ReadStats::default()
    };
    let mut scans = ScanTally::default();
    let mut messages = file.messages();
    let mut first = None;
    for raw in &mut messages {
        let raw = raw?;
        let first = *first.get_or_insert(raw.log_time);
        if let Some(sink) = labels.as_mut().filter(|l| l.topic == raw.topic()) {
            stats.messages += 1;
            deliver_labels(&raw, &raw.at, sink, &mut stats)?;
        } else if wanted.contains(&raw.topic()) {
            stats.messages += 1;
            let at = (&raw.at as &dyn std::fmt::Display, first);
            deliver(&raw, at, topics, &mut stats, &mut scans, on_sample)?;
        }
    }
    stats.unattributed = messages.skipped_count();
    report_salvage(
        path,
        why.as_deref(),
        messages.cut(),
        &wanted,
        stats.messages,
    )?;
    check_scans(path, &topics.scan, &scans)?;
    Ok(stats)
}

fn read_bag(
    path: &Path,
    topics: &Topics,
    on_sample: &mut OnLoggedSample<'_>,
    mut labels: Option<LabelSink<'_>>,
) -> anyhow::Result<ReadStats> {
    // A bag cut short (or never indexed) is read by walking its records: its
    // connections are only known once the chunks holding them have been read, so a
    // first pass collects them (it stops at damage, which the reading pass reports).
    let mut bag = Bag::open_salvaging(path)?;
    let why = bag.salvaged().map(str::to_owned);
    let mut first_cut = None;
    if why.is_some() {
        let mut pass = bag.messages().only_topics(&[]);
        for m in &mut pass {
            if m.is_err() {
                break;
            }
        }
        first_cut = pass.cut().map(|c| c.to_string());
    }
    let mut wanted = topics.all();
    wanted.extend(labels.as_ref().map(|l| l.topic));
    let present: Vec<(String, String)> = bag
        .connections()
        .map(|c| (c.topic.clone(), c.msg_type.clone()))
        .collect();
    let cut_note = first_cut.as_deref().or(why.as_deref());
    check_topics(
        path,
        topics,
        labels.as_ref().map(|l| l.topic),
        &present,
        cut_note,
    )?;
    let mut stats = ReadStats {
        salvaged: why.is_some(),
        ..ReadStats::default()
    };
    let mut scans = ScanTally::default();
    let mut messages = bag.messages().only_topics(&wanted);
    let mut first = None;
    for raw in &mut messages {
        let raw = raw?;
        let first = *first.get_or_insert(raw.time);
        stats.messages += 1;
        if let Some(sink) = labels.as_mut().filter(|l| l.topic == raw.topic()) {
            deliver_labels(&raw, &raw.at, sink, &mut stats)?;
        } else {
            let at = (&raw.at as &dyn std::fmt::Display, first);
            deliver(&raw, at, topics, &mut stats, &mut scans, on_sample)?;
        }
    }
    stats.unattributed = messages.skipped_count();
    let cut = messages.cut().copied();
    report_salvage(path, why.as_deref(), cut.as_ref(), &wanted, stats.messages)?;
    check_scans(path, &topics.scan, &scans)?;
    Ok(stats)
}
