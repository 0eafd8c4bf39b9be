//! Golden target traces (issue 31, "first, a net"): for every built-in scenario, seeds
//! 0-2, fused and laser-only, and for three of leg_tracker's real recordings, the
//! sequence of the target lock's transitions (time, from, to: state, track, loss
//! reason; and which transition of design 5.6 it was) and the candidates it refused, checked in under `tests/golden/targets/`. The
//! test recomputes every trace and fails with a unified diff of the lines that moved.
//! The lock itself is design 5.6 and 11.
//!
//! To rewrite the files on purpose (after a change to the lock that is meant to move
//! them), and to see what moved in `git diff`:
//!
//! ```sh
//! TETHER_BLESS=1 cargo nextest run --release -p tether --test target_traces
//! ```
//!
//! Transitions are derived tick to tick from the pipeline's [`TargetStateLine`] (the
//! words of `tether track`'s `target_state`): a line whenever the state's name, its
//! track or its loss reason changes, or the lock reports a transition, ending with the
//! transition's name (`: reacquired`). A `somebody_else` refusal says why in brackets
//! (`somebody_else (seen_beside)`). Refusals are collapsed within each stretch between
//! two transitions: one line per (track, reason) at its first time, with the count of
//! ticks that refused it and the last time when more than one.
//!
//! The real recordings go through the `tether` binary (`tether track`, its defaults), so
//! the trace is what a user gets; they need `../shared`: without it the test prints why
//! and skips, unless `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use tether::results::TargetStateLine;
use tether_eval::closed_loop;
use tether_pipeline::PipelineConfig;
use tether_sim::{BUILTIN_NAMES, Scenario};

/// The variable that rewrites the golden files instead of comparing with them.
const BLESS: &str = "TETHER_BLESS";

/// The command that rewrites the golden files.
const BLESS_COMMAND: &str =
    "TETHER_BLESS=1 cargo nextest run --release -p tether --test target_traces";

/// Seeds of each scenario and mode.
const SEEDS: [u64; 3] = [0, 1, 2];

/// Lines of context around each change in a diff.
const CONTEXT_LINES: usize = 2;

/// The real recordings: leg_tracker's bag and its scan topic.
const RECORDINGS: [(&str, &str); 3] = [
    ("positive_6_extracted.bag", "/training_scan"),
    ("positive_7_extracted.bag", "/training_scan"),
    ("demo_stationary_simple_environment.bag", "/scan"),
];

fn golden_dir(kind: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden/targets")
        .join(kind)
}

fn blessing() -> bool {
    std::env::var(BLESS).is_ok_and(|v| v == "1")
}

/// One tick of the target lock: time since the start in milliseconds, its state as
/// written in a trace, the tracks refused at that tick and why.
#[derive(Debug, Clone, PartialEq)]
struct TickTarget {
    t_ms: i64,
    state: String,
    transition: Option<String>,
    refused: Vec<(u64, String)>,
}

/// `searching`, `locked(track 4)` or `lost(track 4, unseen)`.
fn state_text(state: &str, track: Option<u64>, reason: Option<&str>) -> String {
    match (track, reason) {
        (Some(t), Some(r)) => format!("{state}(track {t}, {r})"),
        (Some(t), None) => format!("{state}(track {t})"),
        (None, Some(r)) => format!("{state}({r})"),
        (None, None) => state.to_owned(),
    }
}

/// `not_walking`, or `somebody_else (seen_beside)` with why it is somebody else.
fn refusal_text(why: &str, because: Option<&str>) -> String {
    match because {
        Some(b) => format!("{why} ({b})"),
        None => why.to_owned(),
    }
}

/// Nanoseconds to whole milliseconds, rounded to nearest.
fn ms_of_ns(ns: i64) -> i64 {
    (ns + 500_000).div_euclid(1_000_000)
}

/// `12.300 s`, right-aligned so that the columns of a file line up.
fn time_text(t_ms: i64) -> String {
    let sign = if t_ms < 0 { "-" } else { "" };
    let a = t_ms.unsigned_abs();
    format!("{:>9} s", format!("{sign}{}.{:03}", a / 1000, a % 1000))
}

/// A refused (track, reason) within one stretch: first time, last time, ticks.
struct Refused {
    first_ms: i64,
    last_ms: i64,
    ticks: u64,
}

fn flush_refusals(lines: &mut Vec<String>, stretch: &mut Vec<((u64, String), Refused)>) {
    for ((track, why), r) in stretch.drain(..) {
        let mut line = format!("{}  refused track {track}: {why}", time_text(r.first_ms));
        if r.ticks > 1 {
            let _ = write!(line, "  x{} until {}", r.ticks, time_text(r.last_ms).trim());
        }
        lines.push(line);
    }
}

/// The trace's body: `start`, every transition, the refusals collapsed per stretch
/// between transitions (in order of first appearance), and `end` with the tick count.
fn trace_lines(ticks: &[TickTarget]) -> Vec<String> {
    let mut lines = Vec::new();
    let mut prev: Option<&str> = None;
    let mut stretch: Vec<((u64, String), Refused)> = Vec::new();
    for tick in ticks {
        if prev != Some(tick.state.as_str()) || tick.transition.is_some() {
            flush_refusals(&mut lines, &mut stretch);
            let mut line = match prev {
                None => format!("{}  start {}", time_text(tick.t_ms), tick.state),
                Some(p) => format!("{}  {p} -> {}", time_text(tick.t_ms), tick.state),
            };
            if let Some(t) = &tick.transition {
                let _ = write!(line, ": {t}");
            }
            lines.push(line);
            prev = Some(&tick.state);
        }
        for key in &tick.refused {
            match stretch.iter_mut().find(|(k, _)| k == key) {
                Some((_, r)) => {
                    r.last_ms = tick.t_ms;
                    r.ticks += 1;
                }
                None => stretch.push((
                    key.clone(),
                    Refused {
                        first_ms: tick.t_ms,
                        last_ms: tick.t_ms,
                        ticks: 1,
                    },
                )),
            }
        }
    }
    flush_refusals(&mut lines, &mut stretch);
    if let (Some(last), Some(state)) = (ticks.last(), prev) {
        lines.push(format!(
            "{}  end {state} ({} ticks)",
            time_text(last.t_ms),
            ticks.len()
        ));
    }
    lines
}

/// A whole file: `header` lines as comments, then the trace.
fn trace_file(header: &[String], ticks: &[TickTarget]) -> String {
    let mut s = String::new();
    for h in header {
        let _ = writeln!(s, "# {h}");
    }
    for line in trace_lines(ticks) {
        let _ = writeln!(s, "{line}");
    }
    s
}

/// The sensor modes of `tether eval-target` traced here.
#[derive(Debug, Clone, Copy)]
enum Mode {
    Fused,
    Laser,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Fused => "fused",
            Mode::Laser => "laser",
        }
    }

    /// The scenario and driving configuration as `tether eval-target --mode` and `tether
    /// sim [--laser-only]` run them (`cmd::eval_target::Mode::config`,
    /// `closed_loop::laser_only`): laser only is the scenario with its
    /// camera off and vision off in the pipeline.
    fn setup(self, scenario: &Scenario) -> (Scenario, PipelineConfig) {
        let mut s = scenario.clone();
        let mut c = closed_loop::config_for(scenario, &PipelineConfig::default());
        if let Mode::Laser = self {
            s.camera_sim.enabled = false;
            c.fusion.use_vision = false;
        }
        (s, c)
    }
}

/// The driving pipeline's target at every tick of a closed-loop run.
fn simulated_ticks(scenario: &Scenario, seed: u64, mode: Mode) -> Vec<TickTarget> {
    let (s, config) = mode.setup(scenario);
    let log = closed_loop::run(&s, seed, &config, &[], &[])
        .unwrap_or_else(|e| panic!("{} seed {seed} {}: {e}", scenario.name, mode.name()));
    log.steps
        .iter()
        .filter_map(|step| step.tick.as_ref())
        .map(|tick| {
            let line = TargetStateLine::of(tick);
            TickTarget {
                t_ms: ms_of_ns(tick.stamp.ns()),
                state: state_text(line.state, line.track, line.reason),
                transition: line.transition.map(str::to_owned),
                refused: line
                    .refused
                    .iter()
                    .map(|r| (r.track, refusal_text(r.why, r.because)))
                    .collect(),
            }
        })
        .collect()
}

/// The target of every line of `tether track`'s output, times from the first scan.
fn recorded_ticks(jsonl: &str) -> Vec<TickTarget> {
    let lines = tether_testkit::json_lines(jsonl);
    let first_ns = lines.first().map_or(0, |l| l["stamp_ns"].as_i64().unwrap());
    lines
        .iter()
        .map(|l| {
            let s = &l["target_state"];
            TickTarget {
                t_ms: ms_of_ns(l["stamp_ns"].as_i64().unwrap() - first_ns),
                state: state_text(
                    s["state"].as_str().unwrap(),
                    s["track"].as_u64(),
                    s["reason"].as_str(),
                ),
                transition: s["transition"].as_str().map(str::to_owned),
                refused: s["refused"].as_array().map_or(Vec::new(), |a| {
                    a.iter()
                        .map(|r| {
                            let why =
                                refusal_text(r["why"].as_str().unwrap(), r["because"].as_str());
                            (r["track"].as_u64().unwrap(), why)
                        })
                        .collect()
                }),
            }
        })
        .collect()
}

/// A line diff of `old` against `new`: `(tag, line)` with tag ' ', '-' or '+', from the
/// longest common subsequence (the files are a few hundred lines at most).
fn line_diff<'a>(old: &[&'a str], new: &[&'a str]) -> Vec<(char, &'a str)> {
    let (n, m) = (old.len(), new.len());
    // lcs[i][j]: the longest common subsequence of old[i..] and new[j..].
    let mut lcs = vec![vec![0u32; m + 1]; n + 1];
    for i in (0..n).rev() {
        for j in (0..m).rev() {
            lcs[i][j] = if old[i] == new[j] {
                lcs[i + 1][j + 1] + 1
            } else {
                lcs[i + 1][j].max(lcs[i][j + 1])
            };
        }
    }
    let (mut i, mut j, mut out) = (0, 0, Vec::new());
    while i < n || j < m {
        if i < n && j < m && old[i] == new[j] {
            out.push((' ', old[i]));
            i += 1;
            j += 1;
        } else if i < n && (j == m || lcs[i + 1][j] >= lcs[i][j + 1]) {
            // What went comes before what came in its place.
            out.push(('-', old[i]));
            i += 1;
        } else {
            out.push(('+', new[j]));
            j += 1;
        }
    }
    out
}

/// The changed lines of `old` -> `new` with [`CONTEXT_LINES`] of context, in hunks
/// headed `@@ -line +line @@` (1-based line numbers in each file).
fn unified_diff(name: &str, old: &str, new: &str) -> String {
    let (old_lines, new_lines): (Vec<&str>, Vec<&str>) =
        (old.lines().collect(), new.lines().collect());
    let diff = line_diff(&old_lines, &new_lines);
    let changed: Vec<usize> = (0..diff.len()).filter(|&k| diff[k].0 != ' ').collect();
    let mut out = format!("--- {name} (checked in)\n+++ {name} (recomputed)\n");
    let mut k = 0;
    while k < changed.len() {
        let start = changed[k].saturating_sub(CONTEXT_LINES);
        let mut end = changed[k];
        while k < changed.len() && changed[k] <= end + 2 * CONTEXT_LINES + 1 {
            end = changed[k];
            k += 1;
        }
        let end = (end + CONTEXT_LINES + 1).min(diff.len());
        let before = &diff[..start];
        let old_at = 1 + before.iter().filter(|(t, _)| *t != '+').count();
        let new_at = 1 + before.iter().filter(|(t, _)| *t != '-').count();
        let _ = writeln!(out, "@@ -{old_at} +{new_at} @@");
        for (tag, line) in &diff[start..end] {
            let _ = writeln!(out, "{tag}{line}");
        }
    }
    out
}

/// Compares the recomputed `traces` (file name -> text) with the files of `dir`, or
/// rewrites them under [`BLESS`]. With `complete`, files of `dir` not recomputed are
/// stale: a failure, deleted when blessing. Panics with every diff.
fn check_against_golden(dir: &Path, traces: &BTreeMap<String, String>, complete: bool) {
    let bless = blessing();
    if bless {
        std::fs::create_dir_all(dir).unwrap();
    }
    let mut failures = String::new();
    let mut moved = 0;
    for (name, new) in traces {
        let path = dir.join(name);
        let old = std::fs::read_to_string(&path).ok();
        if old.as_deref() == Some(new.as_str()) {
            continue;
        }
        moved += 1;
        if bless {
            std::fs::write(&path, new).unwrap();
            println!("rewrote {}", path.display());
        } else if let Some(old) = old {
            failures.push_str(&unified_diff(name, &old, new));
        } else {
            let _ = writeln!(failures, "{} is missing", path.display());
        }
    }
    if complete && let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if traces.contains_key(&name) {
                continue;
            }
            moved += 1;
            if bless {
                std::fs::remove_file(&path).unwrap();
                println!("removed {} (no such trace any more)", path.display());
            } else {
                let _ = writeln!(failures, "{} is no trace any more", path.display());
            }
        }
    }
    if !bless && moved > 0 {
        panic!(
            "{moved} of {} target traces under {} moved:\n\n{failures}\nIf the change is \
             meant, rewrite them with `{BLESS_COMMAND}` and commit the files.",
            traces.len(),
            dir.display()
        );
    }
    println!(
        "{} target traces under {}: {}",
        traces.len(),
        dir.display(),
        if bless {
            format!("{moved} rewritten")
        } else {
            "as checked in".to_owned()
        }
    );
}

/// The simulated traces: every built-in scenario at its full length, seeds [`SEEDS`],
/// fused and laser only, in parallel.
fn simulated_traces() -> BTreeMap<String, String> {
    let jobs: Vec<(&str, u64, Mode)> = BUILTIN_NAMES
        .iter()
        .flat_map(|&name| {
            SEEDS
                .iter()
                .flat_map(move |&seed| [Mode::Fused, Mode::Laser].map(|m| (name, seed, m)))
        })
        .collect();
    jobs.par_iter()
        .map(|&(name, seed, mode)| {
            let scenario = Scenario::builtin(name).unwrap();
            let ticks = simulated_ticks(&scenario, seed, mode);
            let header = [
                format!(
                    "Target lock transitions of the built-in scenario `{name}`, seed {seed}, {}, \
                     {} s simulated (the scenario's full length), the pipeline's defaults.",
                    match mode {
                        Mode::Fused => "fused (laser and camera)",
                        Mode::Laser => "laser only (the camera off)",
                    },
                    scenario.duration_s
                ),
                "Time since the start; refusals collapsed per stretch between transitions."
                    .to_owned(),
                format!("Rewrite on purpose: {BLESS_COMMAND}"),
            ];
            (
                format!("{name}-seed{seed}-{}.txt", mode.name()),
                trace_file(&header, &ticks),
            )
        })
        .collect()
}

#[test]
fn simulated_target_traces_match_the_golden_files() {
    check_against_golden(&golden_dir("sim"), &simulated_traces(), true);
}

#[test]
fn real_target_traces_match_the_golden_files() {
    let dir = common::scratch("target-traces");
    let mut traces = BTreeMap::new();
    for (bag_name, topic) in RECORDINGS {
        let Some(bag) = common::leg_tracker(bag_name) else {
            return;
        };
        let out = dir.join(bag_name.replace(".bag", ".jsonl"));
        let run = common::on_recording("track", &bag, topic, &[], &out);
        assert!(run.status.success(), "{}", common::text(&run.stderr));
        let ticks = recorded_ticks(&std::fs::read_to_string(&out).unwrap());
        let header = [
            format!(
                "Target lock transitions of `tether track {bag_name} --scan-topic {topic}` \
                 (leg_tracker's recording in ../shared, the defaults)."
            ),
            "Time since the recording's first scan; refusals collapsed per stretch between \
             transitions."
                .to_owned(),
            format!("Rewrite on purpose: {BLESS_COMMAND}"),
        ];
        traces.insert(
            bag_name.replace(".bag", ".txt"),
            trace_file(&header, &ticks),
        );
    }
    check_against_golden(&golden_dir("real"), &traces, true);
}

/// The runs traced are those of `tether sim` (the modes are set up here as the binary
/// does, which a test cannot call): its first lock, to the millisecond, in both modes.
#[test]
fn the_traced_runs_are_those_of_tether_sim() {
    let dir = common::scratch("target-traces-sim");
    for (name, mode) in [
        ("occlusion", Mode::Fused),
        ("occlusion", Mode::Laser),
        ("crossing", Mode::Fused),
        ("crossing", Mode::Laser),
    ] {
        let seed = 1;
        let out = dir.join(format!("{name}-{}", mode.name()));
        let mut args = vec!["sim", "--scenario", name, "--seed", "1"];
        if let Mode::Laser = mode {
            args.push("--laser-only");
        }
        args.extend(["--out", out.to_str().unwrap()]);
        let run = common::tether(&args);
        assert!(run.status.success(), "{}", common::text(&run.stderr));
        let metrics: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("metrics.json")).unwrap())
                .unwrap();
        let sim_first_lock_s = metrics["first_lock_s"].as_f64().unwrap();
        let ticks = simulated_ticks(&Scenario::builtin(name).unwrap(), seed, mode);
        let traced_first_lock_ms = ticks
            .iter()
            .find(|t| t.state.starts_with("locked"))
            .unwrap()
            .t_ms;
        assert_eq!(
            ms_of_ns((sim_first_lock_s * 1e9).round() as i64),
            traced_first_lock_ms,
            "{name} {}: `tether sim` locked first at {sim_first_lock_s} s",
            mode.name()
        );
    }
}

#[test]
fn a_moved_transition_shows_as_a_small_diff() {
    let old: String = (0..20).map(|i| format!("line {i}\n")).collect();
    let new = old.replace("line 10\n", "line 10 moved\n");
    let d = unified_diff("x.txt", &old, &new);
    assert_eq!(
        d,
        "--- x.txt (checked in)\n+++ x.txt (recomputed)\n@@ -9 +9 @@\n line 8\n line 9\n\
         -line 10\n+line 10 moved\n line 11\n line 12\n"
    );
    assert_eq!(
        unified_diff("x.txt", &old, &old),
        "--- x.txt (checked in)\n+++ x.txt (recomputed)\n"
    );
}

#[test]
fn transitions_are_derived_tick_to_tick_and_refusals_collapse() {
    let tick = |t_ms, state: &str, transition: Option<&str>, refused: &[(u64, &str)]| TickTarget {
        t_ms,
        state: state.to_owned(),
        transition: transition.map(str::to_owned),
        refused: refused.iter().map(|&(t, w)| (t, w.to_owned())).collect(),
    };
    let ticks = [
        tick(0, "searching", None, &[]),
        tick(100, "locked(track 4)", Some("chosen"), &[]),
        tick(200, "locked(track 4)", None, &[]),
        tick(
            12_300,
            "lost(track 4, unseen)",
            Some("lost"),
            &[(7, "somebody_else")],
        ),
        tick(
            12_400,
            "lost(track 4, unseen)",
            None,
            &[(7, "somebody_else"), (8, "not_walking")],
        ),
        tick(
            12_500,
            "lost(track 4, unseen)",
            None,
            &[(7, "somebody_else")],
        ),
        tick(13_000, "locked(track 9)", Some("reacquired"), &[]),
    ];
    assert_eq!(
        trace_lines(&ticks),
        [
            "    0.000 s  start searching",
            "    0.100 s  searching -> locked(track 4): chosen",
            "   12.300 s  locked(track 4) -> lost(track 4, unseen): lost",
            "   12.300 s  refused track 7: somebody_else  x3 until 12.500 s",
            "   12.400 s  refused track 8: not_walking",
            "   13.000 s  lost(track 4, unseen) -> locked(track 9): reacquired",
            "   13.000 s  end locked(track 9) (7 ticks)",
        ]
    );
}
