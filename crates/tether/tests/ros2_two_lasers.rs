//! Two scanners over DDS (design 5.7): the `all_round` scenario's robot carries a 180-
//! degree scanner facing forward and one facing back, and its target walks all the way
//! round it. `tether ros2` reads the second scanner from `-p extra_scan_topics`.
//!
//! - An independent DDS peer (Python `cyclonedds`, `tests/ros2/peer.py`) publishes both
//!   scan topics of a simulated run, its odometry and the two mounts on `/tf_static`; the
//!   node, given no configuration, takes the rear scanner's mount from `/tf_static`.
//! - The simulator on the graph (`tether sim --scenario all_round --ros2`) publishes
//!   `/scan` and `/rear_laser/scan` and drives from `/cmd_vel`: the closed loop.
//!
//! DDS discovery multicasts, so every run happens in a private network namespace with
//! only loopback up (`unshare -n`, as root); nothing reaches a real interface. Skips,
//! printing why, where namespaces or the Python peer are unavailable, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![cfg(feature = "ros2")]
#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::dds::{in_private_network, peer_available};
use common::{scratch, tether, text};
use serde_json::Value;

/// Where the front scanner (180 degrees, a little ahead of the axle) sees no more: the
/// target's bearing from the robot beyond this, rad, is the rear scanner's alone.
const BEYOND_THE_FRONT_SCANNER_RAD: f64 = 1.6;

/// The target and the robot at one scan of the simulated run (world frame).
#[derive(Debug, Clone, Copy)]
struct Truth {
    target: (f64, f64),
    robot: (f64, f64, f64),
}

impl Truth {
    /// The target's bearing from the robot's heading, rad.
    fn bearing_rad(&self) -> f64 {
        let (x, y, yaw) = self.robot;
        let b = (self.target.1 - y).atan2(self.target.0 - x) - yaw;
        b.sin().atan2(b.cos())
    }
}

/// The run's truth by scan stamp (`truth.jsonl`).
fn truth_by_stamp(dir: &Path) -> BTreeMap<i64, Truth> {
    let text = std::fs::read_to_string(dir.join("truth.jsonl")).unwrap();
    text.lines()
        .map(|l| serde_json::from_str::<Value>(l).unwrap())
        .filter_map(|v| {
            let target = v["people"]
                .as_array()?
                .iter()
                .find(|p| p["target"] == true)?
                .clone();
            let f = |v: &Value| v.as_f64().unwrap();
            Some((
                v["stamp_ns"].as_i64()?,
                Truth {
                    target: (f(&target["world"]["x"]), f(&target["world"]["y"])),
                    robot: (
                        f(&v["robot"]["x"]),
                        f(&v["robot"]["y"]),
                        f(&v["robot"]["yaw"]),
                    ),
                },
            ))
        })
        .collect()
}

fn rows(v: &Value) -> Vec<Vec<Value>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_array().unwrap().clone())
        .collect()
}

/// Simulates `all_round` (seed 1) into a bag with both scanners, then has the peer
/// publish it to `tether ros2 -p extra_scan_topics:=[rear_laser/scan]`, given no
/// configuration; returns what the peer saw and the run's truth.
fn peer_publishing_both_scanners() -> (Value, BTreeMap<i64, Truth>) {
    let dir = scratch("ros2-two-lasers-peer");
    let bag = dir.join("all_round.bag");
    let out = tether(&[
        "sim",
        "--scenario",
        "all_round",
        "--seed",
        "1",
        "--record-bag",
        bag.to_str().unwrap(),
        "--out",
        dir.join("sim").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let truth = truth_by_stamp(&dir.join("sim"));
    let scenario = tether_sim::Scenario::resolve("all_round").unwrap().0;
    let front = scenario.laser.mount;
    let rear = scenario.extra_lasers[0].laser.mount;
    let arg = |v: f64| v.to_string();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/peer.py");
    let mut inner: Vec<String> = [
        "python3",
        script.to_str().unwrap(),
        "--tether",
        env!("CARGO_BIN_EXE_tether"),
        "--bag",
        bag.to_str().unwrap(),
        "--extra-scan",
        "/rear_laser/scan",
        "--odom-topic",
        "/odom",
        "--stamped",
        "--seconds",
        "26",
        "--mount",
    ]
    .map(str::to_owned)
    .to_vec();
    inner.extend([front.x_m, front.y_m, front.yaw_rad, front.height_m].map(arg));
    inner.extend(["--extra-mount".to_owned(), "rear_laser".to_owned()]);
    inner.extend([rear.x_m, rear.y_m, rear.yaw_rad, rear.height_m].map(arg));
    // No configuration: the node knows the rear scanner from its topic and /tf_static.
    inner.extend(
        [
            "--",
            "--ros-args",
            "-p",
            "extra_scan_topics:=[rear_laser/scan]",
            "-p",
            "cmd_vel_stamped:=true",
        ]
        .map(str::to_owned),
    );
    let quoted: Vec<String> = inner.iter().map(|a| format!("'{a}'")).collect();
    let out = in_private_network(&format!("exec {}", quoted.join(" ")));
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "peer failed: {}\n{stdout}",
        text(&out.stderr)
    );
    (serde_json::from_str(stdout.trim()).unwrap(), truth)
}

#[test]
fn a_person_walking_round_the_robot_stays_one_track_when_a_peer_publishes_both_scanners() {
    if !peer_available() {
        return;
    }
    let (seen, truth) = peer_publishing_both_scanners();
    let stderr = seen["stderr"].as_str().unwrap();
    assert_eq!(seen["exit_code"], 0, "{stderr}");
    assert!(
        stderr.contains("scans from /scan, /rear_laser/scan"),
        "{stderr}"
    );
    assert!(
        stderr.contains(
            "/rear_laser/scan: laser rear_laser, like the first laser, mount from /tf_static"
        ),
        "{stderr}"
    );
    let rear_sent = seen["extra_scans_sent"]["/rear_laser/scan"]
        .as_u64()
        .unwrap();
    assert!(rear_sent > 200, "{rear_sent} rear scans sent");
    let taken_line = stderr
        .lines()
        .find(|l| l.contains("/rear_laser/scan: ") && l.contains("scans taken"))
        .unwrap_or_else(|| panic!("no count of the rear scans: {stderr}"));
    eprintln!("{taken_line}");
    assert!(taken_line.contains("for laser rear_laser (0 of another frame skipped)"));

    // One track, locked from the first lock to the end.
    let states: Vec<Value> = rows(&seen["target_state"])
        .iter()
        .map(|r| serde_json::from_str(r[1].as_str().unwrap()).unwrap())
        .collect();
    let first_lock = states
        .iter()
        .position(|s| s["state"] == "locked")
        .expect("a lock");
    let after = &states[first_lock..];
    let locked = after.iter().filter(|s| s["state"] == "locked").count();
    let tracks: std::collections::BTreeSet<u64> =
        after.iter().filter_map(|s| s["track"].as_u64()).collect();
    eprintln!(
        "locked in {locked} of {} states after the first lock (state {first_lock}); tracks {tracks:?}",
        after.len()
    );
    assert_eq!(tracks.len(), 1, "the target changed tracks: {tracks:?}");
    assert!(
        locked * 100 >= after.len() * 95,
        "{locked} of {}",
        after.len()
    );

    check_where_and_toward(&seen, &truth);
}

/// Where the node put the target at each scan's tick, against where they were, and
/// that its commands turn the robot toward them.
fn check_where_and_toward(seen: &Value, truth: &BTreeMap<i64, Truth>) {
    let bag_time: BTreeMap<i64, i64> = rows(&seen["scan_stamps"])
        .iter()
        .map(|r| (r[0].as_i64().unwrap(), r[1].as_i64().unwrap()))
        .collect();
    let mut errors = Vec::new();
    let mut behind = Vec::new();
    let mut bearings = Vec::new();
    for p in rows(&seen["target_pose"]) {
        let Some(t) = bag_time
            .get(&p[0].as_i64().unwrap())
            .and_then(|t| truth.get(t))
        else {
            continue;
        };
        let e = (p[1].as_f64().unwrap() - t.target.0).hypot(p[2].as_f64().unwrap() - t.target.1);
        let b = t.bearing_rad();
        bearings.push(b);
        errors.push(e);
        if b.abs() > BEYOND_THE_FRONT_SCANNER_RAD {
            behind.push(e);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let widest = |side: f64| bearings.iter().map(|b| b * side).fold(0.0, f64::max);
    eprintln!(
        "target poses at scans: {}, mean error {:.3} m; beyond the front scanner's view \
         (|bearing| > {BEYOND_THE_FRONT_SCANNER_RAD} rad): {}, mean error {:.3} m; bearings \
         from {:.2} to {:.2} rad",
        errors.len(),
        mean(&errors),
        behind.len(),
        mean(&behind),
        -widest(-1.0),
        widest(1.0)
    );
    assert!(errors.len() > 300, "{} target poses matched", errors.len());
    assert!(mean(&errors) < 0.25, "mean error {}", mean(&errors));
    // The person passed beside and behind the robot, where only the rear scanner sees
    // them (the robot turns to keep them ahead, so not for long), and was tracked there.
    assert!(behind.len() >= 5, "{} poses behind", behind.len());
    assert!(mean(&behind) < 0.3, "mean error behind {}", mean(&behind));

    // Followed: the commands of the scans' ticks turn the robot toward the person.
    let mut toward = 0;
    let mut turning = 0;
    for c in rows(&seen["cmd_vel"]) {
        let (w, stamp) = (c[2].as_f64().unwrap(), c[3].as_i64().unwrap());
        let Some(t) = bag_time.get(&stamp).and_then(|t| truth.get(t)) else {
            continue;
        };
        let b = t.bearing_rad();
        if b.abs() > 0.5 && w.abs() > 0.05 {
            turning += 1;
            if w.signum() == b.signum() {
                toward += 1;
            }
        }
    }
    eprintln!("{toward} of {turning} turning commands (person off by > 0.5 rad) turn toward them");
    assert!(
        turning > 50 && toward * 10 >= turning * 8,
        "{toward} of {turning}"
    );
    let cmds = rows(&seen["cmd_vel"]);
    let last = cmds.last().unwrap();
    assert_eq!((last[1].as_f64(), last[2].as_f64()), (Some(0.0), Some(0.0)));
}

#[test]
fn on_the_graph_the_simulated_robot_with_two_scanners_follows_its_target_all_the_way_round() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-two-lasers-sim");
    let bin = env!("CARGO_BIN_EXE_tether");
    // The node reads the scenario's rear scanner on rear_laser/scan, as the simulator
    // publishes it.
    let script = format!(
        "'{bin}' ros2 --scenario all_round --laser-only 2> '{d}/ros2.err' & ROS2=$!; \
         '{bin}' sim --scenario all_round --ros2 --laser-only --ideal-laser --out '{d}/sim' \
         > '{d}/sim.out' 2> '{d}/sim.err'; sleep 2; kill -INT $ROS2; wait $ROS2",
        d = dir.display(),
    );
    let out = in_private_network(&script);
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap_or_default();
    let ros2 = read("ros2.err");
    assert!(
        out.status.success(),
        "{}\nsim: {}\nros2: {ros2}",
        text(&out.stderr),
        read("sim.err"),
    );
    let run: Value = serde_json::from_str(&read("sim/ros2_run.json")).unwrap();
    eprintln!("{}", read("sim.out").trim());
    let taken = ros2
        .lines()
        .find(|l| l.contains("/rear_laser/scan: ") && l.contains("scans taken"))
        .unwrap_or_else(|| panic!("no count of the rear scans: {ros2}"));
    let target = ros2
        .lines()
        .find(|l| l.contains("target locked"))
        .unwrap_or_default();
    eprintln!("{taken}\n{target}");
    assert!(
        ros2.contains("laser rear_laser, mount from /tf_static"),
        "{ros2}"
    );
    // One track all the way round: no hand-over to another track. (The one loss the
    // closing line counts is at the end, after the simulator stopped publishing.)
    assert!(target.contains("0 handed over between tracks"), "{ros2}");
    let rear: u64 = taken
        .split("/rear_laser/scan: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert!(rear > 200, "{taken}");
    let error = run["mean_abs_distance_error_m"].as_f64().unwrap();
    eprintln!("all_round over DDS: mean |d - d0| {error:.3} m: {run}");
    assert_eq!(run["collisions"], 0, "{run}");
    assert!(error <= 0.6, "{run}");
}
