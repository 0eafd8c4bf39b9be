//! Where the live robot's commands go: JSON lines (stdout), an iRobot Create's Open
//! Interface, wheel-speed lines.
//!
//! Every output is a [`CommandSink`]: it gets each command the pipeline produces (zero
//! before a target is locked, as the pipeline decides) and, when the run ends for any
//! reason, a final stop.
//!
//! ## JSON lines
//!
//! One object per pipeline tick ([`CommandLine`]):
//!
//! ```json
//! {"stamp_ns":1700000000000000000,"input":"scan","v_mps":0.42,"w_radps":-0.05,
//!  "left_mps":0.43,"right_mps":0.41,"stop":null,
//!  "target":{"id":3,"x_m":5.1,"y_m":0.2,"range_m":1.4,"bearing_rad":-0.03}}
//! ```
//!
//! `input` is `scan`, `camera`, `timer` or, on the last line, `final` (a stop sent
//! because the run ends; `stop` then says why: `duration`, `interrupted`, `laser_failed`,
//! `output_failed`, `inputs_closed`, `panicked` (a bug in the loop; the stop still goes out), or `startup_failed` when a sensor could not be
//! started after the outputs were opened). `stop` names why the robot is held (`no_target`, `target_lost`,
//! `stale_laser`, `stale_target`, `unseen_among_others`, `obstacle`) or is `null`. `target` is the locked
//! target, in the dead-reckoned odometry frame (`x_m`, `y_m`) and from the robot
//! (`range_m`, `bearing_rad`), or `null`.
//!
//! ## iRobot Create Open Interface
//!
//! At start `Start` (128) and `Safe` (131): in Safe mode the Create still stops by itself
//! on a cliff or a wheel drop. Each command is `Drive Direct` (145) with the right
//! wheel's then the left wheel's speed in mm/s, big-endian signed 16-bit, at most 500
//! in magnitude (both scaled down together when one is beyond, keeping the curvature).
//! At the end `Drive Direct 0 0`, then `Start` (128) again, which puts the robot back in
//! Passive mode (on a Create 1 and a Create 2 alike).
//!
//! ## Wheel-speed lines
//!
//! For a base with its own motor controller: one line per command with the left and
//! right wheel speeds, m/s (`v -+ w b / 2`), either JSON
//! (`{"stamp_ns":..,"left_mps":0.431,"right_mps":0.409}`) or text (`0.431 0.409`), on a
//! serial port or into a file (a FIFO works too).

use std::io::{self, Write};

use serde::Serialize;

/// A command as it goes out: the pipeline's `(v, w)`, the wheel speeds for the
/// configured track width, why it stops and the target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CommandLine {
    /// Host time of the tick, ns.
    pub stamp_ns: i64,
    /// `scan`, `camera`, `timer`, or `final` for the stop at the end of the run.
    pub input: &'static str,
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Turn rate, counter-clockwise, rad/s.
    pub w_radps: f64,
    /// Left wheel speed, m/s.
    pub left_mps: f64,
    /// Right wheel speed, m/s.
    pub right_mps: f64,
    /// Why the robot is held, if it is.
    pub stop: Option<&'static str>,
    /// The locked target.
    pub target: Option<TargetLine>,
    /// The target's state: locked, lost (and why) or searching, and the candidates
    /// refused at this tick (absent on the final stop).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target_state: Option<crate::results::TargetStateLine>,
}

/// The locked target in a [`CommandLine`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TargetLine {
    /// Track id.
    pub id: u64,
    /// Position in the odometry frame, m.
    pub x_m: f64,
    /// Position in the odometry frame, m.
    pub y_m: f64,
    /// Distance from the robot's origin (centre of the wheel axis), m.
    pub range_m: f64,
    /// Bearing from the robot's x axis, rad.
    pub bearing_rad: f64,
}

impl CommandLine {
    /// A command line for `(v, w)` with wheel speeds for `track_width_m`.
    pub fn new(
        stamp_ns: i64,
        input: &'static str,
        v_mps: f64,
        w_radps: f64,
        track_width_m: f64,
    ) -> Self {
        let half = 0.5 * track_width_m * w_radps;
        CommandLine {
            stamp_ns,
            input,
            v_mps,
            w_radps,
            left_mps: v_mps - half,
            right_mps: v_mps + half,
            stop: None,
            target: None,
            target_state: None,
        }
    }

    /// The final stop at the end of a run, saying why the run ended.
    pub fn final_stop(stamp_ns: i64, why: &'static str) -> Self {
        CommandLine {
            stop: Some(why),
            ..CommandLine::new(stamp_ns, "final", 0.0, 0.0, 0.0)
        }
    }
}

/// An output of the commands.
pub trait CommandSink {
    /// A short name for messages (`stdout`, `create /dev/ttyUSB0`...).
    fn name(&self) -> &str;
    /// Sends one command.
    fn send(&mut self, command: &CommandLine) -> io::Result<()>;
    /// Everything else the tick produced (tracks, observations, the target), just
    /// before its command, for outputs that publish it; most outputs ignore it.
    fn tick(&mut self, _tick: &tether_pipeline::Tick) -> io::Result<()> {
        Ok(())
    }
    /// Sends the final stop (`command` is a [`CommandLine::final_stop`]) and leaves the
    /// output in a safe state.
    fn finish(&mut self, command: &CommandLine) -> io::Result<()> {
        self.send(command)
    }
}

/// JSON lines, one per command (stdout).
pub struct JsonLines<W: Write> {
    name: String,
    out: W,
}

impl<W: Write> JsonLines<W> {
    /// JSON lines into `out`, called `name` in messages.
    pub fn new(name: impl Into<String>, out: W) -> Self {
        JsonLines {
            name: name.into(),
            out,
        }
    }

    /// The writer back.
    pub fn into_inner(self) -> W {
        self.out
    }
}

impl<W: Write> CommandSink for JsonLines<W> {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        serde_json::to_writer(&mut self.out, command)?;
        self.out.write_all(b"\n")?;
        self.out.flush()
    }
}

/// JSON lines written by a thread of their own, so that a reader who stops reading
/// (an SSH session over a failing link, a slow `tee`, a pipe nobody drains) never holds
/// up the loop: lines wait in a queue of [`QueuedLines::CAPACITY`]; when it is full, a
/// line is dropped and counted (the first drop is warned about, the count is reported
/// at the end). A write that fails (a closed pipe) is returned by the next `send`, as
/// with [`JsonLines`]. The final stop waits at most [`QueuedLines::FINISH_WAIT`] for
/// room and for the queue to drain.
pub struct QueuedLines {
    name: String,
    queue: Option<std::sync::mpsc::SyncSender<Vec<u8>>>,
    state: std::sync::Arc<QueueState>,
    writer: Option<std::thread::JoinHandle<()>>,
    dropped: u64,
}

/// What the writer thread tells the loop.
#[derive(Default)]
struct QueueState {
    /// The write error that ended the writer, if one did.
    failed: std::sync::Mutex<Option<(io::ErrorKind, String)>>,
    /// Lines written.
    written: std::sync::atomic::AtomicU64,
}

impl QueuedLines {
    /// Lines waiting to be written at most (about 1.5 s of a 20 Hz loop with 10 Hz scans).
    pub const CAPACITY: usize = 48;
    /// Longest the final stop waits for the writer, in all.
    pub const FINISH_WAIT: std::time::Duration = std::time::Duration::from_millis(500);

    /// Lines into `out` on a thread of their own, called `name` in messages.
    pub fn new<W: Write + Send + 'static>(name: impl Into<String>, mut out: W) -> io::Result<Self> {
        let name = name.into();
        let (queue, lines) = std::sync::mpsc::sync_channel::<Vec<u8>>(Self::CAPACITY);
        let state = std::sync::Arc::new(QueueState::default());
        let shared = std::sync::Arc::clone(&state);
        let writer = std::thread::Builder::new()
            .name(format!("{name}-writer"))
            .spawn(move || {
                for line in lines {
                    if let Err(e) = out.write_all(&line).and_then(|()| out.flush()) {
                        *shared.failed.lock().unwrap_or_else(|p| p.into_inner()) =
                            Some((e.kind(), e.to_string()));
                        return;
                    }
                    shared
                        .written
                        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                }
            })?;
        Ok(QueuedLines {
            name,
            queue: Some(queue),
            state,
            writer: Some(writer),
            dropped: 0,
        })
    }

    /// Lines dropped because the queue was full.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Lines written so far.
    pub fn written(&self) -> u64 {
        self.state
            .written
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    fn failure(&self) -> Option<io::Error> {
        self.state
            .failed
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .as_ref()
            .map(|(kind, text)| io::Error::new(*kind, text.clone()))
    }

    fn line(command: &CommandLine) -> io::Result<Vec<u8>> {
        let mut line = serde_json::to_vec(command)?;
        line.push(b'\n');
        Ok(line)
    }
}

impl CommandSink for QueuedLines {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        if let Some(e) = self.failure() {
            return Err(e);
        }
        let line = Self::line(command)?;
        let Some(queue) = &self.queue else {
            return Err(io::Error::other("the output was already finished"));
        };
        match queue.try_send(line) {
            Ok(()) => Ok(()),
            Err(std::sync::mpsc::TrySendError::Full(_)) => {
                self.dropped += 1;
                if self.dropped == 1 {
                    tracing::warn!(
                        "{}: nothing is reading it fast enough; lines are dropped (and \
                         counted) rather than holding up the robot",
                        self.name
                    );
                }
                Ok(())
            }
            Err(std::sync::mpsc::TrySendError::Disconnected(_)) => Err(self
                .failure()
                .unwrap_or_else(|| io::Error::other("the writer thread stopped"))),
        }
    }

    fn finish(&mut self, command: &CommandLine) -> io::Result<()> {
        let deadline = std::time::Instant::now() + Self::FINISH_WAIT;
        let mut line = Some(Self::line(command)?);
        // Queue the stop, waiting for room until the deadline...
        let queued = loop {
            if let Some(e) = self.failure() {
                break Err(e);
            }
            let Some(queue) = &self.queue else {
                break Err(io::Error::other("the output was already finished"));
            };
            match queue.try_send(line.take().unwrap_or_default()) {
                Ok(()) => break Ok(()),
                Err(std::sync::mpsc::TrySendError::Full(back)) => {
                    if std::time::Instant::now() >= deadline {
                        self.dropped += 1;
                        break Err(io::Error::new(
                            io::ErrorKind::TimedOut,
                            "nothing read the output, so the final stop could not be queued",
                        ));
                    }
                    line = Some(back);
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
                Err(std::sync::mpsc::TrySendError::Disconnected(_)) => {
                    break Err(self
                        .failure()
                        .unwrap_or_else(|| io::Error::other("the writer thread stopped")));
                }
            }
        };
        // ...then for the writer to write everything queued, the stop last, and end.
        // A writer stuck in a write nobody reads is left behind (it ends with the
        // process).
        self.queue = None;
        let mut result = queued;
        if let Some(writer) = self.writer.take() {
            while !writer.is_finished() && std::time::Instant::now() < deadline {
                std::thread::sleep(std::time::Duration::from_millis(5));
            }
            if writer.is_finished() {
                let _ = writer.join();
                if let (Ok(()), Some(e)) = (&result, self.failure()) {
                    result = Err(e);
                }
            } else if result.is_ok() {
                result = Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "nothing read the output, so the final stop was not written",
                ));
            }
        }
        if self.dropped > 0 {
            tracing::warn!(
                "{}: {} lines dropped because nothing read them fast enough ({} written)",
                self.name,
                self.dropped,
                self.written()
            );
        }
        result
    }
}

/// Open Interface opcode `Start` (to Passive mode).
pub const OI_START: u8 = 128;
/// Open Interface opcode `Safe`.
pub const OI_SAFE: u8 = 131;
/// Open Interface opcode `Drive Direct`.
pub const OI_DRIVE_DIRECT: u8 = 145;
/// Largest wheel speed the Open Interface accepts, mm/s.
pub const OI_MAX_WHEEL_MMPS: f64 = 500.0;

/// `Drive Direct` for the left and right wheel speeds (m/s): opcode 145, then the
/// right wheel's then the left wheel's speed in mm/s as big-endian `i16`, both scaled
/// down together to at most 500 mm/s. Non-finite speeds give a stop.
pub fn drive_direct(left_mps: f64, right_mps: f64) -> [u8; 5] {
    let (mut left, mut right) = if left_mps.is_finite() && right_mps.is_finite() {
        (left_mps * 1000.0, right_mps * 1000.0)
    } else {
        (0.0, 0.0)
    };
    let top = left.abs().max(right.abs());
    if top > OI_MAX_WHEEL_MMPS {
        left *= OI_MAX_WHEEL_MMPS / top;
        right *= OI_MAX_WHEEL_MMPS / top;
    }
    let r = (right.round() as i16).to_be_bytes();
    let l = (left.round() as i16).to_be_bytes();
    [OI_DRIVE_DIRECT, r[0], r[1], l[0], l[1]]
}

/// An iRobot Create on its serial port (Open Interface).
pub struct CreateBase<W: Write> {
    name: String,
    port: W,
}

impl<W: Write> CreateBase<W> {
    /// Starts the Open Interface in Safe mode (`128 131`).
    pub fn start(name: impl Into<String>, mut port: W) -> io::Result<Self> {
        port.write_all(&[OI_START, OI_SAFE])?;
        port.flush()?;
        Ok(CreateBase {
            name: name.into(),
            port,
        })
    }

    /// The port back.
    pub fn into_inner(self) -> W {
        self.port
    }
}

impl<W: Write> CommandSink for CreateBase<W> {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        self.port
            .write_all(&drive_direct(command.left_mps, command.right_mps))?;
        self.port.flush()
    }

    /// `Drive Direct 0 0`, then `Start` (Passive mode).
    fn finish(&mut self, _command: &CommandLine) -> io::Result<()> {
        self.port.write_all(&drive_direct(0.0, 0.0))?;
        self.port.write_all(&[OI_START])?;
        self.port.flush()
    }
}

/// Format of [`WheelLines`].
pub use crate::config::WheelFormat;
use crate::config::{BaseKind, BaseSection};

/// Left and right wheel speeds as lines.
pub struct WheelLines<W: Write> {
    name: String,
    format: WheelFormat,
    out: W,
}

#[derive(Serialize)]
struct WheelLine {
    stamp_ns: i64,
    left_mps: f64,
    right_mps: f64,
}

impl<W: Write> WheelLines<W> {
    /// Wheel-speed lines in `format` into `out`.
    pub fn new(name: impl Into<String>, format: WheelFormat, out: W) -> Self {
        WheelLines {
            name: name.into(),
            format,
            out,
        }
    }

    /// The writer back.
    pub fn into_inner(self) -> W {
        self.out
    }
}

/// Rounds to the millimetre per second and turns `-0` into `0`.
fn mm(v: f64) -> f64 {
    let r = (v * 1000.0).round() / 1000.0;
    if r == 0.0 || !r.is_finite() { 0.0 } else { r }
}

impl<W: Write> CommandSink for WheelLines<W> {
    fn name(&self) -> &str {
        &self.name
    }

    fn send(&mut self, command: &CommandLine) -> io::Result<()> {
        let (left, right) = (mm(command.left_mps), mm(command.right_mps));
        match self.format {
            WheelFormat::Json => {
                let line = WheelLine {
                    stamp_ns: command.stamp_ns,
                    left_mps: left,
                    right_mps: right,
                };
                serde_json::to_writer(&mut self.out, &line)?;
                self.out.write_all(b"\n")?;
            }
            WheelFormat::Text => writeln!(self.out, "{left:.3} {right:.3}")?,
        }
        self.out.flush()
    }
}

/// Why the base of `[base]` cannot be opened.
#[derive(Debug, thiserror::Error)]
pub enum BaseError {
    /// The serial port cannot be opened.
    #[error("cannot open the base's serial port {port} at {baud} baud")]
    Serial {
        /// The port.
        port: String,
        /// The baud rate.
        baud: u32,
        /// What the system said.
        source: serialport::Error,
    },
    /// A Create needs a baud rate.
    #[error("base.baud is missing")]
    NoBaud,
    /// The Create did not take `Start` and `Safe`.
    #[error("starting the Create's Open Interface on {port}")]
    Create {
        /// The port.
        port: String,
        /// What the system said.
        source: io::Error,
    },
    /// The file or FIFO of the wheel speeds cannot be opened.
    #[error("cannot open {path} for the wheel speeds")]
    WheelFile {
        /// The file.
        path: String,
        /// What the system said.
        source: io::Error,
    },
}

/// Opens a base's device that is not a serial port (a FIFO that a motor driver reads, a
/// character device, or a file that logs the commands) for appending. It must exist:
/// tether creates nothing, so that a run started before its reader made the FIFO leaves
/// no regular file in the FIFO's place. Opening a FIFO waits for its reader.
pub fn open_existing_device(path: &std::path::Path) -> io::Result<std::fs::File> {
    std::fs::OpenOptions::new()
        .append(true)
        .open(path)
        .map_err(|e| {
            if e.kind() == io::ErrorKind::NotFound {
                io::Error::new(
                    e.kind(),
                    format!(
                        "{} does not exist, and tether creates no device: make the FIFO the \
                         base's reader listens on (`mkfifo {}`; `tether urg-emulator \
                         --commands {}` reads one), or name an existing file",
                        path.display(),
                        path.display(),
                        path.display()
                    ),
                )
            } else {
                e
            }
        })
}

/// Opens the base adapter of `[base]`: `None` without a device or with `kind = "none"`.
pub fn open_base(base: &BaseSection) -> Result<Option<Box<dyn CommandSink>>, BaseError> {
    let Some(device) = &base.device else {
        return Ok(None);
    };
    let shown = device.display().to_string();
    let serial = |baud: u32| {
        serialport::new(shown.clone(), baud)
            .timeout(std::time::Duration::from_millis(200))
            .open()
            .map_err(|source| BaseError::Serial {
                port: shown.clone(),
                baud,
                source,
            })
    };
    match base.kind {
        BaseKind::None => Ok(None),
        BaseKind::Create => {
            let baud = base.baud.ok_or(BaseError::NoBaud)?;
            let port = serial(baud)?;
            let create = CreateBase::start(format!("create {shown}"), port).map_err(|source| {
                BaseError::Create {
                    port: shown.clone(),
                    source,
                }
            })?;
            Ok(Some(Box::new(create)))
        }
        BaseKind::Wheels => {
            let format = base.format.unwrap_or_default();
            let name = format!("wheels {shown}");
            Ok(Some(match base.baud {
                Some(baud) => Box::new(WheelLines::new(name, format, serial(baud)?)),
                None => {
                    let file =
                        open_existing_device(device).map_err(|source| BaseError::WheelFile {
                            path: shown.clone(),
                            source,
                        })?;
                    Box::new(WheelLines::new(name, format, file))
                }
            }))
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    /// A writer that takes `accept` writes, then blocks until the test ends.
    struct Stalls {
        accept: usize,
        got: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
        hold: std::sync::mpsc::Receiver<()>,
    }

    impl Write for Stalls {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.accept == 0 {
                let _ = self.hold.recv();
                return Err(io::Error::new(io::ErrorKind::BrokenPipe, "closed"));
            }
            self.accept -= 1;
            self.got.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn queued_lines_never_block_and_count_what_they_drop() {
        let got = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let (release, hold) = std::sync::mpsc::channel();
        let out = Stalls {
            accept: 3,
            got: std::sync::Arc::clone(&got),
            hold,
        };
        let mut lines = QueuedLines::new("stdout", out).unwrap();
        let started = std::time::Instant::now();
        for k in 0..200 {
            lines
                .send(&CommandLine::new(k, "timer", 0.1, 0.0, 0.3))
                .unwrap();
        }
        // 200 sends against a stalled reader: none waited, and what did not fit in
        // the queue was dropped and counted.
        assert!(started.elapsed() < std::time::Duration::from_millis(500));
        assert!(lines.dropped() >= 200 - 3 - QueuedLines::CAPACITY as u64 - 1);
        let e = lines
            .finish(&CommandLine::final_stop(200, "interrupted"))
            .unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::TimedOut);
        assert!(started.elapsed() < std::time::Duration::from_secs(2));
        let text = String::from_utf8(got.lock().unwrap().clone()).unwrap();
        assert_eq!(text.lines().count(), 3);
        assert!(text.starts_with("{\"stamp_ns\":0,"), "{text}");
        drop(release);
    }

    #[test]
    fn queued_lines_write_everything_in_order_and_report_a_closed_pipe() {
        let got = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let (release, hold) = std::sync::mpsc::channel();
        let mut lines = QueuedLines::new(
            "stdout",
            Stalls {
                accept: usize::MAX,
                got: std::sync::Arc::clone(&got),
                hold,
            },
        )
        .unwrap();
        for k in 0..20 {
            lines
                .send(&CommandLine::new(k, "scan", 0.0, 0.0, 0.3))
                .unwrap();
        }
        lines
            .finish(&CommandLine::final_stop(20, "duration"))
            .unwrap();
        let text = String::from_utf8(got.lock().unwrap().clone()).unwrap();
        let stamps: Vec<i64> = text
            .lines()
            .map(|l| {
                serde_json::from_str::<serde_json::Value>(l).unwrap()["stamp_ns"]
                    .as_i64()
                    .unwrap()
            })
            .collect();
        assert_eq!(stamps, (0..=20).collect::<Vec<_>>());
        assert_eq!(lines.dropped(), 0);
        drop(release);

        // A reader that goes away: the next send says so, as a blocking write would.
        let (release, hold) = std::sync::mpsc::channel();
        drop(release);
        let mut lines = QueuedLines::new(
            "stdout",
            Stalls {
                accept: 0,
                got: std::sync::Arc::new(std::sync::Mutex::new(Vec::new())),
                hold,
            },
        )
        .unwrap();
        lines
            .send(&CommandLine::new(0, "scan", 0.0, 0.0, 0.3))
            .unwrap();
        let started = std::time::Instant::now();
        let e = loop {
            match lines.send(&CommandLine::new(1, "scan", 0.0, 0.0, 0.3)) {
                Err(e) => break e,
                Ok(()) => {
                    assert!(started.elapsed() < std::time::Duration::from_secs(2));
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
            }
        };
        assert_eq!(e.kind(), io::ErrorKind::BrokenPipe);
    }

    #[test]
    fn drive_direct_bytes() {
        // 0.2 m/s right, -0.1 m/s left: 200 = 0x00C8, -100 = 0xFF9C.
        assert_eq!(drive_direct(-0.1, 0.2), [145, 0x00, 0xC8, 0xFF, 0x9C]);
        assert_eq!(drive_direct(0.0, 0.0), [145, 0, 0, 0, 0]);
        // 500 mm/s is the largest; 1.0 and 0.5 m/s scale together to 500 and 250.
        assert_eq!(drive_direct(0.5, 1.0), [145, 0x01, 0xF4, 0x00, 0xFA]);
        assert_eq!(drive_direct(-2.0, -2.0), [145, 0xFE, 0x0C, 0xFE, 0x0C]);
        assert_eq!(drive_direct(f64::NAN, 0.3), [145, 0, 0, 0, 0]);
        // Rounded to the nearest mm/s.
        assert_eq!(drive_direct(0.0014, 0.0016), [145, 0, 2, 0, 1]);
    }

    #[test]
    fn create_session_bytes() {
        let mut base = CreateBase::start("create", Vec::new()).unwrap();
        // v = 0.3 m/s, w = 1 rad/s on a 0.2 m track: left 0.2, right 0.4 m/s.
        base.send(&CommandLine::new(1, "scan", 0.3, 1.0, 0.2))
            .unwrap();
        base.finish(&CommandLine::final_stop(2, "interrupted"))
            .unwrap();
        assert_eq!(
            base.into_inner(),
            vec![
                128, 131, // Start, Safe
                145, 0x01, 0x90, 0x00, 0xC8, // right 400, left 200
                145, 0, 0, 0, 0,   // stop
                128, // Passive
            ]
        );
    }

    #[test]
    fn wheel_lines() {
        let mut json = WheelLines::new("wheels", WheelFormat::Json, Vec::new());
        json.send(&CommandLine::new(7, "timer", 0.3, 1.0, 0.2))
            .unwrap();
        json.finish(&CommandLine::final_stop(8, "duration"))
            .unwrap();
        assert_eq!(
            String::from_utf8(json.into_inner()).unwrap(),
            "{\"stamp_ns\":7,\"left_mps\":0.2,\"right_mps\":0.4}\n\
             {\"stamp_ns\":8,\"left_mps\":0.0,\"right_mps\":0.0}\n"
        );
        let mut text = WheelLines::new("wheels", WheelFormat::Text, Vec::new());
        text.send(&CommandLine::new(7, "timer", 0.3, -1.0, 0.2))
            .unwrap();
        text.send(&CommandLine::new(8, "timer", -0.0001, 0.0, 0.2))
            .unwrap();
        assert_eq!(
            String::from_utf8(text.into_inner()).unwrap(),
            "0.400 0.200\n0.000 0.000\n"
        );
    }

    #[test]
    fn json_lines_carry_the_command() {
        let mut out = JsonLines::new("stdout", Vec::new());
        let mut line = CommandLine::new(5, "scan", 0.5, 0.0, 0.3);
        line.stop = Some("obstacle");
        out.send(&line).unwrap();
        let text = String::from_utf8(out.into_inner()).unwrap();
        let v: serde_json::Value = serde_json::from_str(text.trim()).unwrap();
        assert_eq!(v["stamp_ns"], 5);
        assert_eq!(v["input"], "scan");
        assert_eq!(v["v_mps"], 0.5);
        assert_eq!(v["left_mps"], 0.5);
        assert_eq!(v["stop"], "obstacle");
        assert!(v["target"].is_null());
    }
}
