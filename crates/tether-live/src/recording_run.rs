//! The loop of `tether track`, `tether eval-track` and `tether replay`: a recording's
//! samples through the pipeline in log order (design 4, 5), with the robot's pose from
//! odometry messages, from scan matching, or taken as still (the scan's frame is then
//! the robot's and the world's).
//!
//! Per scan and per camera frame the caller gets the pipeline's tick, the
//! `world_from_robot` used for it and the tracker's tracks after it; per scan also the
//! scan and the configured `robot_from_laser` of its laser, so that it can put the
//! tracks (in the world frame) and the scan's labels (in the laser frame) in one frame:
//! `world_from_laser = world_from_robot * robot_from_laser`. With scan matching, the
//! first laser's scans are matched; another scanner's take the pose of the last match.
//!
//! The run is the live loop's (design 6), at its control period
//! ([`Options::control_period`]): the pipeline also ticks at the control timer's instants
//! ([`crate::control_timer`]) between the data, each datum is handled when it was
//! logged (its arrival; [`arrival`]: its stamp when the recording was written after the
//! fact) after the instants up to it, and a datum stamped before the last
//! tick is processed at that tick's time (counted in [`RunCounts::clamped`]). With the
//! poses of [`KeptPoses::Commands`], a replay of a live run's recording sends the commands
//! the live run sent, tick for tick. These rules are the [`Driver`]'s, the one the live
//! loop drives its pipeline with.

use crate::ego::ScanOdometry;
use std::cell::RefCell;
use std::path::Path;
use std::time::Duration;
use tether_scanmatch::MotionPrior;

use tether_control::Twist;
use tether_core::{
    CameraIntrinsics, GrayImage, Laser, LaserScan, PixelBox, Point2, Pose2, Robot, Stamp, World,
};
use tether_fusion::Track;
use tether_pipeline::{Pipeline, Tick};

use tether_recording::samples::{self, LabelMessage, LogTimes, ReadStats, Sample, Topics};

use crate::control_timer::ControlTimer;
use crate::driver::{Driver, PoseSource};
use crate::robot_pose::RobotPose;

/// Where the robot's pose comes from during a run over a recording.
#[derive(Debug)]
pub enum KeptPoses {
    /// The odometry topic's messages (`Topics::odom`); inputs before the first are left
    /// out.
    Odometry,
    /// Scan matching, each scan against the static scene, the people being tracked left
    /// out; odometry messages are counted, not used.
    ScanMatching(ScanOdometry),
    /// None: the robot stands still at the identity.
    Still,
    /// The robot drove the pipeline's own commands (a recording of `tether run`): the
    /// dead reckoning of the commands, corrected by scan matching when the
    /// [`RobotPose`] matches scans, as the live loop keeps it.
    Commands(RobotPose),
}

impl KeptPoses {
    /// The dead reckoning of the pipeline's commands, corrected by `scan_odometry` as
    /// the live loop corrects it.
    pub fn commands(scan_odometry: Option<ScanOdometry>) -> Self {
        KeptPoses::Commands(RobotPose::new(
            Stamp::from_ns(i64::MIN),
            scan_odometry,
            false,
        ))
    }

    /// The scan matching, when the scans are matched.
    pub fn scan_odometry(&self) -> Option<&ScanOdometry> {
        match self {
            KeptPoses::ScanMatching(odometry) => Some(odometry),
            KeptPoses::Commands(robot) => robot.scan_odometry(),
            KeptPoses::Odometry | KeptPoses::Still => None,
        }
    }
}

/// [`KeptPoses`] as the driver's pose source, with the pose of the ones that are not
/// [`KeptPoses::Commands`] (`None` before the first odometry message).
struct RecordingPoses<'k> {
    kept: &'k mut KeptPoses,
    pose: Option<Pose2<World, Robot>>,
}

impl RecordingPoses<'_> {
    /// An odometry message: the pose with [`KeptPoses::Odometry`].
    fn odometry(&mut self, world_from_robot: Pose2<World, Robot>) {
        if let KeptPoses::Odometry = self.kept {
            self.pose = Some(world_from_robot);
        }
    }
}

impl PoseSource for RecordingPoses<'_> {
    fn for_scan(
        &mut self,
        scan: &LaserScan,
        first: bool,
        people: &mut dyn Iterator<Item = Point2<World>>,
    ) -> Option<Pose2<World, Robot>> {
        // The matcher aligns the first laser's scans (at its mount); another scanner's
        // take the pose of the last one (design 5.7).
        match &mut *self.kept {
            KeptPoses::Commands(robot) => robot.for_scan(scan, first, people),
            KeptPoses::ScanMatching(odometry) if first => {
                let prior = MotionPrior::ConstantVelocity;
                self.pose = Some(odometry.update(scan, prior, people));
                self.pose
            }
            _ => self.pose,
        }
    }

    fn between_scans(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        match &mut *self.kept {
            KeptPoses::Commands(robot) => robot.between_scans(stamp),
            _ => self.pose,
        }
    }

    fn at_timer(&mut self, stamp: Stamp) -> Option<Pose2<World, Robot>> {
        match &*self.kept {
            KeptPoses::Commands(robot) => Some(robot.at_timer(stamp)),
            _ => self.pose,
        }
    }

    fn commanded(&mut self, at: Stamp, command: Twist) {
        if let KeptPoses::Commands(robot) = &mut *self.kept {
            robot.commanded(at, command);
        }
    }
}

/// How a run over a recording goes besides its poses.
#[derive(Debug, Clone, Copy)]
pub struct Options<'a> {
    /// A topic whose messages are handed over as [`Step::Labels`], in log order.
    pub labels_topic: Option<&'a str>,
    /// The live loop's control period: the pipeline also ticks on the control timer
    /// ([`Step::Timer`]) between the data, each handled when it arrived.
    pub control_period: Duration,
}

impl Default for Options<'_> {
    /// No labels; the live loop's period ([`crate::control_timer::CONTROL_PERIOD`]).
    fn default() -> Self {
        Options {
            labels_topic: None,
            control_period: crate::control_timer::CONTROL_PERIOD,
        }
    }
}

/// One tick of the control timer.
#[derive(Debug, Clone, Copy)]
pub struct TimerStep<'a> {
    /// What the pipeline made of it.
    pub tick: &'a Tick,
    /// The robot's pose at the tick.
    pub world_from_robot: Pose2<World, Robot>,
    /// The tracker's tracks after the tick.
    pub tracks: &'a [Track],
}

/// One scan through the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct ScanStep<'a> {
    /// The scan (its stamp is the tick's).
    pub scan: &'a LaserScan,
    /// What the pipeline made of it.
    pub tick: &'a Tick,
    /// The robot's pose the scan was processed with.
    pub world_from_robot: Pose2<World, Robot>,
    /// Where the scan's laser sits on the robot.
    pub robot_from_laser: Pose2<Robot, Laser>,
    /// The tracker's tracks after the tick.
    pub tracks: &'a [Track],
}

/// One camera frame through the pipeline.
#[derive(Debug, Clone, Copy)]
pub struct CameraStep<'a> {
    /// The frame's stamp.
    pub stamp: Stamp,
    /// What the pipeline made of its boxes.
    pub tick: &'a Tick,
    /// How many boxes the camera found in it.
    pub boxes: usize,
    /// The robot's pose the frame was processed with.
    pub world_from_robot: Pose2<World, Robot>,
    /// The tracker's tracks after the tick.
    pub tracks: &'a [Track],
}

/// What the loop reports, in log order.
#[derive(Debug)]
pub enum Step<'a> {
    /// A scan went through the pipeline.
    Scan(ScanStep<'a>),
    /// A camera frame went through the pipeline.
    Camera(CameraStep<'a>),
    /// The control timer ticked (every [`Options::control_period`]).
    Timer(TimerStep<'a>),
    /// A message of the labels topic.
    Labels(LabelMessage),
}

/// Finds people boxes in a frame of a camera of the given intrinsics (each frame's
/// camera is the one its header names: [`Pipeline::camera_of`]).
pub type CameraBoxes<'a> =
    dyn FnMut(&GrayImage, &CameraIntrinsics) -> anyhow::Result<Vec<PixelBox>> + 'a;

/// What a run over a recording counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunCounts {
    /// Messages the reader skipped.
    pub read: ReadStats,
    /// Scans read.
    pub scans_read: usize,
    /// Camera frames read (with a camera to look at them).
    pub camera_frames_read: usize,
    /// Scans through the pipeline.
    pub scans: usize,
    /// Camera frames through the pipeline.
    pub camera_frames: usize,
    /// Odometry messages.
    pub odom: usize,
    /// Scans and frames before the first odometry message (with an odometry topic),
    /// left out: the robot's pose was not known yet.
    pub waiting_for_odom: usize,
    /// Timer ticks (every [`Options::control_period`]).
    pub timer_ticks: usize,
    /// Data processed at the last tick's time because they were stamped before it.
    pub clamped: usize,
}

/// The longest a datum's log time may follow (or precede) its stamp and still be when
/// it arrived, ns: past that the recording was written after the fact (a bag extracted
/// or re-recorded from another), and its log times say nothing of the robot's.
pub const MAX_LATENCY_NS: i64 = 1_000_000_000;

/// When a datum stamped `stamp` and logged at `log` arrived: its log time (the time the
/// recorder, or a live tether run, received it), unless the two are more than
/// [`MAX_LATENCY_NS`] apart, when it is taken to arrive as it was taken.
pub fn arrival(stamp: Stamp, log: Stamp) -> Stamp {
    if log.ns_since(stamp).abs() <= MAX_LATENCY_NS {
        log
    } else {
        stamp
    }
}

/// The loop's state between samples.
struct Run<'p, 'c, 'q, 'k> {
    driver: Driver<'p, RecordingPoses<'k>>,
    camera: Option<&'c mut CameraBoxes<'q>>,
    counts: RunCounts,
    period: Duration,
}

type OnStep<'s> = dyn FnMut(Step<'_>) -> anyhow::Result<()> + 's;

impl Run<'_, '_, '_, '_> {
    /// The datum stamped `stamp` and logged at `times` arrives: the timer's instants up
    /// to its arrival ([`arrival`]) tick first.
    fn arrive(
        &mut self,
        stamp: Stamp,
        times: LogTimes,
        on_step: &mut OnStep<'_>,
    ) -> anyhow::Result<()> {
        let arrival = arrival(stamp, times.log);
        if !self.driver.has_timer() {
            // The timer runs from the recording's first message when that is the clock
            // the data arrived on (a live run's first tick), else from the first datum.
            let start = if times.first <= arrival && arrival.ns_since(times.first) <= MAX_LATENCY_NS
            {
                times.first
            } else {
                arrival
            };
            let period_ns = i64::try_from(self.period.as_nanos()).unwrap_or(i64::MAX);
            self.driver.start_timer(
                ControlTimer::new(start, period_ns),
                Stamp::from_ns(i64::MIN),
            );
        }
        let arrived = self.driver.arrival(arrival);
        while let Some(at) = self.driver.due(arrived) {
            let Some(driven) = self.driver.timer(at) else {
                continue;
            };
            on_step(Step::Timer(TimerStep {
                tick: &driven.tick,
                world_from_robot: driven.world_from_robot,
                tracks: self.driver.pipeline().tracker().tracks(),
            }))?;
        }
        self.driver.arrived(arrived);
        Ok(())
    }

    fn camera(
        &mut self,
        (stamp, frame_id): (Stamp, &str),
        image: &GrayImage,
        on_step: &mut OnStep<'_>,
    ) -> anyhow::Result<()> {
        let Some(camera) = self.camera.as_mut() else {
            return Ok(());
        };
        self.counts.camera_frames_read += 1;
        let Some(world_from_robot) = self.driver.camera_pose(stamp) else {
            return Ok(());
        };
        let intrinsics = self.driver.pipeline().camera_of(frame_id).intrinsics;
        let boxes = camera(image, &intrinsics)?;
        let driven = self
            .driver
            .camera(stamp, frame_id, &boxes, world_from_robot);
        on_step(Step::Camera(CameraStep {
            stamp: driven.stamp,
            tick: &driven.tick,
            boxes: boxes.len(),
            world_from_robot,
            tracks: self.driver.pipeline().tracker().tracks(),
        }))
    }

    fn scan(&mut self, mut scan: LaserScan, on_step: &mut OnStep<'_>) -> anyhow::Result<()> {
        self.counts.scans_read += 1;
        let Some(driven) = self.driver.scan(&mut scan) else {
            return Ok(());
        };
        on_step(Step::Scan(ScanStep {
            scan: &scan,
            tick: &driven.tick,
            world_from_robot: driven.world_from_robot,
            robot_from_laser: self.driver.pipeline().robot_from_laser_of(&scan.frame_id),
            tracks: self.driver.pipeline().tracker().tracks(),
        }))
    }
}

/// Runs `pipeline` over the recording at `path`: its scans (`topics.scan`), camera
/// frames (`topics.images`, through `camera`, each frame read through the model of the
/// camera its header names; ignored without `camera`) and odometry
/// (`topics.odom`), the robot's pose as `poses` says, as `options` say (labels, the
/// control timer). `on_step` may stop the run by returning an error.
pub fn run_recording(
    path: &Path,
    topics: &Topics,
    options: Options<'_>,
    pipeline: &mut Pipeline,
    camera: Option<&mut CameraBoxes<'_>>,
    poses: &mut KeptPoses,
    on_step: &mut dyn FnMut(Step<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<RunCounts> {
    let pose = match poses {
        KeptPoses::Odometry => None,
        _ => Some(Pose2::IDENTITY),
    };
    let poses = RecordingPoses { kept: poses, pose };
    let mut run = Run {
        driver: Driver::new(pipeline, poses),
        camera,
        counts: RunCounts::default(),
        period: options.control_period,
    };
    // Both callbacks of the reader hand steps on; never at the same time.
    let on_step = RefCell::new(on_step);
    let mut on_sample = |times: LogTimes, sample: Sample| -> anyhow::Result<()> {
        let mut on_step = on_step.borrow_mut();
        let stamp = match &sample {
            Sample::Odom { stamp, .. } | Sample::Camera { stamp, .. } => *stamp,
            Sample::Scan(scan) => scan.stamp,
        };
        run.arrive(stamp, times, &mut **on_step)?;
        match sample {
            Sample::Odom {
                world_from_robot, ..
            } => {
                run.counts.odom += 1;
                run.driver.poses_mut().odometry(world_from_robot);
                Ok(())
            }
            Sample::Camera {
                stamp,
                frame_id,
                image,
            } => run.camera((stamp, &frame_id), &image, &mut **on_step),
            Sample::Scan(scan) => run.scan(scan, &mut **on_step),
        }
    };
    let mut on_labels = |labels: LabelMessage| -> anyhow::Result<()> {
        (on_step.borrow_mut())(Step::Labels(labels))
    };
    let labels = options.labels_topic.map(|topic| {
        (
            topic,
            &mut on_labels as &mut dyn FnMut(LabelMessage) -> anyhow::Result<()>,
        )
    });
    let read = samples::read_logged(path, topics, labels, &mut on_sample)?;
    let driven = run.driver.counts();
    Ok(RunCounts {
        read,
        scans: count(driven.scans),
        camera_frames: count(driven.frames),
        waiting_for_odom: count(driven.without_pose),
        timer_ticks: count(driven.timer_ticks),
        clamped: count(driven.clamped),
        ..run.counts
    })
}

fn count(n: u64) -> usize {
    usize::try_from(n).unwrap_or(usize::MAX)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;
    use tether_msgs::LaserScanMsg;

    const MS: i64 = 1_000_000;

    /// A recording of three scans stamped 0.1, 0.2 and 0.3 s, each logged `lag_ms`
    /// later; what the loop made of it with the control timer, as `(input, tick stamp
    /// in ms)`, and its counts.
    fn steps_with_lag(lag_ms: i64) -> (Vec<(&'static str, i64)>, RunCounts) {
        let path = std::env::temp_dir().join(format!(
            "tether-recording-run-{}-{lag_ms}.mcap",
            std::process::id()
        ));
        let mut writer = crate::results::ResultWriter::create_streaming(&path, "odom").unwrap();
        for k in 1..=3 {
            let stamp = Stamp::from_ns(k * 100 * MS);
            let scan =
                LaserScan::new(stamp, "laser", -2.0, 0.006, 0.02, 5.6, vec![3.0; 682]).unwrap();
            let log = stamp.saturating_add_ns(lag_ms * MS);
            writer
                .mcap()
                .write("/scan", log, &LaserScanMsg::new(scan, 0.0, 0.1))
                .unwrap();
        }
        writer.finish().unwrap();
        let mut pipeline = Pipeline::new(tether_pipeline::PipelineConfig::default(), None).unwrap();
        let topics = Topics {
            scan: "/scan".into(),
            images: Vec::new(),
            odom: None,
        };
        let options = Options {
            labels_topic: None,
            control_period: Duration::from_millis(50),
        };
        let mut steps = Vec::new();
        let counts = run_recording(
            &path,
            &topics,
            options,
            &mut pipeline,
            None,
            &mut KeptPoses::Still,
            &mut |step| {
                match step {
                    Step::Scan(s) => steps.push(("scan", s.tick.stamp.ns() / MS)),
                    Step::Timer(t) => steps.push(("timer", t.tick.stamp.ns() / MS)),
                    Step::Camera(_) | Step::Labels(_) => {}
                }
                Ok(())
            },
        )
        .unwrap();
        let _ = std::fs::remove_file(&path);
        (steps, counts)
    }

    /// Logged 80 ms after they were taken, the scans come after the timer's instants up
    /// to their arrival, and one taken before the last tick is processed at its time.
    #[test]
    fn the_timer_ticks_up_to_each_arrival_and_late_scans_take_the_tick_s_time() {
        let (steps, counts) = steps_with_lag(80);
        assert_eq!(
            steps,
            [
                ("scan", 100),
                ("timer", 200),
                ("timer", 250),
                ("scan", 250),
                ("timer", 300),
                ("timer", 350),
                ("scan", 350),
            ]
        );
        assert_eq!(
            (counts.timer_ticks, counts.clamped, counts.scans),
            (4, 2, 3)
        );
    }

    /// Logged 5 s after they were taken (a bag written after the fact), the scans
    /// arrive at their stamps: no scan is late.
    #[test]
    fn a_recording_written_after_the_fact_arrives_at_its_stamps() {
        let (steps, counts) = steps_with_lag(5_000);
        assert_eq!(
            steps,
            [
                ("timer", 100),
                ("scan", 100),
                ("timer", 150),
                ("timer", 200),
                ("scan", 200),
                ("timer", 250),
                ("timer", 300),
                ("scan", 300),
            ]
        );
        assert_eq!((counts.timer_ticks, counts.clamped), (5, 0));
        assert_eq!(
            arrival(Stamp::from_ns(0), Stamp::from_ns(MAX_LATENCY_NS)),
            Stamp::from_ns(MAX_LATENCY_NS)
        );
        assert_eq!(
            arrival(Stamp::from_ns(0), Stamp::from_ns(MAX_LATENCY_NS + 1)),
            Stamp::from_ns(0)
        );
    }
}
