//! `tether eval-track`: the pipeline over an annotated recording, measured against its
//! labels (CLEAR MOT and the target measures; see `tether_eval::track_eval`).

use std::path::PathBuf;

use anyhow::Context;
use tether_eval::track_eval::{EvalOptions, LabelsFrame, Pairing, PoseLabels, TrackEval};
use tether_live::pipeline_file;
use tether_live::recording_run::{Options, Step, run_recording};
use tether_recording::samples::Topics;

/// Options of `tether eval-track`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The annotated recording: a ROS 1 bag or an MCAP file.
    pub recording: PathBuf,
    /// The `sensor_msgs/LaserScan` topic.
    #[arg(long, value_name = "TOPIC")]
    pub scan_topic: String,
    /// The labels: `leg_tracker/PersonArray` (an id and a pose per person, in the
    /// scan's frame), `leg_tracker/Person` (one labelled person a message, no header,
    /// as Leigh et al.'s benchmark recordings: every Person message between scan k and
    /// scan k+1 belongs to scan k, whatever `--pairing` says) or
    /// `geometry_msgs/PoseArray` (positions in the scan's frame).
    #[arg(long, value_name = "TOPIC")]
    pub labels_topic: String,
    /// A `nav_msgs/Odometry` topic: the robot's motion (the laser mount of `--config`
    /// then places the scans on the robot). Without it the sensor is taken as still.
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Where the robot's motion comes from when no odometry topic is given: `auto` or
    /// `scans` (matching each scan against the static scene, the people being tracked
    /// left out), `none` (the sensor is taken as still).
    #[arg(long, value_enum, default_value_t = tether::ego_motion::EgoMotion::Auto)]
    pub ego_motion: tether::ego_motion::EgoMotion,
    /// The labelled person the robot should follow (default: the only label id, when
    /// the labels have one).
    #[arg(long, value_name = "ID")]
    pub target_label: Option<u32>,
    /// Which scan a label message belongs to. auto: a label stamped like the scan just
    /// before it goes to that scan; a label with a zero stamp goes to the next scan
    /// (leg_tracker's extracted training bags); any other to the nearer in stamp of the
    /// scans before and after it. before: the next scan; after: the previous scan.
    #[arg(long, value_enum, default_value_t = Pairing::Auto)]
    pub pairing: Pairing,
    /// PoseArray labels are the legs of one person (at their mean), or people.
    #[arg(long, value_enum, default_value_t = PoseLabels::Legs)]
    pub pose_labels: PoseLabels,
    /// The frame of the labels: the scan's, or the world (the odometry frame with
    /// `--odom-topic`), as `/truth/people` of `tether sim --record` is.
    #[arg(long, value_enum, default_value_t = LabelsFrame::Scan)]
    pub labels_frame: LabelsFrame,
    /// A gap between labelled scans longer than this starts a new stretch, s.
    #[arg(long, default_value_t = 0.5, value_name = "S")]
    pub gap_s: f64,
    /// A pipeline configuration (TOML; every table optional).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// Also write the figures as JSON.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
}

/// Runs the evaluation.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.gap_s.is_finite() && args.gap_s > 0.0,
        "--gap-s must be a positive number of seconds, got {}",
        args.gap_s
    );
    let mut config =
        pipeline_file::load_for_recording(args.config.as_deref(), args.odom_topic.is_some())?;
    config.fusion.use_vision = false;
    args.leg_model.apply(&mut config);
    let (_, mut poses) = args
        .ego_motion
        .for_recording(args.odom_topic.is_some(), &config)
        .map_err(anyhow::Error::msg)?;
    let mut pipeline = tether_live::leg_model::pipeline(config)?;
    let topics = Topics {
        scan: args.scan_topic.clone(),
        images: Vec::new(),
        odom: args.odom_topic.clone(),
    };
    let mut eval = TrackEval::new(EvalOptions {
        pairing: args.pairing,
        pose_labels: args.pose_labels,
        labels_frame: args.labels_frame,
        target_label: args.target_label,
        gap_s: args.gap_s,
    });
    let counts = run_recording(
        &args.recording,
        &topics,
        Options {
            labels_topic: Some(&args.labels_topic),
            ..Options::default()
        },
        &mut pipeline,
        None,
        &mut poses,
        &mut |step| {
            match step {
                Step::Scan(s) => eval.on_scan(&s),
                Step::Labels(l) => eval.on_labels(l),
                Step::Camera(_) | Step::Timer(_) => {}
            }
            Ok(())
        },
    )?;
    let skipped = counts.read.bad_messages + counts.read.unattributed;
    if let Some(odometry) = poses.scan_odometry() {
        tracing::info!("{}", odometry.summary());
    }
    if skipped > 0 {
        tracing::warn!("{skipped} messages could not be decoded and were skipped");
    }
    if counts.waiting_for_odom > 0 {
        tracing::warn!(
            "{} scans came before the first odometry message and were not used",
            counts.waiting_for_odom
        );
    }
    let report = eval.finish();
    anyhow::ensure!(
        report.labelled_scans > 0,
        "no scan of {} got a label from {} ({} label messages): check the topics and --pairing",
        args.scan_topic,
        args.labels_topic,
        report.label_messages
    );
    tether::outln!("{}", report.text().trim_end())?;
    if let Some(path) = &args.json {
        std::fs::write(path, serde_json::to_string_pretty(&report)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
