//! What the tests of `tether run` against the emulator share (`live_run.rs`): the
//! emulator and the run started with their configs, following, waiting for lines and
//! the final stop they must end with.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{ChildStdin, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::live::{Proc, pty_path, tether_command, wheels_config};

/// `tether ARGS` with `stdin`, its stdout piped.
pub fn spawn(name: &str, dir: &Path, args: &[&str], stdin: Stdio) -> Proc {
    Proc::start(
        name,
        dir,
        tether_command(args).stdin(stdin).stdout(Stdio::piped()),
    )
}

/// The emulator on a new pty serving `corridor`, its robot driven by the commands on its
/// stdin; returns it with the pty's path.
pub fn emulator(dir: &Path) -> (Proc, String) {
    emulator_reading(dir, &["--commands-stdin"])
}

/// The emulator on a new pty serving `corridor`, with `commands` saying where its
/// robot's commands come from.
pub fn emulator_reading(dir: &Path, commands: &[&str]) -> (Proc, String) {
    let truth = dir.join("truth.jsonl");
    let mut args = vec!["urg-emulator", "--pty", "--scenario", "corridor"];
    args.extend_from_slice(commands);
    args.extend(["--truth", truth.to_str().unwrap()]);
    let mut emu = spawn("urg-emulator", dir, &args, Stdio::piped());
    let pty = pty_path(&mut emu);
    (emu, pty)
}

/// A config for the corridor's robot (the simulator's defaults) on `pty`.
pub fn config(dir: &Path, pty: &str) -> PathBuf {
    config_with(dir, pty, "")
}

/// [`config`] with `extra` tables.
pub fn config_with(dir: &Path, pty: &str, extra: &str) -> PathBuf {
    wheels_config(dir, pty, extra)
}

/// `tether run` with its stdout lines kept and passed on to `feed` (the emulator's
/// stdin).
pub fn run(
    dir: &Path,
    config: &Path,
    extra: &[&str],
    feed: ChildStdin,
) -> (Proc, Arc<Mutex<Vec<String>>>) {
    run_feeding(dir, config, extra, vec![feed])
}

/// [`run`], its lines passed on to each of `feeds` (the emulators of several scanners).
pub fn run_feeding(
    dir: &Path,
    config: &Path,
    extra: &[&str],
    feeds: Vec<ChildStdin>,
) -> (Proc, Arc<Mutex<Vec<String>>>) {
    let mut args = vec!["run", "--config", config.to_str().unwrap()];
    args.extend_from_slice(extra);
    let mut run = spawn("run", dir, &args, Stdio::null());
    let stdout = run.child.stdout.take().unwrap();
    let lines = Arc::new(Mutex::new(Vec::new()));
    let kept = Arc::clone(&lines);
    std::thread::spawn(move || {
        let mut feeds: Vec<Option<ChildStdin>> = feeds.into_iter().map(Some).collect();
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            for feed in &mut feeds {
                if let Some(f) = feed.as_mut()
                    && writeln!(f, "{line}").is_err()
                {
                    *feed = None;
                }
            }
            kept.lock().unwrap().push(line);
        }
    });
    (run, lines)
}

/// `tether run` with `extra` arguments and the config's `tables` on a fresh emulator's
/// pty, its commands driving the emulator's robot: the emulator, the run and the lines
/// it printed so far.
pub fn following(
    dir: &Path,
    tables: &str,
    extra: &[&str],
) -> (Proc, Proc, Arc<Mutex<Vec<String>>>) {
    following_with(dir, &["--commands-stdin"], tables, |text| text, extra)
}

/// [`following`] with the emulator's `commands` arguments (which must keep
/// `--commands-stdin`) and the config's text passed through `edit`.
pub fn following_with(
    dir: &Path,
    commands: &[&str],
    tables: &str,
    edit: impl FnOnce(String) -> String,
    extra: &[&str],
) -> (Proc, Proc, Arc<Mutex<Vec<String>>>) {
    let (mut emu, pty) = emulator_reading(dir, commands);
    let feed = emu.child.stdin.take().unwrap();
    let config = config_with(dir, &pty, tables);
    std::fs::write(&config, edit(std::fs::read_to_string(&config).unwrap())).unwrap();
    let (run, lines) = run(dir, &config, extra, feed);
    (emu, run, lines)
}

pub fn json(line: &str) -> serde_json::Value {
    serde_json::from_str(line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"))
}

/// Waits until `ready` holds for the lines `run` has printed; fails the test when the
/// run exits first, or with `failure` after 60 s.
pub fn wait_until(
    run: &mut Proc,
    lines: &Mutex<Vec<String>>,
    ready: impl Fn(&[String]) -> bool,
    failure: &str,
) {
    let started = Instant::now();
    while !ready(&lines.lock().unwrap()) {
        if let Some(status) = run.child.try_wait().unwrap() {
            panic!("tether run exited early ({status}):\n{}", run.stderr());
        }
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "{failure}; stderr:\n{}",
            run.stderr()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Waits until one of the `recent` last lines `run` printed drives forward faster than
/// `mps`; fails the test with `failure` after 60 s.
pub fn wait_until_driving(
    run: &mut Proc,
    lines: &Mutex<Vec<String>>,
    recent: usize,
    mps: f64,
    failure: &str,
) {
    wait_until(
        run,
        lines,
        |l| {
            l.iter()
                .rev()
                .take(recent)
                .any(|l| json(l)["v_mps"].as_f64().unwrap_or(0.0) > mps)
        },
        failure,
    );
}

/// Waits until `run` has printed `n` lines.
pub fn wait_for_lines(run: &mut Proc, lines: &Mutex<Vec<String>>, n: usize) {
    wait_until(
        run,
        lines,
        |l| l.len() >= n,
        &format!("tether run printed fewer than {n} lines in 60 s"),
    );
}

/// The last line, checked to be the final stop for `why`.
pub fn assert_final_stop(lines: &Mutex<Vec<String>>, why: &str, stderr: &str) {
    // The reader thread may still be taking the last line.
    let started = Instant::now();
    loop {
        let last = lines.lock().unwrap().last().map(|l| json(l));
        if let Some(last) = last
            && last["input"] == "final"
        {
            assert_eq!(last["v_mps"], 0.0);
            assert_eq!(last["w_radps"], 0.0);
            assert_eq!(last["stop"], why, "{last}");
            return;
        }
        assert!(
            started.elapsed() < Duration::from_secs(5),
            "the last line is not a final stop: {:?}\nstderr:\n{stderr}",
            lines.lock().unwrap().last()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// A free TCP port on loopback (bound, then let go).
pub fn free_loopback_address() -> String {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().to_string()
}

/// The lines of an emulator's `--truth` file.
pub fn emulator_truth(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(json)
        .collect()
}

/// `(x, y)` of a truth line's pose or person, m.
pub fn xy(v: &serde_json::Value) -> (f64, f64) {
    (v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap())
}

/// The distance from the robot to the target in a truth line, m.
pub fn gap_to_target(t: &serde_json::Value) -> f64 {
    let (rx, ry) = xy(&t["robot"]);
    let target = t["people"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["target"] == true)
        .unwrap();
    let (px, py) = xy(target);
    (px - rx).hypot(py - ry)
}
