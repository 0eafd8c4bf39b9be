//! `tether sim --scenario NAME --ros2`: the simulated robot on the ROS 2 graph, in real
//! time. It publishes the simulated laser on `/scan` (best effort, keep last 5, frame
//! `laser`), its mount on `/tf_static` (`base_link` -> `laser`, reliable and transient
//! local) and, when the scenario's robot has odometry, its pose on `/odom` and `/tf`
//! (`odom` -> `base_link`, 20 Hz), and drives from `/cmd_vel` (`Twist`). Like a real
//! base, it stops when no command has come for 0.5 s. The camera is not published
//! (the robot is laser-only on the graph).
//!
//! `tether ros2 --scenario NAME` is the node that matches it (the scenario's laser
//! mount, follow distance and base limits). At the end (the scenario's duration, or
//! Ctrl-C) the simulator prints how well the robot followed: mean |d - d0| from the
//! first command that moved it, and collisions, and writes them to `OUT/ros2_run.json`.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::Context;
use tether_control::SpringConfig;
use tether_core::{Point2, Stamp};
use tether_io::mcap::{
    Header, LaserScanMsg, OdometryMsg, Pose3, TfMessage, TransformStampedMsg, TwistMsg,
};
use tether_io::scip::{Clock, SystemClock};
use tether_ros2::{NodeIdentity, Received, RosNode, Wire, qos, spawn_reader};
use tether_sim::{Command, Scenario, SensorData, Simulation};

/// A base stops when its commands stop for this long.
const COMMAND_TIMEOUT: Duration = Duration::from_millis(500);

/// What the run measured, as `ros2_run.json` holds it.
#[derive(Debug, serde::Serialize)]
struct Ros2RunSummary {
    scenario: String,
    seed: u64,
    simulated_s: f64,
    scans_published: u64,
    odometry_published: u64,
    commands_received: u64,
    /// Seconds from the start to the first command that moved the robot.
    first_motion_s: Option<f64>,
    /// Mean |d - d0| from the first motion on, m (d: from the spring's attachment point
    /// ahead of the wheel axis to the target's body centre).
    mean_abs_distance_error_m: Option<f64>,
    follow_distance_m: f64,
    collisions: u32,
    distance_driven_m: f64,
}

/// Runs `scenario` in real time on the graph until its end or `stop`.
pub fn run(scenario: &Scenario, seed: u64, out: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C")?;
    let domain_id = tether_ros2::domain_id(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    let mut node = RosNode::start(NodeIdentity {
        name: "tether_sim".into(),
        namespace: "/".into(),
        domain_id,
    })?;
    let scans = node.publisher::<LaserScanMsg>("/scan", qos::sensor_data())?;
    let odom = node.publisher::<OdometryMsg>("/odom", qos::sensor_data())?;
    let tf = node.publisher::<TfMessage>("/tf", qos::reliable(100))?;
    let tf_static = node.publisher::<TfMessage>("/tf_static", qos::latched(1))?;
    let commands = node.subscribe::<TwistMsg>("/cmd_vel", qos::reliable(10))?;
    let latest: Arc<Mutex<Option<(Instant, Command, u64)>>> = Arc::new(Mutex::new(None));
    let (stop_reader, reader_stops) = mpsc::channel();
    let reader = {
        let latest = Arc::clone(&latest);
        spawn_reader("sim-cmd-vel", commands, reader_stops, move |received| {
            if let Received::Message { message, .. } = received {
                let command = Command {
                    v_mps: message.v_mps(),
                    w_radps: message.w_radps(),
                };
                if command.v_mps.is_finite() && command.w_radps.is_finite() {
                    let mut slot = latest.lock().unwrap_or_else(|e| e.into_inner());
                    let n = slot.map_or(0, |(_, _, n)| n) + 1;
                    *slot = Some((Instant::now(), command, n));
                }
            }
            true
        })?
    };

    let mut sim = Simulation::new(scenario, seed)?;
    // Commands are taken up at every event: 100 Hz timer events keep the base's
    // reaction within 10 ms of a command's arrival, as a real base's controller would;
    // odometry goes out at every fifth (20 Hz).
    sim.set_control_rate_hz(100.0);
    let mut timer_events = 0u64;
    let odometry = scenario.odometry_available();
    let scan_period_s = scenario.laser.scan_period_s;
    let attach_ahead_m = SpringConfig::default().attach_ahead_m;
    let d0 = scenario.robot.follow_distance_m;
    let unix0 = SystemClock.now_ns();
    // The robot's description: where its laser sits (sent once; late joiners get it).
    let m = scenario.laser.mount;
    let mut mount = Pose3::planar(m.x_m, m.y_m, m.yaw_rad);
    mount.position_m[2] = m.height_m;
    let mount = TfMessage {
        transforms: vec![TransformStampedMsg {
            header: Header::new(Stamp::from_ns(unix0), "base_link"),
            child_frame_id: "laser".into(),
            transform: mount,
        }],
    };
    tf_static
        .publish(Wire(mount))
        .map_err(|e| anyhow::anyhow!("/tf_static: {e:?}"))?;
    let wall0 = Instant::now();
    tracing::info!(
        "simulating `{}` (seed {seed}) on ROS 2 domain {domain_id} in real time: /scan{}, \
         driving from /cmd_vel; follow with `tether ros2 --scenario {}`",
        scenario.name,
        if odometry { ", /odom" } else { "" },
        scenario.name.trim_end_matches("-laser-only"),
    );
    let mut summary = Ros2RunSummary {
        scenario: scenario.name.clone(),
        seed,
        simulated_s: 0.0,
        scans_published: 0,
        odometry_published: 0,
        commands_received: 0,
        first_motion_s: None,
        mean_abs_distance_error_m: None,
        follow_distance_m: d0,
        collisions: 0,
        distance_driven_m: 0.0,
    };
    let mut errors = Vec::new();
    let mut last_position: Option<Point2<tether_core::World>> = None;
    while !stop.load(Ordering::Relaxed) {
        let Some(event) = sim.advance() else {
            break;
        };
        let t_ns = event.truth.stamp.ns();
        let due = wall0 + Duration::from_nanos(t_ns.max(0) as u64);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }
        let stamp = Stamp::from_ns(unix0.saturating_add(t_ns));
        let command = match *latest.lock().unwrap_or_else(|e| e.into_inner()) {
            Some((at, command, n)) => {
                summary.commands_received = n;
                if at.elapsed() <= COMMAND_TIMEOUT {
                    command
                } else {
                    Command::default()
                }
            }
            None => Command::default(),
        };
        sim.set_command(command);
        if summary.first_motion_s.is_none() && (command.v_mps != 0.0 || command.w_radps != 0.0) {
            summary.first_motion_s = Some(t_ns as f64 * 1e-9);
        }
        match event.data {
            SensorData::Scan(mut scan) => {
                scan.stamp = stamp;
                let beams = scan.len().max(1) as f64;
                let msg = LaserScanMsg::new(scan, scan_period_s / beams, scan_period_s);
                scans
                    .publish(Wire(msg))
                    .map_err(|e| anyhow::anyhow!("/scan: {e:?}"))?;
                summary.scans_published += 1;
            }
            SensorData::Timer => {
                let truth = &event.truth;
                timer_events += 1;
                if odometry && timer_events % 5 == 1 {
                    let msg = OdometryMsg::planar(
                        Header::new(stamp, "odom"),
                        "base_link",
                        truth.world_from_robot,
                        command.v_mps,
                        command.w_radps,
                    );
                    odom.publish(Wire(msg))
                        .map_err(|e| anyhow::anyhow!("/odom: {e:?}"))?;
                    let moved = TfMessage {
                        transforms: vec![TransformStampedMsg {
                            header: Header::new(stamp, "odom"),
                            child_frame_id: "base_link".into(),
                            transform: Pose3::from_pose2(truth.world_from_robot),
                        }],
                    };
                    tf.publish(Wire(moved))
                        .map_err(|e| anyhow::anyhow!("/tf: {e:?}"))?;
                    summary.odometry_published += 1;
                }
                if timer_events % 5 != 1 {
                    summary.simulated_s = t_ns as f64 * 1e-9;
                    continue;
                }
                let here = truth.world_from_robot.translation();
                if let Some(last) = last_position {
                    summary.distance_driven_m += last.distance_m(here);
                }
                last_position = Some(here);
                if summary.first_motion_s.is_some()
                    && let Some(target) = truth.target()
                {
                    let attach = truth.world_from_robot * Point2::new(attach_ahead_m, 0.0);
                    errors.push((attach.distance_m(target.position) - d0).abs());
                }
            }
            SensorData::Camera(_) => {}
        }
        summary.simulated_s = t_ns as f64 * 1e-9;
    }
    // The robot is left standing: nothing drives it after the simulation ends.
    let _ = stop_reader.send(());
    if reader.join().is_err() {
        tracing::error!("the /cmd_vel reader thread panicked");
    }
    drop(node);
    summary.collisions = sim.collisions();
    summary.mean_abs_distance_error_m =
        (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64);
    let path = out.join("ros2_run.json");
    let json = serde_json::to_string_pretty(&summary)?;
    std::fs::write(&path, json + "\n").with_context(|| format!("writing {}", path.display()))?;
    println!(
        "{}: {:.1} s simulated in real time, {} scans and {} odometry messages published, {} \
         commands received, first motion at {}, mean |d - d0| {} (d0 = {d0} m), {} collisions, \
         {:.1} m driven -> {}",
        scenario.name,
        summary.simulated_s,
        summary.scans_published,
        summary.odometry_published,
        summary.commands_received,
        summary
            .first_motion_s
            .map_or("never".into(), |s| format!("{s:.1} s")),
        summary
            .mean_abs_distance_error_m
            .map_or("n/a".into(), |e| format!("{e:.3} m")),
        summary.collisions,
        summary.distance_driven_m,
        path.display()
    );
    Ok(())
}
