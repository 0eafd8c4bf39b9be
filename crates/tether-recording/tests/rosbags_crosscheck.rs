//! Cross-check of the bag reader against an independent one, the Python `rosbags`
//! package, on the real recordings in `../shared/data/laser/leg_tracker/` (issue 3).
//!
//! For every bag (uncompressed chunks), and for bz2 and lz4 copies written by rosbags'
//! own writer with small chunks, the test compares the order of all messages and, per
//! topic: message count, record times, header stamps, frame ids and sequence numbers,
//! every range bit for bit, the beams tether counts as returns and as malformed, and the
//! labelled positions.
//!
//! Needs `../shared` beside the checkout and `python3` with `rosbags`; without them it
//! prints why and skips, unless `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a
//! failure.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;
use tether_core::Laser;
use tether_msgs::{LaserScanMsg, PoseArrayMsg, RawLaserScan};
use tether_recording::rosbag::Bag;

mod support;

use support::{scratch_dir, skip};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/rosbags_reference.py");

fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/laser/leg_tracker");
    if dir.is_dir() {
        Some(dir)
    } else {
        skip(&format!(
            "{} is absent (it sits beside the checkout for developers and CI)",
            dir.display()
        ));
        None
    }
}

fn have_rosbags() -> bool {
    support::have_python(
        "rosbags.rosbag1, numpy",
        "python3 with the `rosbags` package is not available (pip install rosbags)",
    )
}

fn python(args: &[&str]) {
    support::python(SCRIPT, args);
}

/// What rosbags reads, in its order (by record time; these recordings were written in
/// time order, so that is also the file order).
struct Reference {
    /// Per topic, the messages as JSON objects in order.
    by_topic: BTreeMap<String, Vec<Value>>,
    /// (topic, record time) of every message in order.
    order: Vec<(String, i64)>,
}

fn reference(bag: &Path, scratch: &Path) -> Reference {
    let out = scratch.join(format!(
        "{}.jsonl",
        bag.file_stem().unwrap().to_string_lossy()
    ));
    python(&["dump", bag.to_str().unwrap(), out.to_str().unwrap()]);
    let mut by_topic: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    let mut order = Vec::new();
    for line in std::fs::read_to_string(&out).unwrap().lines() {
        let v: Value = serde_json::from_str(line).unwrap();
        order.push((
            v["topic"].as_str().unwrap().to_string(),
            v["time_ns"].as_i64().unwrap(),
        ));
        by_topic
            .entry(v["topic"].as_str().unwrap().to_string())
            .or_default()
            .push(v);
    }
    Reference { by_topic, order }
}

fn hex(bytes: impl IntoIterator<Item = u8>) -> String {
    bytes.into_iter().map(|b| format!("{b:02x}")).collect()
}

/// Compares what tether-recording reads from `bag` with the rosbags reference; returns the
/// number of messages compared.
fn compare(bag_path: &Path, reference: &Reference) -> usize {
    let name = bag_path.display();
    let mut bag = Bag::open(bag_path).unwrap();
    let mut mine: BTreeMap<String, Vec<tether_recording::rosbag::RawMessage>> = BTreeMap::new();
    let mut order = Vec::new();
    let mut messages = bag.messages();
    for m in &mut messages {
        let m = m.unwrap();
        order.push((m.topic().to_string(), m.time.ns()));
        mine.entry(m.topic().to_string()).or_default().push(m);
    }
    assert_eq!(messages.skipped_count(), 0, "{name}");
    assert!(order == reference.order, "{name}: bag order differs");
    assert_eq!(
        mine.keys().collect::<Vec<_>>(),
        reference.by_topic.keys().collect::<Vec<_>>(),
        "{name}: topics"
    );
    let mut compared = 0;
    for (topic, theirs) in &reference.by_topic {
        let ours = &mine[topic];
        assert_eq!(ours.len(), theirs.len(), "{name} {topic}: message count");
        assert_eq!(
            bag.message_count(topic),
            ours.len() as u64,
            "{name} {topic}: index count"
        );
        for (i, (o, t)) in ours.iter().zip(theirs).enumerate() {
            let what = format!("{name} {topic} message {i}");
            assert_eq!(o.time.ns(), t["time_ns"].as_i64().unwrap(), "{what}: time");
            match t["type"].as_str().unwrap() {
                "sensor_msgs/msg/LaserScan" => {
                    let raw = o.decode::<RawLaserScan>().unwrap();
                    assert_eq!(raw.header.seq, t["seq"].as_u64().unwrap() as u32, "{what}");
                    assert_eq!(
                        raw.header.stamp.ns(),
                        t["stamp_ns"].as_i64().unwrap(),
                        "{what}"
                    );
                    assert_eq!(
                        raw.header.frame_id,
                        t["frame_id"].as_str().unwrap(),
                        "{what}"
                    );
                    for (field, value) in [
                        ("angle_min", raw.angle_min),
                        ("angle_max", raw.angle_max),
                        ("angle_increment", raw.angle_increment),
                        ("range_min", raw.range_min),
                        ("range_max", raw.range_max),
                    ] {
                        assert_eq!(
                            hex(f64::from(value).to_le_bytes()),
                            t[field].as_str().unwrap(),
                            "{what}: {field}"
                        );
                    }
                    let ranges_hex = hex(raw.ranges.iter().flat_map(|r| r.to_le_bytes()));
                    assert_eq!(
                        ranges_hex,
                        t["ranges_hex"].as_str().unwrap(),
                        "{what}: ranges"
                    );
                    let scan = o.decode::<LaserScanMsg>().unwrap().scan;
                    assert_eq!(scan.stamp.ns(), t["stamp_ns"].as_i64().unwrap(), "{what}");
                    assert_eq!(scan.frame_id, t["frame_id"].as_str().unwrap(), "{what}");
                    assert_eq!(
                        scan.returns() as u64,
                        t["returns"].as_u64().unwrap(),
                        "{what}"
                    );
                    assert_eq!(
                        scan.malformed_beams() as u64,
                        t["malformed"].as_u64().unwrap(),
                        "{what}"
                    );
                }
                "geometry_msgs/msg/PoseArray" => {
                    let m = o.decode::<PoseArrayMsg>().unwrap();
                    assert_eq!(
                        m.header.stamp.ns(),
                        t["stamp_ns"].as_i64().unwrap(),
                        "{what}"
                    );
                    assert_eq!(m.header.frame_id, t["frame_id"].as_str().unwrap(), "{what}");
                    let theirs = t["positions"].as_array().unwrap();
                    assert_eq!(m.poses.len(), theirs.len(), "{what}");
                    for (p, q) in m.poses.iter().zip(theirs) {
                        for k in 0..3 {
                            assert_eq!(
                                hex(p.position_m[k].to_le_bytes()),
                                q[k].as_str().unwrap(),
                                "{what}"
                            );
                        }
                    }
                    assert_eq!(m.positions_2d::<Laser>().len(), theirs.len());
                }
                other => {
                    // Types without a tether decoder: the payload must at least be there.
                    assert!(!o.data.is_empty(), "{what}: {other}");
                }
            }
            compared += 1;
        }
    }
    compared
}

#[test]
fn uncompressed_bags_match_rosbags() {
    let Some(dir) = data_dir() else { return };
    if !have_rosbags() {
        return;
    }
    let scratch = scratch_dir("uncompressed");
    let mut bags: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "bag"))
        .collect();
    bags.sort();
    assert_eq!(bags.len(), 8, "the leg_tracker recordings");
    let mut total = 0;
    for bag in &bags {
        let theirs = reference(bag, &scratch);
        let n = compare(bag, &theirs);
        println!("{}: {n} messages identical", bag.display());
        total += n;
    }
    // 1,265 + 1,304 + 591 + 249 + 525 + 885 + 561 + 801 messages in all.
    assert_eq!(total, 6181);
    std::fs::remove_dir_all(&scratch).unwrap();
}

#[test]
fn bz2_and_lz4_copies_written_by_rosbags_match() {
    let Some(dir) = data_dir() else { return };
    if !have_rosbags() {
        return;
    }
    let scratch = scratch_dir("compressed");
    for name in ["positive_2_extracted.bag", "negative_2.bag"] {
        let original = dir.join(name);
        let theirs = reference(&original, &scratch);
        for compression in ["bz2", "lz4"] {
            let copy = scratch.join(format!("{compression}_{name}"));
            python(&[
                "compress",
                original.to_str().unwrap(),
                copy.to_str().unwrap(),
                compression,
                "65536",
            ]);
            let n = compare(&copy, &theirs);
            let bag = Bag::open(&copy).unwrap();
            assert!(
                bag.chunk_infos().len() > 2,
                "{compression} copy of {name} should span several chunks"
            );
            println!("{compression} copy of {name}: {n} messages identical");
        }
    }
    std::fs::remove_dir_all(&scratch).unwrap();
}
