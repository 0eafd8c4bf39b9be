//! `tether ros2` against an independent DDS implementation: Python `cyclonedds` (Eclipse
//! Cyclone DDS, a ROS 2 middleware) publishes the scans of a simulated run on `/scan` and
//! listens to `/cmd_vel`, the results and the graph (`tests/ros2/peer.py`).
//!
//! DDS discovery multicasts, so every run happens in a private network namespace with
//! only loopback up (`unshare -n`, as root); nothing reaches a real interface. Skips,
//! printing why, where namespaces or the Python peer are unavailable, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![cfg(feature = "ros2")]
#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::dds::{in_private_network, peer_available, runs};
use common::{scratch, text};
use tether_testkit::{opencv_cascade, or_skip, python_modules, skip_unless};

fn corridor_bag(dir: &Path) -> PathBuf {
    common::corridor_bag(dir, 25)
}

/// What the peer saw.
struct Seen {
    json: serde_json::Value,
}

impl Seen {
    fn series(&self, key: &str) -> Vec<Vec<serde_json::Value>> {
        self.json[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_array().unwrap().clone())
            .collect()
    }

    fn f(v: &serde_json::Value) -> f64 {
        v.as_f64().unwrap()
    }
}

/// Runs the peer (and through it `tether ros2 ARGS`) in a fresh namespace; the peer
/// publishes the laser's mount on `/tf_static` first.
fn peer(bag: &Path, peer_args: &[&str], tether_args: &[&str]) -> Seen {
    peer_with(bag, peer_args, tether_args, true)
}

/// [`peer`], with or without the mount on `/tf_static`.
fn peer_with(bag: &Path, peer_args: &[&str], tether_args: &[&str], mount: bool) -> Seen {
    peer_of(
        Path::new(env!("CARGO_BIN_EXE_tether")),
        bag,
        peer_args,
        tether_args,
        mount,
    )
}

/// [`peer_with`], running the tether binary `tether`.
fn peer_of(
    tether: &Path,
    bag: &Path,
    peer_args: &[&str],
    tether_args: &[&str],
    mount: bool,
) -> Seen {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/peer.py");
    let mut inner = vec![
        "python3".to_owned(),
        script.display().to_string(),
        "--tether".into(),
        tether.display().to_string(),
        "--bag".into(),
        bag.display().to_string(),
    ];
    inner.extend(peer_args.iter().map(|s| (*s).to_owned()));
    // The robot's description, as a ROS robot publishes it: the laser of the bag's
    // scenario on /tf_static.
    let m = tether_sim::Scenario::resolve("corridor")
        .unwrap()
        .0
        .laser
        .mount;
    if mount {
        inner.push("--mount".into());
        inner.extend([m.x_m, m.y_m, m.yaw_rad, m.height_m].map(|v| v.to_string()));
    }
    inner.push("--".into());
    inner.extend(tether_args.iter().map(|s| (*s).to_owned()));
    let quoted: Vec<String> = inner.iter().map(|a| format!("'{a}'")).collect();
    let out = in_private_network(&format!("exec {}", quoted.join(" ")));
    let stdout = text(&out.stdout);
    assert!(
        out.status.success(),
        "peer failed: {}\n{stdout}",
        text(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap_or_else(|e| {
        panic!(
            "peer output is not JSON ({e}): {stdout}\n{}",
            text(&out.stderr)
        )
    });
    Seen { json }
}

/// The bars every run must meet: tether is a node, follows, never moves before a lock,
/// and its last command is a stop.
fn check_follows_and_stops(seen: &Seen) {
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap_or_default();
    assert_eq!(j["exit_code"], 0, "tether ros2 failed: {stderr}");
    let nodes = j["nodes"].as_array().unwrap();
    assert!(
        nodes.iter().any(|n| n[0] == "/" && n[1] == "tether"),
        "tether is not listed as a node in ros_discovery_info: {nodes:?}"
    );
    let scans = j["scans_sent"].as_u64().unwrap();
    assert!(scans >= 150, "{scans} scans sent");
    let cmds = seen.series("cmd_vel");
    // A command on every scan and every 50 ms timer tick.
    assert!(
        cmds.len() as u64 >= 2 * scans,
        "{} commands for {scans} scans",
        cmds.len()
    );
    let moving = cmds.iter().filter(|c| Seen::f(&c[1]) > 0.05).count();
    assert!(
        moving > cmds.len() / 3,
        "{moving} of {} commands drive",
        cmds.len()
    );
    let last = cmds.last().unwrap();
    assert_eq!(
        (Seen::f(&last[1]), Seen::f(&last[2])),
        (0.0, 0.0),
        "the last command is a stop"
    );
    let exited = Seen::f(&j["exited_at"]);
    assert!(
        Seen::f(&last[0]) <= exited + 0.5,
        "the stop came while tether was there"
    );
    // Nothing drives before the target is locked.
    let states = seen.series("target_state");
    let first_lock = states
        .iter()
        .find(|s| s[1].as_str().unwrap().contains("\"locked\""))
        .map(|s| Seen::f(&s[0]))
        .expect("the target was locked");
    let first_drive = cmds
        .iter()
        .find(|c| Seen::f(&c[1]) != 0.0 || Seen::f(&c[2]) != 0.0)
        .map(|c| Seen::f(&c[0]))
        .unwrap();
    assert!(
        first_drive >= first_lock - 0.05,
        "a command at {first_drive} before the lock at {first_lock}"
    );
    let people = seen.series("people");
    assert!(people.iter().any(|p| p[1].as_u64().unwrap() >= 1));
    assert!(people.iter().all(|p| p[2] == "odom"));
    assert!(
        stderr.contains("interrupted"),
        "the summary says why it ended: {stderr}"
    );
    // Joined after the peer published the mount, and got it (transient local).
    assert!(
        stderr.contains("laser mount from /tf_static: base_link -> laser"),
        "{stderr}"
    );
}

#[test]
fn follows_from_best_effort_scans_and_stops_on_ctrl_c() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-best-effort");
    let bag = corridor_bag(&dir);
    let seen = peer(&bag, &["--seconds", "20", "--signal", "INT"], &[]);
    check_follows_and_stops(&seen);
}

#[test]
fn follows_from_reliable_scans_and_stops_on_sigterm() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-reliable");
    let bag = corridor_bag(&dir);
    let seen = peer(
        &bag,
        &["--seconds", "20", "--reliable", "--signal", "TERM"],
        &[],
    );
    check_follows_and_stops(&seen);
}

#[test]
fn stamped_commands_carry_their_scan_s_stamp_and_the_latency_is_printed() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-stamped");
    let bag = corridor_bag(&dir);
    let seen = peer(
        &bag,
        &["--seconds", "20", "--stamped"],
        &["--ros-args", "-p", "cmd_vel_stamped:=true"],
    );
    check_follows_and_stops(&seen);
    let latency = &seen.json["latency_ms"];
    let scans = seen.json["scans_sent"].as_u64().unwrap();
    let matched = latency["scans_matched"].as_u64().unwrap();
    // A scan's command carries the scan's stamp. A scan that arrives after a timer tick
    // later than its own stamp is processed at that tick's time and is not matched:
    // with a 1-3 ms delay and 50 ms ticks that is a few percent, more on a loaded
    // machine, so the bar is only that most scans match.
    assert!(matched * 2 >= scans, "{matched} of {scans} scans matched");
    // Measured, not asserted (speed belongs to benchmarks): from the peer's write of a
    // scan (its serialisation in Python included) to the arrival of its command.
    eprintln!(
        "scan -> /cmd_vel over loopback DDS: median {:.2} ms, 99th percentile {:.2} ms, max \
         {:.2} ms ({matched} scans)",
        Seen::f(&latency["median"]),
        Seen::f(&latency["p99"]),
        Seen::f(&latency["max"]),
    );
}

/// The tether binary built for a Humble graph (`cargo build --release -p tether
/// --no-default-features --features humble`), from `TETHER_HUMBLE_BIN`: CI builds it
/// before the tests.
fn humble_binary() -> Result<PathBuf, String> {
    let how = "build it with `cargo build --release -p tether --no-default-features \
               --features humble`, copy target/release/tether aside and set \
               TETHER_HUMBLE_BIN to the copy";
    match std::env::var_os("TETHER_HUMBLE_BIN") {
        Some(path) if Path::new(&path).is_file() => Ok(PathBuf::from(path)),
        Some(path) => Err(format!(
            "TETHER_HUMBLE_BIN={} is not a file: {how}",
            Path::new(&path).display()
        )),
        None => Err(format!("no Humble build of tether: {how}")),
    }
}

/// A Humble graph's discovery information has 24-byte gids where Jazzy's has 16, under
/// the same type name: a node of the other layout is not listed (Cyclone DDS cannot
/// read its participant). The Humble build follows like the default one, is listed by
/// a peer reading Humble's layout, and is not by one reading Jazzy's; the default
/// build, the other way round.
#[test]
fn the_humble_build_is_a_node_on_a_humble_graph_and_the_default_on_jazzy_s() {
    if !peer_available() {
        return;
    }
    let Some(humble) = or_skip(humble_binary()) else {
        return;
    };
    let dir = scratch("ros2-humble");
    let bag = corridor_bag(&dir);
    let listed = |seen: &Seen| {
        seen.json["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .any(|n| n[0] == "/" && n[1] == "tether")
    };
    let seen = peer_of(&humble, &bag, &["--seconds", "20", "--humble"], &[], true);
    check_follows_and_stops(&seen);
    let seen = peer_of(&humble, &bag, &["--seconds", "4"], &[], true);
    assert!(!listed(&seen), "a Jazzy reader listed the Humble build");
    let jazzy = Path::new(env!("CARGO_BIN_EXE_tether"));
    let seen = peer_of(jazzy, &bag, &["--seconds", "4", "--humble"], &[], true);
    assert!(!listed(&seen), "a Humble reader listed the default build");
}

#[test]
fn the_base_s_odometry_is_the_robot_s_pose() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-odom");
    let bag = corridor_bag(&dir);
    let seen = peer(&bag, &["--seconds", "20", "--odom-topic", "/odom"], &[]);
    check_follows_and_stops(&seen);
    let odom_sent = seen.json["odom_sent"].as_u64().unwrap();
    assert!(odom_sent >= 150, "{odom_sent} odometry messages sent");
    let stderr = seen.json["stderr"].as_str().unwrap();
    let used = count_before(stderr, " odometry messages used");
    assert!(used * 10 >= odom_sent * 9, "{used} of {odom_sent} used");
    assert!(
        stderr.contains("(0 refused, 0 scans skipped on stale odometry)"),
        "{stderr}"
    );
}

#[test]
fn the_base_s_pose_from_tf_is_used_and_the_robot_stops_when_it_stops() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-tf");
    let bag = corridor_bag(&dir);
    // The base's pose only as odom -> base_link on /tf, which stops 14 s in while the
    // scans go on.
    let seen = peer(
        &bag,
        &[
            "--seconds",
            "20",
            "--odom-topic",
            "/odom",
            "--odom-as-tf",
            "--odom-until",
            "14",
        ],
        &[],
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    let sent = j["odom_sent"].as_u64().unwrap();
    assert!(sent >= 100, "{sent} transforms sent");
    let from_tf = count_before(stderr, " base poses from /tf");
    assert!(
        from_tf * 10 >= sent * 9,
        "{from_tf} of {sent} transforms used: {stderr}"
    );
    assert!(
        count_before(stderr, " scans skipped on stale odometry") > 0,
        "{stderr}"
    );
    // It drove while the transforms came, and once they stopped (14 s after the first
    // scan) the commands came to a stop and stayed there.
    let cmds = seen.series("cmd_vel");
    let t0 = Seen::f(&cmds[0][0]);
    assert!(
        cmds.iter()
            .any(|c| Seen::f(&c[0]) < t0 + 13.0 && Seen::f(&c[1]) > 0.2),
        "it drove on /tf's poses"
    );
    let after: Vec<f64> = cmds
        .iter()
        .filter(|c| Seen::f(&c[0]) > t0 + 16.0)
        .map(|c| Seen::f(&c[1]).abs() + Seen::f(&c[2]).abs())
        .collect();
    assert!(
        !after.is_empty(),
        "commands came after the transforms stopped"
    );
    assert!(
        after.iter().all(|&x| x == 0.0),
        "no motion without the base's pose: {after:?}"
    );
}

/// The number before `what` in `text` (`"... 300 frames received ..."`).
fn count_before(text: &str, what: &str) -> u64 {
    text.split(what)
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count before {what:?} in {text}"))
}

#[test]
fn camera_frames_at_30_hz_arrive_without_loss_beside_the_scans() {
    if !peer_available() || or_skip(opencv_cascade("haarcascade_upperbody.xml")).is_none() {
        return;
    }
    let dir = scratch("ros2-camera");
    let bag = corridor_bag(&dir);
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/robot.example.toml");
    let seen = peer(
        &bag,
        &[
            "--seconds",
            "10",
            "--images-hz",
            "30",
            "--read-tf-static",
            "8",
        ],
        &["--config", config.to_str().unwrap()],
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    // The peer's frames name `camera`, which nobody describes on /tf_static: tether
    // takes the config's camera mount and publishes it there for the others.
    assert!(
        stderr.contains("no transform from base_link to the camera's camera on /tf_static"),
        "{stderr}"
    );
    assert!(
        stderr.contains("published the config's camera mount on /tf_static: base_link -> camera"),
        "{stderr}"
    );
    let mounts = j["tf_static"].as_array().unwrap();
    assert!(
        mounts.iter().any(|t| t[0] == "base_link"
            && t[1] == "camera"
            && (Seen::f(&t[2]) - 0.05).abs() < 1e-9
            && Seen::f(&t[3]).abs() < 1e-9
            && (Seen::f(&t[4]) - 0.65).abs() < 1e-9),
        "{mounts:?}"
    );
    let sent = j["images_sent"].as_u64().unwrap();
    assert!(sent >= 290, "{sent} frames sent in 10 s");
    // 640x480 rgb8 (0.9 MB, fragmented on the wire), every one of them received.
    assert_eq!(count_before(stderr, " frames received"), sent, "{stderr}");
    assert!(count_before(stderr, " processed") > 0, "{stderr}");
    assert!(
        stderr.contains("0 refused for their size, 0 malformed"),
        "{stderr}"
    );
    // The camera sees nobody, so with both sensors required there is no lock and the
    // robot never moves.
    let cmds = seen.series("cmd_vel");
    assert!(cmds.len() as u64 >= j["scans_sent"].as_u64().unwrap());
    assert!(
        cmds.iter()
            .all(|c| Seen::f(&c[1]) == 0.0 && Seen::f(&c[2]) == 0.0)
    );
}

#[test]
fn a_node_renamed_in_a_namespace_on_another_domain_with_a_remapped_scan_follows() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-names");
    let bag = corridor_bag(&dir);
    // Everything in /robot1 on domain 7: the scans on /robot1/front_scan, the mount on
    // /robot1/tf_static, the commands expected on /robot1/cmd_vel; tether named
    // `follower`, its spring's loops set by parameters.
    let seen = peer(
        &bag,
        &[
            "--seconds",
            "12",
            "--ns",
            "/robot1",
            "--scan-name",
            "front_scan",
            "--domain",
            "7",
        ],
        &[
            "--ros-args",
            "-r",
            "__ns:=/robot1",
            "-r",
            "__node:=follower",
            "-r",
            "scan:=front_scan",
            "-p",
            "distance_omega:=3.0",
            "-p",
            "bearing_omega:=2.5",
        ],
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap_or_default();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    let nodes = j["nodes"].as_array().unwrap();
    assert!(
        nodes
            .iter()
            .any(|n| n[0] == "/robot1" && n[1] == "follower"),
        "the node is /robot1/follower on domain 7: {nodes:?}\n{stderr}"
    );
    assert!(
        stderr.contains("laser mount from /tf_static"),
        "the mount came from /robot1/tf_static: {stderr}"
    );
    let cmds = seen.series("cmd_vel");
    assert!(
        cmds.iter().filter(|c| Seen::f(&c[1]) > 0.05).count() > cmds.len() / 3,
        "the commands on /robot1/cmd_vel drive: {} of them\n{stderr}",
        cmds.len()
    );
    let last = cmds.last().unwrap();
    assert_eq!((Seen::f(&last[1]), Seen::f(&last[2])), (0.0, 0.0));
}

#[test]
fn compressed_camera_frames_arrive_and_are_decoded() {
    if !peer_available()
        || or_skip(opencv_cascade("haarcascade_upperbody.xml")).is_none()
        // The Python peer encodes JPEG with OpenCV.
        || or_skip(python_modules(&["cv2"], "opencv-python-headless")).is_none()
    {
        return;
    }
    let dir = scratch("ros2-compressed");
    let bag = corridor_bag(&dir);
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/robot.example.toml");
    let seen = peer(
        &bag,
        &["--seconds", "8", "--images-hz", "15", "--compressed"],
        &[
            "--config",
            config.to_str().unwrap(),
            "--ros-args",
            "-p",
            "image_transport:=compressed",
        ],
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    let sent = j["images_sent"].as_u64().unwrap();
    assert!(sent >= 100, "{sent} frames sent in 8 s");
    // JPEG frames of the camera's size, every one received, decoded and run through the
    // detector or superseded by a newer one, none refused.
    assert_eq!(count_before(stderr, " frames received"), sent, "{stderr}");
    assert!(count_before(stderr, " processed") > 0, "{stderr}");
    assert!(
        stderr.contains("0 refused for their size, 0 malformed"),
        "{stderr}"
    );
}

/// A second camera (`[[camera]]` with `frame_id = "rear_camera"`) read from its default
/// topic, `rear_camera/image_raw`, on a detector thread of its own, beside the first.
#[test]
fn a_second_camera_s_frames_arrive_on_its_own_topic() {
    if !peer_available() || or_skip(opencv_cascade("haarcascade_upperbody.xml")).is_none() {
        return;
    }
    let dir = scratch("ros2-two-cameras-images");
    let bag = corridor_bag(&dir);
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs/robot.example.toml");
    let example = std::fs::read_to_string(example).unwrap();
    let rear = "\n[[camera]]\nv4l2 = \"/dev/video2\"\nframe_id = \"rear_camera\"\n\
                intrinsics = { fx_px = 460.0, fy_px = 460.0, cx_px = 319.5, cy_px = 239.5, \
                width_px = 640, height_px = 480 }\n\
                mount = { x_m = -0.05, y_m = 0.0, yaw_rad = 3.1416, height_m = 0.65, \
                tilt_rad = 0.49 }\n\n[follow]";
    let config = dir.join("two_cameras.toml");
    std::fs::write(
        &config,
        example
            .replacen("\n[camera]\n", "\n[[camera]]\n", 1)
            .replacen("\n[follow]", rear, 1),
    )
    .unwrap();
    let seen = peer(
        &bag,
        &[
            "--seconds",
            "6",
            "--images-hz",
            "10",
            "--extra-camera",
            "rear_camera",
            "--read-tf-static",
            "4",
        ],
        &["--config", config.to_str().unwrap()],
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    let sent = j["images_sent"].as_u64().unwrap();
    assert!(sent >= 50, "{sent} frames sent in 6 s");
    let counted = stderr
        .lines()
        .find(|l| l.contains("camera \"rear_camera\" (/rear_camera/image_raw): "))
        .unwrap_or_else(|| panic!("no count of the rear camera's frames: {stderr}"));
    assert!(
        counted.contains(&format!("): {sent} messages received"))
            && counted.contains("0 refused for their size, 0 malformed"),
        "{counted}"
    );
    // Nobody describes the rear camera's frame: its own table's mount goes out on
    // /tf_static, beside the first camera's.
    assert!(
        stderr.contains("no transform from base_link to the camera \"rear_camera\"'s rear_camera"),
        "{stderr}"
    );
    let mounts = j["tf_static"].as_array().unwrap();
    assert!(
        mounts.iter().any(|t| t[0] == "base_link"
            && t[1] == "rear_camera"
            && (Seen::f(&t[2]) + 0.05).abs() < 1e-9),
        "{mounts:?}"
    );
}

#[test]
fn publishers_and_subscribers_dds_will_not_connect_are_reported_with_the_fix() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-misfit");
    let bin = env!("CARGO_BIN_EXE_tether");
    let misfit = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/misfit.py");
    let script = format!(
        "(cd '{tests}' && python3 '{misfit}' --seconds 9) & \
         S=$(date +%s%N); '{bin}' ros2 --duration 7 2> '{d}/ros2.err'; R=$?; \
         echo $(( $(date +%s%N) - S )) > '{d}/elapsed_ns'; wait; exit $R",
        tests = misfit.parent().unwrap().display(),
        misfit = misfit.display(),
        d = dir.display(),
    );
    let out = in_private_network(&script);
    let log = std::fs::read_to_string(dir.join("ros2.err")).unwrap_or_default();
    // `--duration` counts from the start, the 5 s wait for a first scan included (it
    // was 12-13 s in all when the wait came on top).
    let elapsed_s = std::fs::read_to_string(dir.join("elapsed_ns"))
        .unwrap()
        .trim()
        .parse::<f64>()
        .unwrap()
        * 1e-9;
    assert!((7.0..9.5).contains(&elapsed_s), "{elapsed_s} s\n{log}");
    // No scan reached the node in its whole run: it says so and fails, after its stop.
    assert!(!out.status.success(), "{}\n{log}", text(&out.stderr));
    assert!(
        log.contains("no scan arrived on /scan in the whole run") && log.contains("final stop"),
        "{log}"
    );
    for expected in [
        // The wrong type on the scans, and how to point tether elsewhere.
        "/scan: a publisher sends std_msgs/msg/String, but tether reads \
         sensor_msgs/msg/LaserScan",
        "-r scan:=",
        // A /tf_static that a late joiner would never get.
        "/tf_static: a publisher offers durability volatile where the tether subscription \
         asks for transient local",
        "make the publisher transient local",
        // Jazzy's TwistStamped controllers.
        "/cmd_vel: a subscriber expects geometry_msgs/msg/TwistStamped",
        "-p cmd_vel_stamped:=true",
        // A subscriber that wants more than tether offers.
        "/tether/people: tether's publisher offers durability volatile where the subscriber \
         asks for transient local",
    ] {
        assert!(log.contains(expected), "no {expected:?} in:\n{log}");
    }
    // Each is said once, and counted at the end.
    assert_eq!(log.matches("/scan: a publisher sends").count(), 1, "{log}");
    assert!(
        log.contains("4 mismatches with the graph's topics"),
        "{log}"
    );
}

#[test]
fn without_a_mount_on_tf_static_the_config_s_is_published_for_others() {
    if !peer_available() {
        return;
    }
    let dir = scratch("ros2-publish-mount");
    let bag = corridor_bag(&dir);
    let seen = peer_with(
        &bag,
        &["--seconds", "12", "--read-tf-static", "8"],
        &["--scenario", "corridor"],
        false,
    );
    let j = &seen.json;
    let stderr = j["stderr"].as_str().unwrap_or_default();
    assert_eq!(j["exit_code"], 0, "{stderr}");
    assert!(
        stderr.contains("no transform from base_link to laser on /tf_static"),
        "{stderr}"
    );
    assert!(
        stderr.contains("published the config's laser mount on /tf_static"),
        "{stderr}"
    );
    // A late joiner gets it (transient local), with the scenario's mount.
    let m = tether_sim::Scenario::resolve("corridor")
        .unwrap()
        .0
        .laser
        .mount;
    let mounts = j["tf_static"].as_array().unwrap();
    assert!(
        mounts.iter().any(|t| t[0] == "base_link"
            && t[1] == "laser"
            && (Seen::f(&t[2]) - m.x_m).abs() < 1e-9
            && (Seen::f(&t[3]) - m.y_m).abs() < 1e-9
            && (Seen::f(&t[4]) - m.height_m).abs() < 1e-9),
        "{mounts:?}"
    );
}

#[test]
fn a_flood_of_bad_scans_and_odometry_neither_crashes_nor_moves_the_robot() {
    if !peer_available() {
        return;
    }
    let flood = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/ros2/flood.py");
    let script = format!(
        "cd '{tests}' && \
         exec python3 '{flood}' --tether '{bin}' --seconds 6",
        tests = flood.parent().unwrap().display(),
        flood = flood.display(),
        bin = env!("CARGO_BIN_EXE_tether"),
    );
    let out = in_private_network(&script);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{}\n{stdout}", text(&out.stderr));
    let j: serde_json::Value = serde_json::from_str(stdout.trim()).expect("the flood's JSON");
    let log = j["stderr"].as_str().unwrap_or_default();
    eprintln!(
        "flood: {} scans at {:.0} Hz, {} odometry messages",
        j["sent"]["scans"], j["rate_hz"], j["sent"]["odometry"]
    );
    assert_eq!(j["exit_code"], 0, "{log}");
    // Far more than a laser's 10-40 Hz, for seconds.
    assert!(j["rate_hz"].as_f64().unwrap() > 200.0, "{j}");
    // Nobody is in the scans: the robot never moves, but it is commanded (stops) all
    // along, and the last command is the final stop.
    assert!(j["commands"].as_u64().unwrap() > 50, "{j}");
    assert_eq!(j["moving_commands"], 0, "{log}");
    // What was refused is said, and counted.
    assert!(
        log.contains("an odometry message refused: its pose is not finite"),
        "{log}"
    );
    assert!(log.contains("stamped on arrival"), "{log}");
    assert!(log.contains("interrupted"), "{log}");
    assert!(!log.contains("panicked"), "{log}");
}

#[test]
fn a_node_with_no_address_to_announce_refuses_to_start() {
    if !skip_unless(
        runs("unshare", &["-n", "true"]),
        "cannot make a private network namespace (`unshare -n` needs root)",
    ) {
        return;
    }
    // A fresh namespace's loopback is down and has no address: DDS would announce
    // nothing, so the node would be on no graph for its whole life.
    let out = Command::new("unshare")
        .args([
            "-n",
            env!("CARGO_BIN_EXE_tether"),
            "ros2",
            "--duration",
            "2",
        ])
        .output()
        .expect("unshare runs");
    let stderr = text(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("no network interface has an IPv4 address")
            && stderr.contains("ip link set lo up"),
        "{stderr}"
    );
}

#[test]
fn the_walk_through_s_namespace_command_runs_as_written() {
    // docs/ros2.md's "The simulator as the robot": its shell block, as written (`sudo`
    // dropped: the tests run as root), from a scratch folder with this tether on the PATH.
    if !skip_unless(
        runs("unshare", &["-n", "true"]),
        "cannot make a private network namespace (`unshare -n` needs root)",
    ) {
        return;
    }
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/ros2.md"))
            .unwrap();
    let block = doc
        .split("```sh\n")
        .skip(1)
        .filter_map(|b| b.split("```").next())
        .find(|b| b.contains("unshare -n"))
        .expect("docs/ros2.md has the namespace command");
    let script = block.trim().strip_prefix("sudo ").unwrap_or(block.trim());
    let dir = scratch("ros2-walk-through");
    let bin = Path::new(env!("CARGO_BIN_EXE_tether")).parent().unwrap();
    let started = std::time::Instant::now();
    let out = Command::new("sh")
        .args(["-c", script])
        .current_dir(&dir)
        .env(
            "PATH",
            format!(
                "{}:{}",
                bin.display(),
                std::env::var("PATH").unwrap_or_default()
            ),
        )
        .output()
        .unwrap();
    let took_s = started.elapsed().as_secs_f64();
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{said}");
    // `tether ros2 --duration 24` ended by its duration, the simulator after its 26 s.
    assert!(said.contains("duration: "), "{said}");
    assert!((25.0..40.0).contains(&took_s), "{took_s} s\n{said}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/ros2/ros2_run.json")).unwrap())
            .unwrap();
    let err = run["mean_abs_distance_error_m"].as_f64().unwrap();
    // 0.042 m on a quiet machine.
    assert!(err < 0.15, "{run}");
    let _ = std::fs::remove_dir_all(&dir);
}
