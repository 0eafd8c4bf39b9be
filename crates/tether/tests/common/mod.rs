//! Helpers shared by the command-line tests: run the binary, make a scratch folder.

#![allow(dead_code, reason = "each test file uses a part")]

pub mod dds;
pub mod live;
pub mod run;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `tether` binary with `args`.
pub fn tether(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tether"))
        .args(args)
        .output()
        .expect("the tether binary runs")
}

#[allow(unused_imports, reason = "each test file uses a part")]
pub use tether_testkit::{scratch, text};

/// `name` in leg_tracker's recordings under `../shared`, or `None` after a printed
/// reason (a failure under `TETHER_REQUIRE_SHARED=1`).
#[track_caller]
pub fn leg_tracker(name: &str) -> Option<PathBuf> {
    tether_testkit::shared(&format!("data/laser/leg_tracker/{name}"))
}

/// `tether COMMAND RECORDING --scan-topic TOPIC EXTRA... --out OUT` (`track`, `replay`).
pub fn on_recording(
    command: &str,
    recording: &Path,
    topic: &str,
    extra: &[&str],
    out: &Path,
) -> Output {
    let mut args = vec![
        command,
        recording.to_str().expect("a UTF-8 path"),
        "--scan-topic",
        topic,
    ];
    args.extend(extra);
    args.extend(["--out", out.to_str().expect("a UTF-8 path")]);
    tether(&args)
}

/// `configs/robot.example.toml`, the robot config the README documents.
pub fn example_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/robot.example.toml")
}

/// `tether sim --scenario corridor --duration SECONDS EXTRA... --out DIR/sim` recorded
/// with `record` (`--record`: MCAP, `--record-bag`: a ROS 1 bag) as `DIR/NAME`, which it
/// returns; the command must succeed.
pub fn record_corridor(
    dir: &Path,
    seconds: u32,
    extra: &[&str],
    record: &str,
    name: &str,
) -> PathBuf {
    let path = dir.join(name);
    let seconds = seconds.to_string();
    let sim = dir.join("sim");
    let mut args = vec!["sim", "--scenario", "corridor", "--duration", &seconds];
    args.extend(extra);
    args.extend([
        "--out",
        sim.to_str().expect("a UTF-8 path"),
        record,
        path.to_str().expect("a UTF-8 path"),
    ]);
    let out = tether(&args);
    assert!(out.status.success(), "sim: {}", text(&out.stderr));
    path
}

/// A simulated laser-only `corridor` run of `seconds` (seed 1) as a ROS 1 bag
/// (`/scan` and the ground truth), `DIR/corridor.bag`.
pub fn corridor_bag(dir: &Path, seconds: u32) -> PathBuf {
    record_corridor(
        dir,
        seconds,
        &["--laser-only", "--seed", "1"],
        "--record-bag",
        "corridor.bag",
    )
}
