//! `tether track`: detection, fusion and tracking over a recording, one JSON line per
//! scan message.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;
use tether::args::{CameraArgs, camera};
use tether_core::GrayImage;
use tether_live::pipeline_file;
use tether_live::recording_run::{CameraBoxes, Options, ScanStep, Step, run_recording};
use tether_live::results::TargetStateLine;
use tether_live::target_log::TargetLog;
use tether_recording::samples::Topics;

/// Options of `tether track`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: a ROS 1 bag (chunks uncompressed, bz2 or lz4) or an MCAP file
    /// (ROS 2).
    pub bag: PathBuf,
    /// The `sensor_msgs/LaserScan` topic, e.g. `/scan`.
    #[arg(long)]
    pub scan_topic: String,
    /// A camera topic (`sensor_msgs/Image` in mono8, rgb8 or bgr8, or
    /// `sensor_msgs/CompressedImage` in JPEG or PNG): its frames go through the cascade
    /// detector and the monocular model (`[camera]` of `--config`: intrinsics, and the
    /// mount taken relative to the laser) and are fused with the scans. Repeat it for
    /// each camera: a frame goes through the model of the camera its header's frame
    /// names (`[[extra_cameras]]`; any other frame is the first camera's). Without it
    /// the run is laser only.
    #[arg(long, value_name = "TOPIC")]
    pub image_topic: Vec<String>,
    /// The camera frames' detector.
    #[command(flatten)]
    pub detector: CameraArgs,
    /// A pipeline configuration (TOML; every table optional: `[legs]`, `[tracker]`,
    /// `[target]`, `[laser.noise]`...).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// A `nav_msgs/Odometry` topic: the robot's motion (the laser mount of `--config`
    /// then places the scans on the robot). Without it, `--ego-motion` says where the
    /// motion comes from.
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Where the robot's motion comes from when no odometry topic is given: `auto` or
    /// `scans` (matching each scan against the static scene, the people being tracked
    /// left out), `none` (the sensor is taken as still).
    #[arg(long, value_enum, default_value_t = tether::ego_motion::EgoMotion::Auto)]
    pub ego_motion: tether::ego_motion::EgoMotion,
    /// Where to write one JSON line per scan message (`-`: standard output).
    #[arg(long, value_name = "FILE.jsonl")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct PersonLine {
    id: u64,
    x: f64,
    y: f64,
    vx: f64,
    vy: f64,
    cov: [f64; 4],
}

#[derive(Serialize)]
struct Line<'a> {
    stamp_ns: i64,
    frame: &'a str,
    people: Vec<PersonLine>,
    target: Option<u64>,
    /// Locked, lost (and why) or searching, and the candidates refused; with the
    /// transition of a tick of the control timer since the last scan, if any.
    target_state: TargetStateLine,
    /// The robot's pose in the odometry frame (`--odom-topic`), in the frame of the
    /// first scan (scan matching), or the origin (`--ego-motion none`).
    robot_pose: PoseLine,
}

#[derive(Serialize)]
struct PoseLine {
    x: f64,
    y: f64,
    yaw: f64,
}

/// Runs the pipeline over the recording's scans (and camera frames, with
/// `--image-topic`), in log order ([`tether_live::recording_run::run_recording`]), with the
/// robot's motion from `--odom-topic`, scan matching or none (`--ego-motion`).
/// Positions and velocities come out in the scan's frame.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config =
        pipeline_file::load_for_recording(args.config.as_deref(), args.odom_topic.is_some())?;
    args.leg_model.apply(&mut config);
    let mut camera = match args.image_topic.is_empty() {
        false => Some(camera(&args.detector)?),
        true => None,
    };
    config.fusion.use_vision = camera.is_some();
    let (_, mut poses) = args
        .ego_motion
        .for_recording(args.odom_topic.is_some(), &config)
        .map_err(anyhow::Error::msg)?;
    let laser_from_robot = config.laser.robot_from_laser().inverse();
    let mut pipeline = tether_live::leg_model::pipeline(config)?;
    let topics = Topics {
        scan: args.scan_topic.clone(),
        images: args.image_topic.clone(),
        odom: args.odom_topic.clone(),
    };
    // Replaces an earlier result only if this run succeeds; `-` is stdout.
    let mut out = tether::output::Output::create(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let to_stdout = out.is_stdout();
    let (mut scans, mut with_target) = (0usize, 0usize);
    let mut ids = std::collections::BTreeSet::new();
    let mut target_log = TargetLog::new();
    // A transition of the lock at a tick of the control timer since the last scan: said
    // on the next scan's line.
    let mut transition_between = None;
    let mut boxes = camera
        .as_mut()
        .map(|c| move |image: &GrayImage, intrinsics: &_| Ok(c.boxes(image, intrinsics)?));
    let counts = run_recording(
        &args.bag,
        &topics,
        Options {
            labels_topic: None,
            ..Options::default()
        },
        &mut pipeline,
        boxes.as_mut().map(|b| b as &mut CameraBoxes<'_>),
        &mut poses,
        &mut |step| {
            let (scan, tick, world_from_robot) = match step {
                Step::Scan(ScanStep {
                    scan,
                    tick,
                    world_from_robot,
                    ..
                }) => (scan, tick, world_from_robot),
                Step::Timer(t) => {
                    target_log.record_tick(t.tick);
                    transition_between = t.tick.transition.map(|t| t.name()).or(transition_between);
                    return Ok(());
                }
                Step::Camera(_) | Step::Labels(_) => return Ok(()),
            };
            // Positions and velocities in the scan's frame, whatever the robot's motion.
            let scan_from_world = laser_from_robot * world_from_robot.inverse();
            let people: Vec<PersonLine> = tick
                .tracks
                .iter()
                .filter(|t| t.confirmed)
                .map(|t| {
                    ids.insert(t.id);
                    let p = t.position.transformed(scan_from_world);
                    let v = scan_from_world.rotate(t.velocity);
                    PersonLine {
                        id: t.id,
                        x: p.mean.x,
                        y: p.mean.y,
                        vx: v.x,
                        vy: v.y,
                        cov: p.cov.to_array(),
                    }
                })
                .collect();
            let target = tick.target.state.locked_track();
            with_target += usize::from(target.is_some());
            let line = Line {
                stamp_ns: scan.stamp.ns(),
                frame: &scan.frame_id,
                people,
                target,
                target_state: {
                    let mut state = TargetStateLine::of(tick);
                    state.transition = state.transition.or(transition_between.take());
                    state
                },
                robot_pose: PoseLine {
                    x: world_from_robot.x,
                    y: world_from_robot.y,
                    yaw: world_from_robot.yaw,
                },
            };
            target_log.record_tick(tick);
            serde_json::to_writer(&mut out, &line)?;
            out.write_all(b"\n")?;
            scans += 1;
            Ok(())
        },
    )?;
    let skipped = counts.read.bad_messages + counts.read.unattributed;
    if let Some(odometry) = poses.scan_odometry() {
        tracing::info!("{}", odometry.summary());
    }
    out.commit()
        .with_context(|| format!("writing {}", args.out.display()))?;
    let stats = pipeline.stats();
    if skipped > 0 {
        tracing::warn!("{skipped} messages could not be decoded and were skipped");
    }
    if stats.out_of_order_ticks > 0 {
        tracing::warn!(
            "{} scans were stamped before one already processed (out of order): they were \
             kept out of the tracks",
            stats.out_of_order_ticks
        );
    }
    if stats.malformed_beams > 0 {
        tracing::warn!(
            "{} beams were NaN or negative (a sensor's error codes): read as no return",
            stats.malformed_beams
        );
    }
    let frames = camera.as_ref().map_or(String::new(), |c| {
        format!(", {} camera frames with {} detections", c.frames, c.boxes)
    });
    let summary = format!(
        "{scans} scans{frames}, {} people tracked, a target in {with_target} scans -> {}",
        ids.len(),
        if to_stdout {
            "stdout".to_string()
        } else {
            args.out.display().to_string()
        }
    );
    let target = target_log.one_line(pipeline.selector().stats());
    if to_stdout {
        // stdout holds the results: the summary goes with the log.
        tracing::info!("{summary}");
        tracing::info!("{target}");
    } else {
        tether::outln!("{summary}")?;
        tether::outln!("{target}")?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use tether_pipeline::PipelineConfig;

    /// [`pipeline_file::load`] of `text` written to a file of its own.
    fn load_text(text: &str) -> anyhow::Result<PipelineConfig> {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let path = std::env::temp_dir().join(format!(
            "tether-track-config-{}-{n}.toml",
            std::process::id()
        ));
        std::fs::write(&path, text).unwrap();
        let config = pipeline_file::load(Some(&path));
        let _ = std::fs::remove_file(&path);
        Ok(config?)
    }

    /// A config that loads makes a pipeline or an error naming the part, never a panic.
    fn check(text: &str) {
        if let Ok(config) = load_text(text) {
            match tether_live::leg_model::pipeline(config) {
                Ok(_) => {}
                Err(e) => assert!(e.to_string().starts_with("invalid "), "{e}"),
            }
        }
    }

    /// `tether config defaults` with the comments out: every table and key, shorter.
    fn defaults() -> &'static str {
        static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
        TEXT.get_or_init(|| {
            let (text, _) = tether_live::config_docs::annotated_defaults().unwrap();
            text.lines()
                .filter(|l| !l.starts_with('#') && !l.is_empty())
                .map(|l| format!("{l}\n"))
                .collect()
        })
    }

    #[test]
    fn the_defaults_load_and_make_a_pipeline() {
        let config = load_text(defaults()).unwrap();
        assert_eq!(config, PipelineConfig::default());
        assert!(tether_live::leg_model::pipeline(config).is_ok());
        assert!(load_text("[limits]\nmax_speed_mps = \"fast\"\n").is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// Arbitrary text, and TOML-like lines of the pipeline's tables and keys.
        #[test]
        fn arbitrary_text_is_refused_or_read_without_a_panic(
            text in "\\PC{0,160}|(\\[(robot|laser|legs|tracker|limits|safety|target|fusion)\\]\n([a-z_]{1,12} = (-?[0-9.e]{1,8}|true|\"[a-z]{0,6}\"|inf|nan)\n){0,4}){0,4}",
        ) {
            check(&text);
        }

        /// The defaults with characters changed, inserted or removed anywhere.
        #[test]
        fn damaged_defaults_are_refused_or_make_a_pipeline(
            edits in proptest::collection::vec(
                (any::<prop::sample::Index>(), prop::sample::select(
                    vec![' ', '\n', '=', '[', ']', '.', '"', '-', '0', '9', 'e', 'x', '#'],
                ), 0u8..3),
                1..6,
            ),
        ) {
            let mut text: Vec<char> = defaults().chars().collect();
            tether_testkit::damage(&mut text, edits);
            check(&text.into_iter().collect::<String>());
        }
    }
}
