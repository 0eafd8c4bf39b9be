//! The simulated robot on a ROS 2 graph (`tether sim --scenario NAME --ros2`), in real
//! time. It publishes the simulated laser on `/scan` (best effort, keep last 5, frame
//! `laser`), each extra laser's scans on `/FRAME/scan` (frame `FRAME`, design 5.7), their
//! mounts on `/tf_static` (`base_link` -> `laser`, -> `FRAME`, reliable and transient
//! local) and, when the scenario's robot has odometry, its pose on `/odom` and `/tf`
//! (`odom` -> `base_link`, 20 Hz), and drives from `/cmd_vel` (`Twist`, or `TwistStamped`
//! with `--cmd-vel-stamped`). Like a real
//! base, it stops when no command has come for 0.5 s. Unless `--laser-only`, the
//! camera's upper-body boxes go out on `/detections` (`vision_msgs/msg/Detection2DArray`,
//! class `person`, best effort, frame `camera`), as a detector node's would, and their
//! ground truth on `/sim/detections_truth` (the noise-free box of every person in front
//! of the camera, `id` the person's, score the share of the upper body in view); each
//! extra camera's boxes on `/FRAME/detections` (frame `FRAME`, its mount on `/tf_static`
//! too; design 5.7).
//!
//! With `--use-sim-time` the stamps are the simulated time from 0, published on
//! `/clock` (`rosgraph_msgs/msg/Clock`, reliable, keep last 1) at every 10 ms step, and
//! `--rate X` runs it X times faster than real time; the command timeout is then in
//! simulated time too.
//!
//! `tether ros2 --scenario NAME` is the node that matches it (the scenario's laser
//! mount, follow distance and base limits). At the end (the scenario's duration, or
//! Ctrl-C) the simulator prints how well the robot followed: mean |d - d0| from the
//! first command that moved it, and collisions ([`Ros2RunSummary`], which the command line
//! writes to `OUT/ros2_run.json`).

use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tether_control::SpringConfig;
use tether_core::{Point2, Stamp};
use tether_live::ros2::camera_mount::camera_pose;
use tether_msgs::{
    ClockMsg, Detection2DArrayMsg, Detection2DMsg, Header, LaserScanMsg, ObjectHypothesisMsg,
    OdometryMsg, Pose3, TfMessage, TransformStampedMsg, TwistMsg, TwistStampedMsg,
};
use tether_ros2::{NodeIdentity, Publisher, Received, RosNode, Wire, qos, spawn_reader};
use tether_scip::{Clock, SystemClock};
use tether_sim::{CameraFrame, CameraTruth, Command, Scenario, SensorData, Simulation};

/// A base stops when its commands stop for this long (simulated time), ns.
const COMMAND_TIMEOUT_NS: i64 = 500_000_000;
/// The first laser's frame: its scans go out on `/scan`.
const LASER_FRAME: &str = <tether_core::Laser as tether_core::Frame>::NAME;

/// The simulator's time on the graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SimTime {
    /// Real time, stamps on the host's wall clock.
    Wall,
    /// Simulated time from 0 on `/clock`, `rate` times faster than real time.
    Published {
        /// Simulated seconds per wall-clock second.
        rate: f64,
    },
}

/// What the run measured, as `ros2_run.json` holds it.
#[derive(Debug, serde::Serialize)]
pub struct Ros2RunSummary {
    /// The scenario's name.
    pub scenario: String,
    /// The seed of its random draws.
    pub seed: u64,
    /// Simulated seconds per wall second; `null` in real time on the wall clock.
    pub sim_time_rate: Option<f64>,
    /// Simulated time, s.
    pub simulated_s: f64,
    /// Scans published (`/scan` and the extra lasers').
    pub scans_published: u64,
    /// Odometry messages published on `/odom`.
    pub odometry_published: u64,
    /// Camera frames whose boxes went out on `/detections` and the extra cameras'
    /// `/FRAME/detections` (0 with `--laser-only`).
    pub camera_frames_published: u64,
    /// Commands received on `/cmd_vel`.
    pub commands_received: u64,
    /// Seconds from the start to the first command that moved the robot.
    pub first_motion_s: Option<f64>,
    /// Mean |d - d0| from the first motion on, m (d: from the spring's attachment point
    /// ahead of the wheel axis to the target's body centre).
    pub mean_abs_distance_error_m: Option<f64>,
    /// The scenario's follow distance d0, m.
    pub follow_distance_m: f64,
    /// Mean |d - d0| over each whole simulated second from the first motion on, m: where
    /// in the run the error came from.
    pub abs_distance_error_by_second_m: Vec<f64>,
    /// Collisions of the robot.
    pub collisions: u32,
    /// Distance the robot drove, m.
    pub distance_driven_m: f64,
}

/// What the simulated robot publishes on.
struct Publishers {
    scans: Publisher<Wire<LaserScanMsg>>,
    /// `/FRAME/scan` of each extra laser, by frame.
    extra_scans: Vec<(String, Publisher<Wire<LaserScanMsg>>)>,
    odom: Publisher<Wire<OdometryMsg>>,
    tf: Publisher<Wire<TfMessage>>,
    tf_static: Publisher<Wire<TfMessage>>,
    /// `/clock`, on simulated time only.
    clock: Option<Publisher<Wire<ClockMsg>>>,
    /// `/detections`, with a simulated camera only.
    detections: Option<Publisher<Wire<Detection2DArrayMsg>>>,
    /// `/FRAME/detections` of each extra camera, by frame (with a simulated camera).
    extra_detections: Vec<(String, Publisher<Wire<Detection2DArrayMsg>>)>,
    /// `/sim/detections_truth`, with a simulated camera only.
    detections_truth: Option<Publisher<Wire<Detection2DArrayMsg>>>,
}

impl Publishers {
    /// The publishers of a run on `time`, with the camera's when `camera`.
    fn new(node: &mut RosNode, time: SimTime, scenario: &Scenario) -> anyhow::Result<Self> {
        let camera = scenario.camera_sim.enabled;
        let scans = node.publisher::<LaserScanMsg>("/scan", qos::sensor_data())?;
        let mut extra_scans = Vec::new();
        for l in &scenario.extra_lasers {
            let topic = format!("/{}/scan", l.frame_id);
            extra_scans.push((
                l.frame_id.clone(),
                node.publisher::<LaserScanMsg>(&topic, qos::sensor_data())?,
            ));
        }
        let odom = node.publisher::<OdometryMsg>("/odom", qos::sensor_data())?;
        let tf = node.publisher::<TfMessage>("/tf", qos::reliable(100))?;
        let tf_static = node.publisher::<TfMessage>("/tf_static", qos::latched(1))?;
        let clock = match time {
            SimTime::Wall => None,
            SimTime::Published { .. } => {
                Some(node.publisher::<ClockMsg>("/clock", qos::reliable(1))?)
            }
        };
        let mut extra_detections = Vec::new();
        for c in scenario.extra_cameras.iter().filter(|_| camera) {
            let topic = format!("/{}/detections", c.frame_id);
            extra_detections.push((
                c.frame_id.clone(),
                node.publisher::<Detection2DArrayMsg>(&topic, qos::sensor_data())?,
            ));
        }
        let (detections, detections_truth) = if camera {
            (
                Some(node.publisher::<Detection2DArrayMsg>("/detections", qos::sensor_data())?),
                Some(node.publisher::<Detection2DArrayMsg>(
                    "/sim/detections_truth",
                    qos::sensor_data(),
                )?),
            )
        } else {
            (None, None)
        };
        Ok(Publishers {
            scans,
            extra_scans,
            odom,
            tf,
            tf_static,
            clock,
            detections,
            extra_detections,
            detections_truth,
        })
    }

    /// A camera frame's boxes: the first camera's on `/detections` with their truth on
    /// `/sim/detections_truth`, an extra camera's on `/FRAME/detections` (its truth is
    /// not kept).
    fn camera(
        &self,
        frame: &CameraFrame,
        camera_truth: &Option<CameraTruth>,
        stamp: Stamp,
    ) -> anyhow::Result<()> {
        if frame.frame_id == tether_core::FIRST_CAMERA_FRAME {
            let (boxes, truth) = camera_messages(frame, camera_truth, stamp);
            for (topic, publisher, message) in [
                ("/detections", &self.detections, boxes),
                ("/sim/detections_truth", &self.detections_truth, truth),
            ] {
                if let Some(publisher) = publisher {
                    publisher
                        .publish(Wire(message))
                        .map_err(|e| anyhow::anyhow!("{topic}: {e:?}"))?;
                }
            }
        } else if let Some((_, publisher)) = self
            .extra_detections
            .iter()
            .find(|(f, _)| *f == frame.frame_id)
        {
            let (boxes, _) = camera_messages(frame, &None, stamp);
            publisher
                .publish(Wire(boxes))
                .map_err(|e| anyhow::anyhow!("/{}/detections: {e:?}", frame.frame_id))?;
        }
        Ok(())
    }

    /// The robot's pose on `/odom` (with the commanded velocity) and on `/tf`
    /// (`odom` -> `base_link`).
    /// Publishes a scan on `/scan` (an extra laser's on `/FRAME/scan`), stamped
    /// `stamp`, its beams spread over `period_s`.
    fn scan(
        &self,
        mut scan: tether_core::LaserScan,
        stamp: Stamp,
        period_s: f64,
    ) -> anyhow::Result<()> {
        let publisher = if scan.frame_id == LASER_FRAME {
            &self.scans
        } else {
            match self.extra_scans.iter().find(|(f, _)| *f == scan.frame_id) {
                Some((_, p)) => p,
                None => anyhow::bail!("a scan of frame {} that no laser has", scan.frame_id),
            }
        };
        scan.stamp = stamp;
        let beams = scan.len().max(1) as f64;
        let frame = scan.frame_id.clone();
        let msg = LaserScanMsg::new(scan, period_s / beams, period_s);
        publisher
            .publish(Wire(msg))
            .map_err(|e| anyhow::anyhow!("the scan of {frame}: {e:?}"))
    }

    fn odometry(
        &self,
        stamp: Stamp,
        world_from_robot: tether_core::Pose2<tether_core::World, tether_core::Robot>,
        command: Command,
    ) -> anyhow::Result<()> {
        let msg = OdometryMsg::planar(
            Header::new(stamp, "odom"),
            "base_link",
            world_from_robot,
            command.v_mps,
            command.w_radps,
        );
        self.odom
            .publish(Wire(msg))
            .map_err(|e| anyhow::anyhow!("/odom: {e:?}"))?;
        let moved = TfMessage {
            transforms: vec![TransformStampedMsg {
                header: Header::new(stamp, "odom"),
                child_frame_id: "base_link".into(),
                transform: Pose3::from_pose2(world_from_robot),
            }],
        };
        self.tf
            .publish(Wire(moved))
            .map_err(|e| anyhow::anyhow!("/tf: {e:?}"))
    }
}

/// The newest command from `/cmd_vel`: the simulated time it came at (ns), the command,
/// and how many have come.
type Latest = Arc<Mutex<Option<(i64, Command, u64)>>>;

/// A thread reading `/cmd_vel` (`Twist`, or `TwistStamped` when `stamped`) into
/// `latest`, stamped with the simulated time `sim_now`; a send on the returned channel
/// stops it.
fn command_reader(
    node: &mut RosNode,
    stamped: bool,
    sim_now: &Arc<AtomicI64>,
    latest: &Latest,
) -> anyhow::Result<(mpsc::Sender<()>, std::thread::JoinHandle<()>)> {
    let (stop_reader, reader_stops) = mpsc::channel();
    let take = {
        let latest = Arc::clone(latest);
        let sim_now = Arc::clone(sim_now);
        move |twist: &TwistMsg| {
            let command = Command {
                v_mps: twist.v_mps(),
                w_radps: twist.w_radps(),
            };
            if command.v_mps.is_finite() && command.w_radps.is_finite() {
                let mut slot = latest.lock().unwrap_or_else(|e| e.into_inner());
                let n = slot.map_or(0, |(_, _, n)| n) + 1;
                *slot = Some((sim_now.load(Ordering::Acquire), command, n));
            }
            true
        }
    };
    let reader = if stamped {
        let commands = node.subscribe::<TwistStampedMsg>("/cmd_vel", qos::reliable(10))?;
        spawn_reader(
            "sim-cmd-vel",
            commands,
            reader_stops,
            move |received| match received {
                Received::Message { message, .. } => take(&message.twist),
                Received::Malformed(_) => true,
            },
        )?
    } else {
        let commands = node.subscribe::<TwistMsg>("/cmd_vel", qos::reliable(10))?;
        spawn_reader(
            "sim-cmd-vel",
            commands,
            reader_stops,
            move |received| match received {
                Received::Message { message, .. } => take(&message),
                Received::Malformed(_) => true,
            },
        )?
    };
    Ok((stop_reader, reader))
}

/// `/tf_static`: where the laser (and, with a simulated camera, the camera) sit on
/// `base_link`.
fn static_transforms(scenario: &Scenario, stamp: Stamp) -> TfMessage {
    let lasers = std::iter::once(("laser", &scenario.laser)).chain(
        scenario
            .extra_lasers
            .iter()
            .map(|l| (l.frame_id.as_str(), &l.laser)),
    );
    let mut transforms: Vec<TransformStampedMsg> = lasers
        .map(|(frame, laser)| TransformStampedMsg {
            header: Header::new(stamp, "base_link"),
            child_frame_id: frame.into(),
            transform: Pose3::laser_mount(&laser.mount),
        })
        .collect();
    if scenario.camera_sim.enabled {
        let cameras = std::iter::once(("camera", &scenario.camera)).chain(
            scenario
                .extra_cameras
                .iter()
                .map(|c| (c.frame_id.as_str(), &c.camera)),
        );
        transforms.extend(cameras.map(|(frame, camera)| TransformStampedMsg {
            header: Header::new(stamp, "base_link"),
            child_frame_id: frame.into(),
            transform: camera_pose(&camera.mount, false),
        }));
    }
    TfMessage { transforms }
}

/// Says in the log what goes out where, and the `tether ros2` command that follows it.
fn announce(
    scenario: &Scenario,
    seed: u64,
    domain_id: u16,
    time: SimTime,
    odometry: bool,
    clock: bool,
) {
    let extra: String = scenario
        .extra_lasers
        .iter()
        .map(|l| format!(", /{}/scan", l.frame_id))
        .chain(
            scenario
                .extra_cameras
                .iter()
                .filter(|_| scenario.camera_sim.enabled)
                .map(|c| format!(", /{}/detections", c.frame_id)),
        )
        .collect();
    tracing::info!(
        "simulating `{}` (seed {seed}) on ROS 2 domain {domain_id} {}: /scan{extra}{}{}{}, driving \
         from /cmd_vel; follow with `tether ros2 --scenario {}{}{}`",
        scenario.name,
        match time {
            SimTime::Wall => "in real time".to_owned(),
            SimTime::Published { rate } => format!("on sim time at {rate} x real time"),
        },
        if odometry { ", /odom" } else { "" },
        if scenario.camera_sim.enabled {
            ", /detections"
        } else {
            ""
        },
        if clock { ", /clock" } else { "" },
        scenario.name.trim_end_matches("-laser-only"),
        if scenario.camera_sim.enabled {
            ""
        } else {
            " --laser-only"
        },
        if clock {
            " --ros-args -p use_sim_time:=true"
        } else {
            ""
        },
    );
}

/// One camera frame's boxes as `/detections` (class `person`, score 1; its header names
/// the frame's camera) and their ground
/// truth as `/sim/detections_truth` (the noise-free box of every person in view, `id`
/// the person's, score the share of the upper body in view).
fn camera_messages(
    frame: &CameraFrame,
    camera_truth: &Option<CameraTruth>,
    stamp: Stamp,
) -> (Detection2DArrayMsg, Detection2DArrayMsg) {
    let header = Header::new(stamp, &frame.frame_id);
    let person = |score| ObjectHypothesisMsg::class("person", score);
    let boxes = Detection2DArrayMsg {
        header: header.clone(),
        detections: frame
            .boxes
            .iter()
            .map(|b| Detection2DMsg::from_box(header.clone(), b, person(1.0), ""))
            .collect(),
    };
    let truth = Detection2DArrayMsg {
        header: header.clone(),
        detections: camera_truth
            .iter()
            .flat_map(|t| &t.people)
            .filter_map(|p| {
                let b = p.true_box?;
                Some(Detection2DMsg::from_box(
                    header.clone(),
                    &b,
                    person(p.visible_frac * p.in_image_frac),
                    p.id.to_string(),
                ))
            })
            .collect(),
    };
    (boxes, truth)
}

/// Runs `scenario` on the graph until its end or until `stop` is set (Ctrl-C), and
/// returns what it measured.
pub fn run(
    scenario: &Scenario,
    seed: u64,
    time: SimTime,
    cmd_vel_stamped: bool,
    stop: &AtomicBool,
) -> anyhow::Result<Ros2RunSummary> {
    let domain_id = tether_ros2::domain_id(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    let mut node = RosNode::start(NodeIdentity {
        name: "tether_sim".into(),
        namespace: "/".into(),
        domain_id,
    })?;
    let out = Publishers::new(&mut node, time, scenario)?;
    // The simulated time now, ns, for the reader to stamp the commands with.
    let sim_now = Arc::new(AtomicI64::new(0));
    let latest: Latest = Arc::new(Mutex::new(None));
    let (stop_reader, reader) = command_reader(&mut node, cmd_vel_stamped, &sim_now, &latest)?;

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
    // Stamps: the wall clock at the start plus the simulated time, or the simulated
    // time alone.
    let (unix0, rate) = match time {
        SimTime::Wall => (SystemClock.now_ns(), 1.0),
        SimTime::Published { rate } => (0, rate),
    };
    // The robot's description: where its laser (and camera) sit (sent once; late
    // joiners get it).
    out.tf_static
        .publish(Wire(static_transforms(scenario, Stamp::from_ns(unix0))))
        .map_err(|e| anyhow::anyhow!("/tf_static: {e:?}"))?;
    let mut wall0 = Instant::now();
    announce(
        scenario,
        seed,
        domain_id,
        time,
        odometry,
        out.clock.is_some(),
    );
    let mut summary = Ros2RunSummary {
        scenario: scenario.name.clone(),
        seed,
        sim_time_rate: out.clock.is_some().then_some(rate),
        simulated_s: 0.0,
        scans_published: 0,
        odometry_published: 0,
        camera_frames_published: 0,
        commands_received: 0,
        first_motion_s: None,
        mean_abs_distance_error_m: None,
        follow_distance_m: d0,
        abs_distance_error_by_second_m: Vec::new(),
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
        let due = wall0 + Duration::from_secs_f64(t_ns.max(0) as f64 * 1e-9 / rate);
        let now = Instant::now();
        match due.checked_duration_since(now) {
            Some(wait) => std::thread::sleep(wait),
            // Behind (a busy machine). On the wall clock the stamps must catch up; on
            // simulated time the clock slows down instead: a burst of steps would give
            // the follower less time to answer than the simulated time says it had.
            None if out.clock.is_some() => wall0 += now - due,
            None => {}
        }
        let stamp = Stamp::from_ns(unix0.saturating_add(t_ns));
        sim_now.store(t_ns, Ordering::Release);
        if let Some(clock) = &out.clock {
            clock
                .publish(Wire(ClockMsg { clock: stamp }))
                .map_err(|e| anyhow::anyhow!("/clock: {e:?}"))?;
        }
        let command = match *latest.lock().unwrap_or_else(|e| e.into_inner()) {
            Some((at_ns, command, n)) => {
                summary.commands_received = n;
                if t_ns.saturating_sub(at_ns) <= COMMAND_TIMEOUT_NS {
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
            SensorData::Scan(scan) => {
                out.scan(scan, stamp, scan_period_s)?;
                summary.scans_published += 1;
            }
            SensorData::Timer => {
                let truth = &event.truth;
                timer_events += 1;
                if odometry && timer_events % 5 == 1 {
                    out.odometry(stamp, truth.world_from_robot, command)?;
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
                    errors.push((t_ns, (attach.distance_m(target.position) - d0).abs()));
                }
            }
            SensorData::Camera(frame) => {
                out.camera(&frame, &event.camera_truth, stamp)?;
                summary.camera_frames_published += 1;
            }
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
    summary.mean_abs_distance_error_m = (!errors.is_empty())
        .then(|| errors.iter().map(|(_, e)| e).sum::<f64>() / errors.len() as f64);
    for second in errors.chunk_by(|a, b| a.0 / 1_000_000_000 == b.0 / 1_000_000_000) {
        let mean = second.iter().map(|(_, e)| e).sum::<f64>() / second.len() as f64;
        summary
            .abs_distance_error_by_second_m
            .push((mean * 1000.0).round() / 1000.0);
    }
    Ok(summary)
}
