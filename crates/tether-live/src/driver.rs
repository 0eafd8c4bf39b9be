//! The one driver of the pipeline (design 6): every way tether runs — the live loop
//! (`tether run`, `tether ros2`, [`crate::run_loop`]), a recording
//! (`replay`, `track`, `eval-track`, [`crate::recording_run`]) and the simulator's
//! closed loop (`tether-eval`) — hands its scans, camera boxes and timer instants to a
//! [`Driver`], which keeps the rules of time and of the robot's pose:
//!
//! - **The control timer.** With its own [`ControlTimer`], the driver ticks the
//!   pipeline at the timer's instants up to each datum's arrival ([`Driver::due`]) before
//!   the datum; the caller's clock says when a datum arrives (the host's clock, a
//!   recording's log times). A clock that delivers the instants itself (the simulator,
//!   whose timer events step the robot's dynamics) calls [`Driver::timer`] directly.
//! - **Late data.** With its own timer, a datum stamped before the last tick is processed
//!   at that tick's time (the pipeline refuses data older than what it has processed),
//!   and the clamp is counted; its pose is still looked up at its own stamp.
//! - **The robot's pose** comes from a [`PoseSource`]: the dead reckoning of the
//!   commands with scan matching or odometry ([`RobotPose`]), a recording's odometry,
//!   or a pose the caller gives ([`GivenPose`]). Each tick's command is handed back to
//!   it at the time of the event that sent it ([`PoseSource::commanded`]).
//!
//! The caller does the rest: reading its inputs and writing its outputs.

use tether_control::Twist;
use tether_core::{LaserScan, PixelBox, Point2, Pose2, Robot, Stamp, World};
use tether_pipeline::{Pipeline, Tick};

use crate::control_timer::ControlTimer;
use crate::robot_pose::RobotPose;

/// Where the robot's pose comes from, for the [`Driver`]. `None` from a lookup skips
/// the datum (the pose is not known: no odometry yet, or it has stopped).
pub trait PoseSource {
    /// The pose `scan` is processed with. `first`: the scan is the first laser's (the
    /// one scan matching aligns, design 5.7); `people`: where the moving people are
    /// (their returns are left out of a match).
    fn for_scan(
        &mut self,
        scan: &LaserScan,
        first: bool,
        people: &mut dyn Iterator<Item = Point2<World>>,
    ) -> Option<Pose2<World, Robot>>;

    /// The pose at `stamp` between scans (a camera frame).
    fn between_scans(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>>;

    /// The pose at a timer tick at `stamp`.
    fn at_timer(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>>;

    /// From `at` (the time of the event whose tick sent it) the robot drives `command`.
    fn commanded(&mut self, at: Stamp, command: Twist);
}

impl PoseSource for RobotPose {
    fn for_scan(
        &mut self,
        scan: &LaserScan,
        first: bool,
        people: &mut dyn Iterator<Item = Point2<World>>,
    ) -> Option<Pose2<World, Robot>> {
        RobotPose::for_scan(self, scan, first, people)
    }

    fn between_scans(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        RobotPose::between_scans(self, stamp)
    }

    fn at_timer(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        Some(RobotPose::at_timer(self, stamp))
    }

    fn commanded(&mut self, at: Stamp, command: Twist) {
        RobotPose::commanded(self, at, command);
    }
}

/// The pose the caller sets before each datum (the simulator's: its truth, or its own
/// dead reckoning of the commands); the commands are the caller's to apply.
#[derive(Debug, Clone, Copy)]
pub struct GivenPose(pub Pose2<World, Robot>);

impl PoseSource for GivenPose {
    fn for_scan(
        &mut self,
        _scan: &LaserScan,
        _first: bool,
        _people: &mut dyn Iterator<Item = Point2<World>>,
    ) -> Option<Pose2<World, Robot>> {
        Some(self.0)
    }

    fn between_scans(&mut self, _stamp: Stamp) -> Option<Pose2<World, Robot>> {
        Some(self.0)
    }

    fn at_timer(&mut self, _stamp: Stamp) -> Option<Pose2<World, Robot>> {
        Some(self.0)
    }

    fn commanded(&mut self, _at: Stamp, _command: Twist) {}
}

/// What the driver counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DriverCounts {
    /// Scans through the pipeline.
    pub scans: u64,
    /// Camera frames through the pipeline.
    pub frames: u64,
    /// Timer ticks.
    pub timer_ticks: u64,
    /// Data processed at the last tick's time because they were stamped before it.
    pub clamped: u64,
    /// Scans and frames skipped because their pose was not known.
    pub without_pose: u64,
}

/// A tick of the pipeline and the robot's pose it was made with.
#[derive(Debug, Clone)]
pub struct Driven {
    /// The stamp the pipeline was given: the datum's or the instant's, or the last
    /// tick's when it was late.
    pub stamp: Stamp,
    /// What the pipeline made of the datum or the timer instant.
    pub tick: Tick,
    /// The robot's pose the pipeline was given.
    pub world_from_robot: Pose2<World, Robot>,
}

/// Drives one pipeline: see the module's documentation.
pub struct Driver<'p, P> {
    pipeline: &'p mut Pipeline,
    poses: P,
    timer: Option<ControlTimer>,
    /// The time of the event being handled: a timer instant, or when a datum arrived
    /// (never before the event before it).
    event: Stamp,
    /// The last tick's stamp (`i64::MIN` before the first: no datum is too old).
    last_stamp: Stamp,
    counts: DriverCounts,
}

impl<'p, P: PoseSource> Driver<'p, P> {
    /// A driver of `pipeline` with the robot's pose from `poses`, without a timer of its
    /// own (until [`Driver::start_timer`]).
    pub fn new(pipeline: &'p mut Pipeline, poses: P) -> Self {
        Driver {
            pipeline,
            poses,
            timer: None,
            event: Stamp::from_ns(i64::MIN),
            last_stamp: Stamp::from_ns(i64::MIN),
            counts: DriverCounts::default(),
        }
    }

    /// From now on the driver ticks on `timer` ([`Driver::due`]), and data stamped
    /// before the last tick are processed at its time. The event time starts at
    /// `start` if it is earlier.
    pub fn start_timer(&mut self, timer: ControlTimer, start: Stamp) {
        self.timer = Some(timer);
        self.event = self.event.max(start);
    }

    /// Whether the driver has a timer of its own.
    pub fn has_timer(&self) -> bool {
        self.timer.is_some()
    }

    /// The next instant of its timer.
    pub fn next_instant(&self) -> Option<Stamp> {
        self.timer.as_ref().map(ControlTimer::next)
    }

    /// The next instant of its timer at or before `now`, for [`Driver::timer`]; the
    /// timer then moves on ([`ControlTimer::due`]).
    pub fn due(&mut self, now: Stamp) -> Option<Stamp> {
        self.timer.as_mut()?.due(now)
    }

    /// When a datum that reaches the caller at `now` arrives: `now`, never before the
    /// event before it.
    pub fn arrival(&self, now: Stamp) -> Stamp {
        now.max(self.event)
    }

    /// The datum being handled arrived at `at` (after the timer's instants up to it).
    pub fn arrived(&mut self, at: Stamp) {
        self.event = self.event.max(at);
    }

    /// The time of the event being handled.
    pub fn event(&self) -> Stamp {
        self.event
    }

    /// The last tick's stamp (`i64::MIN` before the first tick).
    pub fn last_stamp(&self) -> Stamp {
        self.last_stamp
    }

    /// What it counted.
    pub fn counts(&self) -> DriverCounts {
        self.counts
    }

    /// The pipeline it drives.
    pub fn pipeline(&self) -> &Pipeline {
        self.pipeline
    }

    /// The pipeline it drives, to change (the camera gone).
    pub fn pipeline_mut(&mut self) -> &mut Pipeline {
        self.pipeline
    }

    /// Where the robot's pose comes from.
    pub fn poses(&self) -> &P {
        &self.poses
    }

    /// Where the robot's pose comes from, to feed (odometry messages, a given pose).
    pub fn poses_mut(&mut self) -> &mut P {
        &mut self.poses
    }

    /// The driver's pose source, at the end.
    pub fn into_poses(self) -> P {
        self.poses
    }

    /// A datum's stamp the pipeline takes: with a timer, not before the last tick.
    fn stamp(&mut self, stamp: Stamp) -> Stamp {
        if self.timer.is_some() && stamp < self.last_stamp {
            self.counts.clamped += 1;
            self.last_stamp
        } else {
            stamp
        }
    }

    /// After a tick at the current event: its command is what the robot drives.
    fn ticked(
        &mut self,
        stamp: Stamp,
        tick: Tick,
        world_from_robot: Pose2<World, Robot>,
    ) -> Driven {
        self.last_stamp = self.last_stamp.max(tick.stamp);
        self.poses.commanded(self.event, tick.command);
        Driven {
            stamp,
            tick,
            world_from_robot,
        }
    }

    /// A tick of the control timer at its instant `at` (`None`: no pose yet).
    pub fn timer(&mut self, at: Stamp) -> Option<Driven> {
        self.event = self.event.max(at);
        let stamp = self.stamp(at);
        let pose = self.poses.at_timer(stamp)?;
        let tick = self.pipeline.on_timer(stamp, pose);
        self.counts.timer_ticks += 1;
        Some(self.ticked(stamp, tick, pose))
    }

    /// A scan (its stamp becomes the tick's: clamped when late). `None`: skipped, its
    /// pose is not known.
    pub fn scan(&mut self, scan: &mut LaserScan) -> Option<Driven> {
        let first = self.pipeline.is_first_lasers(&scan.frame_id);
        let pose = {
            let mut people = crate::ego::moving_people(self.pipeline.tracker().tracks());
            self.poses.for_scan(scan, first, &mut people)
        };
        let Some(pose) = pose else {
            self.counts.without_pose += 1;
            return None;
        };
        scan.stamp = self.stamp(scan.stamp);
        let tick = self.pipeline.on_scan(scan, pose);
        self.counts.scans += 1;
        Some(self.ticked(scan.stamp, tick, pose))
    }

    /// The pose a camera frame stamped `stamp` is processed with; `None`: it is skipped.
    /// Asked before the frame's boxes are found, so that a frame without a pose costs
    /// no detection.
    pub fn camera_pose(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        let pose = self.poses.between_scans(stamp);
        if pose.is_none() {
            self.counts.without_pose += 1;
        }
        pose
    }

    /// A frame's `boxes` of the camera of `frame_id` (`camera`: the first), stamped
    /// `stamp`, at the pose [`Driver::camera_pose`] gave.
    pub fn camera(
        &mut self,
        stamp: Stamp,
        frame_id: &str,
        boxes: &[PixelBox],
        world_from_robot: Pose2<World, Robot>,
    ) -> Driven {
        let stamp = self.stamp(stamp);
        let tick = self
            .pipeline
            .on_camera_boxes_from(frame_id, stamp, boxes, world_from_robot);
        self.counts.frames += 1;
        self.ticked(stamp, tick, world_from_robot)
    }
}
