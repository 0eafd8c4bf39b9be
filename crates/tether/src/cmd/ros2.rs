//! `tether ros2 [--config robot.toml] [--ros-args ...]`: tether as a node on a ROS 2
//! robot's graph, with no ROS installation (a pure-Rust DDS participant).
//!
//! It subscribes to the scans, runs the same loop as `tether run` (the pipeline on every
//! scan and on a 20 Hz timer, its watchdog, a final stop on every exit), and publishes
//! the commands on `cmd_vel` and its results on `tether/...` as the MCAP results name
//! them. Names are relative, so `__ns:=/robot1` puts them all under `/robot1`.
//!
//! | topic | type | QoS |
//! |---|---|---|
//! | `scan` (in) | `sensor_msgs/msg/LaserScan` | best effort, keep last 5 (matches reliable and best-effort publishers) |
//! | `odom` (in) | `nav_msgs/msg/Odometry` (the pose of `child_frame_id` in `header.frame_id`) | best effort, keep last 5 |
//! | `tf` (in) | `tf2_msgs/msg/TFMessage`: `fixed_frame` -> `base_frame`, the base's pose while `odom` is silent | best effort, keep last 5 |
//! | `clock` (in, with `use_sim_time`) | `rosgraph_msgs/msg/Clock` | best effort, keep last 1 |
//! | `tf_static` (in) | `tf2_msgs/msg/TFMessage` (the laser's mount below `base_frame`) | reliable, transient local |
//! | `image_raw` or `image_raw/compressed` (in, when the config has a `[camera]`) | `sensor_msgs/msg/Image` (`mono8`, `rgb8`, `bgr8`) or `sensor_msgs/msg/CompressedImage` (JPEG, PNG) | best effort, keep last 5 |
//! | `detections` (in, with `camera_input:=detections`, and from the simulator) | `vision_msgs/msg/Detection2DArray` (upper-body boxes in pixels of the configured camera) | best effort, keep last 5 |
//! | `cmd_vel` (out) | `geometry_msgs/msg/Twist` (or `TwistStamped`) | reliable, keep last 10 |
//! | `tether/people`, `tether/laser_people` (out) | `geometry_msgs/msg/PoseArray` | reliable, keep last 10 |
//! | `tether/target` (out) | `geometry_msgs/msg/PoseWithCovarianceStamped` | reliable, keep last 10 |
//! | `tether/target_state` (out) | `std_msgs/msg/String` (JSON) | reliable, keep last 10 |
//! | `tether/markers` (out) | `visualization_msgs/msg/MarkerArray` (tracks, ellipses, the target, observations) | reliable, keep last 10 |
//!
//! Parameters (`-p NAME:=VALUE`): `fixed_frame` (default `odom`: the frame of the
//! results), `base_frame` (default `base_link`), `cmd_vel_stamped` (default `false`;
//! `true`: `geometry_msgs/msg/TwistStamped` in `base_frame`, stamped with the time of
//! the scan or timer tick that made the command, as Jazzy's diff-drive controller
//! takes it), `follow_distance` (m, the spring's free length), `attach_ahead` (m, where
//! the spring is attached ahead of the wheel axis), `distance_omega` and `bearing_omega`
//! (rad/s, the natural frequencies of the distance and bearing loops, from which the
//! spring's gains follow), `use_sim_time` (default
//! `false`; `true`: time is the newest `/clock`, `rosgraph_msgs/msg/Clock`, which the
//! node waits for at the start; `--duration` then counts simulated seconds, and a clock
//! that stands still for 1 s stops the robot), `image_transport` (`raw`, the default,
//! or `compressed`), `camera_input` (`images`, the default with a `[camera]`: frames
//! through the cascade; `detections`: boxes from a detector node, whose boxes must be
//! upper-body boxes like the cascade's, since the monocular model reads the range from
//! their top and size), `detection_class` (default `person`: the class of the boxes
//! taken; a box with no hypothesis is taken too; empty: every box).
//!
//! With `--scenario NAME` the node is the robot of `tether sim --scenario NAME --ros2`:
//! its laser mount, follow distance and base limits, and its camera's boxes on
//! `detections` (`--laser-only` for a simulator started with `--laser-only`).
//!
//! The graph: every second the node compares its topics with the publishers and
//! subscribers discovery has found on them, and warns once about each that DDS will not
//! connect (another message type, a QoS that does not match), saying what to change.
//!
//! The camera: frames are taken as they arrive; the detector gets the newest one when
//! it is free (frames it had no time for are counted as superseded, never queued).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::Context;
use tether::ego::EgoMotion;
use tether::live::base::CommandSink;
use tether::live::clock::{LiveClock, MonotonicClock, SimClock};
use tether::live::config::RobotConfig;
use tether::live::ros2::{
    CameraCounters, LatestFrame, OutputTopics, RosOutputs, ScanCounters, start_camera_reader,
    start_clock_reader, start_detections_reader, start_odometry_reader, start_scan_reader,
    start_tf_reader,
};
use tether::live::run_loop::{self, Ending, Input, LoopConfig, Recorder};
use tether::results::TickMessages;
use tether_core::LaserMount;
use tether_io::mcap::{Header, Pose3, TfMessage, TransformStampedMsg};
use tether_io::scip::Clock;
use tether_pipeline::{Pipeline, PipelineConfig};
use tether_ros2::{
    GraphWatcher, NodeIdentity, ParamValue, Received, RosArgs, RosNode, StaticTransforms, qos,
    spawn_reader,
};
use tether_scanmatch::ScanMatcherConfig;

/// Options of `tether ros2`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot's configuration, the same TOML as `tether run` (its `[laser]` needs
    /// only the mount; `[base]` is not used: the commands go to `cmd_vel`). Default: a
    /// TurtleBot 4-sized base (track 0.235 m, radius 0.17 m, 0.3 m/s). Either way the
    /// laser's mount on `/tf_static`, when published, is the one used.
    #[arg(long, value_name = "robot.toml")]
    pub config: Option<PathBuf>,
    /// The robot of a built-in simulated scenario (its laser mount, follow distance and
    /// base limits), to follow `tether sim --scenario NAME --ros2`.
    #[arg(long, value_name = "NAME", conflicts_with = "config")]
    pub scenario: Option<String>,
    /// Follow with the laser alone: the camera of `--config` or of the scenario is not
    /// used (for `tether sim --scenario NAME --ros2 --laser-only`).
    #[arg(long)]
    pub laser_only: bool,
    /// Stop after this many seconds (default: until Ctrl-C or SIGTERM).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Where the robot's motion comes from: `auto` (the `odom` topic once it publishes;
    /// until then, and without it, the dead reckoning of the commands corrected by
    /// matching each scan against the static scene), `scans` (that, even when `odom`
    /// publishes), `odom` (the `odom` topic; dead reckoning of the commands until it
    /// publishes).
    #[arg(long, value_enum, default_value_t = EgoMotion::Auto)]
    pub ego_motion: EgoMotion,
    /// The `--ros-args` block (filled in before clap sees the command line).
    #[arg(skip)]
    pub ros: RosArgs,
}

/// The parameters `tether ros2` reads.
const PARAMETERS: [&str; 11] = [
    "fixed_frame",
    "base_frame",
    "cmd_vel_stamped",
    "image_transport",
    "camera_input",
    "detection_class",
    "follow_distance",
    "attach_ahead",
    "distance_omega",
    "bearing_omega",
    "use_sim_time",
];

/// Where a numeric parameter goes in the pipeline's settings.
type Field = fn(&mut PipelineConfig) -> &mut f64;

/// The follower's numeric parameters: name, what it sets, its unit.
const FOLLOWER_PARAMETERS: [(&str, Field, &str); 4] = [
    (
        "follow_distance",
        |p| &mut p.follower.follow_distance_m,
        "m",
    ),
    ("attach_ahead", |p| &mut p.follower.attach_ahead_m, "m"),
    (
        "distance_omega",
        |p| &mut p.follower.distance_omega_radps,
        "rad/s",
    ),
    (
        "bearing_omega",
        |p| &mut p.follower.bearing_omega_radps,
        "rad/s",
    ),
];

/// Where the camera's people come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CameraInput {
    /// Images on `image_raw` (or `image_raw/compressed`), run through the cascade.
    Images,
    /// Boxes on `detections` (`vision_msgs/msg/Detection2DArray`) from a detector node
    /// or the simulator.
    Detections,
}

/// What the parameters set besides the pipeline.
struct NodeParameters {
    fixed_frame: String,
    /// The robot's frame (the sensors' mounts are looked up in it).
    base_frame: String,
    /// `Some(base_frame)` when the commands go out as `TwistStamped`.
    cmd_vel_stamped: Option<String>,
    /// `image_transport:=compressed`: the camera as `image_raw/compressed`.
    compressed_images: bool,
    /// `use_sim_time:=true`: time from `/clock`.
    use_sim_time: bool,
    /// `camera_input`, when given.
    camera_input: Option<CameraInput>,
    /// `detection_class`: the class of the boxes taken for people (empty: all).
    detection_class: String,
}

/// A TurtleBot 4 (iRobot Create 3 base): what the node assumes without `--config`.
fn turtlebot_pipeline() -> PipelineConfig {
    let mut p = PipelineConfig::default();
    p.limits.track_width_m = 0.235;
    p.limits.max_speed_mps = 0.3;
    p.limits.max_wheel_speed_mps = 0.306;
    p.limits.max_reverse_mps = 0.0;
    p.safety.robot_radius_m = 0.17;
    // Until /tf_static says otherwise: at the centre of the wheel axis, looking ahead.
    p.laser.mount.x_m = 0.0;
    p.laser.mount.y_m = 0.0;
    p.laser.mount.yaw_rad = 0.0;
    p
}

fn frame_parameter(ros: &RosArgs, name: &str, default: &str) -> anyhow::Result<String> {
    match ros.params.get(name) {
        None => Ok(default.to_owned()),
        Some(v) => match v.as_str() {
            Some(f) if !f.is_empty() => Ok(f.to_owned()),
            _ => anyhow::bail!("parameter {name} must be a frame name, got {v:?}"),
        },
    }
}

fn parameters(ros: &RosArgs, pipeline: &mut PipelineConfig) -> anyhow::Result<NodeParameters> {
    for name in ros.params.keys() {
        if !PARAMETERS.contains(&name.as_str()) {
            tracing::warn!(
                "parameter {name} is not one of tether's ({}); ignored",
                PARAMETERS.join(", ")
            );
        }
    }
    let fixed_frame = frame_parameter(ros, "fixed_frame", "odom")?;
    let base_frame = frame_parameter(ros, "base_frame", "base_link")?;
    let stamped = match ros.params.get("cmd_vel_stamped") {
        None => false,
        Some(v) => v.as_bool().ok_or_else(|| {
            anyhow::anyhow!("parameter cmd_vel_stamped must be true or false, got {v:?}")
        })?,
    };
    // The spring: its free length, where it is attached, and its gains as the natural
    // frequencies of the distance and bearing loops (design 6).
    for (name, field, unit) in FOLLOWER_PARAMETERS {
        if let Some(v) = ros.params.get(name) {
            match v.as_f64() {
                Some(x) if x.is_finite() && x > 0.0 => *field(pipeline) = x,
                _ => {
                    anyhow::bail!("parameter {name} must be a positive number in {unit}, got {v:?}")
                }
            }
        }
    }
    let use_sim_time = match ros.params.get("use_sim_time") {
        None => false,
        Some(ParamValue::Bool(b)) => *b,
        Some(v) => anyhow::bail!("parameter use_sim_time must be true or false, got {v:?}"),
    };
    let compressed_images = match ros.params.get("image_transport") {
        None => false,
        Some(v) => match v.as_str() {
            Some("raw") => false,
            Some("compressed") => true,
            _ => anyhow::bail!("parameter image_transport must be raw or compressed, got {v:?}"),
        },
    };
    let camera_input = match ros.params.get("camera_input") {
        None => None,
        Some(v) => Some(match v.as_str() {
            Some("images") => CameraInput::Images,
            Some("detections") => CameraInput::Detections,
            _ => anyhow::bail!("parameter camera_input must be images or detections, got {v:?}"),
        }),
    };
    let detection_class = match ros.params.get("detection_class") {
        None => "person".to_owned(),
        Some(v) => v
            .as_str()
            .ok_or_else(|| {
                anyhow::anyhow!("parameter detection_class must be a class name, got {v:?}")
            })?
            .to_owned(),
    };
    Ok(NodeParameters {
        fixed_frame,
        cmd_vel_stamped: stamped.then(|| base_frame.clone()),
        base_frame,
        compressed_images,
        use_sim_time,
        camera_input,
        detection_class,
    })
}

/// How long the node waits at the start for a scan and its mount on `/tf_static`.
const TF_WAIT: Duration = Duration::from_secs(5);

/// Takes the laser's mount from `/tf_static` (`base_frame` -> the scans' frame) when it
/// is published within [`TF_WAIT`] of the start: the robot's description is what a ROS
/// robot says about itself. Otherwise the config's (or the default) mount stays, with a
/// warning naming the frames. The scans that arrive meanwhile are dropped. Returns the
/// scans' frame when a scan came but no transform to it.
fn mount_from_tf(
    rx: &mpsc::Receiver<Input>,
    transforms: &Mutex<StaticTransforms>,
    base_frame: &str,
    scan_topic: &str,
    mount_given: bool,
    pipeline: &mut PipelineConfig,
) -> Option<String> {
    let started = std::time::Instant::now();
    let mut scan_frame = None;
    while started.elapsed() < TF_WAIT {
        if let Ok(Input::Scan(scan)) = rx.recv_timeout(Duration::from_millis(50)) {
            scan_frame = Some(scan.frame_id);
        }
        let Some(frame) = &scan_frame else {
            continue;
        };
        let tree = transforms.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(pose) = tree.lookup(base_frame, frame) {
            let mount = LaserMount {
                x_m: pose.position_m[0],
                y_m: pose.position_m[1],
                yaw_rad: pose.yaw_rad(),
                height_m: pose.position_m[2],
            };
            let old = pipeline.laser.mount;
            if mount_given
                && ((old.x_m - mount.x_m).hypot(old.y_m - mount.y_m) > 0.01
                    || (old.yaw_rad - mount.yaw_rad).abs() > 0.01)
            {
                tracing::warn!(
                    "the laser's mount in the config ({:.3}, {:.3}, yaw {:.3}) is not the one \
                     on /tf_static; using /tf_static's",
                    old.x_m,
                    old.y_m,
                    old.yaw_rad
                );
            }
            tracing::info!(
                "laser mount from /tf_static: {base_frame} -> {frame} at ({:.3}, {:.3}) m, \
                 yaw {:.3} rad, {:.3} m up",
                mount.x_m,
                mount.y_m,
                mount.yaw_rad,
                mount.height_m
            );
            pipeline.laser.mount = mount;
            return None;
        }
    }
    let m = pipeline.laser.mount;
    let source = if mount_given {
        "the config's"
    } else {
        "the default"
    };
    match &scan_frame {
        Some(frame) => {
            let heard = transforms
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .frames();
            tracing::warn!(
                "no transform from {base_frame} to {frame} on /tf_static within {} s (frames \
                 heard: {}); the laser is taken at {source} mount ({:.3}, {:.3}), yaw {:.3}",
                TF_WAIT.as_secs(),
                if heard.is_empty() {
                    "none".into()
                } else {
                    heard.join(", ")
                },
                m.x_m,
                m.y_m,
                m.yaw_rad
            );
        }
        None => tracing::warn!(
            "no scan on {scan_topic} within {} s; the laser is taken at {source} mount",
            TF_WAIT.as_secs()
        ),
    }
    scan_frame
}

/// The laser's mount as the robot's description: `base_frame` -> `scan_frame` on
/// `/tf_static` (latched), for RViz and other nodes, when the config gives the mount
/// and nobody else publishes it. The publisher must live as long as the node.
fn publish_mount(
    node: &mut RosNode,
    topic: &str,
    base_frame: &str,
    scan_frame: &str,
    mount: LaserMount,
    stamp_ns: i64,
) -> anyhow::Result<ros2_client::dds::Publisher<tether_ros2::Wire<TfMessage>>> {
    let publisher = node.publisher::<TfMessage>(topic, qos::latched(1))?;
    let mut pose = Pose3::planar(mount.x_m, mount.y_m, mount.yaw_rad);
    pose.position_m[2] = mount.height_m;
    let message = TfMessage {
        transforms: vec![TransformStampedMsg {
            header: Header::new(tether_core::Stamp::from_ns(stamp_ns), base_frame),
            child_frame_id: scan_frame.to_owned(),
            transform: pose,
        }],
    };
    publisher
        .publish(tether_ros2::Wire(message))
        .map_err(|e| anyhow::anyhow!("publishing the laser mount on {topic}: {e:?}"))?;
    tracing::info!(
        "published the config's laser mount on {topic}: {base_frame} -> {scan_frame} (nobody \
         else did)"
    );
    Ok(publisher)
}

/// How often the node compares its topics with the graph's.
const GRAPH_CHECK_PERIOD: Duration = Duration::from_secs(1);

/// Warns, once each, about publishers and subscribers on tether's topics that DDS will
/// not connect to it (another type, an incompatible QoS), with the fix; returns how many
/// there were when `stop` fires.
fn watch_graph(
    watcher: GraphWatcher,
    stop: mpsc::Receiver<()>,
) -> anyhow::Result<std::thread::JoinHandle<usize>> {
    std::thread::Builder::new()
        .name("ros2-graph".into())
        .spawn(move || {
            let mut told = std::collections::BTreeSet::new();
            loop {
                for mismatch in watcher.mismatches() {
                    let text = mismatch.to_string();
                    if told.insert(text.clone()) {
                        tracing::warn!("{text}");
                    }
                }
                if !matches!(
                    stop.recv_timeout(GRAPH_CHECK_PERIOD),
                    Err(mpsc::RecvTimeoutError::Timeout)
                ) {
                    return told.len();
                }
            }
        })
        .context("starting the graph thread")
}

/// How long the node waits at the start for `/clock` with `use_sim_time`.
const CLOCK_WAIT: Duration = Duration::from_secs(10);

/// Waits for the first `/clock` (nothing can be stamped before it).
fn wait_for_clock(clock: &SimClock, topic: &str) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    while !clock.started() {
        if started.elapsed() >= CLOCK_WAIT {
            anyhow::bail!(
                "use_sim_time is true but nothing was published on {topic} within {} s: start \
                 the simulator (e.g. `tether sim --scenario corridor --ros2 --use-sim-time`), \
                 or set -p use_sim_time:=false",
                CLOCK_WAIT.as_secs()
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    tracing::info!(
        "sim time from {topic}: {:.3} s",
        clock.now_ns() as f64 * 1e-9
    );
    Ok(())
}

/// Runs the node.
pub fn run(args: Args) -> anyhow::Result<()> {
    let duration = match args.duration {
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e6 => Some(Duration::from_secs_f64(s)),
        Some(s) => anyhow::bail!("--duration must be a positive number of seconds, got {s}"),
        None => None,
    };
    // Until odometry arrives (and with `scans` throughout), the dead reckoning of the
    // commands corrected by scan matching.
    let (scan_odometry, odometry_input) = match args.ego_motion {
        EgoMotion::Auto => (Some(ScanMatcherConfig::default()), true),
        EgoMotion::Scans => (Some(ScanMatcherConfig::default()), false),
        EgoMotion::Odom => (None, true),
        EgoMotion::None => anyhow::bail!(
            "--ego-motion none: a robot that drives cannot be taken to stand still; use \
             scans (the default) or odom (dead reckoning of the commands)"
        ),
    };
    let robot = match &args.config {
        Some(path) => Some(RobotConfig::load_for_ros2(path)?),
        None => None,
    };
    let scenario = match &args.scenario {
        Some(name) => Some(tether_sim::Scenario::resolve(name)?.0),
        None => None,
    };
    let mut pipeline_config = match (&robot, &args.config, &scenario) {
        (Some(robot), Some(path), _) => robot
            .pipeline_config()
            .map_err(|e| anyhow::anyhow!("config {}: {e}", path.display()))?,
        (_, _, Some(scenario)) => {
            tether::closed_loop::config_for(scenario, &PipelineConfig::default())
        }
        _ => turtlebot_pipeline(),
    };
    let NodeParameters {
        fixed_frame,
        base_frame,
        cmd_vel_stamped,
        compressed_images,
        use_sim_time,
        camera_input,
        detection_class,
    } = parameters(&args.ros, &mut pipeline_config)?;
    // The camera is used when the config describes one (its intrinsics, mount and, for
    // images, cascade; its `folder` or `v4l2` is not used) or the scenario's robot has
    // one, unless --laser-only; else the laser alone. The simulator publishes boxes,
    // not images.
    let config_camera = robot.as_ref().and_then(|r| r.camera.clone());
    let scenario_camera = scenario.as_ref().is_some_and(|s| s.camera_sim.enabled);
    let camera = if args.laser_only {
        None
    } else if config_camera.is_some() {
        Some(camera_input.unwrap_or(CameraInput::Images))
    } else if scenario_camera {
        anyhow::ensure!(
            camera_input != Some(CameraInput::Images),
            "camera_input:=images: the simulator publishes its camera's boxes on detections, \
             not images"
        );
        Some(CameraInput::Detections)
    } else {
        None
    };
    // The cascade's settings, for images only.
    let camera_section = config_camera.filter(|_| camera == Some(CameraInput::Images));
    pipeline_config.fusion.use_vision = camera.is_some();
    let mount_given = args.config.is_some() || args.scenario.is_some();
    let domain_id = tether_ros2::domain_id(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?;
    let identity = NodeIdentity {
        name: args
            .ros
            .node_name
            .clone()
            .unwrap_or_else(|| "tether".into()),
        namespace: args.ros.namespace.clone().unwrap_or_else(|| "/".into()),
        domain_id,
    };
    let topic = |name: &str| args.ros.topic(name, &identity.name, &identity.namespace);
    let scan_topic = topic("scan");
    let outputs = OutputTopics {
        cmd_vel: topic("cmd_vel"),
        cmd_vel_stamped,
        results: [
            TickMessages::PEOPLE,
            TickMessages::LASER_PEOPLE,
            TickMessages::VISION_PEOPLE,
            TickMessages::TARGET,
            TickMessages::TARGET_STATE,
            TickMessages::MARKERS,
        ]
        .map(|t| topic(t.trim_start_matches('/'))),
    };
    let pipeline_config_intrinsics = pipeline_config.camera.intrinsics;
    // Checked now, so a bad config fails before the node joins the graph.
    Pipeline::new(pipeline_config.clone(), None)?;

    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C, so the robot could not be stopped cleanly")?;

    let mut node = RosNode::start(identity.clone())?;
    let mut sinks: Vec<Box<dyn CommandSink>> = vec![Box::new(RosOutputs::new(
        &mut node,
        &outputs,
        &fixed_frame,
    )?)];
    let (tx, rx) = mpsc::sync_channel(32);
    let (stop_clock, clock_stops) = mpsc::channel();
    let (clock, clock_reader) = if use_sim_time {
        let sim = SimClock::new();
        let clock_topic = topic("clock");
        let reader = start_clock_reader(
            &mut node,
            &clock_topic,
            sim.clone(),
            tx.clone(),
            clock_stops,
        )?;
        wait_for_clock(&sim, &clock_topic)?;
        (LiveClock::Sim(sim), Some(reader))
    } else {
        (LiveClock::Host(MonotonicClock::new()), None)
    };
    let (stop_reader, reader_stops) = mpsc::channel();
    let counters = Arc::new(ScanCounters::default());
    let odom_topic = topic("odom");
    let (stop_odometry, odometry_stops) = mpsc::channel();
    let odometry_reader = start_odometry_reader(
        &mut node,
        &odom_topic,
        clock.clone(),
        tx.clone(),
        odometry_stops,
        Arc::clone(&counters),
    )?;
    // The base's pose from /tf while odom is silent (fixed_frame -> base_frame).
    let tf_topic = topic("tf");
    let (stop_tf_poses, tf_pose_stops) = mpsc::channel();
    let tf_pose_reader = start_tf_reader(
        &mut node,
        &tf_topic,
        &fixed_frame,
        &base_frame,
        clock.clone(),
        tx.clone(),
        tf_pose_stops,
        Arc::clone(&counters),
    )?;
    let camera_counters = Arc::new(CameraCounters::default());
    let latest = Arc::new(LatestFrame::default());
    let mut camera_threads = Vec::new();
    if camera == Some(CameraInput::Detections) {
        let intrinsics = pipeline_config_intrinsics;
        let detections_topic = topic("detections");
        let (stop_camera, camera_stops) = mpsc::channel();
        camera_threads.push((
            stop_camera,
            start_detections_reader(
                &mut node,
                &detections_topic,
                detection_class.clone(),
                (intrinsics.width_px, intrinsics.height_px),
                clock.clone(),
                tx.clone(),
                camera_stops,
                Arc::clone(&camera_counters),
            )?,
        ));
        tracing::info!(
            "camera: boxes from {detections_topic}{}",
            if detection_class.is_empty() {
                " (every class)".to_owned()
            } else {
                format!(" (class {detection_class:?})")
            }
        );
    }
    if let Some(section) = &camera_section {
        let intrinsics = pipeline_config_intrinsics;
        let mut detector = super::run::camera_detector(section)?;
        let image_topic = topic(if compressed_images {
            "image_raw/compressed"
        } else {
            "image_raw"
        });
        let (stop_camera, camera_stops) = mpsc::channel();
        camera_threads.push((
            stop_camera,
            start_camera_reader(
                &mut node,
                &image_topic,
                compressed_images,
                (intrinsics.width_px, intrinsics.height_px),
                clock.clone(),
                Arc::clone(&latest),
                camera_stops,
                Arc::clone(&camera_counters),
            )?,
        ));
        let frames = Arc::clone(&latest);
        let counters = Arc::clone(&camera_counters);
        let tx = tx.clone();
        let detector_thread = std::thread::Builder::new()
            .name("camera-detector".into())
            .spawn(move || {
                while let Some((stamp, frame)) = frames.take() {
                    let boxes = frame.gray().and_then(|g| detector.boxes(&g, &intrinsics));
                    match boxes {
                        Ok(boxes) => {
                            if tx
                                .send(Input::Camera {
                                    stamp,
                                    boxes,
                                    frame: None,
                                })
                                .is_err()
                            {
                                break;
                            }
                        }
                        Err(e) => {
                            if counters.malformed.fetch_add(1, Ordering::Relaxed) == 0 {
                                tracing::warn!("a camera frame skipped: {e:#}");
                            }
                        }
                    }
                }
            })
            .context("starting the camera detector thread")?;
        let (never, _) = mpsc::channel();
        camera_threads.push((never, detector_thread));
        tracing::info!("camera: {image_topic}");
    }
    let transforms = Arc::new(Mutex::new(StaticTransforms::default()));
    let (stop_tf, tf_stops) = mpsc::channel();
    let tf_reader = {
        let transforms = Arc::clone(&transforms);
        let subscription = node.subscribe::<TfMessage>(&topic("tf_static"), qos::latched(100))?;
        spawn_reader("ros2-tf-static", subscription, tf_stops, move |received| {
            if let Received::Message { message, .. } = received {
                let mut tree = transforms.lock().unwrap_or_else(|e| e.into_inner());
                let skipped = tree.insert(&message);
                if skipped > 0 {
                    tracing::warn!("/tf_static: {skipped} transforms skipped (not a rotation)");
                }
            }
            true
        })
        .context("starting the /tf_static reader")?
    };
    let reader = start_scan_reader(
        &mut node,
        &scan_topic,
        clock.clone(),
        tx,
        reader_stops,
        Arc::clone(&counters),
    )?;
    let (stop_graph, graph_stops) = mpsc::channel::<()>();
    let graph_thread = watch_graph(node.graph_watcher(), graph_stops)?;
    tracing::info!(
        "node {}{}{} on ROS 2 domain {domain_id} ({} graph ids): scans from {scan_topic}, \
         commands to {}, results in {fixed_frame}",
        identity.namespace,
        if identity.namespace.ends_with('/') {
            ""
        } else {
            "/"
        },
        identity.name,
        tether_ros2::DISTRIBUTION,
        outputs.cmd_vel
    );

    let unmounted_frame = mount_from_tf(
        &rx,
        &transforms,
        &base_frame,
        &scan_topic,
        mount_given,
        &mut pipeline_config,
    );
    let mount_publisher = match unmounted_frame {
        Some(frame) if mount_given => Some(publish_mount(
            &mut node,
            &topic("tf_static"),
            &base_frame,
            &frame,
            pipeline_config.laser.mount,
            clock.now_ns(),
        )?),
        _ => None,
    };
    let mut pipeline = Pipeline::new(pipeline_config, None)?;
    let track_width_m = pipeline.config().limits.track_width_m;
    let scan_period_s = pipeline.config().laser.scan_period_s;
    let loop_config = LoopConfig {
        control_period: Duration::from_millis(50),
        duration,
        track_width_m,
        scan_odometry,
        odometry_input,
    };
    let summary = run_loop::run(
        &mut pipeline,
        &clock,
        &rx,
        &mut sinks,
        None::<&mut Recorder<std::io::Cursor<Vec<u8>>>>,
        &stop,
        &loop_config,
        scan_period_s,
    );
    // A reliable writer resends what its readers have not acknowledged: give the final
    // stop time to arrive before the participant goes.
    std::thread::sleep(Duration::from_millis(300));
    let _ = stop_reader.send(());
    let _ = stop_odometry.send(());
    let _ = stop_tf_poses.send(());
    let _ = stop_tf.send(());
    let _ = stop_clock.send(());
    let _ = stop_graph.send(());
    drop(rx);
    latest.close();
    for (stop, _) in &camera_threads {
        let _ = stop.send(());
    }
    let threads = [
        ("scan", reader),
        ("odometry", odometry_reader),
        ("tf", tf_pose_reader),
        ("tf_static", tf_reader),
    ]
    .into_iter()
    .chain(clock_reader.map(|t| ("clock", t)))
    .chain(camera_threads.into_iter().map(|(_, t)| ("camera", t)));
    for (name, thread) in threads {
        if thread.join().is_err() {
            tracing::error!("the {name} thread panicked");
        }
    }
    let graph_problems = graph_thread.join().unwrap_or_else(|_| {
        tracing::error!("the graph thread panicked");
        0
    });
    drop(sinks);
    drop(mount_publisher);
    drop(node);
    let load = |c: &std::sync::atomic::AtomicU64| c.load(Ordering::Relaxed);
    tracing::info!(
        "{}: {} scans ({} dropped while the loop was behind, {} stamped on arrival, {} \
         malformed samples), {} odometry messages used ({} refused, {} scans skipped on \
         stale odometry), {} base poses from {tf_topic}, {} ticks ({} with a target)",
        summary.ending.name(),
        load(&counters.delivered),
        load(&counters.dropped),
        load(&counters.restamped),
        load(&counters.malformed),
        summary.odometry_messages,
        load(&counters.odometry_refused),
        summary.skipped_stale_odometry,
        load(&counters.tf_poses),
        summary.ticks,
        summary.ticks_with_target,
    );
    if let LiveClock::Sim(sim) = &clock {
        tracing::info!(
            "sim time: ended at {:.3} s, {} stalls of the clock, {} clock messages that went \
             back (ignored)",
            sim.now_ns() as f64 * 1e-9,
            summary.clock_stalls,
            sim.backward_jumps()
        );
    }
    match camera {
        Some(CameraInput::Images) => tracing::info!(
            "camera: {} frames received, {} processed, {} superseded by a newer frame \
             before the detector got to them, {} refused for their size, {} malformed",
            load(&camera_counters.received),
            summary.frames,
            load(&camera_counters.superseded),
            load(&camera_counters.wrong_size),
            load(&camera_counters.malformed),
        ),
        Some(CameraInput::Detections) => tracing::info!(
            "camera: {} detection messages received, {} processed, {} dropped while the \
             loop was behind, {} malformed; {} boxes refused (not finite, not positive or \
             outside the image), {} of another class",
            load(&camera_counters.received),
            summary.frames,
            load(&camera_counters.superseded),
            load(&camera_counters.malformed),
            load(&camera_counters.bad_boxes),
            load(&camera_counters.other_class),
        ),
        None => {}
    }
    tracing::info!("{}", summary.target.one_line(pipeline.selector().stats()));
    if graph_problems > 0 {
        tracing::warn!(
            "{graph_problems} mismatches with the graph's topics were reported above (types \
             or QoS that DDS does not connect)"
        );
    }
    let mut problems: Vec<String> = summary
        .final_stop_failures
        .iter()
        .map(|(o, e)| format!("the final stop to {o} failed: {e}"))
        .collect();
    match &summary.ending {
        Ending::Duration | Ending::Interrupted => {}
        Ending::OutputFailed { output, error } => {
            problems.insert(0, format!("publishing on {output} failed: {error}"));
        }
        other => problems.insert(0, format!("the run ended: {}", other.name())),
    }
    if problems.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "{}; a final stop was published where it still could be",
            problems.join("; ")
        )
    }
}
