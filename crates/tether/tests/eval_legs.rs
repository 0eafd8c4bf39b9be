//! `tether eval-legs` on labelled recordings and `tether eval-track` on header-less
//! `leg_tracker/Person` labels, end to end through the binary (issue 30): a simulated
//! bag measured by eval-legs against a count this test makes itself from `tether legs`
//! and the bag's labels; the same labels as PersonArray and as one Person message per
//! person give the same figures; and the leg_tracker test split's range-binned table
//! (from `../shared`; skipped with a printed reason when absent).

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

mod common;

use std::path::{Path, PathBuf};

use common::{scratch, tether, text};
use serde_json::Value;
use tether_core::Stamp;
use tether_msgs::{LaserScanMsg, OdometryMsg, PersonArrayMsg, PersonMsg};
use tether_recording::rosbag::{Bag, BagWriter};

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn run_ok(args: &[&str]) -> String {
    let out = tether(args);
    assert!(
        out.status.success(),
        "tether {args:?} failed:\n{}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Range bins of the command, m (upper edges).
const UPPER_M: [f64; 6] = [0.5, 1.0, 1.5, 2.0, 3.0, f64::INFINITY];

fn bin(x: f64, y: f64) -> usize {
    let r = x.hypot(y);
    UPPER_M.iter().position(|&u| r < u).unwrap()
}

/// Per bin: labels, found, false detections; matched one to one by repeatedly taking
/// the closest remaining pair within `radius_m` (ties: lower detection, then label).
fn count(detected: &[(f64, f64)], labels: &[(f64, f64)], radius_m: f64, out: &mut [[usize; 3]; 6]) {
    let mut used_d = vec![false; detected.len()];
    let mut used_l = vec![false; labels.len()];
    loop {
        let mut best: Option<(f64, usize, usize)> = None;
        for (i, d) in detected.iter().enumerate().filter(|(i, _)| !used_d[*i]) {
            for (j, l) in labels.iter().enumerate().filter(|(j, _)| !used_l[*j]) {
                let dist = (d.0 - l.0).hypot(d.1 - l.1);
                if dist <= radius_m && best.is_none_or(|b| dist < b.0) {
                    best = Some((dist, i, j));
                }
            }
        }
        let Some((_, i, j)) = best else { break };
        used_d[i] = true;
        used_l[j] = true;
    }
    for (l, found) in labels.iter().zip(&used_l) {
        out[bin(l.0, l.1)][0] += 1;
        out[bin(l.0, l.1)][1] += usize::from(*found);
    }
    for (d, used) in detected.iter().zip(&used_d) {
        if !used {
            out[bin(d.0, d.1)][2] += 1;
        }
    }
}

/// A simulated `crossing` run (two people, realistic laser) as a ROS 1 bag.
fn crossing_bag(dir: &Path) -> PathBuf {
    let bag = dir.join("crossing.bag");
    run_ok(&[
        "sim",
        "--scenario",
        "crossing",
        "--seed",
        "2",
        "--laser-only",
        "--duration",
        "30",
        "--out",
        p(&dir.join("sim")),
        "--record-bag",
        p(&bag),
    ]);
    bag
}

#[test]
fn simulated_bag_matches_an_independent_count() {
    let dir = scratch("eval-legs-sim");
    let bag = crossing_bag(&dir);
    let out = dir.join("e.json");
    let stdout = run_ok(&[
        "eval-legs",
        p(&bag),
        "--scan-topic",
        "/scan",
        "--labels-topic",
        "/people_truth",
        "--json",
        p(&out),
    ]);
    assert!(
        stdout.contains("range (m)") && stdout.contains("3+"),
        "{stdout}"
    );
    let v = json(&out);
    assert_eq!(v["labels"], "people");
    assert_eq!(v["match_m"], 0.5);

    // The independent count: the people `tether legs` writes, the labels read from
    // the bag and paired with their scan by stamp (the simulator stamps them alike).
    let legs = dir.join("l.jsonl");
    run_ok(&["legs", p(&bag), "--topic", "/scan", "--out", p(&legs)]);
    let lines = tether_testkit::json_lines(&std::fs::read_to_string(&legs).unwrap());
    let mut truth = std::collections::HashMap::new();
    for m in Bag::open(&bag).unwrap().messages() {
        let m = m.unwrap();
        if m.topic() == "/people_truth" {
            let a = m.decode::<PersonArrayMsg>().unwrap();
            let people: Vec<(f64, f64)> = a
                .people
                .iter()
                .map(|q| (q.pose.position_m[0], q.pose.position_m[1]))
                .collect();
            assert!(truth.insert(a.header.stamp.ns(), people).is_none());
        }
    }
    let mut expected = [[0usize; 3]; 6];
    let mut labelled = 0;
    for line in &lines {
        let Some(labels) = truth.get(&line["stamp_ns"].as_i64().unwrap()) else {
            continue;
        };
        labelled += 1;
        let detected: Vec<(f64, f64)> = line["people"]
            .as_array()
            .unwrap()
            .iter()
            .map(|q| (q["x"].as_f64().unwrap(), q["y"].as_f64().unwrap()))
            .collect();
        count(&detected, labels, 0.5, &mut expected);
    }
    assert_eq!(v["scans"].as_u64().unwrap() as usize, lines.len());
    assert_eq!(v["labelled_scans"].as_u64().unwrap(), labelled);
    let bins = v["bins"].as_array().unwrap();
    let got: Vec<[usize; 3]> = bins
        .iter()
        .map(|b| {
            let u = |k: &str| b[k].as_u64().unwrap() as usize;
            [u("labels"), u("found"), u("false_positives")]
        })
        .collect();
    assert_eq!(got, expected.to_vec());
    // Something to measure: two people seen over hundreds of scans, many found, many
    // missed (realistic laser: 149 of 365 found, 17 false detections, when written),
    // at several ranges.
    let labels: usize = expected.iter().map(|b| b[0]).sum();
    let found: usize = expected.iter().map(|b| b[1]).sum();
    assert!(
        labels > 300 && found > labels / 4 && found < labels,
        "{expected:?}"
    );
    assert!(
        expected.iter().filter(|b| b[0] > 0).count() >= 3,
        "{expected:?}"
    );
    let recall = v["recall"].as_f64().unwrap();
    assert!((recall - found as f64 / labels as f64).abs() < 1e-12);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Rewrites a `tether sim --record-bag` bag with its labels both as PersonArray
/// (`/people_array`, only for scans with somebody labelled) and as one header-less
/// `leg_tracker/Person` message per person right after the scan (`/people`), as Leigh
/// et al.'s benchmark recordings hold them.
fn with_person_messages(from: &Path, to: &Path) {
    let mut bag = Bag::open(from).unwrap();
    let mut w = BagWriter::create(to).unwrap();
    let c_scan = w.add_connection::<LaserScanMsg>("/scan").unwrap();
    let c_odom = w.add_connection::<OdometryMsg>("/odom").unwrap();
    let c_array = w.add_connection::<PersonArrayMsg>("/people_array").unwrap();
    let c_person = w.add_connection::<PersonMsg>("/people").unwrap();
    let mut labelled = 0;
    for m in bag.messages() {
        let m = m.unwrap();
        match m.topic() {
            "/scan" => w.write_raw(c_scan, m.time, &m.data).unwrap(),
            "/odom" => w.write_raw(c_odom, m.time, &m.data).unwrap(),
            "/people_truth" => {
                let a = m.decode::<PersonArrayMsg>().unwrap();
                if a.people.is_empty() {
                    continue;
                }
                labelled += 1;
                w.write(c_array, m.time, &a).unwrap();
                for q in &a.people {
                    w.write(c_person, m.time, q).unwrap();
                }
            }
            _ => {}
        }
    }
    w.finish().unwrap();
    assert!(labelled > 100, "{labelled} labelled scans");
}

#[test]
fn person_messages_read_like_person_arrays() {
    let dir = scratch("eval-person-messages");
    let bag = dir.join("persons.bag");
    with_person_messages(&crossing_bag(&dir), &bag);
    let track = |topic: &str, name: &str| {
        let out = dir.join(name);
        run_ok(&[
            "eval-track",
            p(&bag),
            "--scan-topic",
            "/scan",
            "--labels-topic",
            topic,
            "--odom-topic",
            "/odom",
            "--target-label",
            "0",
            "--json",
            p(&out),
        ]);
        json(&out)
    };
    let array = track("/people_array", "array.json");
    let person = track("/people", "person.json");
    assert_eq!(array["clear_mot"], person["clear_mot"]);
    assert_eq!(array["target"], person["target"]);
    assert_eq!(array["labelled_scans"], person["labelled_scans"]);
    assert_eq!(array["label_ids"], serde_json::json!([0, 1]));
    // One Person message per labelled person.
    let m = &array["clear_mot"];
    assert_eq!(person["label_messages"], m["objects"]);
    assert!(m["objects"].as_u64().unwrap() > array["labelled_scans"].as_u64().unwrap());
    assert!(m["matches"].as_u64().unwrap() > 0);

    let legs = |topic: &str, name: &str| {
        let out = dir.join(name);
        run_ok(&[
            "eval-legs",
            p(&bag),
            "--scan-topic",
            "/scan",
            "--labels-topic",
            topic,
            "--json",
            p(&out),
        ]);
        json(&out)
    };
    let (a, b) = (legs("/people_array", "la.json"), legs("/people", "lb.json"));
    assert_eq!(a["bins"], b["bins"]);
    assert_eq!(a["labelled_scans"], b["labelled_scans"]);
    assert_eq!(b["labels"], "people");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn leg_tracker_test_split_by_range() {
    let Some(bag) = common::leg_tracker("positive_6_extracted.bag") else {
        return;
    };
    let data = bag.parent().unwrap();
    let dir = scratch("eval-legs-split");
    let out = dir.join("split.json");
    let stdout = run_ok(&["eval-legs", "--data", p(data), "--json", p(&out)]);
    assert!(
        stdout.contains("learned, by range from the scanner"),
        "{stdout}"
    );
    let v = json(&out);
    let learned = &v.as_array().unwrap()[1];
    assert_eq!(learned["detector"], "learned");
    // Issue 30's figures, built-in model: recall by range and overall, precision with
    // every false detection on the labelled scans and negative_2's rear scanner.
    let recall: Vec<f64> = learned["bins"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| b["recall"].as_f64().unwrap())
        .collect();
    let round2 = |x: f64| (x * 100.0).round() / 100.0;
    // Issue 30's bars on the test split (0.70 under 0.5 m, 0.85 at 0.5-1.5 m; overall
    // precision 0.70 and recall 0.85) are met, with narrow legs confirmed over the last
    // scans (design 4.6; 0.644 precision and 0.874 recall without: 227 false legs on
    // the rear scanner, 105 on the labelled scans).
    assert_eq!(round2(recall[0]), 0.82, "{recall:?}");
    assert_eq!(round2(recall[1]), 0.92, "{recall:?}");
    assert_eq!(round2(recall[2]), 0.93, "{recall:?}");
    assert!(recall[3] >= 0.94 && recall[4] >= 0.88, "{recall:?}");
    let (recall, precision) = (
        learned["recall"].as_f64().unwrap(),
        learned["precision"].as_f64().unwrap(),
    );
    assert!(recall >= 0.85 && precision >= 0.70, "{recall} {precision}");
    // The rear scanner's own robot body at the edges of its view is no candidate.
    assert_eq!(learned["false_positives_on_empty_scans"], 166);
    // Issue 3's count stays: nothing false inside the labeller's window.
    assert_eq!(learned["false_positives_in_labeller_window"], 0);

    // The same figures from the recordings one by one, through the general path.
    let mut tp = 0;
    let mut fp = 0;
    for name in ["positive_6_extracted.bag", "positive_7_extracted.bag"] {
        let o = dir.join(format!("{name}.json"));
        run_ok(&[
            "eval-legs",
            p(&data.join(name)),
            "--scan-topic",
            "/training_scan",
            "--labels-topic",
            "/leg_cluster_positions",
            "--json",
            p(&o),
        ]);
        let r = json(&o);
        assert_eq!(r["labels"], "legs");
        assert_eq!(r["unlabelled_scans"], 0);
        tp += r["true_positives"].as_u64().unwrap();
        fp += r["false_positives"].as_u64().unwrap();
    }
    assert_eq!(tp, learned["true_positives"].as_u64().unwrap());
    assert_eq!(fp + 166, learned["false_positives"].as_u64().unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A detector config file changes what is measured, JSON or TOML alike; a bad one is
/// refused naming the field.
#[test]
fn detector_config_files() {
    let dir = scratch("eval-legs-config");
    let bag = crossing_bag(&dir);
    let run = |extra: &[&str]| {
        let out = dir.join("c.json");
        let mut args = vec![
            "eval-legs",
            p(&bag),
            "--scan-topic",
            "/scan",
            "--labels-topic",
            "/people_truth",
            "--json",
            p(&out),
        ];
        args.extend_from_slice(extra);
        run_ok(&args);
        json(&out)
    };
    let default = run(&[]);
    let toml = dir.join("d.toml");
    std::fs::write(&toml, "min_points = 12\n").unwrap();
    let json_file = dir.join("d.json");
    std::fs::write(&json_file, "{\"min_points\": 12}").unwrap();
    let a = run(&["--detector-config", p(&toml)]);
    let b = run(&["--detector-config", p(&json_file)]);
    assert_eq!(a["bins"], b["bins"]);
    assert!(
        a["true_positives"].as_u64() < default["true_positives"].as_u64(),
        "{a} {default}"
    );
    // `tether legs` takes the same file: fewer legs than with the defaults.
    let count_legs = |extra: &[&str]| -> usize {
        let mut args = vec!["legs", p(&bag), "--topic", "/scan", "--out", "-"];
        args.extend_from_slice(extra);
        tether_testkit::json_lines(&run_ok(&args))
            .iter()
            .map(|l| l["legs"].as_array().unwrap().len())
            .sum()
    };
    assert!(count_legs(&["--detector-config", p(&toml)]) < count_legs(&[]));
    std::fs::write(&toml, "min_pionts = 12\n").unwrap();
    let out = tether(&[
        "eval-legs",
        p(&bag),
        "--scan-topic",
        "/scan",
        "--labels-topic",
        "/people_truth",
        "--detector-config",
        p(&toml),
    ]);
    let err = text(&out.stderr);
    assert!(!out.status.success() && err.contains("min_pionts"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn header_less_people_before_the_first_scan_are_unpaired() {
    let dir = scratch("eval-person-unpaired");
    let bag = dir.join("b.bag");
    let mut w = BagWriter::create(&bag).unwrap();
    let c_person = w.add_connection::<PersonMsg>("/people").unwrap();
    let c_scan = w.add_connection::<LaserScanMsg>("/scan").unwrap();
    let person = |x: f64| PersonMsg {
        pose: tether_msgs::Pose3::planar(x, 0.0, 0.0),
        id: 3,
    };
    let scan = |k: i64| {
        let s = tether_core::LaserScan::new(
            Stamp::from_ns(1_000_000_000 + k * 100_000_000),
            "laser",
            -1.0,
            0.01,
            0.02,
            5.0,
            vec![f32::INFINITY; 201],
        )
        .unwrap();
        tether_msgs::RawLaserScan::from_scan(0, &s, 0.0, 0.1)
            .into_msg()
            .unwrap()
    };
    let t = |k: i64| Stamp::from_ns(1_000_000_000 + k * 100_000_000);
    w.write(c_person, t(0), &person(1.0)).unwrap();
    for k in 1..4 {
        w.write(c_scan, t(k), &scan(k)).unwrap();
        if k != 2 {
            w.write(c_person, t(k), &person(1.0)).unwrap();
            w.write(c_person, t(k), &person(2.0)).unwrap();
        }
    }
    w.finish().unwrap();
    let out = dir.join("o.json");
    run_ok(&[
        "eval-legs",
        p(&bag),
        "--scan-topic",
        "/scan",
        "--labels-topic",
        "/people",
        "--json",
        p(&out),
    ]);
    let v = json(&out);
    assert_eq!(v["unpaired_label_messages"], 1);
    assert_eq!(v["labelled_scans"], 2);
    assert_eq!(v["unlabelled_scans"], 1);
    // Empty scans: every labelled person missed, two a scan.
    assert_eq!(v["false_negatives"], 4);
    let _ = std::fs::remove_dir_all(&dir);
}
