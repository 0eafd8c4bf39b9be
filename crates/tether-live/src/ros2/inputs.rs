//! The ROS 2 topics as the loop's sources: scans, odometry, the base's pose on `/tf`,
//! `/clock`, camera frames and detections, each read on a thread of its own
//! (`tether_ros2::spawn_reader`) and sent to the loop as [`Input`]s without ever
//! blocking DDS (a full queue drops, counted).
//!
//! Time: the loop runs on the host's clock ([`crate::clock::MonotonicClock`], wall time
//! that never jumps) or, with `use_sim_time`, on `/clock` ([`SimClock`]). A scan keeps
//! its header stamp when that is plausible on this clock (at most 1 s old and not in the
//! future); otherwise (a publisher with a skewed clock or zero stamps) it is stamped on
//! arrival, and that is counted and reported once.

use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;

use tether_core::{Pose2, Robot, World};
use tether_image::ImreadError;
use tether_msgs::{
    ClockMsg, CompressedImageMsg, Detection2DArrayMsg, ImageMsg, ImageMsgError, LaserScanMsg,
    OdometryMsg, TfMessage,
};
use tether_ros2::{Received, Ros2Error, RosNode, offer, qos, spawn_reader};
use tether_scip::Clock;
use tether_vision::DetectError;

use super::extra_scans::{ExtraScanTopic, Pass};
use crate::clock::{LiveClock, SimClock};
use crate::sources::{Input, LaserFault};

/// How far a scan's header stamp may lag the host clock and still be used, ns.
const MAX_SCAN_AGE_NS: i64 = 1_000_000_000;
/// How far ahead of the host clock a stamp may be (clocks a little apart), ns.
const MAX_SCAN_LEAD_NS: i64 = 50_000_000;

/// What the scan reader counted.
#[derive(Debug, Default)]
pub struct ScanCounters {
    /// Scans handed to the loop.
    pub delivered: AtomicU64,
    /// Scans dropped because the loop was behind (its queue full).
    pub dropped: AtomicU64,
    /// Scans stamped on arrival because their header stamp was implausible.
    pub restamped: AtomicU64,
    /// Scans that did not decode or were not usable.
    pub malformed: AtomicU64,
    /// Odometry messages refused: undecodable, a non-finite pose, or a velocity no
    /// ground robot has ([`MAX_ODOMETRY_SPEED_MPS`], [`MAX_ODOMETRY_TURN_RADPS`]).
    pub odometry_refused: AtomicU64,
    /// When the last odometry message was taken, on the loop's clock, ns (0: never).
    pub odometry_last_ns: AtomicI64,
    /// Poses of the base taken from `/tf` (while no odometry message came).
    pub tf_poses: AtomicU64,
}

/// Fastest forward speed an odometry message may report, m/s.
pub const MAX_ODOMETRY_SPEED_MPS: f64 = 20.0;
/// Fastest turn rate an odometry message may report, rad/s.
pub const MAX_ODOMETRY_TURN_RADPS: f64 = 20.0;

/// The stamp the loop uses for a scan stamped `header_ns` that arrived at `now_ns`.
pub fn loop_stamp(header_ns: i64, now_ns: i64) -> Option<i64> {
    let age = now_ns.saturating_sub(header_ns);
    (-MAX_SCAN_LEAD_NS..=MAX_SCAN_AGE_NS)
        .contains(&age)
        .then_some(header_ns)
}

/// The loop's stamp of a message stamped `header_ns` that arrived at `now_ns`: its
/// header stamp when plausible ([`loop_stamp`]), else its arrival.
fn stamp_on_arrival(header_ns: i64, now_ns: i64) -> tether_core::Stamp {
    tether_core::Stamp::from_ns(loop_stamp(header_ns, now_ns).unwrap_or(now_ns))
}

/// Whether a velocity is one a ground robot can have ([`MAX_ODOMETRY_SPEED_MPS`],
/// [`MAX_ODOMETRY_TURN_RADPS`]).
fn ground_robot_velocity(moving: &tether_control::Twist) -> bool {
    moving.v_mps.abs() <= MAX_ODOMETRY_SPEED_MPS && moving.w_radps.abs() <= MAX_ODOMETRY_TURN_RADPS
}

/// Whether every coordinate of `pose` is finite.
fn finite_pose(pose: &Pose2<World, Robot>) -> bool {
    pose.x.is_finite() && pose.y.is_finite() && pose.yaw.is_finite()
}

/// Counts a sample of `topic` that did not decode in `counter`, warning about the first.
fn count_skipped(counter: &AtomicU64, topic: &str, why: &str) {
    if counter.fetch_add(1, Ordering::Relaxed) == 0 {
        tracing::warn!("{topic}: a sample skipped: {why} (further ones are counted)");
    }
}

/// [`offer`], counting a drop in `counter` as well.
fn offer_counted(
    tx: &SyncSender<Input>,
    input: Input,
    dropped: &mut u64,
    counter: &AtomicU64,
) -> bool {
    let before = *dropped;
    let open = offer(tx, input, dropped);
    if *dropped > before {
        counter.fetch_add(1, Ordering::Relaxed);
    }
    open
}

/// The error of a reader `thread` (e.g. "the clock reader thread") that did not start.
fn not_started(domain: u16, thread: &'static str) -> impl FnOnce(std::io::Error) -> Ros2Error {
    move |e| Ros2Error::Join {
        domain,
        message: format!("cannot start {thread}: {e}"),
    }
}

/// Subscribes to `topic` and sends its scans to the loop until `stop` fires or the
/// loop goes away. Never blocks DDS: a full queue drops the scan (counted). An extra
/// scan topic's scans pass its `gate` first ([`ExtraScanTopic::pass`]).
pub fn start_scan_reader(
    node: &mut RosNode,
    topic: &str,
    clock: LiveClock,
    (tx, stop): (SyncSender<Input>, Receiver<()>),
    counters: Arc<ScanCounters>,
    gate: Option<Arc<ExtraScanTopic>>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    let subscription = node.subscribe::<LaserScanMsg>(topic, qos::sensor_data())?;
    let topic_name = topic.to_owned();
    let mut dropped = 0;
    spawn_reader("ros2-scan", subscription, stop, move |received| {
        let input = match received {
            Received::Message { message, .. } => {
                let mut scan = message.scan;
                if gate
                    .as_ref()
                    .is_some_and(|g| g.pass(&scan.frame_id) != Pass::Take)
                {
                    return true;
                }
                let now = clock.now_ns();
                match loop_stamp(scan.stamp.ns(), now) {
                    Some(_) => {}
                    None => {
                        if counters.restamped.fetch_add(1, Ordering::Relaxed) == 0 {
                            tracing::warn!(
                                "{topic_name}: a scan stamped {:.3} s from this host's clock; \
                                 such scans are stamped on arrival (is the publisher's clock \
                                 set, or is it on sim time?)",
                                (scan.stamp.ns() - now) as f64 * 1e-9
                            );
                        }
                        scan.stamp = tether_core::Stamp::from_ns(now);
                    }
                }
                counters.delivered.fetch_add(1, Ordering::Relaxed);
                Input::Scan(scan)
            }
            Received::Malformed(why) => {
                count_skipped(&counters.malformed, &topic_name, &why);
                Input::LaserFault(LaserFault::Sample {
                    topic: topic_name.clone(),
                    why,
                })
            }
        };
        offer_counted(&tx, input, &mut dropped, &counters.dropped)
    })
    .map_err(not_started(domain, "the reader thread"))
}

/// Subscribes to `/clock` (`rosgraph_msgs/msg/Clock`, best effort, keep last 1, which
/// matches every publisher) and sets `clock` from it; each advance wakes the loop
/// ([`Input::ClockAdvanced`]) so that its timer runs on simulated time.
pub fn start_clock_reader(
    node: &mut RosNode,
    topic: &str,
    clock: SimClock,
    tx: SyncSender<Input>,
    stop: Receiver<()>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    let subscription = node.subscribe::<ClockMsg>(topic, qos::clock())?;
    let topic_name = topic.to_owned();
    let mut dropped = 0;
    let mut warned = false;
    spawn_reader(
        "ros2-clock",
        subscription,
        stop,
        move |received| match received {
            Received::Message { message, .. } => {
                let ns = message.clock.ns();
                if !clock.set(ns) {
                    if !warned {
                        tracing::warn!(
                            "{topic_name}: the clock went back to {:.3} s; ignored (restart tether \
                         ros2 after restarting the simulation)",
                            ns as f64 * 1e-9
                        );
                        warned = true;
                    }
                    return true;
                }
                // A full queue is no loss: the loop reads the clock, not the messages.
                offer(&tx, Input::ClockAdvanced, &mut dropped)
            }
            Received::Malformed(why) => {
                tracing::warn!("{topic_name}: a sample skipped: {why}");
                true
            }
        },
    )
    .map_err(not_started(domain, "the clock reader thread"))
}

/// Subscribes to the base's odometry on `topic` and sends each pose to the loop, stamped
/// as scans are ([`loop_stamp`]).
pub fn start_odometry_reader(
    node: &mut RosNode,
    topic: &str,
    clock: LiveClock,
    tx: SyncSender<Input>,
    stop: Receiver<()>,
    counters: Arc<ScanCounters>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    // Parallel to start_scan_reader on purpose: every reader is wired alike (node, topic,
    // clock, queue, stop, counters) and differs in the message it decodes.
    let subscription = node.subscribe::<OdometryMsg>(topic, qos::sensor_data())?;
    let topic_name = topic.to_owned();
    let mut dropped = 0;
    spawn_reader("ros2-odom", subscription, stop, move |received| {
        let input = match received {
            Received::Message { message, .. } => {
                let now = clock.now_ns();
                let stamp = stamp_on_arrival(message.header.stamp.ns(), now);
                let pose = message.pose;
                let world_from_robot: Pose2<World, Robot> = pose.pose2();
                let moving = tether_control::Twist {
                    v_mps: message.twist.v_mps(),
                    w_radps: message.twist.w_radps(),
                };
                let problem = if !finite_pose(&world_from_robot) {
                    Some("its pose is not finite".to_owned())
                } else if !ground_robot_velocity(&moving) {
                    Some(format!(
                        "its velocity ({} m/s, {} rad/s) is not a ground robot's",
                        moving.v_mps, moving.w_radps
                    ))
                } else {
                    None
                };
                if let Some(problem) = problem {
                    if counters.odometry_refused.fetch_add(1, Ordering::Relaxed) == 0 {
                        tracing::warn!(
                            "{topic_name}: an odometry message refused: {problem} (further \
                             ones are counted)"
                        );
                    }
                    return true;
                }
                counters.odometry_last_ns.store(now, Ordering::Relaxed);
                Input::Odometry {
                    stamp,
                    world_from_robot,
                    moving,
                }
            }
            Received::Malformed(why) => {
                count_skipped(&counters.odometry_refused, &topic_name, &why);
                return true;
            }
        };
        offer(&tx, input, &mut dropped)
    })
    .map_err(not_started(domain, "the odometry reader thread"))
}

/// A frame name as tf2 compares them: without a leading `/`.
fn frame_name(id: &str) -> &str {
    id.strip_prefix('/').unwrap_or(id)
}

/// How long after the last odometry message `/tf` takes over as the base's pose, ns.
const TF_AFTER_ODOMETRY_NS: i64 = 500_000_000;

/// The base's velocity between two poses `dt_s` apart: forward speed along the robot's
/// heading at the start and the turn rate, `v = (R(-yaw_a) (p_b - p_a))_x / dt`,
/// `w = wrap(yaw_b - yaw_a) / dt`.
pub fn velocity_between(
    a: Pose2<World, Robot>,
    b: Pose2<World, Robot>,
    dt_s: f64,
) -> tether_control::Twist {
    let (sin, cos) = a.yaw.sin_cos();
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    tether_control::Twist {
        v_mps: (cos * dx + sin * dy) / dt_s,
        w_radps: tether_core::wrap_angle_rad(b.yaw - a.yaw) / dt_s,
    }
}

/// Subscribes to `/tf` (`topic`) and sends the base's pose in the fixed frame (the
/// transform `fixed_frame` -> `base_frame`, as a diff-drive controller or a robot's
/// odometry node publishes it) to the loop as odometry, with the velocity between
/// successive poses, while the `odom` topic is silent (it wins when both publish).
/// When those transforms stop, the loop's odometry watchdog stops the robot.
#[allow(
    clippy::too_many_arguments,
    reason = "the reader's topic, frames, clock, channel and counters"
)]
pub fn start_tf_reader(
    node: &mut RosNode,
    topic: &str,
    fixed_frame: &str,
    base_frame: &str,
    clock: LiveClock,
    tx: SyncSender<Input>,
    stop: Receiver<()>,
    counters: Arc<ScanCounters>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    let subscription = node.subscribe::<TfMessage>(topic, qos::sensor_data())?;
    let (fixed, base) = (
        frame_name(fixed_frame).to_owned(),
        frame_name(base_frame).to_owned(),
    );
    let mut previous: Option<(i64, Pose2<World, Robot>)> = None;
    let mut dropped = 0;
    spawn_reader("ros2-tf", subscription, stop, move |received| {
        let Received::Message { message, .. } = received else {
            return true;
        };
        let now = clock.now_ns();
        let last_odometry = counters.odometry_last_ns.load(Ordering::Relaxed);
        if last_odometry > 0 && now.saturating_sub(last_odometry) < TF_AFTER_ODOMETRY_NS {
            return true;
        }
        for t in &message.transforms {
            if frame_name(&t.header.frame_id) != fixed || frame_name(&t.child_frame_id) != base {
                continue;
            }
            let pose: Pose2<World, Robot> = t.transform.pose2();
            if !finite_pose(&pose) {
                counters.odometry_refused.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            let stamp = loop_stamp(t.header.stamp.ns(), now).unwrap_or(now);
            let moving = match previous {
                Some((at, before)) if stamp > at && stamp - at <= TF_AFTER_ODOMETRY_NS => {
                    velocity_between(before, pose, (stamp - at) as f64 * 1e-9)
                }
                _ => tether_control::Twist::STOP,
            };
            previous = Some((stamp, pose));
            if !ground_robot_velocity(&moving) {
                counters.odometry_refused.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            counters.tf_poses.fetch_add(1, Ordering::Relaxed);
            let input = Input::Odometry {
                stamp: tether_core::Stamp::from_ns(stamp),
                world_from_robot: pose,
                moving,
            };
            if !offer(&tx, input, &mut dropped) {
                return false;
            }
        }
        true
    })
    .map_err(not_started(domain, "the /tf reader thread"))
}

/// What the camera reader counted.
#[derive(Debug, Default)]
pub struct CameraCounters {
    /// Frames taken from the topic.
    pub received: AtomicU64,
    /// Frames replaced by a newer one before the detector got to them.
    pub superseded: AtomicU64,
    /// Frames refused: their size is not the camera model's.
    pub wrong_size: AtomicU64,
    /// Samples that did not decode.
    pub malformed: AtomicU64,
    /// Boxes of detection messages refused: not finite, not positive, or not inside the
    /// camera model's image.
    pub bad_boxes: AtomicU64,
    /// Boxes of detection messages left out: another class than the one followed.
    pub other_class: AtomicU64,
    /// The camera's frame, as the first message named it (its mount is looked up on
    /// `/tf_static` under this name).
    pub frame_id: OnceLock<String>,
}

impl CameraCounters {
    /// Keeps `frame_id` when it is the first frame named.
    fn name_frame(&self, frame_id: &str) {
        if self.frame_id.get().is_none() {
            let _ = self.frame_id.set(frame_name(frame_id).to_owned());
        }
    }
}

/// The boxes of a `vision_msgs/msg/Detection2DArray` that `tether ros2` takes for
/// people: those with no hypothesis or one of class `class_id` (every box when
/// `class_id` is empty), upright (a rotated box by the upright box that holds it), with
/// finite, positive sizes and inside an image of `size_px` (a margin of one image
/// around it: a person partly out of view still gives a box). Returns the boxes and how
/// many were bad and of another class.
pub fn detection_boxes(
    message: &Detection2DArrayMsg,
    class_id: &str,
    size_px: (u32, u32),
) -> (Vec<tether_core::PixelBox>, u64, u64) {
    let (w, h) = (f64::from(size_px.0), f64::from(size_px.1));
    let (mut boxes, mut bad, mut other) = (Vec::new(), 0, 0);
    for d in &message.detections {
        if !class_id.is_empty()
            && !d.results.is_empty()
            && !d.results.iter().any(|r| r.class_id == class_id)
        {
            other += 1;
            continue;
        }
        match d.pixel_box() {
            Some(b) if b.x > -w && b.y > -h && b.x + b.w < 2.0 * w && b.y + b.h < 2.0 * h => {
                boxes.push(b);
            }
            _ => bad += 1,
        }
    }
    (boxes, bad, other)
}

/// Subscribes to `topic` (`vision_msgs/msg/Detection2DArray`, sensor-data QoS: a
/// detector node's boxes, or `tether sim --ros2`'s simulated camera) and sends each
/// message's people boxes ([`detection_boxes`]) to the loop as a frame of the
/// pipeline's camera of `frame_id`, stamped
/// as the scans are. Never blocks DDS: a full queue drops the frame (counted as
/// superseded).
#[allow(
    clippy::too_many_arguments,
    reason = "each is a separate part of the reader"
)]
pub fn start_detections_reader(
    node: &mut RosNode,
    (topic, frame_id): (&str, &str),
    class_id: String,
    size_px: (u32, u32),
    clock: LiveClock,
    tx: SyncSender<Input>,
    stop: Receiver<()>,
    counters: Arc<CameraCounters>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    let subscription = node.subscribe::<Detection2DArrayMsg>(topic, qos::sensor_data())?;
    let topic_name = topic.to_owned();
    let frame_id = frame_id.to_owned();
    let mut dropped = 0;
    spawn_reader("ros2-detections", subscription, stop, move |received| {
        let message = match received {
            Received::Message { message, .. } => message,
            Received::Malformed(why) => {
                count_skipped(&counters.malformed, &topic_name, &why);
                return true;
            }
        };
        counters.received.fetch_add(1, Ordering::Relaxed);
        counters.name_frame(&message.header.frame_id);
        let (boxes, bad, other) = detection_boxes(&message, &class_id, size_px);
        if bad > 0 && counters.bad_boxes.fetch_add(bad, Ordering::Relaxed) == 0 {
            tracing::warn!(
                "{topic_name}: a box with a size that is not finite and positive, or outside \
                 the camera model's {}x{} image, skipped (further ones are counted; are the \
                 boxes in pixels of the camera that --config describes?)",
                size_px.0,
                size_px.1
            );
        }
        counters.other_class.fetch_add(other, Ordering::Relaxed);
        let stamp = stamp_on_arrival(message.header.stamp.ns(), clock.now_ns());
        let input = Input::Camera {
            frame_id: frame_id.clone(),
            stamp,
            boxes,
            frame: None,
        };
        offer_counted(&tx, input, &mut dropped, &counters.superseded)
    })
    .map_err(not_started(domain, "the detections reader thread"))
}

/// A camera frame as it came (decoded on the detector's thread).
#[derive(Debug)]
pub enum Frame {
    /// `sensor_msgs/msg/Image`.
    Raw(ImageMsg),
    /// `sensor_msgs/msg/CompressedImage` (JPEG or PNG).
    Compressed(CompressedImageMsg),
}

/// Why a camera frame from a topic was skipped.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// A raw image that is not a grey, RGB or BGR image of its stated size.
    #[error(transparent)]
    Raw(#[from] ImageMsgError),
    /// A compressed image that does not decode.
    #[error(transparent)]
    Compressed(#[from] ImreadError),
    /// The detector refused it.
    #[error(transparent)]
    Detect(#[from] DetectError),
}

impl Frame {
    /// The frame as 8-bit grey.
    pub fn gray(&self) -> Result<tether_core::GrayImage, FrameError> {
        match self {
            Frame::Raw(m) => Ok(m.to_gray()?),
            Frame::Compressed(m) => Ok(tether_image::imread::decode_gray(&m.data)?),
        }
    }
}

/// The newest frame not yet taken by the detector: the reader never waits for the
/// detector, and the detector always gets the newest frame.
#[derive(Debug, Default)]
pub struct LatestFrame {
    slot: std::sync::Mutex<(Option<(tether_core::Stamp, Frame)>, bool)>,
    ready: std::sync::Condvar,
}

impl LatestFrame {
    /// Puts `frame` in the slot; `true` when it replaced one not yet taken.
    pub fn put(&self, stamp: tether_core::Stamp, frame: Frame) -> bool {
        let mut slot = self
            .slot
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let replaced = slot.0.replace((stamp, frame)).is_some();
        self.ready.notify_one();
        replaced
    }

    /// Ends [`LatestFrame::take`]'s waits.
    pub fn close(&self) {
        let mut slot = self
            .slot
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        slot.1 = true;
        self.ready.notify_all();
    }

    /// Waits for a frame; `None` once closed.
    pub fn take(&self) -> Option<(tether_core::Stamp, Frame)> {
        let mut slot = self
            .slot
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        loop {
            if slot.1 {
                return None;
            }
            if let Some(frame) = slot.0.take() {
                return Some(frame);
            }
            slot = self
                .ready
                .wait(slot)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }
}

/// Subscribes to the camera on `topic` (`compressed`: `sensor_msgs/msg/CompressedImage`,
/// else `sensor_msgs/msg/Image`) and puts each frame in `latest`. Raw frames whose size is
/// not `size_px` (the camera model's) are refused, counted and warned about once.
#[allow(
    clippy::too_many_arguments,
    reason = "each is a separate part of the reader"
)]
pub fn start_camera_reader(
    node: &mut RosNode,
    topic: &str,
    compressed: bool,
    size_px: (u32, u32),
    clock: LiveClock,
    latest: Arc<LatestFrame>,
    stop: Receiver<()>,
    counters: Arc<CameraCounters>,
) -> Result<JoinHandle<()>, Ros2Error> {
    let domain = node.identity().domain_id;
    let topic_name = topic.to_owned();
    let stamp_of = move |header_ns: i64| stamp_on_arrival(header_ns, clock.now_ns());
    let malformed = {
        let counters = Arc::clone(&counters);
        let topic_name = topic_name.clone();
        move |why: String| {
            if counters.malformed.fetch_add(1, Ordering::Relaxed) == 0 {
                tracing::warn!("{topic_name}: a sample skipped: {why}");
            }
            true
        }
    };
    let size_counters = Arc::clone(&counters);
    let size_topic = topic_name.clone();
    let keep = move |stamp, frame_id: &str, frame| {
        counters.received.fetch_add(1, Ordering::Relaxed);
        counters.name_frame(frame_id);
        if latest.put(stamp, frame) {
            counters.superseded.fetch_add(1, Ordering::Relaxed);
        }
        true
    };
    let started = if compressed {
        let subscription = node.subscribe::<CompressedImageMsg>(topic, qos::sensor_data())?;
        spawn_reader(
            "ros2-camera",
            subscription,
            stop,
            move |received| match received {
                Received::Message { message, .. } => {
                    let frame_id = message.header.frame_id.clone();
                    keep(
                        stamp_of(message.header.stamp.ns()),
                        &frame_id,
                        Frame::Compressed(message),
                    )
                }
                Received::Malformed(why) => malformed(why),
            },
        )
    } else {
        let subscription = node.subscribe::<ImageMsg>(topic, qos::sensor_data())?;
        spawn_reader(
            "ros2-camera",
            subscription,
            stop,
            move |received| match received {
                Received::Message { message, .. } => {
                    if (message.width, message.height) != size_px {
                        if size_counters.wrong_size.fetch_add(1, Ordering::Relaxed) == 0 {
                            tracing::warn!(
                                "{size_topic}: a {}x{} frame, but the camera model is {}x{}: \
                                 such frames are refused (set [camera] intrinsics in \
                                 --config to this camera's)",
                                message.width,
                                message.height,
                                size_px.0,
                                size_px.1
                            );
                        }
                        return true;
                    }
                    let frame_id = message.header.frame_id.clone();
                    keep(
                        stamp_of(message.header.stamp.ns()),
                        &frame_id,
                        Frame::Raw(message),
                    )
                }
                Received::Malformed(why) => malformed(why),
            },
        )
    };
    started.map_err(not_started(domain, "the camera reader thread"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_msgs::Header;

    #[test]
    fn the_velocity_between_two_poses_is_along_the_heading_and_the_turn() {
        let a = Pose2::<World, Robot>::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        // 0.1 m along the heading (+y in the world) and 0.05 rad left in 0.1 s.
        let b = Pose2::<World, Robot>::new(1.0, 2.1, std::f64::consts::FRAC_PI_2 + 0.05);
        let t = velocity_between(a, b, 0.1);
        assert!((t.v_mps - 1.0).abs() < 1e-9, "{t:?}");
        assert!((t.w_radps - 0.5).abs() < 1e-9, "{t:?}");
        // Across +-pi the turn is the short way round.
        let c = Pose2::<World, Robot>::new(0.0, 0.0, 3.1);
        let d = Pose2::<World, Robot>::new(0.0, 0.0, -3.1);
        let t = velocity_between(c, d, 0.1);
        assert!((t.w_radps - (2.0 * std::f64::consts::PI - 6.2) / 0.1).abs() < 1e-9);
        assert_eq!(frame_name("/base_link"), "base_link");
    }

    #[test]
    fn detection_boxes_keep_people_inside_the_image() {
        use tether_core::{PixelBox, Stamp};
        use tether_msgs::{Detection2DMsg, ObjectHypothesisMsg};
        let header = Header::new(Stamp::from_ns(1), "camera");
        let at = |x: f64, w: f64, class: Option<&str>| {
            let mut d = Detection2DMsg::from_box(
                header.clone(),
                &PixelBox {
                    x,
                    y: 50.0,
                    w,
                    h: 80.0,
                },
                ObjectHypothesisMsg::class(class.unwrap_or(""), 0.8),
                "",
            );
            if class.is_none() {
                d.results.clear();
            }
            d
        };
        let message = Detection2DArrayMsg {
            header: header.clone(),
            detections: vec![
                at(100.0, 60.0, Some("person")),
                at(200.0, 60.0, None),
                at(300.0, 60.0, Some("chair")),
                at(400.0, 0.0, Some("person")),
                at(5000.0, 60.0, Some("person")),
                at(-30.0, 60.0, Some("person")),
            ],
        };
        let (boxes, bad, other) = detection_boxes(&message, "person", (640, 480));
        let lefts: Vec<f64> = boxes.iter().map(|b| b.x).collect();
        assert_eq!(lefts, [100.0, 200.0, -30.0]);
        assert_eq!((bad, other), (2, 1));
        // An empty class takes every well-formed box.
        let (boxes, bad, other) = detection_boxes(&message, "", (640, 480));
        assert_eq!((boxes.len(), bad, other), (4, 2, 0));
    }

    #[test]
    fn plausible_stamps_are_kept_others_are_not() {
        let now = 1_700_000_000_000_000_000;
        assert_eq!(loop_stamp(now - 30_000_000, now), Some(now - 30_000_000));
        assert_eq!(loop_stamp(now + 10_000_000, now), Some(now + 10_000_000));
        assert_eq!(loop_stamp(now - 2_000_000_000, now), None);
        assert_eq!(loop_stamp(0, now), None);
        assert_eq!(loop_stamp(now + 500_000_000, now), None);
    }
}
