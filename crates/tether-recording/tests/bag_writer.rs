//! The ROS 1 bag writer: what it writes reads back with tether's own reader and with
//! an independent one, the Python `rosbags` package; the MD5 sums it computes from the
//! message definitions are ROS's; a bag cut short reads up to the cut with the
//! salvaging reader.
//!
//! The `rosbags` half needs `python3` with `rosbags`; without it the test prints why
//! and skips that half, unless `TETHER_REQUIRE_SHARED=1` (set in CI) makes it a
//! failure.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::io::Cursor;
use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;
use tether_core::{Laser, LaserScan, Stamp};
use tether_msgs::{
    Header, LaserScanMsg, OdometryMsg, PersonArrayMsg, PersonMsg, Pose3, PoseArrayMsg,
    RawLaserScan, RosMessage, RosMessageOut, definition_md5,
};
use tether_recording::rosbag::{Bag, BagWriter};

mod support;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/bag_writer_reference.py");

fn md5_of<M: RosMessageOut>() -> String {
    definition_md5(M::TYPE, M::DEFINITION).unwrap()
}

#[test]
fn md5_sums_are_ros_ones() {
    // As `rosmsg md5` prints them (ROS Noetic).
    assert_eq!(md5_of::<RawLaserScan>(), "90c7ef2dc6895d81024acba2ac42f369");
    assert_eq!(md5_of::<PoseArrayMsg>(), "916c28c5764443f268b296bb671b9d97");
    assert_eq!(md5_of::<OdometryMsg>(), "cd5e73d190d741a2f92e81eda573aca7");
    // And every type's constant is its definition's sum (leg_tracker's two included).
    assert_eq!(md5_of::<LaserScanMsg>(), LaserScanMsg::MD5SUM);
    assert_eq!(md5_of::<PersonMsg>(), PersonMsg::MD5SUM);
    assert_eq!(md5_of::<PersonArrayMsg>(), PersonArrayMsg::MD5SUM);
    // The definition as rosbag stores it from the .msg files, comments and all.
    let laser_as_recorded = "# Single scan\n\nHeader header   # stamp of the first ray\n\
        float32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n\n\
        float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n\
        float32[] ranges  # m\nfloat32[] intensities\n\n\
        ================================================================================\n\
        MSG: std_msgs/Header\n# seq\nuint32 seq\ntime stamp\nstring frame_id\n";
    assert_eq!(
        definition_md5("sensor_msgs/LaserScan", laser_as_recorded).unwrap(),
        "90c7ef2dc6895d81024acba2ac42f369"
    );
}

fn scan(k: u32) -> LaserScanMsg {
    let t = Stamp::from_ns(1_700_000_000_000_000_000 / 1000 + i64::from(k) * 100_000_000);
    let ranges: Vec<f32> = (0..31)
        .map(|b| {
            if b == 7 {
                f32::INFINITY
            } else {
                1.0 + 0.01 * (b as f32) + k as f32 * 0.001
            }
        })
        .collect();
    let s = LaserScan::new(t, "laser", -1.5, 0.1, 0.02, 5.6, ranges).unwrap();
    let raw = RawLaserScan::from_scan(k, &s, 0.1 / 1024.0, 0.1);
    raw.into_msg().unwrap()
}

fn people(k: u32, stamp: Stamp) -> PersonArrayMsg {
    PersonArrayMsg {
        header: Header {
            seq: k,
            stamp,
            frame_id: "laser".into(),
        },
        people: (0..k % 3)
            .map(|i| PersonMsg {
                pose: Pose3::planar(1.0 + f64::from(i), -0.5 * f64::from(k), 0.25),
                id: 10 + i,
            })
            .collect(),
    }
}

/// A bag with scans, people after each scan, legs before each scan and odometry.
fn write_bag(chunk_bytes: usize) -> Vec<u8> {
    let mut w = BagWriter::new(Cursor::new(Vec::new()))
        .unwrap()
        .with_chunk_bytes(chunk_bytes);
    let c_scan = w.add_connection::<LaserScanMsg>("/scan").unwrap();
    let c_people = w.add_connection::<PersonArrayMsg>("/people_truth").unwrap();
    let c_legs = w.add_connection::<PoseArrayMsg>("/legs").unwrap();
    let c_odom = w.add_connection::<OdometryMsg>("/odom").unwrap();
    for k in 0..40u32 {
        let s = scan(k);
        let t = s.scan.stamp;
        let legs = PoseArrayMsg {
            header: Header {
                seq: 0,
                stamp: Stamp::from_ns(0),
                frame_id: "laser".into(),
            },
            poses: vec![Pose3::planar(2.0, f64::from(k) * 0.1, 0.0)],
        };
        w.write(c_legs, t, &legs).unwrap();
        let odom = OdometryMsg::planar(
            Header::new(t, "odom"),
            "base_link",
            tether_core::Pose2::<tether_core::World, tether_core::Robot>::new(
                0.1 * f64::from(k),
                0.0,
                0.01 * f64::from(k),
            ),
            0.5,
            0.1,
        );
        w.write(c_odom, t, &odom).unwrap();
        w.write(c_scan, t, &s).unwrap();
        w.write(c_people, Stamp::from_ns(t.ns() + 1), &people(k, t))
            .unwrap();
    }
    w.finish().unwrap().into_inner()
}

#[test]
fn reads_back_with_tethers_reader() {
    let bytes = write_bag(4096);
    let mut bag = Bag::from_reader(Cursor::new(&bytes[..])).unwrap();
    assert!(bag.chunk_infos().len() > 3, "small chunks: several of them");
    assert_eq!(bag.message_count("/scan"), 40);
    assert_eq!(
        bag.topics(),
        vec!["/legs", "/odom", "/people_truth", "/scan"]
    );
    let c = bag
        .connections()
        .find(|c| c.topic == "/people_truth")
        .unwrap();
    assert_eq!(c.msg_type, "leg_tracker/PersonArray");
    assert!(c.message_definition.contains("MSG: leg_tracker/Person"));
    let order: Vec<String> = bag
        .messages()
        .map(|m| m.unwrap().topic().to_string())
        .collect();
    assert_eq!(order.len(), 160);
    assert_eq!(&order[..4], ["/legs", "/odom", "/scan", "/people_truth"]);
    let scans: Vec<_> = bag
        .decoded::<LaserScanMsg>(&["/scan"])
        .map(|m| m.unwrap().message)
        .collect();
    for (k, s) in scans.iter().enumerate() {
        assert_eq!(s, &scan(k as u32), "scan {k} round trip");
    }
    let ppl: Vec<_> = bag
        .decoded::<PersonArrayMsg>(&["/people_truth"])
        .map(|m| m.unwrap())
        .collect();
    for (k, m) in ppl.iter().enumerate() {
        assert_eq!(m.message, people(k as u32, scans[k].scan.stamp));
        assert_eq!(m.time.ns(), scans[k].scan.stamp.ns() + 1);
    }
    let legs: Vec<_> = bag
        .decoded::<PoseArrayMsg>(&["/legs"])
        .map(|m| m.unwrap().message.positions_2d::<Laser>())
        .collect();
    assert!((legs[39][0].y - 3.9).abs() < 1e-12);
    let odom: Vec<_> = bag
        .decoded::<OdometryMsg>(&["/odom"])
        .map(|m| m.unwrap().message)
        .collect();
    assert_eq!(odom.len(), 40);
    assert!((odom[20].pose.yaw_rad() - 0.2).abs() < 1e-12);
    assert_eq!(odom[20].twist.v_mps(), 0.5);
}

#[test]
fn same_input_same_bytes() {
    assert_eq!(write_bag(4096), write_bag(4096));
}

#[test]
fn a_bag_cut_short_reads_up_to_the_cut() {
    let bytes = write_bag(3000);
    let whole = Bag::from_reader(Cursor::new(&bytes[..])).unwrap();
    let chunks: Vec<u64> = whole.chunk_infos().iter().map(|c| c.chunk_pos).collect();
    assert!(chunks.len() >= 4);
    let scans_whole = 40;
    let mut previous = 0;
    // Cuts in the middle of chunk 2, of the last chunk, and in the index section.
    for cut in [
        (chunks[2] + chunks[3]) / 2,
        (chunks[chunks.len() - 1] + bytes.len() as u64) / 2,
        bytes.len() as u64 - 10,
    ] {
        let cut_bytes = &bytes[..cut as usize];
        assert!(
            Bag::from_reader(Cursor::new(cut_bytes)).is_err(),
            "the strict reader refuses a cut bag"
        );
        let mut bag = Bag::from_reader_salvaging(Cursor::new(cut_bytes)).unwrap();
        assert!(bag.salvaged().is_some());
        let mut it = bag.decoded::<LaserScanMsg>(&["/scan"]);
        let scans: Vec<_> = (&mut it).map(|m| m.unwrap().message).collect();
        assert!(!scans.is_empty() && scans.len() <= scans_whole, "cut {cut}");
        for (k, s) in scans.iter().enumerate() {
            assert_eq!(s, &scan(k as u32), "cut {cut}: scan {k}");
        }
        assert!(
            scans.len() >= previous,
            "a later cut keeps at least as many"
        );
        previous = scans.len();
        if cut < chunks[chunks.len() - 1] {
            assert_eq!(it.bad_count(), 0, "the cut is not a bad message");
            let cut_at = it.cut().expect("the cut is reported");
            assert!(
                cut_at.to_string().starts_with("the file ends inside the"),
                "{cut_at}"
            );
        } else if cut > bytes.len() as u64 - 100 {
            assert_eq!(scans.len(), scans_whole, "only the index is cut");
        }
    }
    // A cut inside an uncompressed chunk still gives the complete messages before it
    // in that chunk: more scans than the chunks before it hold.
    let mut bag = Bag::from_reader(Cursor::new(&bytes[..])).unwrap();
    let in_first_two: usize = bag
        .decoded::<LaserScanMsg>(&["/scan"])
        .map(|m| m.unwrap())
        .filter(|m| match m.at {
            tether_recording::rosbag::Location::InChunk { chunk, .. } => chunk < chunks[2],
            tether_recording::rosbag::Location::File(_) => false,
        })
        .count();
    let cut = (chunks[2] + chunks[3]) / 2;
    let mut bag = Bag::from_reader_salvaging(Cursor::new(&bytes[..cut as usize])).unwrap();
    let got = bag.decoded::<LaserScanMsg>(&["/scan"]).count();
    assert!(
        got > in_first_two,
        "{got} scans vs {in_first_two} before the cut chunk"
    );
}

fn require_python() -> bool {
    support::have_python(
        "rosbags.rosbag1",
        "python3 with the `rosbags` package is not available (pip install rosbags)",
    )
}

#[test]
fn reads_back_with_rosbags() {
    if !require_python() {
        return;
    }
    let path: PathBuf = std::env::temp_dir().join(format!(
        "tether-recording-writer-{}.bag",
        std::process::id()
    ));
    std::fs::write(&path, write_bag(4096)).unwrap();
    let out = Command::new("python3")
        .arg(SCRIPT)
        .arg(&path)
        .output()
        .unwrap();
    let _ = std::fs::remove_file(&path);
    assert!(
        out.status.success(),
        "rosbags failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let conns = v["connections"].as_array().unwrap();
    assert_eq!(conns.len(), 4);
    for c in conns {
        assert_eq!(c["md5_stored"], c["md5_rosbags"], "{c}");
    }
    let msgs = v["messages"].as_array().unwrap();
    assert_eq!(msgs.len(), 160);
    let scans: Vec<&Value> = msgs.iter().filter(|m| m["topic"] == "/scan").collect();
    for (k, m) in scans.iter().enumerate() {
        let s = scan(k as u32);
        assert_eq!(m["stamp_ns"].as_i64().unwrap(), s.scan.stamp.ns());
        assert_eq!(m["time_ns"].as_i64().unwrap(), s.scan.stamp.ns());
        assert_eq!(m["frame_id"], "laser");
        assert_eq!(m["seq"].as_u64().unwrap(), k as u64);
        let ranges = m["ranges"].as_array().unwrap();
        assert_eq!(ranges.len(), s.scan.len());
        for (b, r) in ranges.iter().enumerate() {
            match s.scan.range_m(b) {
                // As f32: serde_json parses decimals to the nearest f64 only approximately.
                Some(x) => assert_eq!(r.as_f64().unwrap() as f32, x),
                None => assert_eq!(r, "inf"),
            }
        }
        assert_eq!(m["angle_min"].as_f64().unwrap(), f64::from(-1.5f32));
    }
    let ppl: Vec<&Value> = msgs
        .iter()
        .filter(|m| m["topic"] == "/people_truth")
        .collect();
    for (k, m) in ppl.iter().enumerate() {
        let want = people(k as u32, scan(k as u32).scan.stamp);
        let got = m["people"].as_array().unwrap();
        assert_eq!(got.len(), want.people.len());
        for (g, w) in got.iter().zip(&want.people) {
            assert_eq!(g[0].as_u64().unwrap(), u64::from(w.id));
            // Within 1e-12: serde_json parses decimals to f64 only approximately.
            assert!((g[1].as_f64().unwrap() - w.pose.position_m[0]).abs() < 1e-12);
            assert!((g[2].as_f64().unwrap() - w.pose.position_m[1]).abs() < 1e-12);
            assert!((g[3].as_f64().unwrap() - w.pose.orientation[2]).abs() < 1e-12);
        }
    }
    let odom: Vec<&Value> = msgs.iter().filter(|m| m["topic"] == "/odom").collect();
    assert_eq!(odom[10]["child_frame_id"], "base_link");
    assert!((odom[10]["pose"][0].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert_eq!(odom[10]["twist"][0].as_f64().unwrap(), 0.5);
    let legs: Vec<&Value> = msgs.iter().filter(|m| m["topic"] == "/legs").collect();
    assert_eq!(legs[5]["stamp_ns"].as_i64().unwrap(), 0);
    assert!((legs[5]["xy"][0][1].as_f64().unwrap() - 0.5).abs() < 1e-12);
}
