//! `tether run` with two scanners (`[[laser]]`, design 5.7): the built-in `all_round`
//! robot's front and rear 180-degree scanners, served by one `tether urg-emulator` on
//! two loopback TCP ports (the rear one with `--extra-tcp rear_laser=ADDR`): one
//! simulated robot carries both, driven by the commands `tether run` prints. Its target
//! walks all the way round the robot: one track, followed, from either scanner's view.
//!
//! Real time on a possibly loaded machine: the bars are loose, every wait has a limit
//! that fails with what the processes said, and the processes are killed whatever
//! happens. The scanners have their full 240 degrees here ([`overlapping_scanners`]):
//! `all_round`'s 180-degree ones leave a blind band beside the robot, where the person
//! was lost in about one run in ten (one in four in clean-clone CI runs, even with
//! nothing beside the test).

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::path::Path;
use std::process::Stdio;
use std::time::Duration;

use common::live::{Proc, announced_endpoint};
use common::run::{
    assert_final_stop, emulator_truth, free_loopback_address, gap_to_target, json, run_feeding,
    spawn, xy,
};
use common::scratch;
use tether_core::LaserMount;

/// `all_round` with each scanner's full 240 degrees (URG-04LX steps 44-725) instead of
/// 180: the two fields overlap beside the robot. With 180 degrees the scanners, 0.1 m
/// ahead of and behind the axle, leave a band beside it that neither sees; a person
/// walking along it for over a second while the robot hardly turns comes back as a new
/// track (docs/measured.md), which is the follower's weakness (issue 32), not what this
/// test is about.
fn overlapping_scanners(dir: &Path) -> std::path::PathBuf {
    let shown = std::process::Command::new(env!("CARGO_BIN_EXE_tether"))
        .args(["scenarios", "--show", "all_round"])
        .output()
        .unwrap();
    assert!(shown.status.success());
    let text = String::from_utf8(shown.stdout).unwrap();
    let half = "first_step = 128, front_step = 384, last_step = 640";
    assert_eq!(text.matches(half).count(), 2, "{text}");
    let path = dir.join("all_round_240.toml");
    let full = "first_step = 44, front_step = 384, last_step = 725";
    std::fs::write(&path, text.replace(half, full)).unwrap();
    path
}

/// The emulator of `all_round`'s two scanners ([`overlapping_scanners`]), the front one
/// on `front`, the rear one on `rear`, its robot driven by its stdin.
fn emulator(dir: &Path, front: &str, rear: &str) -> Proc {
    let truth = dir.join("urg-emulator.truth.jsonl");
    let rear = format!("rear_laser={rear}");
    let scenario = overlapping_scanners(dir);
    let args = vec![
        "urg-emulator",
        "--tcp",
        front,
        "--extra-tcp",
        rear.as_str(),
        "--scenario",
        scenario.to_str().unwrap(),
        "--seed",
        "1",
        "--commands-stdin",
        "--truth",
        truth.to_str().unwrap(),
    ];
    let mut emu = spawn("urg-emulator", dir, &args, Stdio::piped());
    assert_eq!(announced_endpoint(&mut emu), front);
    emu
}

/// One `[[laser]]` table.
fn laser_table(address: &str, mount: LaserMount, frame: Option<&str>) -> String {
    format!(
        "[[laser]]\ntcp = \"{address}\"\n{}mount = {{ x_m = {}, y_m = {}, yaw_rad = {}, \
         height_m = {} }}\n",
        frame.map_or(String::new(), |f| format!("frame_id = \"{f}\"\n")),
        mount.x_m,
        mount.y_m,
        mount.yaw_rad,
        mount.height_m
    )
}

#[test]
fn a_robot_with_two_scanners_follows_its_person_all_the_way_round() {
    let dir = scratch("live-two-lasers");
    let scenario = tether_sim::Scenario::resolve("all_round").unwrap().0;
    let (front, rear) = (free_loopback_address(), free_loopback_address());
    let mut emu = emulator(&dir, &front, &rear);
    let config = dir.join("robot.toml");
    std::fs::write(
        &config,
        format!(
            "[robot]\nradius_m = 0.2\ntrack_width_m = 0.3\nmax_speed_mps = 1.4\n\
             max_wheel_speed_mps = 1.6\nmax_accel_mps2 = 1.2\n\n{}\n{}\n[follow]\n\
             follow_distance_m = {}\nattach_ahead_m = 0.3\ndistance_omega_radps = 4.0\n\
             bearing_omega_radps = 3.0\n\n[base]\nkind = \"none\"\n\n[output]\nstdout = true\n\n\
             # A loaded test machine may delay a scan now and then.\n[pipeline.safety]\n\
             laser_timeout_s = 0.5\n",
            laser_table(&front, scenario.laser.mount, None),
            laser_table(
                &rear,
                scenario.extra_lasers[0].laser.mount,
                Some("rear_laser")
            ),
            scenario.robot.follow_distance_m,
        ),
    )
    .unwrap();
    let feeds = vec![emu.child.stdin.take().unwrap()];
    let (mut run, lines) = run_feeding(&dir, &config, &["--duration", "24"], feeds);
    let status = run.wait_or_fail(
        Duration::from_secs(90),
        "tether run did not end within 90 s",
    );
    let stderr = run.stderr();
    assert!(status.success(), "tether run failed:\n{stderr}");
    assert!(stderr.contains("frame rear_laser"), "{stderr}");
    // Both scanners' scans reached the pipeline: 10 Hz each for 24 s (480 here).
    let scans: u64 = stderr
        .split("duration: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count of scans: {stderr}"));
    assert!(scans > 400, "{scans} scans");
    assert_final_stop(&lines, "duration", &stderr);
    drop(emu);

    // One track from the first lock to the end, followed round the robot.
    let lines: Vec<serde_json::Value> = lines.lock().unwrap().iter().map(|l| json(l)).collect();
    let first_lock = lines
        .iter()
        .position(|l| !l["target"].is_null())
        .unwrap_or_else(|| panic!("never locked a target; stderr:\n{stderr}"));
    let after = &lines[first_lock..lines.len() - 1];
    let ids: std::collections::BTreeSet<u64> = after
        .iter()
        .filter_map(|l| l["target"]["id"].as_u64())
        .collect();
    let locked = after.iter().filter(|l| l["target"].is_object()).count();
    let widest = |side: f64| {
        after
            .iter()
            .filter_map(|l| l["target"]["bearing_rad"].as_f64())
            .map(|b| b * side)
            .fold(0.0, f64::max)
    };
    eprintln!(
        "first lock at line {first_lock}; locked in {locked} of {} lines; tracks {ids:?}; \
         bearings from {:.2} to {:.2} rad",
        after.len(),
        -widest(-1.0),
        widest(1.0)
    );
    assert_eq!(ids.len(), 1, "the target changed tracks: {ids:?}");
    assert!(
        locked * 100 >= after.len() * 90,
        "{locked} of {}",
        after.len()
    );
    assert!(
        widest(1.0) > 1.6 || widest(-1.0) > 1.6,
        "never beside or behind"
    );

    // The emulator's truth: the robot kept clear of the person and hit nothing.
    let truth = emulator_truth(&dir.join("urg-emulator.truth.jsonl"));
    let closest = truth
        .iter()
        .map(gap_to_target)
        .fold(f64::INFINITY, f64::min);
    let driven: f64 = truth
        .windows(2)
        .map(|w| {
            let ((x0, y0), (x1, y1)) = (xy(&w[0]["robot"]), xy(&w[1]["robot"]));
            (x1 - x0).hypot(y1 - y0)
        })
        .sum();
    eprintln!("robot drove {driven:.2} m; closest {closest:.2} m");
    assert!(driven > 3.0, "the robot drove only {driven:.2} m");
    assert!(closest > 0.3, "the robot came within {closest:.2} m");
    assert_eq!(truth.last().unwrap()["collisions"], 0);
}
