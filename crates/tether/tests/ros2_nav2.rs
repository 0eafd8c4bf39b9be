//! What `tether ros2` offers Nav2, and its `cmd_vel` guard (design 12), against an
//! independent DDS implementation: Python `cyclonedds` (`tests/ros2/nav2_peer.py`)
//! publishes a simulated run's scans and the laser's mount, and listens to `cmd_vel`,
//! `tether/target_pose`, `/tf`, `tether/target`, the target's state and every writer on
//! the graph.
//!
//! - The target goes out as a `PoseStamped` and as a frame on `/tf` while it is locked,
//!   at the same stamps and positions as `tether/target`, and never before the lock.
//! - With `publish_cmd_vel:=false` nothing on the graph writes `cmd_vel`.
//! - Killed (`SIGKILL`) or frozen (`SIGSTOP`) while it drives, the node's guard puts a
//!   zero command on `cmd_vel` within half a second.
//!
//! Every run happens in a private network namespace with only loopback up (`unshare -n`,
//! as root); nothing reaches a real interface. Skips, printing why, where namespaces or
//! the Python peer are unavailable, unless `TETHER_REQUIRE_SHARED=1` makes that a failure.

#![cfg(feature = "ros2")]
#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

mod common;

use std::collections::BTreeMap;
use std::path::Path;

use common::dds::{in_private_network, peer_available};
use common::{scratch, text};
use serde_json::Value;

/// Runs `nav2_peer.py PEER_ARGS -- TETHER_ARGS` (and through it `tether ros2`) in a fresh
/// namespace over 25 s of the corridor scenario; returns what the peer saw.
fn nav2_peer(name: &str, peer_args: &[&str], tether_args: &[&str]) -> Value {
    let dir = scratch(name);
    let bag = common::corridor_bag(&dir, 25);
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/nav2_peer.py");
    let m = tether_sim::Scenario::resolve("corridor")
        .unwrap()
        .0
        .laser
        .mount;
    let mut args = vec![
        "python3".to_owned(),
        script.display().to_string(),
        "--tether".into(),
        env!("CARGO_BIN_EXE_tether").into(),
        "--bag".into(),
        bag.display().to_string(),
        "--mount".into(),
    ];
    args.extend([m.x_m, m.y_m, m.yaw_rad, m.height_m].map(|v| v.to_string()));
    args.extend(peer_args.iter().map(|s| (*s).to_owned()));
    args.push("--".into());
    args.extend(tether_args.iter().map(|s| (*s).to_owned()));
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    let out = in_private_network(&format!("exec {}", quoted.join(" ")));
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "peer failed: {}\n{stdout}",
        text(&out.stderr)
    );
    serde_json::from_str(stdout.trim()).unwrap_or_else(|e| {
        panic!(
            "peer output is not JSON ({e}): {stdout}\n{}",
            text(&out.stderr)
        )
    })
}

fn rows<'a>(seen: &'a Value, key: &str) -> &'a [Value] {
    seen[key].as_array().unwrap()
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

/// The smallest turn from `a` to `b`, rad.
fn angle_between(a: f64, b: f64) -> f64 {
    let d = (b - a).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

/// When the peer first heard the target locked.
fn first_lock_s(seen: &Value) -> f64 {
    rows(seen, "target_state")
        .iter()
        .find(|s| s[1].as_str().unwrap().contains("\"locked\""))
        .map(|s| f(&s[0]))
        .expect("the target was locked")
}

/// The target on `tether/target_pose` and `/tf` (child `frame`) against
/// `tether/target`: the same stamps (so only while locked), the same positions in `odom`,
/// the target's walking direction or the one held from before, and nothing before the
/// first lock.
fn check_target_outputs(seen: &Value, frame: &str) {
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    let poses = rows(seen, "target_pose");
    let tf: Vec<&Value> = rows(seen, "tf").iter().filter(|t| t[3] == frame).collect();
    assert!(poses.len() > 100, "{} target poses\n{stderr}", poses.len());
    // Keyed by stamp: [arrival, stamp, frame, x, y, z, yaw].
    let by_stamp = |rows: &[&Value]| -> BTreeMap<i64, Value> {
        rows.iter()
            .map(|r| (r[1].as_i64().unwrap(), (*r).clone()))
            .collect()
    };
    let poses = by_stamp(&poses.iter().collect::<Vec<_>>());
    let targets = by_stamp(&rows(seen, "target").iter().collect::<Vec<_>>());
    let frames = by_stamp(&tf);
    assert_eq!(
        poses.keys().collect::<Vec<_>>(),
        targets.keys().collect::<Vec<_>>(),
        "tether/target_pose goes out at exactly the ticks tether/target does (while locked)"
    );
    assert_eq!(
        frames.keys().collect::<Vec<_>>(),
        poses.keys().collect::<Vec<_>>(),
        "the {frame} frame goes out with every target pose"
    );
    let mut held = None::<f64>;
    let mut walking = 0;
    for (stamp, pose) in &poses {
        let target = &targets[stamp];
        let t = &frames[stamp];
        assert_eq!(pose[2], "odom", "{pose}");
        assert_eq!(t[2], "odom", "the frame's parent is the fixed frame: {t}");
        for i in 3..6 {
            assert!(
                (f(&pose[i]) - f(&target[i])).abs() < 1e-9,
                "{pose} {target}"
            );
            assert!((f(&t[i + 1]) - f(&pose[i])).abs() < 1e-9, "{t} {pose}");
        }
        let yaw = f(&pose[6]);
        assert!(angle_between(f(&t[7]), yaw) < 1e-9, "{t} {pose}");
        // tether/target's heading is the velocity's direction; tether/target_pose's is
        // that while the person walks, and the last one while they stand.
        if angle_between(f(&target[6]), yaw) < 1e-9 {
            walking += 1;
        } else {
            let before = held.unwrap_or_else(|| panic!("no heading to hold at {pose}"));
            assert!(angle_between(before, yaw) < 1e-9, "{pose}: not held");
        }
        held = Some(yaw);
    }
    assert!(
        walking * 2 > poses.len(),
        "{walking} of {} headings are the walk's",
        poses.len()
    );
    // Nothing before the lock (the pose goes out just before the state in a tick).
    let lock = first_lock_s(seen);
    let states_before = rows(seen, "target_state")
        .iter()
        .filter(|s| f(&s[0]) < lock)
        .count();
    assert!(states_before > 5, "the peer heard the node before the lock");
    for r in rows(seen, "target_pose").iter().chain(tf.iter().copied()) {
        let arrival = f(&r[0]);
        assert!(arrival >= lock - 0.1, "{r} before the lock at {lock}");
    }
}

/// The writers on the graph (DDS topic, type).
fn writers(seen: &Value) -> Vec<(String, String)> {
    rows(seen, "writers")
        .iter()
        .map(|w| {
            (
                w[0].as_str().unwrap().to_owned(),
                w[1].as_str().unwrap().to_owned(),
            )
        })
        .collect()
}

fn has_node(seen: &Value, name: &str) -> bool {
    rows(seen, "nodes").iter().any(|n| n[1] == name)
}

#[test]
fn the_target_goes_to_nav2_as_a_pose_and_a_frame_only_while_locked() {
    if !peer_available() {
        return;
    }
    let seen = nav2_peer("ros2-nav2-target", &["--seconds", "20"], &[]);
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    assert_eq!(seen["exit_code"], 0, "{stderr}");
    check_target_outputs(&seen, "target");
    // It drives, and its guard is on the graph beside it with a cmd_vel writer.
    let moving = rows(&seen, "cmd_vel")
        .iter()
        .filter(|c| f(&c[1]) > 0.05)
        .count();
    assert!(moving > 50, "{moving} commands drive\n{stderr}");
    assert!(has_node(&seen, "tether") && has_node(&seen, "tether_guard"));
    assert!(
        writers(&seen).contains(&(
            "rt/cmd_vel".to_owned(),
            "geometry_msgs::msg::dds_::Twist_".to_owned()
        )),
        "{:?}",
        writers(&seen)
    );
    assert!(stderr.contains("interrupted"), "{stderr}");
}

#[test]
fn with_publish_cmd_vel_false_nobody_writes_cmd_vel_and_the_target_still_goes_out() {
    if !peer_available() {
        return;
    }
    let seen = nav2_peer(
        "ros2-nav2-no-cmd-vel",
        &["--seconds", "20"],
        &[
            "--ros-args",
            "-p",
            "publish_cmd_vel:=false",
            "-p",
            "target_frame:=person",
        ],
    );
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    assert_eq!(seen["exit_code"], 0, "{stderr}");
    check_target_outputs(&seen, "person");
    assert!(
        rows(&seen, "cmd_vel").is_empty(),
        "{:?}",
        rows(&seen, "cmd_vel").first()
    );
    // Not a writer of any type on cmd_vel, from tether or a guard; tether's other
    // writers are seen, so the peer did hear them.
    let all = writers(&seen);
    assert!(
        all.iter().all(|(topic, _)| !topic.ends_with("cmd_vel")),
        "{all:?}"
    );
    for topic in ["rt/tether/target_pose", "rt/tf", "rt/tether/people"] {
        assert!(all.iter().any(|(t, _)| t == topic), "{topic}: {all:?}");
    }
    assert!(has_node(&seen, "tether"));
    assert!(!has_node(&seen, "tether_guard"), "{stderr}");
    assert!(
        stderr.contains("commands to nothing (publish_cmd_vel is false: Nav2 drives)"),
        "{stderr}"
    );
}

/// The commands the peer heard around a signal: that the robot drove just before it,
/// and when the first zero came after it; that no motion came after it (but for what
/// was already on its way, 50 ms); returns the first zero's delay, s.
fn zero_after_signal(seen: &Value) -> f64 {
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    let at = f(&seen["signalled_at"]);
    let cmds = rows(seen, "cmd_vel");
    let driving = cmds
        .iter()
        .filter(|c| (at - 0.5..at).contains(&f(&c[0])) && f(&c[1]) > 0.05)
        .count();
    assert!(driving > 3, "the robot drove before the signal\n{stderr}");
    let zero = cmds
        .iter()
        .find(|c| f(&c[0]) >= at && f(&c[1]) == 0.0 && f(&c[2]) == 0.0)
        .unwrap_or_else(|| panic!("no zero command after the signal\n{stderr}"));
    for c in cmds.iter().filter(|c| f(&c[0]) > at + 0.05) {
        let until = seen["continued_at"].as_f64().unwrap_or(f64::INFINITY);
        if f(&c[0]) < until {
            assert_eq!((f(&c[1]), f(&c[2])), (0.0, 0.0), "motion after the signal");
        }
    }
    f(&zero[0]) - at
}

#[test]
fn killed_while_it_drives_its_guard_puts_a_zero_on_cmd_vel_within_half_a_second() {
    if !peer_available() {
        return;
    }
    let seen = nav2_peer(
        "ros2-guard-kill",
        &["--signal-at", "12", "--signal", "KILL", "--after", "1.5"],
        &[],
    );
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    assert_eq!(seen["exit_code"], -9, "{stderr}");
    let delay = zero_after_signal(&seen);
    eprintln!("kill -KILL -> zero on cmd_vel: {:.1} ms", delay * 1e3);
    assert!(delay <= 0.5, "{delay} s\n{stderr}");
    let last = rows(&seen, "cmd_vel").last().unwrap();
    assert_eq!((f(&last[1]), f(&last[2])), (0.0, 0.0));
    assert!(
        stderr.contains("cmd_vel guard: tether ros2 ended without its final stop (killed?)"),
        "{stderr}"
    );
}

#[test]
fn frozen_while_it_drives_its_guard_puts_a_stamped_zero_on_cmd_vel_within_half_a_second() {
    if !peer_available() {
        return;
    }
    let seen = nav2_peer(
        "ros2-guard-stop",
        &[
            "--stamped",
            "--signal-at",
            "12",
            "--signal",
            "STOP",
            "--after",
            "1.0",
        ],
        &["--ros-args", "-p", "cmd_vel_stamped:=true"],
    );
    let stderr = seen["stderr"].as_str().unwrap_or_default();
    let delay = zero_after_signal(&seen);
    eprintln!("kill -STOP -> zero on cmd_vel: {:.1} ms", delay * 1e3);
    assert!(delay <= 0.5, "{delay} s\n{stderr}");
    assert!(
        stderr.contains("cmd_vel guard: no command from tether ros2 for 250 ms"),
        "{stderr}"
    );
    // Continued, the node ends in order on SIGINT, with its own final stop last.
    assert_eq!(seen["exit_code"], 0, "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    let last = rows(&seen, "cmd_vel").last().unwrap();
    assert_eq!((f(&last[1]), f(&last[2])), (0.0, 0.0));
}
