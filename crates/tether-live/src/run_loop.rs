//! The live robot's main loop: sensor data from threads, the pipeline, a control timer,
//! the outputs.
//!
//! The laser and the camera run on their own threads and send [`Input`]s over a
//! channel. The loop waits on the channel at most until the next control instant, so the
//! pipeline gets its timer ticks (`on_timer`, 20 Hz) even when every sensor falls
//! silent, and its watchdog then commands a stop. Every tick's command goes to every
//! output at once; when the run ends (its duration, Ctrl-C, a failed laser or output)
//! every output gets a final stop.
//!
//! Time: every stamp is the host's clock (`Clock`), the one the laser driver maps the
//! sensor's stamps to. The timer ticks at the instants of [`ControlTimer`] (the
//! multiples of the period). A datum is handled when it arrives, after every timer
//! instant up to then; the recording logs it at that time, so that a replay of the
//! recording ([`crate::recording_run`]) handles it as this loop did. The pipeline
//! refuses data older than what it has already processed, but a scan arrives a little
//! after it was taken, often after a timer tick: such data are processed at the last
//! tick's time (the clamp is counted), while the robot's pose ([`RobotPose`]) is still
//! looked up at the data's own stamp. Nothing else reads the clock between events: the
//! commands are dead-reckoned from the event that sent them.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::Duration;

use tether_control::Twist;
use tether_core::{LaserScan, PixelBox, Stamp, World};
use tether_pipeline::{Pipeline, TickInput};
use tether_scanmatch::ScanMatcherConfig;
use tether_scip::{Clock, ScipError};

use crate::base::{CommandLine, CommandSink, TargetLine};
use crate::control_timer::ControlTimer;
use crate::driver::{Driven, Driver};
use crate::ego::ScanOdometry;
use crate::monitor::FollowMonitor;
use crate::recorder::{Recorder, RecordingError};
use crate::results::TargetStateLine;
pub use crate::robot_pose::ODOMETRY_TIMEOUT_NS;
use crate::robot_pose::RobotPose;
pub use crate::sources::Input;
use crate::sources::frames::EncodedFrame;
use crate::stop_log::StopLog;
use crate::target_log::TargetLog;

/// A clock that stands still this long in wall time (a simulator that stopped
/// publishing `/clock`) gets the robot a stop: the timer, and with it the watchdog,
/// runs on that clock and would never fire.
pub const CLOCK_STALL: Duration = Duration::from_secs(1);

/// Settings of the loop.
#[derive(Debug, Clone)]
pub struct LoopConfig {
    /// Control timer period. Default 50 ms (20 Hz).
    pub control_period: Duration,
    /// Stop after this long; `None`: until interrupted.
    pub duration: Option<Duration>,
    /// Track width, for the wheel speeds of the outputs, m.
    pub track_width_m: f64,
    /// Correct the dead reckoning of the commands by matching each scan against the
    /// static scene (the commands' motion as the prior); `None`: dead reckoning alone.
    pub scan_odometry: Option<ScanMatcherConfig>,
    /// What [`Input::Odometry`] does: `true`, it is the robot's pose from the first
    /// message on (dead reckoning and scan matching are left), and a datum that finds the
    /// newest odometry older than [`ODOMETRY_TIMEOUT_NS`] is skipped (counted), so the
    /// watchdog stops the robot rather than let it track people in a frozen frame;
    /// `false`, odometry messages are ignored.
    pub odometry_input: bool,
}

/// Why the run ended.
#[derive(Debug)]
pub enum Ending {
    /// The duration passed.
    Duration,
    /// Ctrl-C (or the stop flag).
    Interrupted,
    /// The laser failed.
    LaserFailed(ScipError),
    /// Every sensor thread is gone.
    InputsClosed,
    /// An output could not be written.
    OutputFailed {
        /// Which output.
        output: String,
        /// What went wrong.
        error: OutputError,
    },
    /// The loop panicked (a bug): the final stop still goes out. The panic's message.
    Panicked(String),
}

/// Why an output (a [`CommandSink`] or the recording) failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// Writing or publishing failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// Writing the recording failed.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The output panicked (a bug in it); the panic's message.
    #[error("it panicked: {0}")]
    Panicked(String),
}

impl Ending {
    /// The `stop` of the final command line.
    pub fn name(&self) -> &'static str {
        match self {
            Ending::Duration => "duration",
            Ending::Interrupted => "interrupted",
            Ending::LaserFailed(_) => "laser_failed",
            Ending::InputsClosed => "inputs_closed",
            Ending::OutputFailed { .. } => "output_failed",
            Ending::Panicked(_) => "panicked",
        }
    }

    /// Whether the run ended as asked (duration, Ctrl-C) rather than on a failure.
    pub fn is_clean(&self) -> bool {
        matches!(self, Ending::Duration | Ending::Interrupted)
    }
}

/// What a run did.
#[derive(Debug)]
pub struct RunSummary {
    /// Why it ended.
    pub ending: Ending,
    /// Pipeline ticks (scans, camera frames, timer).
    pub ticks: u64,
    /// Scans processed.
    pub scans: u64,
    /// Camera frames processed.
    pub frames: u64,
    /// Laser faults the driver recovered from.
    pub laser_faults: u64,
    /// Times the laser stopped answering and was opened again.
    pub laser_reconnects: u64,
    /// Camera frames skipped because they could not be used.
    pub bad_frames: u64,
    /// Data processed at the last tick's time because they were older.
    pub clamped_stamps: u64,
    /// Ticks with a locked target.
    pub ticks_with_target: u64,
    /// Outputs whose final stop failed, with the error.
    pub final_stop_failures: Vec<(String, OutputError)>,
    /// Distance driven by dead reckoning, m.
    pub distance_m: f64,
    /// The target's locks, losses (with reasons) and refusals.
    pub target: TargetLog,
    /// Why the robot was held, and for how long.
    pub holds: StopLog,
    /// Odometry messages taken as the robot's pose.
    pub odometry_messages: u64,
    /// Scans and frames skipped because the odometry had stopped.
    pub skipped_stale_odometry: u64,
    /// Times the clock stood still for [`CLOCK_STALL`] and the robot was stopped.
    pub clock_stalls: u64,
    /// Warnings that the robot could not keep up (the target pulling away at the
    /// speed limit; [`FollowMonitor`]).
    pub cannot_keep_up: u64,
}

/// The loop's state.
struct Live<'a, W: std::io::Write + std::io::Seek + Send + 'static> {
    /// The pipeline, the control timer and the robot's pose: dead reckoning of the
    /// commands, scan matching, odometry. Its event time is when the datum being
    /// handled arrived; a recording logs each datum at it, so that a replay handles
    /// them as this loop did.
    driver: Driver<'a, RobotPose>,
    clock: &'a dyn Clock,
    sinks: &'a mut [Box<dyn CommandSink>],
    recorder: Option<&'a mut Recorder<W>>,
    config: &'a LoopConfig,
    summary: RunSummary,
    scan_period_s: f64,
    /// Where the distance driven was last measured to.
    travelled_to: tether_core::Point2<World>,
    /// Says when the target is lost and when the robot cannot keep up.
    monitor: FollowMonitor,
}

impl<W: std::io::Write + std::io::Seek + Send + 'static> Live<'_, W> {
    fn now(&self) -> Stamp {
        Stamp::from_ns(self.clock.now_ns())
    }

    fn scan(&mut self, mut scan: LaserScan) -> Result<(), Ending> {
        scan.round_to_message();
        if let Some(r) = self.recorder.as_deref_mut() {
            r.scan(&scan, self.scan_period_s, self.driver.event())
                .map_err(recording_failed)?;
        }
        match self.driver.scan(&mut scan) {
            Some(driven) => self.emit(&driven),
            None => Ok(()),
        }
    }

    fn camera(
        &mut self,
        frame_id: &str,
        stamp: Stamp,
        boxes: &[PixelBox],
        frame: Option<EncodedFrame>,
    ) -> Result<(), Ending> {
        let Some(pose) = self.driver.camera_pose(stamp) else {
            return Ok(());
        };
        if let (Some(r), Some(frame)) = (self.recorder.as_deref_mut(), frame) {
            r.camera(frame_id, stamp, self.driver.event(), frame)
                .map_err(recording_failed)?;
        }
        let driven = self.driver.camera(stamp, frame_id, boxes, pose);
        self.emit(&driven)
    }

    /// A tick of the control timer at its instant `at`.
    fn timer(&mut self, at: Stamp) -> Result<(), Ending> {
        match self.driver.timer(at) {
            Some(driven) => self.emit(&driven),
            None => Ok(()),
        }
    }

    /// Sends a tick's command to every output (the driver has already handed it to the
    /// dead reckoning).
    fn emit(&mut self, driven: &Driven) -> Result<(), Ending> {
        let (tick, pose) = (&driven.tick, driven.world_from_robot);
        self.summary.ticks += 1;
        let here = self
            .driver
            .poses()
            .dead_reckoned(self.driver.event())
            .translation();
        self.summary.distance_m += self.travelled_to.distance_m(here);
        self.travelled_to = here;
        let input = match tick.input {
            TickInput::Scan => "scan",
            TickInput::Camera => "camera",
            TickInput::Timer => "timer",
        };
        let mut line = CommandLine::new(
            tick.stamp.ns(),
            input,
            tick.command.v_mps,
            tick.command.w_radps,
            self.config.track_width_m,
        );
        line.stop = tick.stop.map(|s| s.name());
        line.target_state = Some(TargetStateLine::of(tick));
        self.summary.target.record_tick(tick);
        self.summary.holds.record(tick.stamp, tick.stop);
        let range_m = tick
            .target
            .estimate
            .filter(|_| tick.target.state.locked_track().is_some())
            .map(|e| (pose.inverse() * e.mean).range_m());
        for warning in
            self.monitor
                .observe(tick.stamp, tick.command.v_mps, range_m, &tick.target.state)
        {
            tracing::warn!("{warning}");
        }
        if let (Some(id), Some(estimate)) = (tick.target.state.locked_track(), tick.target.estimate)
        {
            self.summary.ticks_with_target += 1;
            let in_robot = pose.inverse() * estimate.mean;
            line.target = Some(TargetLine {
                id,
                x_m: estimate.mean.x,
                y_m: estimate.mean.y,
                range_m: in_robot.range_m(),
                bearing_rad: in_robot.bearing_rad(),
            });
        }
        if let Some(r) = self.recorder.as_deref_mut() {
            r.tick(tick, pose, tick.command).map_err(recording_failed)?;
        }
        for sink in self.sinks.iter_mut() {
            sink.tick(tick)
                .and_then(|()| sink.send(&line))
                .map_err(|e| Ending::OutputFailed {
                    output: sink.name().to_owned(),
                    error: e.into(),
                })?;
        }
        Ok(())
    }

    /// The clock stands still: a stop to every output, until it moves again.
    fn clock_stalled(&mut self, now: Stamp) -> Result<(), Ending> {
        self.summary.clock_stalls += 1;
        tracing::warn!(
            "the clock has not moved for {:.1} s (has the simulator stopped publishing \
             /clock?): the robot is stopped until it moves again",
            CLOCK_STALL.as_secs_f64()
        );
        let line = CommandLine {
            stop: Some("clock_stalled"),
            ..CommandLine::new(now.ns(), "timer", 0.0, 0.0, self.config.track_width_m)
        };
        for sink in self.sinks.iter_mut() {
            sink.send(&line).map_err(|e| Ending::OutputFailed {
                output: sink.name().to_owned(),
                error: e.into(),
            })?;
        }
        Ok(())
    }

    fn run(&mut self, inputs: &Receiver<Input>, stop: &AtomicBool) -> Ending {
        let period_ns = i64::try_from(self.config.control_period.as_nanos())
            .unwrap_or(i64::MAX)
            .max(1_000_000);
        let start = self.now();
        let end = self
            .config
            .duration
            .map(|d| start.saturating_add_ns(i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)));
        self.driver
            .start_timer(ControlTimer::new(start, period_ns), start);
        // The frames of the cameras that stopped.
        let mut cameras_gone: Vec<String> = Vec::new();
        // When the clock last moved (wall time), and whether the stop for a stalled
        // clock has gone out.
        let (mut clock_seen, mut clock_moved_at, mut stall_stopped) =
            (start, std::time::Instant::now(), false);
        loop {
            if stop.load(Ordering::Relaxed) {
                return Ending::Interrupted;
            }
            let now = self.now();
            if now > clock_seen {
                (clock_seen, clock_moved_at, stall_stopped) =
                    (now, std::time::Instant::now(), false);
            } else if !stall_stopped && clock_moved_at.elapsed() >= CLOCK_STALL {
                stall_stopped = true;
                if let Err(e) = self.clock_stalled(now) {
                    return e;
                }
            }
            if end.is_some_and(|end| now >= end) {
                return Ending::Duration;
            }
            if let Some(at) = self.driver.due(now) {
                if let Err(e) = self.timer(at) {
                    return e;
                }
                continue;
            }
            let next = self.driver.next_instant().unwrap_or(now);
            let wait_ns = next.ns_since(now).clamp(0, period_ns);
            let wait = Duration::from_nanos(wait_ns as u64);
            let input = match inputs.recv_timeout(wait) {
                Ok(input) => input,
                Err(RecvTimeoutError::Timeout) => continue,
                Err(RecvTimeoutError::Disconnected) => return Ending::InputsClosed,
            };
            // The datum is handled at its arrival, after every timer instant up to it
            // (as a replay of the recording handles it).
            let arrived = self.driver.arrival(self.now());
            while let Some(at) = self.driver.due(arrived) {
                if let Err(e) = self.timer(at) {
                    return e;
                }
            }
            self.driver.arrived(arrived);
            if let Err(ending) = self.input(input, &mut cameras_gone) {
                return ending;
            }
        }
    }

    /// Handles one input at [`Live::event`].
    fn input(&mut self, input: Input, cameras_gone: &mut Vec<String>) -> Result<(), Ending> {
        match input {
            Input::Scan(scan) => self.scan(scan),
            Input::Camera {
                frame_id,
                stamp,
                boxes,
                frame,
            } => {
                if cameras_gone.contains(&frame_id) {
                    Ok(())
                } else {
                    self.camera(&frame_id, stamp, &boxes, frame)
                }
            }
            Input::LaserFault(fault) => {
                self.summary.laser_faults += 1;
                tracing::debug!("laser: {fault}");
                Ok(())
            }
            Input::LaserLost {
                laser,
                error,
                within_s,
            } => {
                tracing::warn!(
                    "the laser stopped answering ({laser}: {error}); the robot stands while \
                         it is opened again, for up to {within_s:.1} s ([laser] reconnect_s)"
                );
                Ok(())
            }
            Input::LaserBack { laser, after_s } => {
                self.summary.laser_reconnects += 1;
                tracing::warn!("the laser answers again after {after_s:.1} s ({laser})");
                Ok(())
            }
            Input::LaserFailed(error) => Err(Ending::LaserFailed(error)),
            Input::CameraFrameBad { frame_id, why } => {
                self.summary.bad_frames += 1;
                let n = self.summary.bad_frames;
                if n <= 5 || n.is_multiple_of(100) {
                    tracing::warn!("camera frame skipped ({frame_id:?}; {n} so far): {why}");
                }
                Ok(())
            }
            Input::CameraEnded { frame_id, why } => {
                let left = self.driver.pipeline_mut().camera_gone_from(&frame_id);
                let from_now_on = match left {
                    true => "the other cameras and the laser from now on",
                    false => "laser only from now on",
                };
                match why {
                    None => tracing::info!("camera {frame_id:?}: its frames ended; {from_now_on}"),
                    Some(e) => tracing::error!("camera {frame_id:?} failed ({e}); {from_now_on}"),
                }
                cameras_gone.push(frame_id);
                Ok(())
            }
            Input::ClockAdvanced => Ok(()),
            Input::Odometry {
                stamp,
                world_from_robot,
                moving,
            } => {
                self.driver
                    .poses_mut()
                    .odometry(stamp, world_from_robot, moving);
                Ok(())
            }
        }
    }

    /// The final stop to every output and the recording (an output that panics on
    /// it does not keep the others from theirs).
    fn finish(&mut self, ending: &Ending) {
        let stamp = self.now().max(self.driver.last_stamp());
        let line = CommandLine::final_stop(stamp.ns(), ending.name());
        for sink in self.sinks.iter_mut() {
            let sent =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| sink.finish(&line)));
            let failure = match sent {
                Ok(Ok(())) => None,
                Ok(Err(e)) => Some(OutputError::Io(e)),
                Err(payload) => Some(OutputError::Panicked(panic_text(payload.as_ref()))),
            };
            if let Some(failure) = failure {
                self.summary
                    .final_stop_failures
                    .push((sink.name().to_owned(), failure));
            }
        }
        if let Some(r) = self.recorder.as_deref_mut()
            && let Err(e) = r.final_stop(stamp)
        {
            self.summary
                .final_stop_failures
                .push(("recording".into(), e.into()));
        }
        let poses = self.driver.poses_mut();
        let here = poses.dead_reckoned(stamp).translation();
        self.summary.distance_m += self.travelled_to.distance_m(here);
        poses.commanded(stamp, Twist::STOP);
    }
}

/// The message a panic carried.
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into())
}

fn recording_failed(e: RecordingError) -> Ending {
    Ending::OutputFailed {
        output: "recording".into(),
        error: e.into(),
    }
}

/// Runs the pipeline on `inputs` until `config.duration` passes, `stop` is set, the
/// laser fails or an output fails; then sends a final stop to every output. The scans'
/// period (`scan_period_s`) only labels the recorded scans.
#[allow(
    clippy::too_many_arguments,
    reason = "each is a separate part of the run"
)]
pub fn run<W: std::io::Write + std::io::Seek + Send + 'static>(
    pipeline: &mut Pipeline,
    clock: &dyn Clock,
    inputs: &Receiver<Input>,
    sinks: &mut [Box<dyn CommandSink>],
    recorder: Option<&mut Recorder<W>>,
    stop: &AtomicBool,
    config: &LoopConfig,
    scan_period_s: f64,
) -> RunSummary {
    let start = Stamp::from_ns(clock.now_ns());
    let pipeline_mount = pipeline.config().laser.robot_from_laser();
    let monitor = FollowMonitor::new(
        pipeline.config().limits.max_speed_mps,
        pipeline.config().follower.follow_distance_m,
    );
    let poses = RobotPose::new(
        start,
        config
            .scan_odometry
            .clone()
            .map(|c| ScanOdometry::new(c, pipeline_mount)),
        config.odometry_input,
    );
    let mut driver = Driver::new(pipeline, poses);
    driver.arrived(start);
    let mut live = Live {
        driver,
        clock,
        sinks,
        recorder,
        config,
        summary: RunSummary {
            ending: Ending::InputsClosed,
            ticks: 0,
            scans: 0,
            frames: 0,
            laser_faults: 0,
            laser_reconnects: 0,
            bad_frames: 0,
            clamped_stamps: 0,
            ticks_with_target: 0,
            final_stop_failures: Vec::new(),
            distance_m: 0.0,
            target: TargetLog::new(),
            holds: StopLog::new(),
            odometry_messages: 0,
            skipped_stale_odometry: 0,
            clock_stalls: 0,
            cannot_keep_up: 0,
        },
        scan_period_s,
        travelled_to: tether_core::Point2::ORIGIN,
        monitor,
    };
    // A panic in the loop (a bug) must not skip the final stop: it ends the run like a
    // failure, and the stop goes out.
    let ending = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| live.run(inputs, stop)))
        .unwrap_or_else(|payload| Ending::Panicked(panic_text(payload.as_ref())));
    live.finish(&ending);
    let mut summary = live.summary;
    summary.ending = ending;
    summary.cannot_keep_up = live.monitor.pull_away_warnings;
    let counts = live.driver.counts();
    (summary.scans, summary.frames, summary.clamped_stamps) =
        (counts.scans, counts.frames, counts.clamped);
    let poses = live.driver.poses();
    summary.odometry_messages = poses.odometry_messages;
    summary.skipped_stale_odometry = poses.skipped_stale_odometry;
    summary
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use std::io::Cursor;
    use std::sync::mpsc;
    use std::sync::{Arc, Mutex};

    use tether_pipeline::PipelineConfig;
    use tether_scip::SystemClock;

    use super::*;
    use crate::results::ResultWriter;

    /// Keeps what it is sent; fails after `fail_after` commands if set.
    struct Keep {
        lines: Arc<Mutex<Vec<CommandLine>>>,
        fail_after: Option<usize>,
    }

    impl CommandSink for Keep {
        fn name(&self) -> &str {
            "keep"
        }

        fn send(&mut self, command: &CommandLine) -> std::io::Result<()> {
            let mut lines = self.lines.lock().unwrap();
            if self.fail_after.is_some_and(|n| lines.len() >= n) && command.input != "final" {
                return Err(std::io::Error::other("unplugged"));
            }
            lines.push(command.clone());
            Ok(())
        }
    }

    fn keep(fail_after: Option<usize>) -> (Box<dyn CommandSink>, Arc<Mutex<Vec<CommandLine>>>) {
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = Keep {
            lines: Arc::clone(&lines),
            fail_after,
        };
        (Box::new(sink), lines)
    }

    fn config(duration_ms: Option<u64>) -> LoopConfig {
        LoopConfig {
            control_period: Duration::from_millis(50),
            duration: duration_ms.map(Duration::from_millis),
            track_width_m: 0.3,
            scan_odometry: Some(ScanMatcherConfig::default()),
            odometry_input: true,
        }
    }

    fn go(
        inputs: &Receiver<Input>,
        sinks: &mut [Box<dyn CommandSink>],
        recorder: Option<&mut Recorder<Cursor<Vec<u8>>>>,
        loop_config: &LoopConfig,
    ) -> (RunSummary, Pipeline) {
        let mut pipeline = Pipeline::new(PipelineConfig::default(), None).unwrap();
        let stop = AtomicBool::new(false);
        let summary = run(
            &mut pipeline,
            &SystemClock,
            inputs,
            sinks,
            recorder,
            &stop,
            loop_config,
            0.1,
        );
        (summary, pipeline)
    }

    /// An empty room 3 m around, stamped `stamp`.
    fn scan(stamp: Stamp) -> LaserScan {
        let beams = 682;
        LaserScan::new(
            stamp,
            "laser",
            -2.086,
            0.006_135_92,
            0.02,
            5.6,
            vec![3.0; beams],
        )
        .unwrap()
    }

    fn now() -> Stamp {
        Stamp::from_ns(SystemClock.now_ns())
    }

    #[test]
    fn silent_sensors_get_timer_ticks_and_zero_commands() {
        let (_tx, rx) = mpsc::sync_channel::<Input>(4);
        let (sink, lines) = keep(None);
        let mut sinks = vec![sink];
        let (summary, _) = go(&rx, &mut sinks, None, &config(Some(400)));
        assert!(matches!(summary.ending, Ending::Duration), "{summary:?}");
        let lines = lines.lock().unwrap();
        // 400 ms at 20 Hz: about 8 ticks (a stalled machine runs fewer, never a burst).
        assert!((2..=9).contains(&summary.ticks), "{} ticks", summary.ticks);
        assert_eq!(lines.len() as u64, summary.ticks + 1);
        for l in &lines[..lines.len() - 1] {
            assert_eq!((l.input, l.v_mps, l.w_radps), ("timer", 0.0, 0.0));
            assert_eq!(l.stop, Some("no_target"));
        }
        let last = lines.last().unwrap();
        assert_eq!(
            (last.input, last.stop, last.v_mps),
            ("final", Some("duration"), 0.0)
        );
        assert!(lines.windows(2).all(|w| w[0].stamp_ns <= w[1].stamp_ns));
    }

    #[test]
    fn late_scans_are_clamped_not_refused_and_recorded() {
        let (tx, rx) = mpsc::sync_channel::<Input>(16);
        let feeder = std::thread::spawn(move || {
            for _ in 0..5 {
                std::thread::sleep(Duration::from_millis(60));
                // Taken 80 ms ago: usually before the last timer tick.
                let stamp = now().saturating_add_ns(-80_000_000);
                tx.send(Input::Scan(scan(stamp))).unwrap();
            }
            tx.send(Input::LaserFailed(ScipError::Closed)).unwrap();
        });
        let (sink, lines) = keep(None);
        let mut sinks = vec![sink];
        let writer = ResultWriter::new(Cursor::new(Vec::new()), "odom").unwrap();
        let mut recorder = Recorder::new(writer);
        let (summary, pipeline) = go(&rx, &mut sinks, Some(&mut recorder), &config(None));
        feeder.join().unwrap();
        assert!(
            matches!(summary.ending, Ending::LaserFailed(ScipError::Closed)),
            "{summary:?}"
        );
        assert_eq!(summary.scans, 5);
        assert!(summary.clamped_stamps >= 1, "{summary:?}");
        assert_eq!(pipeline.stats().out_of_order_ticks, 0);
        let lines = lines.lock().unwrap();
        assert_eq!(lines.iter().filter(|l| l.input == "scan").count(), 5);
        assert_eq!(lines.last().unwrap().stop, Some("laser_failed"));
        let bytes = recorder.finish().unwrap().into_inner();
        assert!(bytes.len() > 5 * 682, "the scans are in the recording");
    }

    #[test]
    fn a_failing_output_ends_the_run_and_the_others_still_stop() {
        let (_tx, rx) = mpsc::sync_channel::<Input>(4);
        let (good, good_lines) = keep(None);
        let (bad, _) = keep(Some(3));
        let mut sinks = vec![good, bad];
        let (summary, _) = go(&rx, &mut sinks, None, &config(Some(5_000)));
        assert!(
            matches!(
                &summary.ending,
                Ending::OutputFailed { output, error: OutputError::Io(e) }
                    if output == "keep" && e.to_string() == "unplugged"
            ),
            "{summary:?}"
        );
        let good_lines = good_lines.lock().unwrap();
        assert_eq!(good_lines.len(), 5, "4 commands, then the final stop");
        assert_eq!(good_lines.last().unwrap().stop, Some("output_failed"));
    }

    /// Panics on its `at`-th command, and on the final stop too.
    struct Panics {
        at: usize,
        sent: usize,
    }

    impl CommandSink for Panics {
        fn name(&self) -> &str {
            "panics"
        }

        fn send(&mut self, _command: &CommandLine) -> std::io::Result<()> {
            self.sent += 1;
            assert!(self.sent < self.at, "a bug in an output");
            Ok(())
        }
    }

    #[test]
    fn a_panic_in_the_loop_still_ends_with_a_stop_to_the_base() {
        let (_tx, rx) = mpsc::sync_channel::<Input>(4);
        let (base, base_lines) = keep(None);
        let mut sinks: Vec<Box<dyn CommandSink>> = vec![base, Box::new(Panics { at: 3, sent: 0 })];
        let (summary, _) = go(&rx, &mut sinks, None, &config(Some(5_000)));
        assert!(
            matches!(&summary.ending, Ending::Panicked(why) if why == "a bug in an output"),
            "{summary:?}"
        );
        let lines = base_lines.lock().unwrap();
        assert_eq!(lines.last().unwrap().input, "final");
        assert_eq!(lines.last().unwrap().stop, Some("panicked"));
        assert_eq!(
            (lines.last().unwrap().v_mps, lines.last().unwrap().w_radps),
            (0.0, 0.0)
        );
        // The output that panicked again on its final stop is reported, not fatal.
        assert_eq!(summary.final_stop_failures.len(), 1, "{summary:?}");
        assert!(matches!(
            &summary.final_stop_failures[0].1,
            OutputError::Panicked(why) if why == "a bug in an output"
        ));
        assert!(
            summary.final_stop_failures[0]
                .1
                .to_string()
                .contains("panicked")
        );
    }

    #[test]
    fn odometry_is_the_pose_and_a_scan_after_it_stopped_is_skipped() {
        let (tx, rx) = mpsc::sync_channel::<Input>(16);
        let feeder = std::thread::spawn(move || {
            let odometry = |stamp| Input::Odometry {
                stamp,
                world_from_robot: tether_core::Pose2::new(2.0, 1.0, 0.5),
                moving: Twist::STOP,
            };
            tx.send(odometry(now())).unwrap();
            std::thread::sleep(Duration::from_millis(20));
            tx.send(Input::Scan(scan(now()))).unwrap();
            std::thread::sleep(Duration::from_millis(20));
            // The odometry stops: 0.6 s later a scan finds it stale.
            let stale_from = now();
            std::thread::sleep(Duration::from_millis(20));
            tx.send(Input::Scan(scan(stale_from.saturating_add_ns(600_000_000))))
                .unwrap();
            std::thread::sleep(Duration::from_millis(20));
            tx.send(Input::LaserFailed(ScipError::Closed)).unwrap();
        });
        let (sink, _) = keep(None);
        let mut sinks = vec![sink];
        let (summary, pipeline) = go(&rx, &mut sinks, None, &config(None));
        feeder.join().unwrap();
        assert_eq!(summary.odometry_messages, 1);
        assert_eq!(summary.scans, 1, "{summary:?}");
        assert_eq!(summary.skipped_stale_odometry, 1);
        assert_eq!(pipeline.stats().out_of_order_ticks, 0);
    }

    #[test]
    fn closed_inputs_end_the_run() {
        let (tx, rx) = mpsc::sync_channel::<Input>(4);
        drop(tx);
        let (sink, lines) = keep(None);
        let mut sinks = vec![sink];
        let (summary, _) = go(&rx, &mut sinks, None, &config(Some(5_000)));
        assert!(
            matches!(summary.ending, Ending::InputsClosed),
            "{summary:?}"
        );
        assert!(!summary.ending.is_clean());
        assert_eq!(lines.lock().unwrap().last().unwrap().input, "final");
    }

    #[test]
    fn a_clock_that_stands_still_gets_the_robot_a_stop_and_time_then_runs_on() {
        // Simulated time that advances 50 ms at a time, then stands still for longer
        // than CLOCK_STALL, then advances again.
        let clock = super::super::clock::SimClock::new();
        clock.set(1_000_000_000);
        let (tx, rx) = mpsc::sync_channel(8);
        let (sink, lines) = keep(None);
        let mut sinks = vec![sink];
        let stop = Arc::new(AtomicBool::new(false));
        let driver = {
            let clock = clock.clone();
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || {
                let mut t = 1_000_000_000;
                for step in 0..60 {
                    if step == 20 {
                        std::thread::sleep(CLOCK_STALL + Duration::from_millis(400));
                    }
                    t += 50_000_000;
                    clock.set(t);
                    let _ = tx.try_send(Input::ClockAdvanced);
                    std::thread::sleep(Duration::from_millis(5));
                }
                stop.store(true, Ordering::Relaxed);
            })
        };
        let mut pipeline = Pipeline::new(PipelineConfig::default(), None).unwrap();
        let live_clock = super::super::clock::LiveClock::Sim(clock.clone());
        let summary = run(
            &mut pipeline,
            &live_clock,
            &rx,
            &mut sinks,
            None::<&mut Recorder<Cursor<Vec<u8>>>>,
            &stop,
            &config(None),
            0.1,
        );
        driver.join().unwrap();
        assert_eq!(summary.clock_stalls, 1);
        let lines = lines.lock().unwrap();
        let stalled: Vec<_> = lines
            .iter()
            .filter(|l| l.stop == Some("clock_stalled"))
            .collect();
        assert_eq!(stalled.len(), 1, "one stop for the stall");
        assert_eq!((stalled[0].v_mps, stalled[0].w_radps), (0.0, 0.0));
        // Timer ticks ran on simulated time: 60 steps of 50 ms are about 60 ticks of
        // the 20 Hz timer, however long the wall clock took.
        let timer_ticks = lines.iter().filter(|l| l.input == "timer").count();
        assert!(
            (50..=62).contains(&timer_ticks),
            "{timer_ticks} timer ticks"
        );
        assert_eq!(lines.last().unwrap().input, "final");
    }
}
