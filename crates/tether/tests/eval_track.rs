//! `tether sim --record-bag` and `tether eval-track` end to end, through the binary: a
//! built-in scenario recorded as a ROS 1 bag in leg_tracker's annotation format, then
//! measured; and eval-track on leg_tracker's test recordings `positive_6/7` (from
//! `../shared`; skipped with a printed reason when absent, unless
//! `TETHER_REQUIRE_SHARED=1`).

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

mod common;

use std::path::{Path, PathBuf};

use common::{scratch, tether, text};
use serde_json::Value;
use tether_msgs::{LaserScanMsg, PersonArrayMsg};
use tether_recording::rosbag::Bag;

fn run_ok(args: &[&str]) -> String {
    let out = tether(args);
    assert!(
        out.status.success(),
        "tether {args:?} failed:\n{}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

fn sim_bag(dir: &Path, scenario: &str, seed: &str, extra: &[&str]) -> PathBuf {
    let bag = dir.join(format!("{scenario}-{seed}.bag"));
    let out = dir.join(format!("{scenario}-{seed}"));
    let mut args = vec![
        "sim",
        "--scenario",
        scenario,
        "--seed",
        seed,
        "--out",
        out.to_str().unwrap(),
        "--record-bag",
        bag.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let stdout = run_ok(&args);
    assert!(stdout.contains("the target is person 0"), "{stdout}");
    bag
}

fn eval(bag: &Path, json: &Path, extra: &[&str]) -> (String, Value) {
    let mut args = vec![
        "eval-track",
        bag.to_str().unwrap(),
        "--scan-topic",
        "/scan",
        "--labels-topic",
        "/people_truth",
        "--json",
        json.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let stdout = run_ok(&args);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    (stdout, v)
}

#[test]
fn simulated_bag_evaluates_sanely_and_deterministically() {
    let dir = scratch("eval-track-sim");
    // The evaluator's bookkeeping on the ideal laser, where the answers are plain (the
    // realistic laser's effect on the target is measured by `target_lock_realistic`).
    let bag = sim_bag(&dir, "corridor", "3", &["--ideal-laser"]);
    // The bag as written: one scan, one odometry and one label message per scan, the
    // labels stamped like their scan and right after it.
    let mut b = Bag::open(&bag).unwrap();
    assert_eq!(b.topics(), vec!["/odom", "/people_truth", "/scan"]);
    let n = b.message_count("/scan");
    assert!(n > 200, "{n} scans");
    assert_eq!(b.message_count("/people_truth"), n);
    let mut last_scan = None;
    for m in b.messages() {
        let m = m.unwrap();
        match m.topic() {
            "/scan" => last_scan = Some(m.decode::<LaserScanMsg>().unwrap().scan),
            "/people_truth" => {
                let p = m.decode::<PersonArrayMsg>().unwrap();
                let s = last_scan
                    .take()
                    .expect("labels come right after their scan");
                assert_eq!(p.header.stamp, s.stamp);
                assert_eq!(
                    (p.header.frame_id.as_str(), s.frame_id.as_str()),
                    ("laser", "laser")
                );
                assert!(
                    p.people.iter().all(|q| q.id == 0),
                    "corridor: one person, id 0"
                );
            }
            _ => {}
        }
    }
    let (stdout, v) = eval(&bag, &dir.join("a.json"), &["--odom-topic", "/odom"]);
    assert!(stdout.contains("CLEAR MOT"), "{stdout}");
    let m = &v["clear_mot"];
    let u = |x: &Value| x.as_u64().unwrap();
    // Consistent counts: every labelled person is matched or missed; MOTA from them.
    assert_eq!(u(&m["matches"]) + u(&m["misses"]), u(&m["objects"]));
    let mota = 1.0
        - (u(&m["misses"]) + u(&m["false_positives"]) + u(&m["id_switches"])) as f64
            / u(&m["objects"]) as f64;
    assert!((m["mota"].as_f64().unwrap() - mota).abs() < 1e-12);
    assert_eq!(u(&v["labelled_scans"]), n);
    assert_eq!(u(&v["unpaired_label_messages"]), 0);
    assert_eq!(u(&v["doubly_labelled_scans"]), 0);
    assert_eq!(
        v["stretches"].as_array().unwrap().len(),
        1,
        "no gap in a simulated run"
    );
    // An easy scenario: the target is on the person nearly all the time once locked.
    let t = &v["target"];
    assert_eq!(u(&t["label"]), 0);
    assert!(t["on_person_share"].as_f64().unwrap() > 0.9, "{t}");
    assert_eq!(u(&t["wrong_scans"]), 0, "{t}");
    assert_eq!(u(&t["switches_in_stretches"]), 0, "{t}");
    assert_eq!(
        u(&t["on_person_scans"]) + u(&t["lost_scans"]) + u(&t["wrong_scans"]),
        u(&t["labelled_scans"])
    );
    assert!(
        m["mota"].as_f64().unwrap() > 0.9 && m["motp_m"].as_f64().unwrap() < 0.1,
        "{m}"
    );
    // Deterministic: the same scenario and seed give the same bag bytes and figures.
    let first = std::fs::read(&bag).unwrap();
    let again = sim_bag(&dir, "corridor", "3", &["--ideal-laser"]);
    assert_eq!(first, std::fs::read(&again).unwrap());
    let (_, v2) = eval(&again, &dir.join("b.json"), &["--odom-topic", "/odom"]);
    assert_eq!(v, v2);
    // Without odometry in the bag, and two people crossing: the target label must be
    // given when there are several ids.
    let bag = sim_bag(&dir, "crossing", "1", &["--bag-without-odom"]);
    assert_eq!(
        Bag::open(&bag).unwrap().topics(),
        vec!["/people_truth", "/scan"]
    );
    let (stdout, v) = eval(&bag, &dir.join("c.json"), &[]);
    assert!(stdout.contains("give --target-label"), "{stdout}");
    assert!(v["target"].is_null());
    assert_eq!(v["label_ids"], serde_json::json!([0, 1]));
    let (_, v) = eval(&bag, &dir.join("d.json"), &["--target-label", "0"]);
    assert!(v["target"]["labelled_scans"].as_u64().unwrap() > 0);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mcap_with_world_frame_pose_labels() {
    // `tether sim --record` writes `/truth/people` (PoseArray, every person, world
    // frame) before each scan and each camera frame: the one stamped like the scan wins.
    let dir = scratch("eval-track-mcap");
    let mcap = dir.join("run.mcap");
    run_ok(&[
        "sim",
        "--scenario",
        "crossing",
        "--seed",
        "2",
        "--out",
        dir.join("run").to_str().unwrap(),
        "--record",
        mcap.to_str().unwrap(),
    ]);
    let json = dir.join("m.json");
    let args = [
        "eval-track",
        mcap.to_str().unwrap(),
        "--scan-topic",
        "/scan",
        "--labels-topic",
        "/truth/people",
        "--odom-topic",
        "/odom",
        "--pose-labels",
        "people",
        "--labels-frame",
        "world",
        "--target-label",
        "0",
        "--json",
        json.to_str().unwrap(),
    ];
    run_ok(&args);
    let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["labelled_scans"], v["scans"]);
    assert!(
        v["doubly_labelled_scans"].as_u64().unwrap() > 0,
        "camera-frame truths"
    );
    assert_eq!(v["frame_mismatches"], 0);
    assert_eq!(v["label_ids"], serde_json::json!([0, 1]));
    let t = &v["target"];
    assert!(t["on_person_share"].as_f64().unwrap() > 0.85, "{t}");
    assert_eq!(t["wrong_scans"], 0, "{t}");
    assert!(v["clear_mot"]["motp_m"].as_f64().unwrap() < 0.1, "{v}");
    // Taken in the scan's frame instead, the world-frame labels are far off: the
    // frame check says so and nothing matches.
    let mut scan_frame = args.to_vec();
    scan_frame[11] = "scan";
    let stdout = run_ok(&scan_frame);
    assert!(
        stdout.contains("in another frame than their scan"),
        "{stdout}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn refuses_a_labels_topic_that_is_not_labels() {
    let dir = scratch("eval-track-bad");
    let bag = sim_bag(&dir, "corridor", "1", &["--duration", "3"]);
    // `tether eval-track BAG --labels-topic LABELS`, which must fail; its stderr.
    let refused = |labels: &str| {
        let out = tether(&[
            "eval-track",
            bag.to_str().unwrap(),
            "--scan-topic",
            "/scan",
            "--labels-topic",
            labels,
        ]);
        assert!(!out.status.success());
        text(&out.stderr)
    };
    let err = refused("/odom");
    // Refused before any scan is read, naming the type and the topics with labels.
    assert!(
        err.contains("holds nav_msgs/Odometry, not labels")
            && err.contains("the topics with labels are: /people_truth"),
        "{err}"
    );
    let err = refused("/nope");
    assert!(err.contains("has no topic \"/nope\""), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn leg_tracker_test_split() {
    // (bag, labelled scans, stretches)
    for (name, scans, stretches) in [
        ("positive_6_extracted.bag", 187, 3),
        ("positive_7_extracted.bag", 267, 4),
    ] {
        let Some(bag) = common::leg_tracker(name) else {
            return;
        };
        let dir = scratch(&format!("eval-track-{name}"));
        let json = dir.join("e.json");
        let stdout = run_ok(&[
            "eval-track",
            bag.to_str().unwrap(),
            "--scan-topic",
            "/training_scan",
            "--labels-topic",
            "/leg_cluster_positions",
            "--json",
            json.to_str().unwrap(),
        ]);
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        // Every PoseArray goes to the scan after it (zero stamps: auto pairing).
        assert_eq!(v["labelled_scans"], scans, "{name}: {stdout}");
        assert_eq!(v["unpaired_label_messages"], 0, "{name}");
        assert_eq!(v["doubly_labelled_scans"], 0, "{name}");
        assert_eq!(
            v["stretches"].as_array().unwrap().len(),
            stretches,
            "{name}"
        );
        assert_eq!(
            v["label_ids"],
            serde_json::json!([0]),
            "{name}: legs are one person"
        );
        let m = &v["clear_mot"];
        assert_eq!(
            m["objects"], scans,
            "{name}: one person in every labelled scan"
        );
        assert!(m["motp_m"].as_f64().unwrap() < 0.15, "{name}: {m}");
        let t = &v["target"];
        assert!(t["on_person_share"].as_f64().unwrap() > 0.8, "{name}: {t}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The robot's pose on each of `track`'s lines, with the poses from `ego_motion`.
fn track_poses(bag: &Path, out: &Path, ego_motion: &str) -> Vec<[f64; 3]> {
    track_poses_with(bag, out, ego_motion, &[])
}

/// [`track_poses`] with more options.
fn track_poses_with(bag: &Path, out: &Path, ego_motion: &str, extra: &[&str]) -> Vec<[f64; 3]> {
    let mut args = vec![
        "track",
        bag.to_str().unwrap(),
        "--scan-topic",
        "/scan",
        "--odom-topic",
        "/odom",
        "--ego-motion",
        ego_motion,
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_ok(&args);
    std::fs::read_to_string(out)
        .unwrap()
        .lines()
        .map(|l| {
            let v: Value = serde_json::from_str(l).unwrap();
            let p = &v["robot_pose"];
            ["x", "y", "yaw"].map(|k| p[k].as_f64().unwrap())
        })
        .collect()
}

/// `--ego-motion` decides where `track` takes the robot's pose from, even when an
/// odometry topic is given (as `replay` does: the loop over a recording is one).
#[test]
fn track_takes_the_robot_s_pose_from_where_ego_motion_says() {
    let dir = scratch("track-ego-motion");
    let bag = sim_bag(&dir, "corridor", "3", &["--ideal-laser", "--duration", "8"]);
    let odom = track_poses(&bag, &dir.join("odom.jsonl"), "odom");
    let scans = track_poses(&bag, &dir.join("scans.jsonl"), "scans");
    let none = track_poses(&bag, &dir.join("none.jsonl"), "none");
    assert_eq!(odom.len(), scans.len());
    assert_eq!(odom.len(), none.len());
    // The robot drives: odometry moves it.
    let moved = |p: &[f64; 3]| p[0].hypot(p[1]) > 0.5;
    assert!(moved(odom.last().unwrap()), "{:?}", odom.last());
    // Scan matching starts at the first scan's frame and moves it too, but not by
    // exactly the odometry's numbers.
    assert_eq!(scans[0], [0.0, 0.0, 0.0]);
    assert!(moved(scans.last().unwrap()), "{:?}", scans.last());
    assert_ne!(odom, scans);
    // None: the robot stands at the origin.
    assert!(none.iter().all(|p| *p == [0.0, 0.0, 0.0]), "{none:?}");
    // The scan matcher takes its settings from the configuration: told that the robot
    // cannot move faster than 1 mm/s, it refuses every match that moves it, and the
    // robot stays where it started.
    let config = dir.join("slow.toml");
    std::fs::write(&config, "[scan_matcher.robot]\nmax_speed_mps = 0.001\n").unwrap();
    let slow = track_poses_with(
        &bag,
        &dir.join("slow.jsonl"),
        "scans",
        &["--config", config.to_str().unwrap()],
    );
    let last = slow.last().unwrap();
    assert!(last[0].hypot(last[1]) < 0.1, "{last:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
