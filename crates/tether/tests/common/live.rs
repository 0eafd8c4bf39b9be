//! What the tests of `tether run` share: the `tether` processes they start (killed when
//! the test ends, however it ends), the emulator's pty and the robot's config.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// `tether ARGS`, to be given its stdin, stdout and environment, then [`Proc::start`].
pub fn tether_command(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_tether"));
    command.args(args);
    command
}

/// A child process killed when the test ends, however it ends.
pub struct Proc {
    pub name: String,
    pub child: Child,
    stderr: PathBuf,
}

impl Proc {
    /// Starts `command` with its stderr in `DIR/NAME.stderr`.
    pub fn start(name: &str, dir: &Path, command: &mut Command) -> Proc {
        let stderr = dir.join(format!("{name}.stderr"));
        let child = command
            .stderr(std::fs::File::create(&stderr).expect("the scratch folder is writable"))
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Proc {
            name: name.to_owned(),
            child,
            stderr,
        }
    }

    /// What the process wrote to its stderr so far.
    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.stderr).unwrap_or_default()
    }

    /// Waits up to `limit` for the process to exit.
    pub fn wait_for(&mut self, limit: Duration) -> Option<ExitStatus> {
        let started = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().expect("the child can be polled") {
                return Some(status);
            }
            if started.elapsed() > limit {
                return None;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Waits up to `limit` for the process to exit; after it fails the test with
    /// `failure` and the stderr.
    pub fn wait_or_fail(&mut self, limit: Duration, failure: &str) -> ExitStatus {
        self.wait_for(limit)
            .unwrap_or_else(|| panic!("{failure}; stderr:\n{}", self.stderr()))
    }

    /// Sends `signal` (`-INT`, `-TERM`, `-KILL`) with `kill`.
    pub fn signal(&self, signal: &str) {
        let status = Command::new("kill")
            .args([signal, &self.child.id().to_string()])
            .status()
            .expect("kill runs");
        assert!(status.success(), "kill {signal} {}", self.name);
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The pty path a started `tether urg-emulator --pty` prints on its first stdout line
/// (its stdout piped); fails the test after 30 s without it.
pub fn pty_path(emu: &mut Proc) -> String {
    let path = announced_endpoint(emu);
    assert!(
        path.starts_with("/dev/"),
        "no pty path in {path:?}; stderr:\n{}",
        emu.stderr()
    );
    path
}

/// Where a started `tether urg-emulator` serves (a pty's path, a TCP address), as its
/// first stdout line says (its stdout piped); fails the test after 30 s without it.
pub fn announced_endpoint(emu: &mut Proc) -> String {
    let stdout = emu
        .child
        .stdout
        .take()
        .expect("the emulator's stdout is piped");
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
                "the emulator printed where it serves in 30 s; stderr:\n{}",
                emu.stderr()
            )
        });
    line.trim()
        .rsplit(" on ")
        .next()
        .filter(|p| !p.is_empty())
        .unwrap_or_else(|| panic!("no endpoint in {line:?}; stderr:\n{}", emu.stderr()))
        .to_owned()
}

/// A robot's config (the corridor's robot, the simulator's defaults) with its laser on
/// `serial`, then `base` (the `[base]` table's keys), `output` (the `[output]` table's)
/// and `extra` tables.
pub fn config_text(serial: &str, base: &str, output: &str, extra: &str) -> String {
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

/// `DIR/robot.toml`: [`config_text`] on `pty` with the wheels' commands in
/// `DIR/wheels.txt` (made empty here) as text, stdout, the recording `DIR/run.mcap`, the laser and
/// target timeouts widened for a loaded machine, and `extra` tables.
pub fn wheels_config(dir: &Path, pty: &str, extra: &str) -> PathBuf {
    let path = dir.join("robot.toml");
    let base = format!(
        "kind = \"wheels\"\ndevice = \"{}\"\nformat = \"text\"",
        dir.join("wheels.txt").display()
    );
    let output = format!(
        "stdout = true\nrecord = \"{}\"",
        dir.join("run.mcap").display()
    );
    let tables = format!(
        "\n# A loaded test machine may delay a scan now and then.\n[pipeline.safety]\n\
         laser_timeout_s = 0.5\ntarget_timeout_s = 0.8\n{extra}"
    );
    std::fs::write(&path, config_text(pty, &base, &output, &tables))
        .expect("the scratch folder is writable");
    // tether writes into the base's device but creates none: the log of the wheel
    // speeds is made here, as a FIFO would be by its reader.
    std::fs::write(dir.join("wheels.txt"), "").expect("the scratch folder is writable");
    path
}
