//! `tether replay`: the per-tick pipeline of the simulator and the live robot, run over
//! a recording (MCAP or ROS 1 bag); writes what tether saw and would have commanded as
//! ROS 2 messages in an MCAP file, and an HTML report (its pictures and track table are
//! drawn by [`tether::replay_report`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::Context;
use tether::ego_motion::{EgoMotion, PoseSource};
use tether::plot::{Plot, Series};
use tether::recording::{self, Sample, Topics};
use tether::replay_report::{
    Chosen, Snapshot, SnapshotPicker, TrackSeen, TrackTable, leg_detector, overview_svg,
    snapshots_html,
};
use tether::report::simple_page;
use tether_core::{Gaussian2, Laser, LaserScan, Pose2, Robot, Stamp, World};
use tether_fusion::tracker::Track;
use tether_fusion::{TargetState, TargetStats};
use tether_laser::LegDetector;
use tether_live::pipeline_file;
use tether_live::results::ResultWriter;
use tether_live::target_log::TargetLog;
use tether_pipeline::Tick;
use tether_scanmatch::MotionPrior;
use tether_sim::svg::xml_escape;

use super::track::CameraArgs;

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
    #[arg(long, value_name = "TOPIC")]
    pub image_topic: Option<String>,
    /// A `nav_msgs/Odometry` topic: the robot's motion. Without it the motion comes
    /// from the scans (see `--ego-motion`).
    #[arg(long, value_name = "TOPIC")]
    pub odom_topic: Option<String>,
    /// Where the robot's motion comes from: `auto` (the odometry topic if given, else
    /// scan matching), `odom`, `scans` (even with odometry), `none` (the robot stands
    /// still; positions in its own frame).
    #[arg(long, value_enum, default_value_t = EgoMotion::Auto)]
    pub ego_motion: EgoMotion,
    /// A pipeline configuration (TOML; every table optional).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: super::leg_model::LegModelArg,
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

/// What the report shows of one tick.
struct TickRow {
    t_s: f64,
    target_range_m: Option<f64>,
    target_bearing_rad: Option<f64>,
    v_mps: f64,
    w_radps: f64,
    tracks: usize,
}

/// The last scan replayed, with the robot's pose at it and its laser people: what a
/// snapshot draws (a loss on a camera frame draws the scan before it).
struct LastScan {
    index: usize,
    scan: LaserScan,
    world_from_robot: Pose2<World, Robot>,
    laser_people: Vec<Gaussian2<World>>,
}

impl LastScan {
    /// A snapshot of this scan with the tick's tracks and target.
    fn snapshot(
        &self,
        tick: &Tick,
        start: Stamp,
        robot_from_laser: Pose2<Robot, Laser>,
        chosen: Chosen,
    ) -> Snapshot {
        Snapshot {
            t_s: tick.stamp.secs_since(start),
            stamp: tick.stamp,
            scan_index: self.index,
            chosen,
            scan: self.scan.clone(),
            world_from_robot: self.world_from_robot,
            robot_from_laser,
            laser_people: self.laser_people.clone(),
            tracks: tick.tracks.clone(),
            target: tick.target.state,
            target_estimate: tick.target.estimate,
        }
    }
}

/// Everything the report needs, gathered while replaying.
struct Summary {
    scans: usize,
    frames: usize,
    boxes: usize,
    odom: usize,
    waiting_for_odom: usize,
    ticks: Vec<TickRow>,
    trails: BTreeMap<u64, Vec<(f64, f64)>>,
    robot_path: Vec<(f64, f64)>,
    target_ids: Vec<u64>,
    start: Option<Stamp>,
    target: TargetLog,
    robot_from_laser: Pose2<Robot, Laser>,
    /// Scans that reached the pipeline (with a pose).
    scans_replayed: usize,
    last_scan: Option<LastScan>,
    snapshots: SnapshotPicker,
    track_table: TrackTable,
    lost: bool,
}

impl Summary {
    fn new(robot_from_laser: Pose2<Robot, Laser>) -> Self {
        Summary {
            scans: 0,
            frames: 0,
            boxes: 0,
            odom: 0,
            waiting_for_odom: 0,
            ticks: Vec::new(),
            trails: BTreeMap::new(),
            robot_path: Vec::new(),
            target_ids: Vec::new(),
            start: None,
            target: TargetLog::new(),
            robot_from_laser,
            scans_replayed: 0,
            last_scan: None,
            snapshots: SnapshotPicker::new(),
            track_table: TrackTable::new(),
            lost: false,
        }
    }

    /// A scan went through the pipeline: it is the last scan, and perhaps one of the
    /// evenly spaced snapshots.
    fn scan(&mut self, scan: LaserScan, world_from_robot: Pose2<World, Robot>, tick: &Tick) {
        let start = *self.start.get_or_insert(tick.stamp);
        let index = self.scans_replayed;
        self.scans_replayed += 1;
        let last = LastScan {
            index,
            scan,
            world_from_robot,
            laser_people: tick.laser_people.clone(),
        };
        let robot_from_laser = self.robot_from_laser;
        self.snapshots.scan(index, || {
            last.snapshot(tick, start, robot_from_laser, Chosen::Evenly)
        });
        self.last_scan = Some(last);
    }

    fn record(&mut self, tick: &Tick, world_from_robot: Pose2<World, Robot>, tracks: &[Track]) {
        let start = *self.start.get_or_insert(tick.stamp);
        self.target.record_tick(tick);
        let lost = matches!(tick.target.state, TargetState::Lost { .. });
        if let (TargetState::Lost { reason, .. }, false, Some(last)) =
            (tick.target.state, self.lost, &self.last_scan)
        {
            let robot_from_laser = self.robot_from_laser;
            self.snapshots
                .loss(|| last.snapshot(tick, start, robot_from_laser, Chosen::Loss(reason)));
        }
        self.lost = lost;
        let seen: Vec<TrackSeen> = tracks.iter().map(TrackSeen::of).collect();
        self.track_table.update(
            tick.stamp,
            matches!(tick.input, tether_pipeline::TickInput::Scan),
            &seen,
            tick.target.state.locked_track(),
        );
        let robot = world_from_robot.translation();
        self.robot_path.push((robot.x, robot.y));
        let target = tick
            .target
            .state
            .locked_track()
            .zip(tick.target.estimate)
            .map(|(id, e)| {
                if self.target_ids.last() != Some(&id) {
                    self.target_ids.push(id);
                }
                world_from_robot.inverse() * e.mean
            });
        for t in tick.tracks.iter().filter(|t| t.confirmed) {
            self.trails
                .entry(t.id)
                .or_default()
                .push((t.position.mean.x, t.position.mean.y));
        }
        self.ticks.push(TickRow {
            t_s: tick.stamp.secs_since(start),
            target_range_m: target.map(|p| p.range_m()),
            target_bearing_rad: target.map(|p| p.bearing_rad()),
            v_mps: tick.command.v_mps,
            w_radps: tick.command.w_radps,
            tracks: tick.tracks.iter().filter(|t| t.confirmed).count(),
        });
    }

    fn series(&self, label: &str, color: &str, f: impl Fn(&TickRow) -> Option<f64>) -> Series {
        Series {
            label: label.into(),
            color: color.into(),
            dashed: false,
            points: self.ticks.iter().map(|r| (r.t_s, f(r))).collect(),
        }
    }

    fn html(
        &mut self,
        recording: &Path,
        frame: &str,
        counts: TargetStats,
        detector: &mut LegDetector,
    ) -> String {
        let duration = self.ticks.last().map_or(0.0, |r| r.t_s);
        let locked = self
            .ticks
            .windows(2)
            .filter(|w| w[0].target_range_m.is_some())
            .map(|w| w[1].t_s - w[0].t_s)
            .sum::<f64>();
        let intro = format!(
            "<p>Replay of <code>{}</code>: {} scans, {} camera frames ({} detections), {} \
             odometry messages over {duration:.1} s; positions in <code>{}</code>. \
             {} people tracked; a target locked for {locked:.1} s (track ids {:?}).</p>",
            xml_escape(&recording.display().to_string()),
            self.scans,
            self.frames,
            self.boxes,
            self.odom,
            xml_escape(frame),
            self.trails.len(),
            self.target_ids
        );
        let target = Plot {
            title: "Target relative to the robot".into(),
            y_label: "range m / bearing rad".into(),
            series: vec![
                self.series("range (m)", "#d62728", |r| r.target_range_m),
                self.series("bearing (rad)", "#1f77b4", |r| r.target_bearing_rad),
            ],
            ..Plot::default()
        };
        let commands = Plot {
            title: "Commands tether would have sent".into(),
            y_label: "m/s, rad/s".into(),
            series: vec![
                self.series("v (m/s)", "#2ca02c", |r| Some(r.v_mps)),
                self.series("w (rad/s)", "#9467bd", |r| Some(r.w_radps)),
            ],
            ..Plot::default()
        };
        let tracks = Plot {
            title: "Confirmed tracks".into(),
            y_label: "count".into(),
            series: vec![self.series("tracks", "#333", |r| Some(r.tracks as f64))],
            ..Plot::default()
        };
        let snapshots = std::mem::take(&mut self.snapshots).finish(self.scans_replayed);
        let start = self.start.unwrap_or(Stamp::ZERO);
        let sections = vec![
            (
                "Map".to_string(),
                overview_svg(&self.trails, &self.robot_path, &self.target_ids, frame),
            ),
            (
                "Snapshots".to_string(),
                snapshots_html(&snapshots, detector, frame),
            ),
            (
                "Target: locks, losses and why".to_string(),
                tether::report::target_html(&self.target, counts),
            ),
            ("Tracks".to_string(), self.track_table.html(start)),
            (
                "Over time".to_string(),
                [target, commands, tracks]
                    .iter()
                    .map(|p| format!("<div class=\"figure\">{}</div>", p.svg()))
                    .collect::<String>(),
            ),
        ];
        simple_page("tether replay", &intro, &sections)
    }
}

/// Replays the recording.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = pipeline_file::load(args.config.as_deref())?;
    let mut camera = match &args.image_topic {
        Some(_) => Some(super::track::camera(&args.detector)?),
        None => None,
    };
    let mut config = config;
    config.fusion.use_vision = camera.is_some();
    args.leg_model.apply(&mut config);
    let intrinsics = config.camera.intrinsics;
    let (source, mut scan_odometry) = args
        .ego_motion
        .for_recording(args.odom_topic.is_some(), config.laser.robot_from_laser())
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
        image: args.image_topic.clone(),
        odom: args.odom_topic.clone(),
    };
    let mut pose: Option<Pose2<World, Robot>> =
        (source != PoseSource::Odometry).then_some(Pose2::IDENTITY);
    let mut summary = Summary::new(pipeline.config().laser.robot_from_laser());
    let stats = recording::read(&args.recording, &topics, &mut |sample| {
        let (tick, world_from_robot) = match sample {
            Sample::Odom {
                world_from_robot, ..
            } => {
                summary.odom += 1;
                if source == PoseSource::Odometry {
                    pose = Some(world_from_robot);
                }
                return Ok(());
            }
            Sample::Scan(scan) => {
                summary.scans += 1;
                if let Some(odometry) = scan_odometry.as_mut() {
                    let people = tether_live::ego::moving_people(pipeline.tracker().tracks());
                    pose = Some(odometry.update(&scan, MotionPrior::ConstantVelocity, people));
                }
                let Some(p) = pose else {
                    summary.waiting_for_odom += 1;
                    return Ok(());
                };
                let tick = pipeline.on_scan(&scan, p);
                summary.scan(scan, p, &tick);
                (tick, p)
            }
            Sample::Camera { stamp, image } => {
                summary.frames += 1;
                let (Some(camera), Some(p)) = (camera.as_mut(), pose) else {
                    return Ok(());
                };
                let boxes = camera.boxes(&image, &intrinsics)?;
                summary.boxes += boxes.len();
                (pipeline.on_camera_boxes(stamp, &boxes, p), p)
            }
        };
        summary.record(&tick, world_from_robot, pipeline.tracker().tracks());
        if let Some(out) = output.as_mut() {
            out.write_tick(&tick)?;
        }
        Ok(())
    })?;
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
    if let Some(odometry) = &scan_odometry {
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
        let mut detector = leg_detector(pipeline.config())?;
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
