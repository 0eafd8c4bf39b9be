//! `tether replay`: the per-tick pipeline of the simulator and the live robot, run over
//! a recording (MCAP or ROS 1 bag); writes what tether saw and would have commanded as
//! ROS 2 messages in an MCAP file, and an HTML report (its pictures and track table are
//! drawn by [`tether_report::replay_report`]).

use std::path::PathBuf;

use anyhow::Context;
use tether::ego_motion::EgoMotion;
use tether_core::GrayImage;
use tether_live::control_timer::CONTROL_PERIOD;
use tether_live::pipeline_file;
use tether_live::recording_run::{CameraBoxes, Options, Step, run_recording};
use tether_live::results::ResultWriter;
use tether_recording::samples::Topics;
use tether_report::replay_report::ReplaySummary;

use tether::args::CameraArgs;

/// Options of `tether replay`.
// Parallel to track's Args on purpose: the options are alike, but each command's help
// says what they mean for it (and their defaults and order differ).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: an MCAP file (ROS 2) or a ROS 1 bag.
    pub recording: PathBuf,
    /// The `sensor_msgs/LaserScan` topic.
    #[arg(long, default_value = "/scan", value_name = "TOPIC")]
    pub scan_topic: String,
    /// A camera topic (`sensor_msgs/Image` mono8/rgb8/bgr8 or `CompressedImage`
    /// JPEG/PNG): its frames go through the Haar cascade and the monocular model.
    /// Repeat it for each camera: a frame goes through the model of the camera its
    /// header's frame names (`[[extra_cameras]]`, or a robot config's `[[camera]]`;
    /// any other frame is the first camera's).
    #[arg(long, value_name = "TOPIC")]
    pub image_topic: Vec<String>,
    /// A `nav_msgs/Odometry` topic: the robot's motion. Without it the motion comes
    /// from the scans (see `--ego-motion`).
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Where the robot's motion comes from: `auto` (the odometry topic if given, else
    /// scan matching), `odom`, `scans` (even with odometry), `none` (the robot stands
    /// still; positions in its own frame), `commands` (a recording of `tether run`: the
    /// robot drove tether's commands, so their dead reckoning corrected by scan
    /// matching, as the live loop kept it; the replay then sends the live run's
    /// commands).
    #[arg(long, value_enum, default_value_t = EgoMotion::Auto)]
    pub ego_motion: EgoMotion,
    /// A pipeline configuration (TOML; every table optional).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// The camera frames' detector.
    #[command(flatten)]
    pub detector: CameraArgs,
    /// Where to write the results (MCAP, ROS 2 messages): `/tether/people` (PoseArray of
    /// confirmed tracks), `/tether/target` (PoseWithCovarianceStamped, while locked),
    /// `/tether/cmd_vel` (Twist, every tick), `/tether/laser_people` and
    /// `/tether/vision_people` (PoseArray, per scan and per camera frame). The report
    /// goes beside it, with the extension `.html`: a map, snapshots of the scan with
    /// the legs, people, tracks and target at chosen instants, the target's locks and
    /// losses, a table of the tracks, and plots over time.
    #[arg(long, value_name = "RESULT.mcap")]
    pub out: Option<PathBuf>,
}

/// Replays the recording.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = pipeline_file::load(args.config.as_deref())?;
    let mut camera = match args.image_topic.is_empty() {
        false => Some(tether::args::camera(&args.detector)?),
        true => None,
    };
    let mut config = config;
    config.fusion.use_vision = camera.is_some();
    args.leg_model.apply(&mut config);
    let (source, mut poses) = args
        .ego_motion
        .for_recording(args.odom_topic.is_some(), &config)
        .map_err(anyhow::Error::msg)?;
    let mut pipeline = tether_live::leg_model::pipeline(config)?;
    let frame = source.frame();
    let mut output = match &args.out {
        Some(path) => Some(
            // Replaces an earlier result only if this replay succeeds.
            tether::output::AtomicFile::create(path)
                .map_err(anyhow::Error::from)
                .and_then(|f| Ok(ResultWriter::new(std::io::BufWriter::new(f), frame)?))
                .with_context(|| format!("cannot create {}", path.display()))?,
        ),
        None => None,
    };
    let topics = Topics {
        scan: args.scan_topic.clone(),
        images: args.image_topic.clone(),
        odom: args.odom_topic.clone(),
    };
    let mut summary = ReplaySummary::new(pipeline.config().laser.robot_from_laser());
    let mut boxes = camera
        .as_mut()
        .map(|c| move |image: &GrayImage, intrinsics: &_| Ok(c.boxes(image, intrinsics)?));
    let counts = run_recording(
        &args.recording,
        &topics,
        Options {
            labels_topic: None,
            ..Options::default()
        },
        &mut pipeline,
        boxes.as_mut().map(|b| b as &mut CameraBoxes<'_>),
        &mut poses,
        &mut |step| {
            let (tick, world_from_robot, tracks) = match step {
                Step::Scan(s) => {
                    summary.scan(s.scan.clone(), s.world_from_robot, s.tick);
                    (s.tick, s.world_from_robot, s.tracks)
                }
                Step::Camera(c) => {
                    summary.boxes += c.boxes;
                    (c.tick, c.world_from_robot, c.tracks)
                }
                Step::Timer(t) => (t.tick, t.world_from_robot, t.tracks),
                Step::Labels(_) => return Ok(()),
            };
            summary.record(tick, world_from_robot, tracks);
            if let Some(out) = output.as_mut() {
                out.write_tick(tick)?;
            }
            Ok(())
        },
    )?;
    let stats = counts.read;
    summary.scans = counts.scans_read;
    summary.frames = counts.camera_frames_read;
    summary.odom = counts.odom;
    summary.waiting_for_odom = counts.scans_read - counts.scans;
    if stats.bad_messages + stats.unattributed > 0 {
        tracing::warn!(
            "{} messages could not be decoded and were skipped, {} records had no topic",
            stats.bad_messages,
            stats.unattributed
        );
    }
    if summary.waiting_for_odom > 0 {
        tracing::warn!(
            "{} scans came before the first odometry message and were not used",
            summary.waiting_for_odom
        );
    }
    tracing::info!(
        "{} timer ticks ({} ms); {} data stamped before the tick before them, processed at \
         its time (as on the robot)",
        counts.timer_ticks,
        CONTROL_PERIOD.as_millis(),
        counts.clamped
    );
    if let Some(odometry) = poses.scan_odometry() {
        tracing::info!("{}", odometry.summary());
    }
    let ps = pipeline.stats();
    let target_counts = pipeline.selector().stats();
    if ps.out_of_order_ticks > 0 {
        tracing::warn!(
            "{} inputs arrived out of order and were kept out of the tracks",
            ps.out_of_order_ticks
        );
    }
    if let (Some(out), Some(path)) = (output, &args.out) {
        out.finish()
            .map_err(anyhow::Error::from)
            .and_then(|w| {
                w.into_inner()
                    .map_err(std::io::IntoInnerError::into_error)?
                    .commit()?;
                Ok(())
            })
            .with_context(|| format!("writing {}", path.display()))?;
        let report = path.with_extension("html");
        let config = pipeline.config();
        let mut detector = tether_live::leg_model::detector(&config.legs, &config.laser)?;
        let html = summary.html(&args.recording, frame, target_counts, &mut detector);
        std::fs::write(&report, html).with_context(|| format!("writing {}", report.display()))?;
        tether::outln!(
            "results -> {}, report -> {}",
            path.display(),
            report.display()
        )?;
    }
    tether::outln!(
        "{} scans, {} camera frames ({} detections), {} odometry messages: {} people tracked, \
         target track ids {:?}; {}",
        summary.scans,
        summary.frames,
        summary.boxes,
        summary.odom,
        summary.trails.len(),
        summary.target_ids,
        summary.target.one_line(target_counts)
    )?;
    Ok(())
}
