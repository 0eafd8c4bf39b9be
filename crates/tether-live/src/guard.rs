//! The base guard: a small process beside `tether run` that holds a handle of its own
//! on the base and stops it when tether stops talking.
//!
//! An iRobot Create keeps driving at its last `Drive Direct` for ever, and a motor
//! controller fed wheel-speed lines may too. tether sends a final stop on every exit it
//! lives through (the end of the run, Ctrl-C, a failed sensor, a panic), but not when
//! it is killed (`kill -KILL`, the OOM killer) or hangs. The guard covers those:
//!
//! - `tether run` starts it (`tether base-guard`, in a process group of its own so
//!   that a terminal's Ctrl-C does not reach it) before it opens the base; the guard
//!   opens the same device (a serial port shared without the exclusive lock, or the
//!   wheel-speed file in append mode) and says `ready`.
//! - tether passes it every command line it sends the base (the JSON of
//!   [`CommandLine`], through a bounded queue: heartbeats never hold up the loop).
//! - When the pipe closes (tether exited or was killed: the kernel closes its end at
//!   once) the guard sends the stop (for a Create `Drive Direct 0 0`, then `Start`,
//!   which leaves it in Passive mode) and exits. When no line comes for
//!   [`GuardSpec::silence`] (tether hangs), it sends a stop and keeps watching: a
//!   tether that recovers drives again.
//!
//! tether's own final stop comes first on an orderly exit; the guard's is then a
//! second, harmless stop.
//!
//! The watch of the command lines ([`watch_heartbeats`]) and the process's start
//! ([`Guard::start`]) are shared with `tether ros2`'s `cmd_vel` guard (`ros2::guard`,
//! design 12), which publishes zero commands where this one writes to a device.

use std::io::{self, BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use crate::base::{CommandLine, CommandSink, WheelLines, drive_direct};
use crate::config::{BaseKind, BaseSection, WheelFormat};

/// The Open Interface's `Start`: back to Passive mode, where the Create does not drive.
const OI_START: u8 = 128;

/// What the guard speaks to the base.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GuardedBase {
    /// An iRobot Create's Open Interface.
    Create,
    /// Wheel-speed lines in this format.
    Wheels(WheelFormat),
}

/// Where the guard finds the base and how long a silence it allows.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardSpec {
    /// The base's device: a serial port, a file or a FIFO.
    pub device: PathBuf,
    /// Baud rate of a serial port; `None` for a file (wheel lines only).
    pub baud: Option<u32>,
    /// The protocol.
    pub base: GuardedBase,
    /// Longest time without a command line before the guard stops the base.
    pub silence: Duration,
}

impl GuardSpec {
    /// The guard of `[base]`, or `None` when there is no base to guard (`kind =
    /// "none"`, no device, or `guard = false`).
    pub fn of(base: &BaseSection) -> Option<GuardSpec> {
        let device = base.device.clone()?;
        let guarded = match base.kind {
            BaseKind::None => return None,
            BaseKind::Create => GuardedBase::Create,
            BaseKind::Wheels => GuardedBase::Wheels(base.format.unwrap_or_default()),
        };
        if !base.guard.unwrap_or(true) {
            return None;
        }
        Some(GuardSpec {
            device,
            baud: base.baud,
            base: guarded,
            silence: Duration::from_secs_f64(base.guard_silence_s.unwrap_or(DEFAULT_SILENCE_S)),
        })
    }

    /// The arguments of `tether base-guard` for this spec.
    pub fn args(&self) -> Vec<String> {
        let mut args = vec![
            "base-guard".to_string(),
            "--device".to_string(),
            self.device.display().to_string(),
            "--protocol".to_string(),
            match self.base {
                GuardedBase::Create => "create",
                GuardedBase::Wheels(WheelFormat::Json) => "json",
                GuardedBase::Wheels(WheelFormat::Text) => "text",
            }
            .to_string(),
            "--silence-ms".to_string(),
            self.silence.as_millis().to_string(),
        ];
        if let Some(baud) = self.baud {
            args.extend(["--baud".to_string(), baud.to_string()]);
        }
        args
    }
}

/// The silence allowed by default, s: ten periods of the 20 Hz control loop.
pub const DEFAULT_SILENCE_S: f64 = 0.5;

/// The bytes that stop the base. `passive`: for a Create, also leave the Open
/// Interface in Passive mode (when tether is gone; after a mere silence the Create
/// stays in Safe mode so that a recovered tether drives it again).
pub fn stop_bytes(base: GuardedBase, stamp_ns: i64, passive: bool) -> Vec<u8> {
    match base {
        GuardedBase::Create => {
            let mut out = drive_direct(0.0, 0.0).to_vec();
            if passive {
                out.push(OI_START);
            }
            out
        }
        GuardedBase::Wheels(format) => {
            let mut lines = WheelLines::new("guard", format, Vec::new());
            // Writing into a Vec cannot fail.
            let _ = lines.send(&CommandLine::final_stop(stamp_ns, "guard"));
            lines.into_inner()
        }
    }
}

/// How a guard's watch ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GuardReport {
    /// Command lines received.
    pub heartbeats: u64,
    /// Stops sent because tether went silent.
    pub silences: u64,
    /// The last line was tether's own final stop: it ended in order (not killed).
    pub orderly: bool,
}

fn open_device(spec: &GuardSpec) -> io::Result<Box<dyn Write>> {
    match spec.baud {
        Some(baud) => {
            let mut port = serialport::new(spec.device.display().to_string(), baud)
                .timeout(Duration::from_millis(200))
                .open_native()
                .map_err(io::Error::other)?;
            // tether opens the port after the guard: the lock would keep it out.
            port.set_exclusive(false).map_err(io::Error::other)?;
            Ok(Box::new(port))
        }
        None => Ok(Box::new(crate::base::open_existing_device(&spec.device)?)),
    }
}

/// The guard's watch (the `tether base-guard` process): opens the device, writes
/// `ready` to `ready`, then reads command lines from `heartbeats` until it closes,
/// stopping the base after each silence and at the end.
pub fn watch<R: BufRead + Send + 'static>(
    spec: &GuardSpec,
    heartbeats: R,
    ready: &mut dyn Write,
) -> io::Result<GuardReport> {
    let mut device = open_device(spec).map_err(|e| {
        io::Error::new(
            e.kind(),
            format!("the base guard cannot open {}: {e}", spec.device.display()),
        )
    })?;
    writeln!(ready, "ready")?;
    ready.flush()?;
    watch_heartbeats(heartbeats, spec.silence, &mut |why, stamp_ns, _| {
        device.write_all(&stop_bytes(spec.base, stamp_ns, why == StopCause::Gone))?;
        device.flush()?;
        if why == StopCause::Silence {
            eprintln!(
                "base guard: no command from tether for {} ms: stop sent to {}",
                spec.silence.as_millis(),
                spec.device.display()
            );
        }
        Ok(())
    })
}

/// Why a guard stops the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopCause {
    /// No command line came for the guard's silence: tether hangs (or is frozen).
    Silence,
    /// The pipe closed: tether exited or was killed.
    Gone,
}

/// The watch of every guard: reads tether's command lines (the JSON of
/// [`CommandLine`]) from `heartbeats` on a thread of its own, and calls `stop` once
/// after each `silence` that follows a line (not again until a line comes), and once
/// when the pipe closes, which ends the watch. `stop` gets tether's clock now (its last
/// stamp and the time since) and the report so far.
pub fn watch_heartbeats<R: BufRead + Send + 'static>(
    heartbeats: R,
    silence: Duration,
    stop: &mut dyn FnMut(StopCause, i64, &GuardReport) -> io::Result<()>,
) -> io::Result<GuardReport> {
    let (tx, rx) = mpsc::channel::<(Option<i64>, bool)>();
    std::thread::Builder::new()
        .name("guard-reader".into())
        .spawn(move || {
            for line in heartbeats.lines() {
                let Ok(line) = line else { break };
                let value = serde_json::from_str::<serde_json::Value>(&line).ok();
                let stamp = value.as_ref().and_then(|v| v["stamp_ns"].as_i64());
                let last = value.is_some_and(|v| v["input"] == "final");
                if tx.send((stamp, last)).is_err() {
                    return;
                }
            }
        })?;
    let mut report = GuardReport {
        heartbeats: 0,
        silences: 0,
        orderly: false,
    };
    let mut last_stamp = (0_i64, Instant::now());
    let mut stopped = false;
    loop {
        match rx.recv_timeout(silence) {
            Ok((stamp, last)) => {
                report.heartbeats += 1;
                report.orderly = last;
                if let Some(s) = stamp {
                    last_stamp = (s, Instant::now());
                }
                stopped = false;
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if !stopped && report.heartbeats > 0 {
                    stop(StopCause::Silence, stamp_now(last_stamp), &report)?;
                    report.silences += 1;
                    stopped = true;
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                stop(StopCause::Gone, stamp_now(last_stamp), &report)?;
                return Ok(report);
            }
        }
    }
}

/// tether's clock now, from its last stamp and the time since.
fn stamp_now((stamp, at): (i64, Instant)) -> i64 {
    stamp.saturating_add(i64::try_from(at.elapsed().as_nanos()).unwrap_or(i64::MAX))
}

/// A running guard process, from `tether run`'s side.
#[derive(Debug)]
pub struct Guard {
    child: Child,
}

impl Guard {
    /// Starts `exe base-guard ...` for `spec` and waits (up to `within`) until it has
    /// the device open; returns it with the pipe its command lines go to.
    pub fn spawn(
        exe: &Path,
        spec: &GuardSpec,
        within: Duration,
    ) -> io::Result<(Guard, ChildStdin)> {
        let what = format!("the base guard on {}", spec.device.display());
        Self::start(exe, &spec.args(), &what, within)
    }

    /// Starts `exe ARGS` as a guard (`what` names it in errors) and waits (up to
    /// `within`) until it says `ready` on its stdout; returns it with the pipe its
    /// command lines go to.
    pub fn start(
        exe: &Path,
        args: &[String],
        what: &str,
        within: Duration,
    ) -> io::Result<(Guard, ChildStdin)> {
        use std::os::unix::process::CommandExt;
        let mut child = Command::new(exe)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            // A terminal's Ctrl-C (or Ctrl-Z) goes to tether's process group, not to the
            // guard: it must outlive tether to send its stop.
            .process_group(0)
            .spawn()?;
        let (Some(stdin), Some(stdout)) = (child.stdin.take(), child.stdout.take()) else {
            let _ = child.kill();
            return Err(io::Error::other(format!("{what} has no pipes")));
        };
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let got = BufReader::new(stdout).read_line(&mut line).map(|_| line);
            let _ = tx.send(got);
        });
        let mut guard = Guard { child };
        match rx.recv_timeout(within) {
            Ok(Ok(line)) if line.trim() == "ready" => Ok((guard, stdin)),
            outcome => {
                let _ = guard.child.kill();
                let status = guard.child.wait().ok();
                Err(io::Error::other(match outcome {
                    Err(_) => format!("{what} was not ready within {:.1} s", within.as_secs_f64()),
                    _ => format!(
                        "{what} could not start ({})",
                        status.map_or_else(|| "no status".into(), |s| s.to_string())
                    ),
                }))
            }
        }
    }

    /// Waits up to `within` for the guard to end (after its pipe closed); kills it
    /// past that.
    pub fn wait(mut self, within: Duration) -> Option<ExitStatus> {
        let deadline = Instant::now() + within;
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return Some(status),
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(10));
                }
                _ => {
                    let _ = self.child.kill();
                    return self.child.wait().ok();
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use super::*;

    fn spec(device: PathBuf, base: GuardedBase) -> GuardSpec {
        GuardSpec {
            device,
            baud: None,
            base,
            silence: Duration::from_millis(100),
        }
    }

    #[test]
    fn stops_are_the_bases_own() {
        assert_eq!(
            stop_bytes(GuardedBase::Create, 0, true),
            vec![145, 0, 0, 0, 0, 128]
        );
        assert_eq!(
            stop_bytes(GuardedBase::Create, 0, false),
            vec![145, 0, 0, 0, 0]
        );
        assert_eq!(
            stop_bytes(GuardedBase::Wheels(WheelFormat::Text), 7, true),
            b"0.000 0.000\n"
        );
        let json =
            String::from_utf8(stop_bytes(GuardedBase::Wheels(WheelFormat::Json), 7, true)).unwrap();
        assert_eq!(
            json,
            "{\"stamp_ns\":7,\"left_mps\":0.0,\"right_mps\":0.0}\n"
        );
    }

    #[test]
    fn a_closed_pipe_and_a_silence_each_end_in_a_stop() {
        let dir = std::env::temp_dir().join(format!("tether-guard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let device = dir.join("wheels.txt");
        std::fs::write(&device, "").unwrap();
        let s = spec(device.clone(), GuardedBase::Wheels(WheelFormat::Text));
        // Two heartbeats, a silence of 300 ms (a stop), one more, then the end.
        let (r, mut w) = io::pipe().unwrap();
        let feeder = std::thread::spawn(move || {
            writeln!(w, "{{\"stamp_ns\":1}}").unwrap();
            writeln!(w, "{{\"stamp_ns\":2}}").unwrap();
            std::thread::sleep(Duration::from_millis(300));
            writeln!(w, "{{\"stamp_ns\":3,\"input\":\"final\"}}").unwrap();
        });
        let mut ready = Vec::new();
        let report = watch(&s, BufReader::new(r), &mut ready).unwrap();
        feeder.join().unwrap();
        assert_eq!(ready, b"ready\n");
        assert_eq!(report.heartbeats, 3);
        assert_eq!(report.silences, 1);
        assert!(report.orderly);
        assert_eq!(
            std::fs::read_to_string(&device).unwrap(),
            "0.000 0.000\n0.000 0.000\n"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
