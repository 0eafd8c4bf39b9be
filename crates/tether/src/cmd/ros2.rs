//! `tether ros2 [--config robot.toml] [--ros-args ...]`: tether as a node on a ROS 2
//! robot's graph, with no ROS installation (a pure-Rust DDS participant).
//!
//! It subscribes to the scans, runs the same loop as `tether run` (the pipeline on every
//! scan and on a 20 Hz timer, its watchdog, a final stop on every exit), and publishes
//! the commands on `cmd_vel` and its results on `tether/...` as the MCAP results name
//! them. The runtime, with the node's topics, their types and QoS, is
//! `tether_live::ros2`; this command reads the options and the parameters, starts it,
//! and says how the run went.
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
//! taken; a box with no hypothesis is taken too; empty: every box), `target_frame`
//! (default `target`: the target's frame on `/tf`, a child of `fixed_frame`, while it is
//! locked), `publish_cmd_vel` (default `true`; `false`: no `cmd_vel` publisher at all,
//! for Nav2's Following Server to drive from `tether/target_pose` or the target's frame),
//! `cmd_vel_guard` (default `true`: a guard process publishes zero commands when the
//! node is killed or frozen; design 12, 13), `extra_scan_topics` (default none: the scan
//! topics of more scanners, e.g. `"[rear/scan]"`; each is a laser of its own, at the
//! configuration's `[[extra_lasers]]` entry of its frame or at its mount on
//! `/tf_static`; design 5.7), `extra_camera_topics` (default `FRAME/image_raw`,
//! `FRAME/image_raw/compressed` or `FRAME/detections` of each further `[[camera]]` of
//! `--config`: one topic per further camera, read like the first, its boxes through its
//! own model). A `--params-file` sets them as well.
//!
//! With `--scenario NAME` the node is the robot of `tether sim --scenario NAME --ros2`:
//! its laser mount, follow distance and base limits, its extra lasers' scans on
//! `FRAME/scan`, its camera's boxes on `detections` and its extra cameras' on
//! `FRAME/detections` (`--laser-only` for a simulator started with `--laser-only`).

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use tether::ego_motion::EgoMotion;
use tether_live::Ending;
use tether_live::clock::LiveClock;
use tether_live::config::RobotConfig;
use tether_live::node_params::{self, Sets};
use tether_live::ros2::{NodeCamera, NodeSettings, run_node};
use tether_pipeline::PipelineConfig;
use tether_ros2::{NodeIdentity, ParamValue, RosArgs};
use tether_scip::Clock;

/// Options of `tether ros2`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot's configuration, the same TOML as `tether run` (its `[laser]` needs
    /// only the mount; `[base]` is not used: the commands go to `cmd_vel`). Default: a
    /// TurtleBot 4-sized base (track 0.235 m, radius 0.17 m, 0.3 m/s). Either way the
    /// laser's mount on `/tf_static`, when published, is the one used.
    #[arg(long, value_name = "robot.toml")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
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
    /// The commands go out as `TwistStamped` in `base_frame`.
    cmd_vel_stamped: bool,
    /// `publish_cmd_vel`: commands on `cmd_vel` (false: none, Nav2 drives).
    publish_cmd_vel: bool,
    /// `cmd_vel_guard`: the guard process beside the node.
    cmd_vel_guard: bool,
    /// `target_frame`: the target's frame on `/tf`.
    target_frame: String,
    /// `image_transport:=compressed`: the camera as `image_raw/compressed`.
    compressed_images: bool,
    /// `use_sim_time:=true`: time from `/clock`.
    use_sim_time: bool,
    /// `camera_input`, when given.
    camera_input: Option<CameraInput>,
    /// `detection_class`: the class of the boxes taken for people (empty: all).
    detection_class: String,
    /// `extra_scan_topics`, when given.
    extra_scan_topics: Option<Vec<String>>,
    /// `extra_camera_topics`, when given.
    extra_camera_topics: Option<Vec<String>>,
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

fn bool_parameter(ros: &RosArgs, name: &str, default: bool) -> anyhow::Result<bool> {
    match ros.params.get(name) {
        None => Ok(default),
        Some(v) => v
            .as_bool()
            .ok_or_else(|| anyhow::anyhow!("parameter {name} must be true or false, got {v:?}")),
    }
}

fn parameters(ros: &RosArgs, pipeline: &mut PipelineConfig) -> anyhow::Result<NodeParameters> {
    for name in ros.params.keys() {
        if node_params::param(name).is_none() {
            tracing::warn!(
                "parameter {name} is not one of tether's ({}); ignored",
                node_params::names()
            );
        }
    }
    let fixed_frame = frame_parameter(ros, "fixed_frame", "odom")?;
    let base_frame = frame_parameter(ros, "base_frame", "base_link")?;
    let stamped = bool_parameter(ros, "cmd_vel_stamped", false)?;
    let publish_cmd_vel = bool_parameter(ros, "publish_cmd_vel", true)?;
    let cmd_vel_guard = bool_parameter(ros, "cmd_vel_guard", true)?;
    let target_frame = frame_parameter(ros, "target_frame", "target")?;
    // A frame that is already in the tree would give it a second parent, or a loop.
    anyhow::ensure!(
        target_frame != fixed_frame && target_frame != base_frame,
        "parameter target_frame ({target_frame}) must be a frame of its own, not the fixed \
         frame ({fixed_frame}) or the base's ({base_frame})"
    );
    // The spring: its free length, where it is attached, and its gains as the natural
    // frequencies of the distance and bearing loops (design 6).
    for p in node_params::NODE_PARAMS {
        if let (Sets::Pipeline { .. }, Some(v)) = (p.sets, ros.params.get(p.name)) {
            anyhow::ensure!(
                v.as_f64().is_some(),
                "parameter {} must be a number in {}, got {v:?}",
                p.name,
                p.unit()
            );
            node_params::set_pipeline(pipeline, p.name, v.as_f64()).map_err(anyhow::Error::msg)?;
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
    let extra_scan_topics = topic_list(ros, "extra_scan_topics", "rear/scan", &["scan"])?;
    let extra_camera_topics = topic_list(
        ros,
        "extra_camera_topics",
        "rear_camera/detections",
        &["image_raw", "image_raw/compressed", "detections"],
    )?;
    Ok(NodeParameters {
        fixed_frame,
        base_frame,
        cmd_vel_stamped: stamped,
        publish_cmd_vel,
        cmd_vel_guard,
        target_frame,
        compressed_images,
        use_sim_time,
        camera_input,
        detection_class,
        extra_scan_topics,
        extra_camera_topics,
    })
}

/// The list of topics of the parameter `name`, when given (`example`: one for the
/// message): each names a topic, none of them `first` (the first sensor's).
fn topic_list(
    ros: &RosArgs,
    name: &str,
    example: &str,
    first: &[&str],
) -> anyhow::Result<Option<Vec<String>>> {
    let topics = match ros.params.get(name) {
        None => return Ok(None),
        Some(ParamValue::StringArray(topics)) => topics.clone(),
        Some(ParamValue::String(topic)) => vec![topic.clone()],
        Some(v) => anyhow::bail!(
            "parameter {name} must be a list of topics, e.g. \"[{example}]\", got {v:?}"
        ),
    };
    for t in &topics {
        let bare = t.trim_matches('/');
        anyhow::ensure!(
            !bare.is_empty() && !first.contains(&bare),
            "parameter {name}: {t:?} is not another sensor's topic"
        );
    }
    Ok(Some(topics))
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
    let (with_scans, odometry_input) = match args.ego_motion {
        EgoMotion::Auto => (true, true),
        EgoMotion::Scans | EgoMotion::Commands => (true, false),
        EgoMotion::Odom => (false, true),
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
            tether_eval::closed_loop::config_for(scenario, &PipelineConfig::default())
        }
        _ => turtlebot_pipeline(),
    };
    args.leg_model.apply(&mut pipeline_config);
    // The scan matcher's settings are the configuration's (`[pipeline.scan_matcher]`).
    let scan_odometry = with_scans.then(|| pipeline_config.scan_matcher.clone());
    let NodeParameters {
        fixed_frame,
        base_frame,
        cmd_vel_stamped,
        publish_cmd_vel,
        cmd_vel_guard,
        target_frame,
        compressed_images,
        use_sim_time,
        camera_input,
        detection_class,
        extra_scan_topics,
        extra_camera_topics,
    } = parameters(&args.ros, &mut pipeline_config)?;
    // The simulator publishes an extra laser's scans on `FRAME/scan`.
    let extra_scan_topics = extra_scan_topics.unwrap_or_else(|| {
        pipeline_config
            .extra_lasers
            .iter()
            .map(|l| format!("{}/scan", l.frame_id))
            .collect()
    });
    // The camera is used when the config describes one (its intrinsics, mount and, for
    // images, cascade; its `folder` or `v4l2` is not used) or the scenario's robot has
    // one, unless --laser-only; else the laser alone. The simulator publishes boxes,
    // not images.
    let cameras = robot.as_ref().and_then(|r| r.camera.as_ref());
    let config_camera = cameras.map(|c| (**c).clone());
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
    let node_camera = match camera {
        Some(CameraInput::Images) => camera_section.map(|section| NodeCamera::Images {
            section: Box::new(section),
            compressed: compressed_images,
        }),
        Some(CameraInput::Detections) => Some(NodeCamera::Detections {
            class: detection_class,
        }),
        None => None,
    };
    // Without a camera the further ones go too (a camera would count as seeing what it
    // never sends).
    if node_camera.is_none() {
        pipeline_config.extra_cameras.clear();
    }
    let extra_cameras = tether_live::ros2::cameras::extra_cameras(
        node_camera.as_ref(),
        extra_camera_topics,
        &pipeline_config,
        cameras.map_or(&[], |c| c.extra()),
    )?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C, so the robot could not be stopped cleanly")?;
    let settings = NodeSettings {
        identity,
        ros: args.ros,
        pipeline: pipeline_config,
        fixed_frame,
        base_frame,
        cmd_vel_stamped,
        publish_cmd_vel,
        cmd_vel_guard,
        target_frame,
        use_sim_time,
        camera: node_camera,
        extra_cameras,
        mount_given,
        duration,
        scan_odometry,
        odometry_input,
        extra_scan_topics,
    };
    let report = run_node(settings, &stop)?;
    summarize(&report, camera)
}

/// Says how the node's run went; an error when it did not end in order (an output or a
/// final stop failed).
fn summarize(
    report: &tether_live::ros2::NodeReport,
    camera: Option<CameraInput>,
) -> anyhow::Result<()> {
    let (summary, counters, camera_counters) = (&report.summary, &report.scans, &report.camera);
    let tf_topic = &report.tf_topic;
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
    for extra in &report.extra_scans {
        let frames = extra.frames();
        tracing::info!(
            "{}: {} scans taken{} ({} of another frame skipped)",
            extra.topic,
            load(&extra.taken),
            if frames.is_empty() {
                " (the topic was not used)".to_owned()
            } else {
                format!(" for laser {}", frames.join(", "))
            },
            load(&extra.other_frame),
        );
    }
    if let LiveClock::Sim(sim) = &report.clock {
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
    for (topic, frame_id, c) in &report.extra_cameras {
        tracing::info!(
            "camera {frame_id:?} ({topic}): {} messages received, {} superseded or dropped \
             while the detector or the loop was behind, {} refused for their size, {} \
             malformed, {} boxes refused, {} of another class",
            load(&c.received),
            load(&c.superseded),
            load(&c.wrong_size),
            load(&c.malformed),
            load(&c.bad_boxes),
            load(&c.other_class),
        );
    }
    tracing::info!(
        "{}",
        summary.target.one_line(report.pipeline.selector().stats())
    );
    tracing::info!("{}", summary.holds.one_line());
    if report.graph_problems > 0 {
        tracing::warn!(
            "{} mismatches with the graph's topics were reported above (types \
             or QoS that DDS does not connect)",
            report.graph_problems
        );
    }
    let mut problems: Vec<String> = summary
        .final_stop_failures
        .iter()
        .map(|(o, e)| format!("the final stop to {o} failed: {e}"))
        .collect();
    if load(&counters.delivered) == 0 && summary.ending.is_clean() {
        problems.insert(
            0,
            format!(
                "no scan arrived on {} in the whole run: is something publishing it on \
                 this ROS_DOMAIN_ID and network, under that name (remap it with --ros-args \
                 -r scan:=/your/scan)?",
                report.scan_topic
            ),
        );
    }
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
