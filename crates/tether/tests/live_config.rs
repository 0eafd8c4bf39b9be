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

use std::path::{Path, PathBuf};
use std::process::{ExitStatus, Stdio};
use std::time::Duration;

use common::live::{Proc, config_text, pty_path, tether_command};
use common::scratch;

/// `tether ARGS`, its stderr in `DIR/NAME.stderr`, its log filter the default one
/// (the warnings are what is checked).
fn spawn(name: &str, dir: &Path, args: &[&str], stdout: Stdio) -> Proc {
    Proc::start(
        name,
        dir,
        tether_command(args)
            .env_remove("RUST_LOG")
            .stdin(Stdio::piped())
            .stdout(stdout),
    )
}

/// Waits up to `limit` for `proc` to exit; fails the test after it.
fn wait(proc: &mut Proc, limit: Duration, what: &str) -> ExitStatus {
    proc.wait_or_fail(limit, &format!("{what} did not end within {limit:?}"))
}

/// The emulator serving `corridor` on a new pty (its robot stands still); returns it
/// with the pty's path.
fn emulator(dir: &Path, name: &str) -> (Proc, String) {
    let mut emu = spawn(
        name,
        dir,
        &["urg-emulator", "--pty", "--scenario", "corridor"],
        Stdio::piped(),
    );
    let pty = pty_path(&mut emu);
    (emu, pty)
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
    let mut run = spawn(
        name,
        dir,
        &["run", "--config", config.to_str().unwrap(), "--duration", s],
        Stdio::null(),
    );
    let status = wait(&mut run, Duration::from_secs(60), "tether run");
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
    // The base's device exists (tether creates none) and stays empty while nothing
    // opens it.
    let wheels = write(&dir, "wheels.txt", "");
    let record = dir.join("run.mcap");
    let base = format!(
        "kind = \"wheels\"\ndevice = \"{}\"\nformat = \"text\"",
        wheels.display()
    );
    let output = format!("stdout = true\nrecord = \"{}\"", record.display());
    let refuse = |name: &str, text: &str, key: &str, says: &str| {
        let path = write(&dir, &format!("{name}.toml"), text);
        let mut run = spawn(
            name,
            &dir,
            &["run", "--config", path.to_str().unwrap()],
            Stdio::piped(),
        );
        let status = wait(&mut run, Duration::from_secs(30), "tether run");
        let stderr = run.stderr();
        assert!(!status.success(), "{key}: accepted:\n{stderr}");
        assert!(
            stderr.contains(key) && stderr.contains(says),
            "{key}: {stderr}"
        );
        // Refused for the key, not for the missing laser: nothing was opened.
        assert!(!stderr.contains("ttyACM9"), "{key}: {stderr}");
        assert_eq!(
            std::fs::read_to_string(&wheels).unwrap(),
            "",
            "{key}: the base's device was opened"
        );
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
    let mut run = spawn(
        "safe",
        &dir,
        &["run", "--config", path.to_str().unwrap()],
        Stdio::null(),
    );
    let status = wait(&mut run, Duration::from_secs(30), "tether run");
    let stderr = run.stderr();
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("ttyACM9"), "{stderr}");
    // The base's device is opened before the laser (and gets the final stop of the
    // failed start): the refusals above came first.
    assert!(
        !std::fs::read_to_string(&wheels).unwrap().is_empty(),
        "{stderr}"
    );
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

#[test]
fn a_run_that_cannot_start_creates_nothing_and_says_what_to_do() {
    // The live walk-through's traps: configs/emulator.toml run before the FIFO exists,
    // or with the placeholder pty left in it.
    let dir = scratch("live-no-start");
    let shipped = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/emulator.toml"),
    )
    .unwrap();
    let fifo = dir.join("tether-wheels");
    let record = dir.join("run.mcap");
    let edited = |serial: &str| {
        shipped
            .replace("/dev/pts/N", serial)
            .replace("/tmp/tether-wheels", fifo.to_str().unwrap())
            .replace("\"run.mcap\"", &format!("{:?}", record))
    };
    let run = |name: &str, text: &str| {
        let config = write(&dir, &format!("{name}.toml"), text);
        let mut run = spawn(
            name,
            &dir,
            &["run", "--config", config.to_str().unwrap()],
            Stdio::piped(),
        );
        let status = wait(&mut run, Duration::from_secs(30), "tether run");
        assert!(!status.success(), "{name}: it ran:\n{}", run.stderr());
        run.stderr()
    };
    let leftovers = || {
        std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".mcap"))
            .collect::<Vec<_>>()
    };
    // No FIFO yet: an error that says how to make it, and no file in its place.
    let stderr = run("no-fifo", &edited("/dev/pts/N"));
    assert!(
        stderr.contains(&format!("mkfifo {}", fifo.display())),
        "{stderr}"
    );
    assert!(
        !fifo.exists(),
        "a file was made where the FIFO goes:\n{stderr}"
    );
    assert!(leftovers().is_empty(), "{:?}", leftovers());
    // The FIFO's reader there (here a plain file stands in for it), but the pty left
    // as the placeholder: the error names the pty to use, and no recording is left.
    std::fs::write(&fifo, "").unwrap();
    let stderr = run("placeholder-pty", &edited("/dev/pts/N"));
    assert!(
        stderr.contains("the one it printed when it started"),
        "{stderr}"
    );
    assert!(
        leftovers().is_empty(),
        "a run that never started left {:?}",
        leftovers()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_emulator_reads_commands_from_a_fifo_only() {
    let dir = scratch("emulator-commands-file");
    let file = write(&dir, "tether-wheels", "0.000 0.000\n");
    let mut emu = spawn(
        "emulator",
        &dir,
        &[
            "urg-emulator",
            "--pty",
            "--scenario",
            "corridor",
            "--commands",
            file.to_str().unwrap(),
        ],
        Stdio::piped(),
    );
    let status = wait(&mut emu, Duration::from_secs(30), "the emulator");
    assert!(!status.success());
    let stderr = emu.stderr();
    assert!(stderr.contains("not a FIFO but a regular file"), "{stderr}");
    assert!(
        stderr.contains(&format!("mkfifo {}", file.display())),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
