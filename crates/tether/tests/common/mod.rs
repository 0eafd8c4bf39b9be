//! Helpers shared by the command-line tests: run the binary, make a scratch folder.

#![allow(dead_code, reason = "each test file uses a part")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `tether` binary with `args`.
pub fn tether(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tether"))
        .args(args)
        .output()
        .expect("the tether binary runs")
}

/// A fresh folder under the temporary directory, unique to this process and `name`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tether-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("the temporary directory is writable");
    dir
}

/// Output bytes as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// A simulated laser-only `corridor` run of `seconds` (seed 1) as a ROS 1 bag
/// (`/scan` and the ground truth), `DIR/corridor.bag`.
pub fn corridor_bag(dir: &Path, seconds: u32) -> PathBuf {
    let bag = dir.join("corridor.bag");
    let out = tether(&[
        "sim",
        "--scenario",
        "corridor",
        "--laser-only",
        "--seed",
        "1",
        "--duration",
        &seconds.to_string(),
        "--out",
        dir.join("sim").to_str().expect("a UTF-8 path"),
        "--record-bag",
        bag.to_str().expect("a UTF-8 path"),
    ]);
    assert!(out.status.success(), "sim: {}", text(&out.stderr));
    bag
}
