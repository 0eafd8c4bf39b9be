//! `tether run --config` through the release binary: what it does with a config before
//! and around a run, against `tether urg-emulator --pty` where a laser is needed. A
//! recording is never overwritten; a safety key that would switch safety off is
//! refused by name before any device is opened; a base of `kind = "none"` ignores the
//! `device` and `baud` left in its table, saying so.
//!
//! Real time on a possibly loaded machine: every wait has a limit that fails with what
//! the processes said, and the processes are killed whatever happens.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::scratch;

/// A child process killed when the test ends, however it ends.
struct Proc {
    child: Child,
    stderr: PathBuf,
}

impl Proc {
    /// `tether ARGS`, its stderr in `DIR/NAME.stderr`, its log filter the default one
    /// (the warnings are what is checked).
    fn spawn(name: &str, dir: &Path, args: &[&str], stdout: Stdio) -> Proc {
        let stderr = dir.join(format!("{name}.stderr"));
        let child = Command::new(env!("CARGO_BIN_EXE_tether"))
            .args(args)
            .env_remove("RUST_LOG")
            .stdin(Stdio::piped())
            .stdout(stdout)
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Proc { child, stderr }
    }

    fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// Waits up to `limit` for the process to exit; fails the test after it.
    fn wait(&mut self, limit: Duration, what: &str) -> ExitStatus {
        let started = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                return status;
            }
            assert!(
                started.elapsed() < limit,
                "{what} did not end within {limit:?}; stderr:\n{}",
                self.stderr()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The emulator serving `corridor` on a new pty (its robot stands still); returns it
/// with the pty's path.
fn emulator(dir: &Path, name: &str) -> (Proc, String) {
    let mut emu = Proc::spawn(
        name,
        dir,
        &["urg-emulator", "--pty", "--scenario", "corridor"],
        Stdio::piped(),
    );
    let stdout = emu.child.stdout.take().unwrap();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = BufReader::new(stdout).read_line(&mut line);
        let _ = tx.send(line);
    });
    let line = rx
        .recv_timeout(Duration::from_secs(30))
        .unwrap_or_else(|_| {
            panic!(
                "the emulator printed no pty path in 30 s; stderr:\n{}",
                emu.stderr()
            )
        });
    let pty = line
        .trim()
        .rsplit(" on ")
        .next()
        .filter(|p| p.starts_with("/dev/"))
        .unwrap_or_else(|| panic!("no pty path in {line:?}; stderr:\n{}", emu.stderr()))
        .to_owned();
    (emu, pty)
}

/// A robot's config with its laser on `serial`, then `base` (the `[base]` table's
/// keys), `output` (the `[output]` table's) and `extra` tables.
fn config_text(serial: &str, base: &str, output: &str, extra: &str) -> String {
    format!(
        r#"[robot]
radius_m = 0.2
track_width_m = 0.3
max_speed_mps = 1.4
max_wheel_speed_mps = 1.6
max_accel_mps2 = 1.2

[laser]
serial = "{serial}"
mount = {{ x_m = 0.10, y_m = 0.0, yaw_rad = 0.0, height_m = 0.30 }}

[follow]
follow_distance_m = 1.0
attach_ahead_m = 0.3
distance_omega_radps = 4.0
bearing_omega_radps = 3.0

[base]
{base}

[output]
{output}
{extra}"#
    )
}

/// Writes `text` to `DIR/NAME`, returns the path.
fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// `tether run --config CONFIG --duration S` against a fresh emulator, to its end;
/// returns its status and stderr.
fn short_run(
    dir: &Path,
    name: &str,
    config_for: impl Fn(&str) -> String,
    s: &str,
) -> (bool, String) {
    let (_emu, pty) = emulator(dir, &format!("{name}-emulator"));
    let config = write(dir, &format!("{name}.toml"), &config_for(&pty));
    let mut run = Proc::spawn(
        name,
        dir,
        &["run", "--config", config.to_str().unwrap(), "--duration", s],
        Stdio::null(),
    );
    let status = run.wait(Duration::from_secs(60), "tether run");
    (status.success(), run.stderr())
}

#[test]
fn a_second_run_records_beside_the_first_and_leaves_it_alone() {
    let dir = scratch("live-record-twice");
    let record = dir.join("run.mcap");
    let config_for = |pty: &str| {
        config_text(
            pty,
            "kind = \"none\"",
            &format!("stdout = true\nrecord = \"{}\"", record.display()),
            "",
        )
    };
    let (ok, stderr) = short_run(&dir, "first", config_for, "2");
    assert!(ok, "the first run failed:\n{stderr}");
    assert!(!stderr.contains("earlier run"), "{stderr}");
    let first = std::fs::read(&record).unwrap();
    assert!(
        first.starts_with(b"\x89MCAP0\r\n") && first.len() > 1000,
        "the first run recorded {} bytes",
        first.len()
    );
    assert!(!dir.join("run-2.mcap").exists());

    let (ok, stderr) = short_run(&dir, "second", config_for, "2");
    assert!(ok, "the second run failed:\n{stderr}");
    let second = dir.join("run-2.mcap");
    assert!(
        stderr.contains(&format!(
            "{} holds an earlier run's recording; this run records to {}",
            record.display(),
            second.display()
        )),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(&record).unwrap(),
        first,
        "the first run's recording changed"
    );
    let recorded = std::fs::read(&second).unwrap();
    assert!(
        recorded.starts_with(b"\x89MCAP0\r\n") && recorded.len() > 1000,
        "the second run recorded {} bytes to {}",
        recorded.len(),
        second.display()
    );
    // The second run's recording reads: scans on /scan.
    let out = common::tether(&["info", second.to_str().unwrap()]);
    assert!(out.status.success(), "{}", common::text(&out.stderr));
    assert!(
        common::text(&out.stdout).contains("/scan"),
        "{}",
        common::text(&out.stdout)
    );
}

#[test]
fn a_safety_key_that_switches_safety_off_is_refused_by_name_before_any_device_opens() {
    let dir = scratch("live-unsafe-keys");
    let laser = dir.join("no-such-dir").join("ttyACM9");
    let laser = laser.to_str().unwrap();
    let wheels = dir.join("wheels.txt");
    let record = dir.join("run.mcap");
    let base = format!(
        "kind = \"wheels\"\ndevice = \"{}\"\nformat = \"text\"",
        wheels.display()
    );
    let output = format!("stdout = true\nrecord = \"{}\"", record.display());
    let refuse = |name: &str, text: &str, key: &str, says: &str| {
        let path = write(&dir, &format!("{name}.toml"), text);
        let mut run = Proc::spawn(
            name,
            &dir,
            &["run", "--config", path.to_str().unwrap()],
            Stdio::piped(),
        );
        let status = run.wait(Duration::from_secs(30), "tether run");
        let stderr = run.stderr();
        assert!(!status.success(), "{key}: accepted:\n{stderr}");
        assert!(
            stderr.contains(key) && stderr.contains(says),
            "{key}: {stderr}"
        );
        // Refused for the key, not for the missing laser: nothing was opened.
        assert!(!stderr.contains("ttyACM9"), "{key}: {stderr}");
        assert!(!wheels.exists(), "{key}: the base's device was opened");
        assert!(!record.exists(), "{key}: the recording was created");
        let mut stdout = String::new();
        let _ = std::io::Read::read_to_string(run.child.stdout.as_mut().unwrap(), &mut stdout);
        assert!(stdout.is_empty(), "{key}: commands were sent: {stdout}");
    };
    refuse(
        "laser-timeout",
        &config_text(
            laser,
            &base,
            &output,
            "[pipeline.safety]\nlaser_timeout_s = inf\n",
        ),
        "laser_timeout_s",
        "(0, 1] s",
    );
    refuse(
        "max-speed",
        &config_text(laser, &base, &output, "")
            .replace("max_speed_mps = 1.4", "max_speed_mps = 1e300"),
        "robot.max_speed_mps",
        "(0, 3] m/s",
    );

    // The same config with safe values gets as far as the laser, which is not there.
    let path = write(
        &dir,
        "safe.toml",
        &config_text(
            laser,
            &base,
            &output,
            "[pipeline.safety]\nlaser_timeout_s = 0.5\n",
        ),
    );
    let mut run = Proc::spawn(
        "safe",
        &dir,
        &["run", "--config", path.to_str().unwrap()],
        Stdio::null(),
    );
    let status = run.wait(Duration::from_secs(30), "tether run");
    let stderr = run.stderr();
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("ttyACM9"), "{stderr}");
    // The base's device is opened before the laser: the refusals above came first.
    assert!(wheels.exists(), "{stderr}");
}

#[test]
fn a_base_of_kind_none_runs_with_its_device_and_baud_left_in_and_says_they_are_ignored() {
    let dir = scratch("live-base-none");
    let device = dir.join("ttyUSB0");
    let base = format!(
        "kind = \"none\"\ndevice = \"{}\"\nbaud = 57600",
        device.display()
    );
    let (ok, stderr) = short_run(
        &dir,
        "run",
        |pty| config_text(pty, &base, "stdout = true", ""),
        "2",
    );
    assert!(ok, "refused:\n{stderr}");
    for key in ["base.device", "base.baud"] {
        assert!(
            stderr.contains(&format!(
                "{key} is set but `kind = \"none\"` drives no base: ignored"
            )),
            "{key}: {stderr}"
        );
    }
    assert!(!stderr.contains("base.format"), "{stderr}");
    assert!(!device.exists(), "the ignored device was opened");
}
