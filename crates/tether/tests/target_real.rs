//! The target lock on leg_tracker's real demo recording (issue 14): once locked, the
//! target stays on the same track while that track is tracked, every line of `tether
//! track` says the target's state, every loss has a reason, and `tether replay`'s report
//! lists the losses with their reasons.
//!
//! Needs `../shared`; without it prints why and skips, unless `TETHER_REQUIRE_SHARED=1`
//! (set in CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::{scratch, text};

fn demo_bag() -> Option<PathBuf> {
    common::leg_tracker("demo_stationary_simple_environment.bag")
}

/// Runs `tether COMMAND BAG --scan-topic /scan --out OUT`; its standard output.
fn on_demo_bag(command: &str, bag: &Path, out: &Path) -> String {
    let run = common::on_recording(command, bag, "/scan", &[], out);
    assert!(run.status.success(), "{}", text(&run.stderr));
    text(&run.stdout)
}

#[test]
fn the_target_never_moves_to_another_track_while_its_own_is_tracked() {
    let Some(bag) = demo_bag() else { return };
    let dir = scratch("target-real");
    let out = dir.join("t.jsonl");
    let stdout = on_demo_bag("track", &bag, &out);
    assert!(stdout.contains("target locked"), "{stdout}");
    let lines = tether_testkit::json_lines(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(lines.len(), 1265);
    let (mut locked, mut losses) = (0, 0);
    let mut followed: Option<u64> = None;
    let mut prev_state = String::new();
    for (i, line) in lines.iter().enumerate() {
        let state = &line["target_state"];
        let name = state["state"].as_str().unwrap().to_owned();
        let tracked: BTreeSet<u64> = line["people"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["id"].as_u64().unwrap())
            .collect();
        match name.as_str() {
            "locked" => {
                locked += 1;
                let id = state["track"].as_u64().unwrap();
                assert_eq!(line["target"].as_u64(), Some(id));
                if let Some(old) = followed
                    && old != id
                {
                    assert!(
                        !tracked.contains(&old),
                        "scan {i}: the target moved from track {old} to {id} while {old} is \
                         still tracked"
                    );
                }
                followed = Some(id);
            }
            "lost" => {
                assert!(line["target"].is_null());
                let reason = state["reason"].as_str().unwrap();
                assert!(
                    ["unseen", "left_view", "sensor_gap", "track_dropped"].contains(&reason),
                    "{reason}"
                );
                if prev_state == "locked" {
                    losses += 1;
                }
            }
            "searching" => assert!(line["target"].is_null()),
            other => panic!("unknown state {other}"),
        }
        prev_state = name;
    }
    println!(
        "demo bag: locked in {locked} of {} scans, {losses} losses",
        lines.len()
    );
    assert!(locked > 400, "locked in {locked} scans");
}

#[test]
fn the_replay_report_lists_every_loss_with_its_reason() {
    let Some(bag) = demo_bag() else { return };
    let dir = scratch("target-real-replay");
    let out = dir.join("r.mcap");
    let stdout = on_demo_bag("replay", &bag, &out);
    let losses: usize = stdout
        .split(" in ")
        .nth(1)
        .and_then(|s| s.split(" losses").next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("no loss count in {stdout}"));
    let html = std::fs::read_to_string(dir.join("r.html")).unwrap();
    assert!(html.contains("Target: locks, losses and why"));
    let rows = html.matches("<tr class=\"lost\">").count();
    assert_eq!(rows, losses, "one row per loss");
    for reason in html.split("<tr class=\"lost\">").skip(1) {
        let why = reason.split("</tr>").next().unwrap();
        assert!(
            ["unseen", "left_view", "sensor_gap", "track_dropped"]
                .iter()
                .any(|r| why.contains(r)),
            "{why}"
        );
    }
}
