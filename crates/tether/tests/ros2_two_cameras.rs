//! Two cameras over DDS (design 5.7): the simulated robot of `all_round`, turned round at
//! its start and nearly unable to move, carries a second camera looking back; its target
//! walks off behind it. `tether sim --ros2` publishes the front camera's boxes on
//! `/detections` and the rear one's on `/rear_camera/detections`, with both mounts on
//! `/tf_static`; `tether ros2` reads the rear camera from its default topic, takes its
//! mount from `/tf_static` and reads its boxes through its own model, so that a Python
//! `cyclonedds` listener (`tests/ros2/listen.py`) sees the camera's people behind the
//! robot. Without the rear camera's topic the node's camera people are all in front.
//!
//! DDS discovery multicasts, so every run happens in a private network namespace with
//! only loopback up (`unshare -n`, as root); nothing reaches a real interface. Skips,
//! printing why, where namespaces or the Python peer are unavailable, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![cfg(feature = "ros2")]
#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

mod common;

use std::path::Path;

use common::dds::{in_private_network, peer_available};
use common::{scratch, tether, text};
use serde_json::Value;

/// Where the robot starts, and its heading (turned round: it faces -x).
const START: (f64, f64, f64) = (4.0, 3.0, std::f64::consts::PI);

/// `all_round` turned round, the robot too slow to turn back, with a rear camera when
/// `rear`: written to `dir`.
fn scenario(dir: &Path, rear: bool) -> std::path::PathBuf {
    let shown = tether(&["scenarios", "--show", "all_round"]);
    assert!(shown.status.success(), "{}", text(&shown.stderr));
    let mut toml = text(&shown.stdout).replace(
        "start = { x = 4.0, y = 3.0, yaw_rad = 0.0 }",
        &format!(
            "start = {{ x = {}, y = {}, yaw_rad = {} }}\nmax_wheel_speed_mps = 0.001",
            START.0, START.1, START.2
        ),
    );
    assert!(toml.contains("max_wheel_speed_mps = 0.001"), "{toml}");
    if rear {
        toml.push_str(
            "\n[[extra_cameras]]\nframe_id = \"rear_camera\"\n\
             camera = { mount = { x_m = -0.1, y_m = 0.0, yaw_rad = 3.141592653589793, \
             height_m = 0.65, tilt_rad = 0.4886921905584123 } }\n",
        );
    }
    let path = dir.join(if rear { "rear.toml" } else { "front.toml" });
    std::fs::write(&path, toml).unwrap();
    path
}

/// The node's closing log and the listener's JSON of a run of `scenario` over DDS.
fn over_dds(dir: &Path, scenario: &Path) -> (String, Value) {
    let bin = env!("CARGO_BIN_EXE_tether");
    let listen = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/listen.py");
    let script = format!(
        "'{bin}' ros2 --scenario '{s}' 2> '{d}/ros2.err' & ROS2=$!; \
         python3 '{listen}' --seconds 14 > '{d}/listen.json' & LISTEN=$!; \
         '{bin}' sim --scenario '{s}' --ros2 --duration 10 --out '{d}/sim' \
         > '{d}/sim.out' 2> '{d}/sim.err'; sleep 2; kill -INT $ROS2; wait $ROS2; ROS2_RC=$?; \
         wait $LISTEN; exit $ROS2_RC",
        s = scenario.display(),
        d = dir.display(),
        listen = listen.display(),
    );
    let out = in_private_network(&script);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    assert!(
        out.status.success(),
        "{}\nsim: {}\nros2: {}",
        text(&out.stderr),
        read("sim.err"),
        read("ros2.err")
    );
    let seen = serde_json::from_str(read("listen.json").trim()).expect("the listener's JSON");
    (read("ros2.err"), seen)
}

/// How many of the camera people the listener saw are behind the robot's start, and
/// how many in all.
fn behind(seen: &Value) -> (usize, usize) {
    let positions = seen["vision_positions"].as_array().unwrap();
    let (x0, y0, yaw) = START;
    let behind = positions
        .iter()
        .filter(|p| {
            let (x, y) = (p[0].as_f64().unwrap() - x0, p[1].as_f64().unwrap() - y0);
            x * yaw.cos() + y * yaw.sin() < -0.5
        })
        .count();
    (behind, positions.len())
}

#[test]
fn over_dds_a_rear_camera_s_people_are_behind_the_robot() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-two-cameras");
    let (log, seen) = over_dds(&dir, &scenario(&dir, true));
    let (back, all) = behind(&seen);
    let counted = log
        .lines()
        .find(|l| l.contains("camera \"rear_camera\" (/rear_camera/detections): "))
        .unwrap_or_else(|| panic!("no count of the rear camera's messages: {log}"));
    eprintln!("{counted}\n{back} of {all} camera people behind the robot");
    assert!(
        log.contains("camera \"rear_camera\" mount from /tf_static"),
        "{log}"
    );
    let received: u64 = counted
        .split("): ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert!(received > 50, "{counted}");
    assert!(back > 50, "{back} of {all} behind\n{log}");

    // The same run without the rear camera: nobody the camera sees is behind.
    let (log, seen) = over_dds(&dir, &scenario(&dir, false));
    let (back, all) = behind(&seen);
    eprintln!("without the rear camera: {back} of {all} camera people behind the robot");
    assert_eq!(back, 0, "{log}");
}
