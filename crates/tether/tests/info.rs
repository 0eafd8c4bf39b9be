//! `tether info` through the release binary (issue 17, "Looking inside recordings"):
//!
//! - on every ROS 1 bag of leg_tracker's recordings in `../shared` (and its
//!   `positive_not_extracted/`), the topics, message types and counts of `--json` equal
//!   what Python's `rosbags` reads from the bag (`tests/info_reference.py`), and every
//!   scan topic shows its geometry, frame ids and rate;
//! - on an MCAP file written by `tether sim --record`, they equal what Python's `mcap`
//!   reads from the summary statistics;
//! - a bag (and an MCAP file) cut in half is read up to the cut and says so;
//! - a file that is no recording, or no file at all, is refused, saying what it is.
//!
//! The bag tests skip when `../shared` is absent and the Python comparisons when
//! `python3` lacks `rosbags` or `mcap` (printing `SKIPPED: reason`), unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use common::{scratch, tether, text};
use serde_json::Value;

const REFERENCE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/info_reference.py");

/// leg_tracker's bags, or `None` (skipped) when `../shared` is missing.
fn leg_tracker_bags() -> Option<Vec<PathBuf>> {
    let dir = tether_testkit::shared("data/laser/leg_tracker")?;
    let mut bags = Vec::new();
    for folder in [dir.clone(), dir.join("positive_not_extracted")] {
        let Ok(entries) = std::fs::read_dir(&folder) else {
            continue;
        };
        bags.extend(
            entries
                .map(|e| e.unwrap().path())
                .filter(|p| p.extension().is_some_and(|e| e == "bag")),
        );
    }
    bags.sort();
    assert!(!bags.is_empty(), "no .bag in {}", dir.display());
    Some(bags)
}

/// Whether `python3` has `rosbags` and `mcap` (else skipped).
fn have_python() -> bool {
    let ok = Command::new("python3")
        .args([REFERENCE, "check"])
        .output()
        .is_ok_and(|o| o.status.success());
    tether_testkit::skip_unless(
        ok,
        "python3 with `rosbags` and `mcap` is not available (pip install rosbags mcap)",
    )
}

/// `tether info FILE --json`, parsed; the command must succeed.
fn info_json(file: &Path) -> Value {
    let out = tether(&["info", file.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "tether info {}: {}\n{}",
        file.display(),
        out.status,
        text(&out.stderr)
    );
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("--json is not JSON ({e}): {}", text(&out.stdout)))
}

/// `{topic: (type, count)}` of tether's JSON.
fn tether_topics(info: &Value) -> BTreeMap<String, (String, u64)> {
    info["topics"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["topic"].as_str().unwrap().to_owned(),
                (
                    t["type"].as_str().unwrap().to_owned(),
                    t["count"].as_u64().unwrap(),
                ),
            )
        })
        .collect()
}

/// `{topic: (type, count)}` as Python reads `file` (`kind`: `bag` or `mcap`).
fn python_topics(kind: &str, file: &Path) -> BTreeMap<String, (String, u64)> {
    let out = Command::new("python3")
        .args([REFERENCE, kind, file.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "info_reference.py {kind} {}: {}",
        file.display(),
        text(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object()
        .unwrap()
        .iter()
        .map(|(topic, t)| {
            (
                topic.clone(),
                (
                    t["type"].as_str().unwrap().to_owned(),
                    t["count"].as_u64().unwrap(),
                ),
            )
        })
        .collect()
}

/// The topic object named `topic` of tether's JSON.
fn topic<'a>(info: &'a Value, topic: &str) -> &'a Value {
    info["topics"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["topic"] == topic)
        .unwrap_or_else(|| panic!("no topic {topic} in {info}"))
}

/// What every scan topic of a whole recording shows: geometry, a frame, a rate.
fn check_scan_topics(info: &Value, file: &Path) {
    let scans: Vec<&Value> = info["topics"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|t| t["type"].as_str().unwrap().ends_with("/LaserScan"))
        .collect();
    assert!(!scans.is_empty(), "{}: no scan topic", file.display());
    for t in scans {
        let what = format!("{} {}", file.display(), t["topic"]);
        let scan = &t["scan"];
        assert!(scan["beams"].as_u64().unwrap() > 100, "{what}: {scan}");
        let fov = scan["fov_deg"].as_f64().unwrap();
        assert!(fov > 90.0 && fov <= 360.0, "{what}: fov {fov}");
        let inc = scan["angle_increment_deg"].as_f64().unwrap();
        let beams = scan["beams"].as_f64().unwrap();
        assert!(
            ((beams - 1.0) * inc - fov).abs() < 1.01 * inc,
            "{what}: {beams} beams of {inc} deg do not span {fov} deg"
        );
        let (rmin, rmax) = (
            scan["range_min_m"].as_f64().unwrap(),
            scan["range_max_m"].as_f64().unwrap(),
        );
        assert!(rmin >= 0.0 && rmax > rmin, "{what}: ranges {rmin}..{rmax}");
        assert_eq!(t["has_header"], true, "{what}");
        assert!(
            !t["frame_ids"].as_array().unwrap().is_empty(),
            "{what}: no frame id"
        );
        assert_eq!(t["bad_headers"], 0, "{what}");
        assert!(t["rate_hz"].as_f64().unwrap() > 0.0, "{what}");
    }
}

#[test]
fn every_leg_tracker_bag_matches_rosbags() {
    let Some(bags) = leg_tracker_bags() else {
        return;
    };
    if !have_python() {
        return;
    }
    for bag in &bags {
        let info = info_json(bag);
        let ours = tether_topics(&info);
        let theirs = python_topics("bag", bag);
        assert_eq!(ours, theirs, "{}: tether info vs rosbags", bag.display());
        assert_eq!(info["format"], "ros1_bag", "{}", bag.display());
        assert_eq!(info["read"]["status"], "whole", "{}", bag.display());
        assert_eq!(info["read"]["whole"], true);
        let total: u64 = theirs.values().map(|(_, n)| n).sum();
        assert_eq!(info["messages"], total, "{}", bag.display());
        assert_eq!(
            info["size_bytes"],
            std::fs::metadata(bag).unwrap().len(),
            "{}",
            bag.display()
        );
        let (start, end) = (
            info["start_ns"].as_i64().unwrap(),
            info["end_ns"].as_i64().unwrap(),
        );
        let duration = info["duration_s"].as_f64().unwrap();
        assert!(end > start, "{}", bag.display());
        assert!(((end - start) as f64 / 1e9 - duration).abs() < 1e-6);
        check_scan_topics(&info, bag);
        println!(
            "{}: {} messages on {} topics over {duration:.3} s",
            bag.file_name().unwrap().to_string_lossy(),
            total,
            ours.len()
        );
    }
    // The one recording of a still robot: a URG-04LX-like scan at 10 Hz for 126 s.
    let demo = bags
        .iter()
        .find(|b| b.ends_with("demo_stationary_simple_environment.bag"))
        .unwrap();
    let info = info_json(demo);
    let scan = topic(&info, "/scan");
    let rate = scan["rate_hz"].as_f64().unwrap();
    assert!((rate - 10.0).abs() < 0.2, "rate {rate}");
    assert!((info["duration_s"].as_f64().unwrap() - 126.0).abs() < 1.0);
    // The human table names the same.
    let out = tether(&["info", demo.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    println!("{table}");
    for needle in [
        "ROS 1 bag 2.0",
        "sensor_msgs/LaserScan",
        "1265",
        "beams",
        "field of view",
    ] {
        assert!(table.contains(needle), "{needle:?} missing from:\n{table}");
    }
}

#[test]
fn a_simulated_mcap_matches_python_mcap() {
    if !have_python() {
        return;
    }
    let dir = scratch("info-mcap");
    let mcap = common::record_corridor(&dir, 3, &["--laser-only"], "--record", "x.mcap");
    let info = info_json(&mcap);
    assert_eq!(
        tether_topics(&info),
        python_topics("mcap", &mcap),
        "tether info vs mcap"
    );
    assert_eq!(info["format"], "mcap");
    assert_eq!(info["profile"], "ros2");
    // The writer names the application, not one of its crates.
    assert_eq!(
        info["library"],
        concat!("tether ", env!("CARGO_PKG_VERSION")),
        "{info}"
    );
    assert_eq!(info["read"]["status"], "whole", "{}", info["read"]);
    check_scan_topics(&info, &mcap);
    let scan = topic(&info, "/scan");
    assert_eq!(scan["type"], "sensor_msgs/msg/LaserScan");
    let rate = scan["rate_hz"].as_f64().unwrap();
    assert!((rate - 10.0).abs() < 0.5, "simulated scans at {rate} Hz");
    let duration = info["duration_s"].as_f64().unwrap();
    assert!(duration > 2.5 && duration <= 3.0, "{duration}");

    // Cut in half: read by a linear scan up to the cut, and said so.
    let bytes = std::fs::read(&mcap).unwrap();
    let cut = dir.join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let info = info_json(&cut);
    assert_eq!(info["read"]["status"], "cut_short", "{}", info["read"]);
    assert_eq!(info["read"]["whole"], false);
    assert!(info["read"]["index_unused"].is_string());
    let scans = topic(&info, "/scan")["count"].as_u64().unwrap();
    assert!(scans > 0, "nothing before the cut");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bag_cut_in_half_is_read_up_to_the_cut() {
    let Some(bags) = leg_tracker_bags() else {
        return;
    };
    let demo = bags
        .iter()
        .find(|b| b.ends_with("demo_stationary_simple_environment.bag"))
        .unwrap();
    let whole = info_json(demo);
    let all = topic(&whole, "/scan")["count"].as_u64().unwrap();
    let bytes = std::fs::read(demo).unwrap();
    let dir = scratch("info-cut");
    let cut = dir.join("cut.bag");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let info = info_json(&cut);
    let read = &info["read"];
    assert_eq!(read["status"], "cut_short", "{read}");
    assert_eq!(read["whole"], false);
    assert!(read["index_unused"].is_string(), "{read}");
    assert!(
        read["cut"].as_str().unwrap().contains("ends inside"),
        "{read}"
    );
    let some = topic(&info, "/scan")["count"].as_u64().unwrap();
    assert!(
        some > all / 4 && some < all,
        "{some} of {all} scans before the cut"
    );
    assert!(topic(&info, "/scan")["scan"]["beams"].as_u64().unwrap() > 100);
    // The table says it too, and the command succeeds.
    let out = tether(&["info", cut.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("cut short"),
        "{}",
        text(&out.stdout)
    );
    // Nothing but the bag header: nothing readable, an error.
    let stub = dir.join("stub.bag");
    std::fs::write(&stub, &bytes[..5000]).unwrap();
    let out = tether(&["info", stub.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(
        text(&out.stderr).contains("nothing readable"),
        "{}",
        text(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_is_no_recording_is_refused_clearly() {
    let dir = scratch("info-refused");
    let cases: [(&str, &[u8], &str); 4] = [
        (
            "notes.bag",
            b"hello, this is text\n",
            "\"hello, this is t\"",
        ),
        (
            "image.mcap",
            b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR",
            "a PNG image",
        ),
        ("empty.bag", b"", "empty"),
        ("old.bag", b"#ROSBAG V1.2\n....", "another format version"),
    ];
    for (name, bytes, what) in cases {
        let file = dir.join(name);
        std::fs::write(&file, bytes).unwrap();
        let out = tether(&["info", file.to_str().unwrap(), "--json"]);
        let err = text(&out.stderr);
        assert!(!out.status.success(), "{name}: accepted");
        assert!(out.stdout.is_empty(), "{name}: {}", text(&out.stdout));
        assert!(
            err.contains("is not a ROS 1 bag or MCAP file: it")
                && err.contains(what)
                && err.contains(name),
            "{name}: {err}"
        );
    }
    let missing = dir.join("no-such.bag");
    let out = tether(&["info", missing.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains(missing.to_str().unwrap()) && err.contains("No such file"),
        "{err}"
    );
    let out = tether(&["info", dir.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(text(&out.stderr).contains("is a folder"));
    let _ = std::fs::remove_dir_all(&dir);
}
