//! Interoperability of the MCAP reader and writer with independent implementations
//! (issue 7): Python `mcap` + `mcap-ros2-support` (Foxglove's) and `rosbags`.
//!
//! - Files they write (zstd, lz4 and uncompressed chunks; rosbags' own rosbag2 writer
//!   and CDR serialiser), tether reads with identical values, field by field and bit
//!   for bit, and re-serialises to identical bytes.
//! - Files tether writes, both read with identical values, and `mcap-ros2-support`
//!   re-serialises every message from tether's schema to the very bytes tether wrote.
//!
//! A message is compared as a flat map from field path to text (see
//! `tests/mcap_reference.py`). The tests need `python3` with `mcap`,
//! `mcap-ros2-support` and `rosbags`; without them they print why and pass, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_json::Value;
use tether_core::{Cov2, Gaussian2, GrayImage, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_msgs::{
    CompressedFormat, CompressedImageMsg, Header, ImageMsg, LaserScanMsg, MarkerArrayMsg,
    MarkerMsg, MeshFile, OdometryMsg, PixelEncoding, Pose3, PoseArrayMsg,
    PoseWithCovarianceStampedMsg, RawLaserScan, Ros2Message, TwistMsg, from_cdr, to_cdr,
};
use tether_recording::mcap::{McapFile, McapWriter, RawMessage};

mod support;

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mcap_reference.py");

type Flat = BTreeMap<String, String>;

/// Skips (prints the reason) or, when `TETHER_REQUIRE_SHARED=1`, fails.
fn have_python() -> bool {
    support::have_python(
        "mcap, mcap_ros2, rosbags, numpy, lz4",
        "python3 with `mcap`, `mcap-ros2-support` and `rosbags` is not available \
         (python3 -m pip install mcap mcap-ros2-support rosbags)",
    )
}

fn scratch_dir(name: &str) -> PathBuf {
    support::scratch_dir(&format!("mcap-{name}"))
}

fn python(args: &[&str]) {
    support::python(SCRIPT, args);
}

fn jsonl(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

fn fields_of(row: &Value) -> Flat {
    row["fields"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.clone(), v.as_str().unwrap().to_owned()))
        .collect()
}

// --- Flattening, the same rules as mcap_reference.py -------------------------------

fn hex(bytes: impl IntoIterator<Item = u8>) -> String {
    bytes.into_iter().map(|b| format!("{b:02x}")).collect()
}

fn f64hex(x: f64) -> String {
    hex(x.to_le_bytes())
}

fn floats(v: impl IntoIterator<Item = f64>) -> String {
    v.into_iter().map(f64hex).collect()
}

fn put(out: &mut Flat, key: &str, value: String) {
    out.insert(key.to_owned(), value);
}

fn flat_header(h: &Header, out: &mut Flat) {
    flat_header_at("", h, out);
}

fn flat_time(prefix: &str, t: Stamp, out: &mut Flat) {
    let ns = t.ns();
    put(
        out,
        &format!("{prefix}sec"),
        ns.div_euclid(1_000_000_000).to_string(),
    );
    put(
        out,
        &format!("{prefix}nanosec"),
        ns.rem_euclid(1_000_000_000).to_string(),
    );
}

fn flat_header_at(prefix: &str, h: &Header, out: &mut Flat) {
    flat_time(&format!("{prefix}header.stamp."), h.stamp, out);
    put(out, &format!("{prefix}header.frame_id"), h.frame_id.clone());
}

/// A sequence of structs: each element under `name[i].`, or `""` when empty.
fn flat_seq<T>(name: &str, items: &[T], out: &mut Flat, mut each: impl FnMut(&str, &T, &mut Flat)) {
    if items.is_empty() {
        put(out, name, String::new());
    }
    for (i, item) in items.iter().enumerate() {
        each(&format!("{name}[{i}]."), item, out);
    }
}

fn flat_color(prefix: &str, c: [f32; 4], out: &mut Flat) {
    for (k, v) in ["r", "g", "b", "a"].iter().zip(c) {
        put(out, &format!("{prefix}{k}"), f64hex(f64::from(v)));
    }
}

fn flat_markers(a: &MarkerArrayMsg, out: &mut Flat) {
    flat_seq("markers", &a.markers, out, |p, m, out| {
        flat_header_at(p, &m.header, out);
        put(out, &format!("{p}ns"), m.ns.clone());
        for (k, v) in [("id", m.id), ("type", m.marker_type), ("action", m.action)] {
            put(out, &format!("{p}{k}"), v.to_string());
        }
        flat_pose(&format!("{p}pose."), &m.pose, out);
        for (k, v) in ["x", "y", "z"].iter().zip(m.scale) {
            put(out, &format!("{p}scale.{k}"), f64hex(v));
        }
        flat_color(&format!("{p}color."), m.color, out);
        flat_time(&format!("{p}lifetime."), Stamp::from_ns(m.lifetime_ns), out);
        put(
            out,
            &format!("{p}frame_locked"),
            u8::from(m.frame_locked).to_string(),
        );
        flat_seq(&format!("{p}points"), &m.points, out, |q, pt, out| {
            for (k, v) in ["x", "y", "z"].iter().zip(pt) {
                put(out, &format!("{q}{k}"), f64hex(*v));
            }
        });
        flat_seq(&format!("{p}colors"), &m.colors, out, |q, c, out| {
            flat_color(q, *c, out)
        });
        put(
            out,
            &format!("{p}texture_resource"),
            m.texture_resource.clone(),
        );
        flat_header_at(&format!("{p}texture."), &m.texture.header, out);
        put(out, &format!("{p}texture.format"), m.texture.format.clone());
        put(
            out,
            &format!("{p}texture.data"),
            hex(m.texture.data.iter().copied()),
        );
        flat_seq(
            &format!("{p}uv_coordinates"),
            &m.uv_coordinates,
            out,
            |q, uv, out| {
                put(out, &format!("{q}u"), f64hex(f64::from(uv[0])));
                put(out, &format!("{q}v"), f64hex(f64::from(uv[1])));
            },
        );
        put(out, &format!("{p}text"), m.text.clone());
        put(out, &format!("{p}mesh_resource"), m.mesh_resource.clone());
        put(
            out,
            &format!("{p}mesh_file.filename"),
            m.mesh_file.filename.clone(),
        );
        put(
            out,
            &format!("{p}mesh_file.data"),
            hex(m.mesh_file.data.iter().copied()),
        );
        put(
            out,
            &format!("{p}mesh_use_embedded_materials"),
            u8::from(m.mesh_use_embedded_materials).to_string(),
        );
    });
}

fn flat_pose(prefix: &str, p: &Pose3, out: &mut Flat) {
    for (k, v) in ["x", "y", "z"].iter().zip(p.position_m) {
        put(out, &format!("{prefix}position.{k}"), f64hex(v));
    }
    for (k, v) in ["x", "y", "z", "w"].iter().zip(p.orientation) {
        put(out, &format!("{prefix}orientation.{k}"), f64hex(v));
    }
}

fn flat_twist(prefix: &str, t: &TwistMsg, out: &mut Flat) {
    for (k, v) in ["x", "y", "z"].iter().zip(t.linear_mps) {
        put(out, &format!("{prefix}linear.{k}"), f64hex(v));
    }
    for (k, v) in ["x", "y", "z"].iter().zip(t.angular_radps) {
        put(out, &format!("{prefix}angular.{k}"), f64hex(v));
    }
}

/// Decodes a stored message by its schema and flattens it; also checks that
/// re-serialising gives the stored bytes and that the tether conversions accept it.
fn decode_flat(m: &RawMessage) -> Flat {
    let mut out = Flat::new();
    let name = m.channel.type_name().to_owned();
    let reencoded = match name.as_str() {
        "sensor_msgs/msg/LaserScan" => {
            let s: RawLaserScan = m.decode().unwrap();
            flat_header(&s.header, &mut out);
            for (k, v) in [
                ("angle_min", s.angle_min),
                ("angle_max", s.angle_max),
                ("angle_increment", s.angle_increment),
                ("time_increment", s.time_increment),
                ("scan_time", s.scan_time),
                ("range_min", s.range_min),
                ("range_max", s.range_max),
            ] {
                put(&mut out, k, f64hex(f64::from(v)));
            }
            put(
                &mut out,
                "ranges",
                floats(s.ranges.iter().map(|&r| f64::from(r))),
            );
            put(
                &mut out,
                "intensities",
                floats(s.intensities.iter().map(|&r| f64::from(r))),
            );
            let scan: LaserScanMsg = m.decode().unwrap();
            assert_eq!(scan.scan.len(), s.ranges.len());
            to_cdr(&s).unwrap()
        }
        "sensor_msgs/msg/Image" => {
            let i: ImageMsg = m.decode().unwrap();
            flat_header(&i.header, &mut out);
            put(&mut out, "height", i.height.to_string());
            put(&mut out, "width", i.width.to_string());
            put(&mut out, "encoding", i.encoding.clone());
            put(&mut out, "is_bigendian", i.is_bigendian.to_string());
            put(&mut out, "step", i.step.to_string());
            put(&mut out, "data", hex(i.data.iter().copied()));
            let g = i.to_gray().unwrap();
            assert_eq!(
                (g.width(), g.height()),
                (i.width as usize, i.height as usize)
            );
            to_cdr(&i).unwrap()
        }
        "sensor_msgs/msg/CompressedImage" => {
            let c: CompressedImageMsg = m.decode().unwrap();
            flat_header(&c.header, &mut out);
            put(&mut out, "format", c.format.clone());
            put(&mut out, "data", hex(c.data.iter().copied()));
            let expected = if c.format == "png" {
                CompressedFormat::Png
            } else {
                CompressedFormat::Jpeg
            };
            assert_eq!(c.detected_format(), Some(expected));
            to_cdr(&c).unwrap()
        }
        "geometry_msgs/msg/Twist" => {
            let t: TwistMsg = m.decode().unwrap();
            flat_twist("", &t, &mut out);
            to_cdr(&t).unwrap()
        }
        "geometry_msgs/msg/PoseArray" => {
            let a: PoseArrayMsg = m.decode().unwrap();
            flat_header(&a.header, &mut out);
            if a.poses.is_empty() {
                put(&mut out, "poses", String::new());
            }
            for (i, p) in a.poses.iter().enumerate() {
                flat_pose(&format!("poses[{i}]."), p, &mut out);
            }
            to_cdr(&a).unwrap()
        }
        "geometry_msgs/msg/PoseWithCovarianceStamped" => {
            let p: PoseWithCovarianceStampedMsg = m.decode().unwrap();
            flat_header(&p.header, &mut out);
            flat_pose("pose.pose.", &p.pose, &mut out);
            put(&mut out, "pose.covariance", floats(p.covariance));
            to_cdr(&p).unwrap()
        }
        "nav_msgs/msg/Odometry" => {
            let o: OdometryMsg = m.decode().unwrap();
            flat_header(&o.header, &mut out);
            put(&mut out, "child_frame_id", o.child_frame_id.clone());
            flat_pose("pose.pose.", &o.pose, &mut out);
            put(&mut out, "pose.covariance", floats(o.pose_covariance));
            flat_twist("twist.twist.", &o.twist, &mut out);
            put(&mut out, "twist.covariance", floats(o.twist_covariance));
            to_cdr(&o).unwrap()
        }
        "visualization_msgs/msg/MarkerArray" => {
            let a: MarkerArrayMsg = m.decode().unwrap();
            flat_markers(&a, &mut out);
            to_cdr(&a).unwrap()
        }
        other => panic!("unexpected type {other}"),
    };
    assert_eq!(
        reencoded,
        m.data,
        "{name} on {}: re-serialised bytes differ",
        m.topic()
    );
    out
}

/// Reads `path` with tether and compares every message with `expected` rows.
fn compare_file(path: &Path, expected: &[Value]) {
    let file = McapFile::open(path).unwrap();
    assert_eq!(file.profile(), "ros2");
    let mut messages = file.messages();
    let mut n = 0;
    for (m, row) in (&mut messages).zip(expected) {
        let m = m.unwrap();
        let what = format!("{} message {n} on {}", path.display(), m.topic());
        assert_eq!(m.topic(), row["topic"].as_str().unwrap(), "{what}");
        assert_eq!(
            m.channel.type_name(),
            row["type"].as_str().unwrap(),
            "{what}"
        );
        assert_eq!(m.channel.message_encoding, "cdr", "{what}");
        assert_eq!(m.log_time.ns(), row["log_time"].as_i64().unwrap(), "{what}");
        assert_eq!(decode_flat(&m), fields_of(row), "{what}");
        n += 1;
    }
    assert!(
        messages.next().is_none(),
        "{}: extra messages",
        path.display()
    );
    assert_eq!(messages.skipped_count(), 0);
    assert_eq!(n, expected.len());
    assert_eq!(n, 42, "six of each of the seven types");
    for topic in file.topics() {
        assert_eq!(file.message_count(topic), 6, "{topic}");
    }
    let scans = file.decoded::<LaserScanMsg>(&["/laserscan"]);
    let count = scans.map(|s| s.unwrap()).collect::<Vec<_>>().len();
    assert_eq!(count, 6);
}

#[test]
fn files_written_by_mcap_ros2_read_identically() {
    if !have_python() {
        return;
    }
    let dir = scratch_dir("python");
    for compression in ["zstd", "lz4", "none"] {
        let mcap = dir.join(format!("{compression}.mcap"));
        let values = dir.join(format!("{compression}.jsonl"));
        python(&[
            "write-mcap",
            mcap.to_str().unwrap(),
            compression,
            values.to_str().unwrap(),
        ]);
        compare_file(&mcap, &jsonl(&values));
        println!("{compression}: 42 messages identical");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn files_written_by_rosbags_read_identically() {
    if !have_python() {
        return;
    }
    let dir = scratch_dir("rosbags");
    let bag = dir.join("bag");
    let values = dir.join("values.jsonl");
    python(&[
        "write-rosbags",
        bag.to_str().unwrap(),
        values.to_str().unwrap(),
    ]);
    compare_file(&bag.join("bag.mcap"), &jsonl(&values));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// What tether writes: every type, with the conversions from tether's own types.
#[allow(
    clippy::too_many_lines,
    reason = "a test's fixture: one message of every type, written in a row"
)]
fn write_tether_file(path: &Path, streaming: bool) -> Vec<(String, &'static str, i64, Flat)> {
    let mut w = if streaming {
        // A live run's recording: no chunks.
        McapWriter::create_streaming(path).unwrap()
    } else {
        McapWriter::create(path).unwrap()
    };
    let mut rows: Vec<(String, &'static str, i64, Vec<u8>)> = Vec::new();
    for k in 0..6i64 {
        let t = Stamp::from_ns(1_700_000_000_000_000_000 + k * 100_000_000);
        let ranges: Vec<f32> = (0..682)
            .map(|i| {
                if i % 31 == 0 {
                    f32::INFINITY
                } else {
                    0.02 + ((i * 13 + k as usize * 7) % 5000) as f32 / 1000.0
                }
            })
            .collect();
        let scan = LaserScan::new(t, "laser", -2.0862, 0.006_135_923, 0.02, 5.6, ranges).unwrap();
        let msg = LaserScanMsg::new(scan, 1e-4, 0.1);
        w.write_stamped("/scan", &msg).unwrap();
        rows.push((
            "/scan".to_owned(),
            LaserScanMsg::TYPE,
            t.ns(),
            to_cdr(&msg).unwrap(),
        ));

        let gray = GrayImage::from_raw(8, 4, (0..32).map(|v| (v * 7 + k) as u8).collect()).unwrap();
        let images = [
            ImageMsg::from_gray(Header::new(t, "camera"), &gray),
            ImageMsg::packed(
                Header::new(t, "camera"),
                PixelEncoding::Rgb8,
                3,
                2,
                (0..18).map(|v| (v * 11 + k) as u8).collect(),
            )
            .unwrap(),
            ImageMsg::packed(
                Header::new(t, "camera"),
                PixelEncoding::Bgr8,
                2,
                2,
                (0..12).map(|v| (v * 5 + k) as u8).collect(),
            )
            .unwrap(),
        ];
        let image = &images[k as usize % 3];
        w.write_stamped("/image", image).unwrap();
        rows.push((
            "/image".to_owned(),
            ImageMsg::TYPE,
            t.ns(),
            to_cdr(image).unwrap(),
        ));

        let (format, magic): (CompressedFormat, &[u8]) = if k % 2 == 0 {
            (CompressedFormat::Jpeg, b"\xff\xd8\xff\xe0")
        } else {
            (CompressedFormat::Png, b"\x89PNG\r\n\x1a\n")
        };
        let mut data = magic.to_vec();
        data.extend((0..50).map(|v| (v * 3 + k) as u8));
        let c = CompressedImageMsg::new(Header::new(t, "camera"), format, data);
        w.write_stamped("/image/compressed", &c).unwrap();
        rows.push((
            "/image/compressed".to_owned(),
            CompressedImageMsg::TYPE,
            t.ns(),
            to_cdr(&c).unwrap(),
        ));

        let twist = TwistMsg::unicycle(0.1 * k as f64, -0.05 * k as f64);
        w.write("/cmd_vel", t, &twist).unwrap();
        rows.push((
            "/cmd_vel".to_owned(),
            TwistMsg::TYPE,
            t.ns(),
            to_cdr(&twist).unwrap(),
        ));

        let people = PoseArrayMsg {
            header: Header::new(t, "world"),
            poses: (0..k % 3)
                .map(|i| Pose3::planar(1.0 + i as f64, -0.5 * i as f64, 0.3 * i as f64))
                .collect(),
        };
        w.write_stamped("/people", &people).unwrap();
        rows.push((
            "/people".to_owned(),
            PoseArrayMsg::TYPE,
            t.ns(),
            to_cdr(&people).unwrap(),
        ));

        let g = Gaussian2::<World>::new(
            Point2::new(2.0 + k as f64, 0.5),
            Cov2::new(0.04, 0.01 * k as f64, 0.09).unwrap(),
        )
        .unwrap();
        let target =
            PoseWithCovarianceStampedMsg::from_gaussian(Header::new(t, "world"), &g, 0.25, 0.5);
        w.write_stamped("/target", &target).unwrap();
        rows.push((
            "/target".to_owned(),
            PoseWithCovarianceStampedMsg::TYPE,
            t.ns(),
            to_cdr(&target).unwrap(),
        ));

        let odom = OdometryMsg::planar(
            Header::new(t, "odom"),
            "base_link",
            Pose2::<World, Robot>::new(0.1 * k as f64, 0.0, 0.05 * k as f64),
            0.3,
            0.1,
        );
        w.write_stamped("/odom", &odom).unwrap();
        rows.push((
            "/odom".to_owned(),
            OdometryMsg::TYPE,
            t.ns(),
            to_cdr(&odom).unwrap(),
        ));

        let markers = MarkerArrayMsg {
            markers: (0..k % 3)
                .map(|i| {
                    let mut m = MarkerMsg::new(
                        Header::new(t, "odom"),
                        "tracks",
                        i as i32,
                        MarkerMsg::SPHERE_LIST,
                    );
                    m.pose = Pose3::planar(0.5 * i as f64, 1.0, 0.2);
                    m.scale = [0.15, 0.25, 1.7];
                    m.color = [0.1, 0.8, 0.2, 0.6];
                    m.lifetime_ns = 500_000_000 + k;
                    m.frame_locked = i == 1;
                    m.points = (0..i).map(|j| [j as f64, -0.5, 0.1]).collect();
                    m.colors = (0..i).map(|_| [1.0, 0.0, 0.5, 1.0]).collect();
                    m.uv_coordinates = (0..i).map(|j| [0.25 * j as f32, 0.5]).collect();
                    m.text = format!("#{i} target");
                    m.mesh_file = MeshFile {
                        filename: if i == 1 {
                            "m.stl".into()
                        } else {
                            String::new()
                        },
                        data: vec![7; i as usize],
                    };
                    m
                })
                .collect(),
        };
        w.write("/tether/markers", t, &markers).unwrap();
        rows.push((
            "/tether/markers".to_owned(),
            MarkerArrayMsg::TYPE,
            t.ns(),
            to_cdr(&markers).unwrap(),
        ));
    }
    w.finish().unwrap();
    // Flatten what was written by decoding the serialised bytes tether produced.
    rows.into_iter()
        .map(|(topic, ty, t, bytes)| {
            let file_channel = tether_recording::mcap::Channel {
                id: 0,
                topic: topic.clone(),
                message_encoding: "cdr".into(),
                schema: Some(std::sync::Arc::new(tether_recording::mcap::Schema {
                    id: 1,
                    name: ty.into(),
                    encoding: "ros2msg".into(),
                    data: Vec::new(),
                })),
                metadata: BTreeMap::new(),
            };
            let m = RawMessage {
                channel: std::sync::Arc::new(file_channel),
                sequence: 0,
                log_time: Stamp::from_ns(t),
                publish_time: Stamp::from_ns(t),
                at: tether_recording::mcap::Location::File(0),
                data: bytes,
            };
            let flat = decode_flat(&m);
            (topic, ty, t, flat)
        })
        .collect()
}

fn check_python_rows(rows: &[Value], written: &[(String, &'static str, i64, Flat)], reader: &str) {
    assert_eq!(rows.len(), written.len(), "{reader}: message count");
    for (i, (row, (topic, ty, t, flat))) in rows.iter().zip(written).enumerate() {
        let what = format!("{reader} message {i} on {topic}");
        assert_eq!(row["topic"].as_str().unwrap(), topic, "{what}");
        assert_eq!(row["type"].as_str().unwrap(), *ty, "{what}");
        assert_eq!(row["log_time"].as_i64().unwrap(), *t, "{what}");
        assert_eq!(&fields_of(row), flat, "{what}");
        assert!(
            row["reencoded_identical"].as_bool().unwrap(),
            "{what}: {reader} re-serialises to other bytes"
        );
    }
}

#[test]
fn files_written_by_tether_read_identically_in_python() {
    if !have_python() {
        return;
    }
    // Chunked (replay's results) and unchunked (a live run's recording).
    for streaming in [false, true] {
        let dir = scratch_dir(if streaming {
            "tether-streaming"
        } else {
            "tether"
        });
        let path = dir.join("run.mcap");
        let written = write_tether_file(&path, streaming);
        assert_eq!(written.len(), 48);

        let out = dir.join("mcap_ros2.jsonl");
        python(&["read-mcap", path.to_str().unwrap(), out.to_str().unwrap()]);
        let rows = jsonl(&out);
        for row in &rows {
            assert_eq!(row["profile"], "ros2");
            assert_eq!(row["schema_encoding"], "ros2msg");
            assert_eq!(row["message_encoding"], "cdr");
            assert_eq!(row["publish_time"], row["log_time"]);
        }
        check_python_rows(&rows, &written, "mcap-ros2-support");

        let out = dir.join("rosbags.jsonl");
        python(&[
            "read-rosbags",
            path.to_str().unwrap(),
            out.to_str().unwrap(),
        ]);
        check_python_rows(&jsonl(&out), &written, "rosbags");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn python_files_survive_a_tether_rewrite() {
    if !have_python() {
        return;
    }
    let dir = scratch_dir("rewrite");
    let original = dir.join("python.mcap");
    let values = dir.join("values.jsonl");
    python(&[
        "write-mcap",
        original.to_str().unwrap(),
        "zstd",
        values.to_str().unwrap(),
    ]);
    // Read with tether, write again with tether, read the copy with Python.
    let copy = dir.join("copy.mcap");
    let file = McapFile::open(&original).unwrap();
    let mut w = McapWriter::create(&copy).unwrap();
    for m in file.messages() {
        let m = m.unwrap();
        let topic = m.topic().to_owned();
        match m.channel.type_name() {
            "sensor_msgs/msg/LaserScan" => {
                w.write(&topic, m.log_time, &m.decode::<RawLaserScan>().unwrap())
            }
            "sensor_msgs/msg/Image" => {
                w.write(&topic, m.log_time, &m.decode::<ImageMsg>().unwrap())
            }
            "sensor_msgs/msg/CompressedImage" => w.write(
                &topic,
                m.log_time,
                &m.decode::<CompressedImageMsg>().unwrap(),
            ),
            "geometry_msgs/msg/Twist" => {
                w.write(&topic, m.log_time, &m.decode::<TwistMsg>().unwrap())
            }
            "geometry_msgs/msg/PoseArray" => {
                w.write(&topic, m.log_time, &m.decode::<PoseArrayMsg>().unwrap())
            }
            "geometry_msgs/msg/PoseWithCovarianceStamped" => w.write(
                &topic,
                m.log_time,
                &m.decode::<PoseWithCovarianceStampedMsg>().unwrap(),
            ),
            "nav_msgs/msg/Odometry" => {
                w.write(&topic, m.log_time, &m.decode::<OdometryMsg>().unwrap())
            }
            other => panic!("{other}"),
        }
        .unwrap();
    }
    w.finish().unwrap();
    let out = dir.join("copy.jsonl");
    python(&["read-mcap", copy.to_str().unwrap(), out.to_str().unwrap()]);
    let expected = jsonl(&values);
    let rows = jsonl(&out);
    assert_eq!(rows.len(), expected.len());
    for (row, want) in rows.iter().zip(&expected) {
        assert_eq!(row["topic"], want["topic"]);
        assert_eq!(row["log_time"], want["log_time"]);
        assert_eq!(fields_of(row), fields_of(want), "{}", row["topic"]);
        assert!(row["reencoded_identical"].as_bool().unwrap());
    }
    // The bytes of every message are the same in both files.
    let a: Vec<Vec<u8>> = McapFile::open(&original)
        .unwrap()
        .messages()
        .map(|m| m.unwrap().data)
        .collect();
    let b: Vec<Vec<u8>> = McapFile::open(&copy)
        .unwrap()
        .messages()
        .map(|m| m.unwrap().data)
        .collect();
    assert_eq!(a, b);
    // And a LaserScan decodes the same through both paths.
    let raw: Vec<RawLaserScan> = McapFile::open(&copy)
        .unwrap()
        .decoded::<RawLaserScan>(&["/laserscan"])
        .map(|m| m.unwrap().message)
        .collect();
    assert_eq!(raw.len(), 6);
    assert_eq!(
        from_cdr::<RawLaserScan>(&to_cdr(&raw[0]).unwrap()).unwrap(),
        raw[0]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
