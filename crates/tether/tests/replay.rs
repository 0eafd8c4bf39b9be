//! `tether sim --record` then `tether replay`: a simulated run recorded as MCAP (ROS 2)
//! and replayed through the pipeline, byte for byte the same each time, with the target
//! where the ground truth says it was.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::path::Path;
use std::process::Output;

use common::{scratch, tether, text};
use tether_core::{Point2, World};
use tether_msgs::{PoseArrayMsg, PoseWithCovarianceStampedMsg, TwistMsg};
use tether_recording::mcap::McapFile;

fn ok(out: &Output) -> String {
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
    stdout
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn a_recorded_run_replays_identically_and_finds_the_target() {
    let dir = scratch("sim");
    let record = common::record_corridor(
        &dir,
        10,
        // Replay's bookkeeping on the ideal laser (the realistic one's effect on the
        // target is measured by `target_lock_realistic`).
        &["--seed", "3", "--ideal-laser"],
        "--record",
        "run.mcap",
    );
    let recorded = McapFile::open(&record).unwrap();
    for topic in ["/scan", "/odom", "/truth/people", "/tether/cmd_vel"] {
        assert!(recorded.message_count(topic) > 0, "{topic} missing");
    }
    let replay = |name: &str| {
        let out = dir.join(name);
        let stdout = ok(&tether(&[
            "replay",
            path(&record),
            "--odom-topic",
            "/odom",
            "--out",
            path(&out),
        ]));
        assert!(stdout.contains("101 scans"), "{stdout}");
        out
    };
    let a = replay("a.mcap");
    let b = replay("b.mcap");
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let html = std::fs::read_to_string(a.with_extension("html")).unwrap();
    assert_eq!(
        html,
        std::fs::read_to_string(b.with_extension("html")).unwrap()
    );
    assert!(html.contains("<svg") && html.contains("tether replay"));

    // The target, laser only, against the ground truth of the same instant.
    let truth: Vec<(i64, Vec<Point2<World>>)> = recorded
        .decoded::<PoseArrayMsg>(&["/truth/people"])
        .map(|m| {
            let m = m.unwrap();
            (m.message.header.stamp.ns(), m.message.positions_2d())
        })
        .collect();
    let results = McapFile::open(&a).unwrap();
    let scans = results.message_count("/tether/laser_people");
    // The target after each scan: the last estimate at a scan's instant (the control
    // timer's ticks between the scans have no ground truth of their own, and one on a
    // scan's instant comes before the scan).
    let estimates: std::collections::BTreeMap<i64, Point2<World>> = results
        .decoded::<PoseWithCovarianceStampedMsg>(&["/tether/target"])
        .map(|m| {
            let m = m.unwrap().message;
            (m.header.stamp.ns(), m.gaussian::<World>().unwrap().mean)
        })
        .collect();
    let mut errors: Vec<f64> = truth
        .iter()
        .filter_map(|(at, people)| {
            let estimate = *estimates.get(at)?;
            Some(
                people
                    .iter()
                    .map(|p| p.distance_m(estimate))
                    .fold(f64::INFINITY, f64::min),
            )
        })
        .collect();
    assert!(
        errors.len() as f64 >= 0.8 * scans as f64,
        "locked in {} of {scans} scans",
        errors.len()
    );
    errors.sort_by(f64::total_cmp);
    let median = errors[errors.len() / 2];
    assert!(median < 0.15, "median target error {median} m");
    // Commands on every tick, and the robot told to move at some point.
    let moving = results
        .decoded::<TwistMsg>(&["/tether/cmd_vel"])
        .filter(|m| m.as_ref().unwrap().message.v_mps() > 0.2)
        .count();
    assert!(moving > 10, "{moving} moving commands");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replay_refuses_what_it_cannot_read() {
    let dir = scratch("bad");
    let missing = tether(&["replay", path(&dir.join("nope.mcap"))]);
    assert!(!missing.status.success());
    assert!(text(&missing.stderr).contains("nope.mcap"));
    let notes = dir.join("notes.mcap");
    std::fs::write(&notes, "not a recording").unwrap();
    let bad = tether(&["replay", path(&notes)]);
    assert!(!bad.status.success());
    let stderr = text(&bad.stderr);
    assert!(stderr.starts_with("error:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
