//! A reader that closes tether's standard output (`tether demo | head -1`) ends the
//! command cleanly: exit status 0, no panic, and a training saves the stage it was on
//! before it stops (issue 16, "Pipes and signals").

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::io::{BufRead, BufReader};
use std::process::{Command, Output, Stdio};

use common::{scratch, text};

/// Runs tether with its stdout on a pipe whose reader takes the first line and then
/// closes it, as `| head -1` does; returns the first line and the finished process.
fn first_line_then_close(args: &[&str]) -> (String, Output) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_tether"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the tether binary runs");
    let mut line = String::new();
    {
        let mut reader = BufReader::new(child.stdout.take().unwrap());
        reader.read_line(&mut line).unwrap();
        // The reader goes away here: tether's next write meets a closed pipe.
    }
    let out = child.wait_with_output().unwrap();
    (line, out)
}

fn assert_clean_end(what: &str, line: &str, out: &Output) {
    let err = text(&out.stderr);
    assert!(!line.is_empty(), "{what}: no first line; stderr: {err}");
    assert!(
        out.status.success(),
        "{what}: exit {:?} after stdout closed; stderr: {err}",
        out.status
    );
    assert!(!err.contains("panicked"), "{what}: {err}");
    assert!(!err.contains("error:"), "{what}: {err}");
}

#[test]
fn a_closed_stdout_ends_demo_and_scenarios_cleanly() {
    let dir = scratch("pipes-demo");
    let (line, out) = first_line_then_close(&["scenarios"]);
    assert_clean_end("scenarios", &line, &out);
    let (line, out) = first_line_then_close(&["demo", "--out", dir.to_str().unwrap()]);
    assert_clean_end("demo", &line, &out);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_closed_stdout_ends_eval_legs_cleanly() {
    let Some(data) = tether_testkit::shared("data/laser/leg_tracker") else {
        return;
    };
    let (line, out) = first_line_then_close(&["eval-legs", "--data", data.to_str().unwrap()]);
    assert_clean_end("eval-legs", &line, &out);
}

#[test]
fn a_training_whose_stdout_closes_saves_the_stage_it_was_on_and_stops() {
    let Some(train) = tether_testkit::shared("data/vtest/train.txt") else {
        return;
    };
    // A small training on six annotated frames (absolute paths, so the info file can
    // live in the scratch folder).
    let dir = scratch("pipes-train");
    let frames = train.parent().unwrap();
    let info: String = std::fs::read_to_string(&train)
        .unwrap()
        .lines()
        .take(6)
        .map(|l| format!("{}/{l}\n", frames.display()))
        .collect();
    let info_path = dir.join("info.dat");
    std::fs::write(&info_path, info).unwrap();
    let xml = dir.join("c.xml");
    let state = dir.join("c.xml.state.json");
    let (line, out) = first_line_then_close(&[
        "train-cascade",
        "--info",
        info_path.to_str().unwrap(),
        "--window",
        "12x24",
        "--stages",
        "6",
        "--num-neg",
        "40",
        "--max-features",
        "300",
        "--threads",
        "1",
        "--out",
        xml.to_str().unwrap(),
    ]);
    assert_clean_end("train-cascade", &line, &out);
    let err = text(&out.stderr);
    assert!(err.contains("the training stopped after stage 1"), "{err}");
    let saved: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&state).unwrap()).unwrap();
    assert_eq!(saved["cascade"]["stages"].as_array().unwrap().len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_closed_stdout_ends_track_and_legs_with_out_dash_cleanly() {
    // Thirty simulated seconds make some 300 lines, more than a pipe holds: tether is
    // still writing when the reader goes.
    let dir = scratch("pipes-track");
    let bag = common::corridor_bag(&dir, 30);
    let bag = bag.to_str().unwrap();
    let (line, out) = first_line_then_close(&["track", bag, "--scan-topic", "/scan", "--out", "-"]);
    assert_clean_end("track --out -", &line, &out);
    let (line, out) = first_line_then_close(&["legs", bag, "--topic", "/scan", "--out", "-"]);
    assert_clean_end("legs --out -", &line, &out);
    let _ = std::fs::remove_dir_all(&dir);
}
