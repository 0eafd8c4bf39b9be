//! The simulated robot and `tether ros2` as two processes on one DDS graph (`tether sim
//! --ros2` publishes the simulated scans, odometry and clock and drives from `/cmd_vel`),
//! with Python `cyclonedds` listening (`tests/ros2/listen.py`): the closed loop of the
//! simulator, with DDS in between.
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
use common::{scratch, text};

/// What the listener or the simulator said, as a number.
struct Seen;

impl Seen {
    fn f(v: &serde_json::Value) -> f64 {
        v.as_f64().unwrap()
    }
}

/// The times `tether ros2` says the robot was held for an obstacle (its closing line
/// `the robot was held for: ... obstacle N times (T s)`), 0 when it never was.
fn held_for_an_obstacle(log: &str) -> u64 {
    let Some(line) = log.lines().find(|l| l.contains("the robot was ")) else {
        panic!("no line on the holds in {log}");
    };
    line.split("obstacle ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .map_or(0, |n| n.parse().unwrap_or_else(|_| panic!("{line}")))
}

/// What a closed loop over DDS left: the simulator's summary, the listener's JSON, and
/// the two processes' logs.
struct ClosedLoop {
    run: serde_json::Value,
    seen: serde_json::Value,
    ros2_log: String,
    sim_log: String,
}

/// `tether sim --scenario corridor --ros2 SIM_ARGS` and `tether ros2 --scenario
/// corridor ROS2_ARGS` as two processes, with the Python listener, on one
/// private graph. `tether ros2` is stopped with SIGINT when the simulation has ended.
fn closed_loop_over_dds(name: &str, sim_args: &str, ros2_args: &str, listen_s: f64) -> ClosedLoop {
    closed_loop_listening(name, sim_args, ros2_args, &format!("--seconds {listen_s}"))
}

/// [`closed_loop_over_dds`] with the listener's arguments.
fn closed_loop_listening(
    name: &str,
    sim_args: &str,
    ros2_args: &str,
    listen_args: &str,
) -> ClosedLoop {
    let dir = scratch(name);
    let bin = env!("CARGO_BIN_EXE_tether");
    let listen = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/listen.py");
    let script = format!(
        "'{bin}' ros2 --scenario corridor {ros2_args} 2> '{d}/ros2.err' & ROS2=$!; \
         python3 '{listen}' {listen_args} > '{d}/listen.json' & LISTEN=$!; \
         '{bin}' sim --scenario corridor --ros2 {sim_args} --out '{d}/sim' \
         > '{d}/sim.out' 2> '{d}/sim.err'; sleep 2; kill -INT $ROS2; wait $ROS2; ROS2_RC=$?; \
         wait $LISTEN; exit $ROS2_RC",
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
    let run = serde_json::from_str(&read("sim/ros2_run.json")).expect("the sim's summary");
    let seen = serde_json::from_str(read("listen.json").trim()).expect("the listener's JSON");
    ClosedLoop {
        run,
        seen,
        ros2_log: read("ros2.err"),
        sim_log: read("sim.out"),
    }
}

/// The closed loop's bars, now with DDS between the simulator and tether: mean |d - d0|
/// at most `bound_m`, no collision, and what a peer on the graph sees. With the ideal
/// laser, as the in-process closed loop's bars are checked (`tests/following.rs`), the
/// bar is that loop's 0.15 m, and over DDS the measure stays within a few millimetres of
/// the in-process one (corridor: 0.050 m laser only, 0.039 m on both sensors). With the
/// realistic laser the robot may be held for a phantom in its path, and as the robot's
/// path depends on the timing of the messages, one run differs from the next; that run's
/// bound counts the holds (see its test).
fn check_closed_loop(what: &str, c: &ClosedLoop, bound_m: f64) {
    let run = &c.run;
    eprintln!("{}", c.sim_log.trim());
    let Some(error) = run["mean_abs_distance_error_m"].as_f64() else {
        panic!(
            "the robot never moved: {run}\ntether ros2:\n{}\nlistener: {}",
            c.ros2_log, c.seen
        );
    };
    eprintln!(
        "corridor over DDS, {what}: mean |d - d0| {error:.3} m (by second: {})",
        run["abs_distance_error_by_second_m"]
    );
    assert!(error <= bound_m, "mean |d - d0| {error} m: {run}");
    assert_eq!(run["collisions"], 0, "{run}");
    assert!(Seen::f(&run["distance_driven_m"]) > 10.0, "{run}");
    assert!(Seen::f(&run["first_motion_s"]) < 5.0, "{run}");
    let ros2 = &c.ros2_log;
    assert!(ros2.contains("odometry messages used"), "{ros2}");
    assert!(
        ros2.contains("laser mount from /tf_static: base_link -> laser"),
        "{ros2}"
    );
    let seen = &c.seen;
    assert!(seen["counts"]["scan"].as_u64().unwrap() > 100, "{seen}");
    assert!(seen["counts"]["cmd_vel"].as_u64().unwrap() > 200, "{seen}");
    assert!(seen["cmd_vel_moving"].as_u64().unwrap() > 100, "{seen}");
    assert!(
        seen["people_with_someone"].as_u64().unwrap() > 100,
        "{seen}"
    );
    // The markers for RViz: the tracks, their labels and ellipses, the target.
    let namespaces = seen["marker_namespaces"].as_array().unwrap();
    for ns in [
        "tracks",
        "track_labels",
        "track_covariance",
        "target",
        "laser_people",
    ] {
        assert!(namespaces.iter().any(|n| n == ns), "{ns}: {seen}");
    }
    assert!(
        !seen["target_labels"].as_array().unwrap().is_empty(),
        "{seen}"
    );
    let nodes = seen["nodes"].as_array().unwrap();
    for name in ["tether", "tether_sim"] {
        assert!(
            nodes.iter().any(|n| n[1] == name),
            "{name} not on the graph: {nodes:?}"
        );
    }
}

#[test]
fn tether_ros2_follows_the_simulated_robot_over_dds_and_a_peer_sees_it() {
    if !peer_available() {
        return;
    }
    let c = closed_loop_over_dds(
        "ros2-sim",
        "--laser-only --ideal-laser --duration 25",
        "--laser-only",
        24.0,
    );
    // 0.051 to 0.056 m over three runs here (0.050 m in-process).
    check_closed_loop("real time, the ideal laser", &c, 0.15);
    assert!(c.seen["clock_ns"].is_null(), "no /clock in real time");
    // Joined /tf_static 5 s late, and still got the mount (transient local).
    let scenario_mount = tether_sim::Scenario::resolve("corridor")
        .unwrap()
        .0
        .laser
        .mount;
    let mounts = c.seen["tf_static"].as_array().unwrap();
    assert!(
        mounts.iter().any(|m| m[0] == "base_link"
            && m[1] == "laser"
            && (Seen::f(&m[2]) - scenario_mount.x_m).abs() < 1e-9
            && (Seen::f(&m[4]) - scenario_mount.height_m).abs() < 1e-9),
        "{mounts:?}"
    );
}

#[test]
fn with_the_simulated_camera_on_detections_the_robot_follows_on_both_sensors() {
    if !peer_available() {
        return;
    }
    let c = closed_loop_over_dds("ros2-sim-camera", "--ideal-laser --duration 25", "", 24.0);
    // 0.040 m over three runs here (0.039 m in-process).
    check_closed_loop("real time, the ideal laser and the camera", &c, 0.15);
    // Both sensors vouch for the person at once: the robot sets off before the laser
    // alone could (a walk of 0.5 m), and the camera's people go out as results.
    assert!(Seen::f(&c.run["first_motion_s"]) < 1.0, "{}", c.run);
    let frames = c.run["camera_frames_published"].as_u64().unwrap();
    assert!(frames > 300, "{}", c.run);
    let seen = &c.seen;
    assert!(seen["boxes"].as_u64().unwrap() > 200, "{seen}");
    assert_eq!(seen["bad_boxes"], 0, "{seen}");
    assert!(!seen["truth_ids"].as_array().unwrap().is_empty(), "{seen}");
    assert!(
        seen["vision_people_with_someone"].as_u64().unwrap() > 100,
        "{seen}"
    );
    let ros2 = &c.ros2_log;
    assert!(ros2.contains("camera: boxes from /detections"), "{ros2}");
    // The camera's mount from the simulator's /tf_static, the same as the scenario's.
    assert!(
        ros2.contains("camera mount from /tf_static: base_link -> camera (x forward)"),
        "{ros2}"
    );
    assert!(!ros2.contains("camera's mount in the config"), "{ros2}");
    let received: u64 = ros2
        .split("camera: ")
        .nth(2)
        .and_then(|t| t.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no camera summary: {ros2}"));
    assert!(received > 300, "{ros2}");
    assert!(
        ros2.contains("0 malformed; 0 boxes refused (not finite, not positive or outside the image), 0 of another class"),
        "{ros2}"
    );
}

#[test]
fn on_sim_time_the_clock_drives_both_at_twice_real_time_with_stamped_commands() {
    if !peer_available() {
        return;
    }
    // With stamped commands (Jazzy's diff-drive controller's TwistStamped) both ways.
    let c = closed_loop_listening(
        "ros2-sim-time",
        "--laser-only --ideal-laser --duration 25 --use-sim-time --rate 2 --cmd-vel-stamped",
        "--laser-only --ros-args -p use_sim_time:=true -p cmd_vel_stamped:=true",
        "--seconds 12 --cmd-vel-stamped",
    );
    // 0.058 to 0.060 m over three runs here.
    check_closed_loop("sim time at 2 x real time, the ideal laser", &c, 0.15);
    assert_eq!(c.run["sim_time_rate"], 2.0, "{}", c.run);
    // Everything is stamped in simulated time (from 0), not on the host's clock.
    let clock_s = Seen::f(&c.seen["clock_ns"]) * 1e-9;
    let people_s = Seen::f(&c.seen["people_stamp_ns"]) * 1e-9;
    assert!((10.0..=25.5).contains(&clock_s), "/clock at {clock_s} s");
    assert!(
        (people_s - clock_s).abs() < 1.0,
        "tether/people stamped {people_s} s, /clock {clock_s} s"
    );
    let ros2 = &c.ros2_log;
    assert!(ros2.contains("sim time from /clock"), "{ros2}");
    // The simulation ended before tether was stopped: its clock stood still, and the
    // robot got a stop for it.
    assert!(ros2.contains("the clock has not moved"), "{ros2}");
}

#[test]
fn with_the_realistic_laser_s_dark_spells_and_phantoms_the_robot_still_follows_over_dds() {
    if !peer_available() {
        return;
    }
    let c = closed_loop_listening(
        "ros2-sim-realistic",
        "--laser-only --duration 25 --use-sim-time --rate 2",
        "--laser-only --ros-args -p use_sim_time:=true",
        "--seconds 12",
    );
    // The simulated scanner's phantoms can appear in the robot's path half a metre
    // ahead, and the obstacle stop holds the robot for them as it must; when that
    // happens depends on the path, which the timing of the messages moves from one run
    // to the next. Without such a hold the bar is issue 32's 0.15 m (0.050 to 0.114 m
    // over 10 runs here on 2026-12-07). Each hold from cruising leaves the robot up to a
    // metre behind, made up at the 0.4 m/s it has over the person (1.4 against
    // 1.0 m/s): about 1.5-2 m s of error over the 23.5 s followed, 0.1 m of the mean
    // is allowed per hold. Before or after, the robot has caught up by the end, where
    // the person stops. (2026-12-07: 2 runs in 20 under load held twice, 0.17 and 0.19
    // m; CI's run of stop 44, 0.32 m, failed the single 0.2 m bound there was.)
    let obstacle_holds = held_for_an_obstacle(&c.ros2_log);
    let bound_m = 0.15 + 0.1 * obstacle_holds as f64;
    check_closed_loop(
        &format!("sim time at 2 x real time, the realistic laser, {obstacle_holds} obstacle holds"),
        &c,
        bound_m,
    );
    let by_second: Vec<f64> = c.run["abs_distance_error_by_second_m"]
        .as_array()
        .unwrap()
        .iter()
        .map(Seen::f)
        .collect();
    let last = &by_second[by_second.len().saturating_sub(2)..];
    assert!(
        last.iter().all(|e| *e <= 0.15),
        "not caught up by the end: {by_second:?}"
    );
    let ros2 = &c.ros2_log;
    assert!(ros2.contains("target locked"), "{ros2}");
}
