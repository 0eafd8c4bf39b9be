//! `tether replay`: the per-tick pipeline of the simulator and the live robot, run over
//! a recording (MCAP or ROS 1 bag); writes what tether saw and would have commanded as
//! ROS 2 messages in an MCAP file, and an HTML report.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use tether::ego::{EgoMotion, PoseSource, ScanOdometry};
use tether::plot::{Plot, Series};
use tether::recording::{self, Sample, Topics};
use tether::report::simple_page;
use tether::results::ResultWriter;
use tether::target_log::TargetLog;
use tether_core::{Pose2, Robot, Stamp, World};
use tether_fusion::TargetStats;
use tether_pipeline::{Pipeline, Tick};
use tether_scanmatch::{MotionPrior, ScanMatcherConfig};
use tether_sim::svg::xml_escape;

use super::track::{Camera, CameraArgs};

/// Options of `tether replay`.
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
    /// The camera frames' detector.
    #[command(flatten)]
    pub detector: CameraArgs,
    /// Where to write the results (MCAP, ROS 2 messages): `/tether/people` (PoseArray of
    /// confirmed tracks), `/tether/target` (PoseWithCovarianceStamped, while locked),
    /// `/tether/cmd_vel` (Twist, every tick), `/tether/laser_people` and
    /// `/tether/vision_people` (PoseArray, per scan and per camera frame). The report
    /// goes beside it, with the extension `.html`.
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

/// Everything the report needs, gathered while replaying.
#[derive(Default)]
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
}

impl Summary {
    fn record(&mut self, tick: &Tick, world_from_robot: Pose2<World, Robot>) {
        let start = *self.start.get_or_insert(tick.stamp);
        self.target
            .record(tick.stamp, &tick.target.state, &tick.refusals);
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

    /// A top view of the tracks' trails and the robot's path, as SVG.
    fn map_svg(&self) -> String {
        let all = self
            .trails
            .values()
            .flatten()
            .chain(self.robot_path.iter())
            .copied();
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in all {
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(y);
            y1 = y1.max(y);
        }
        if x0 > x1 {
            return String::from("<p>No tracks.</p>");
        }
        let span = (x1 - x0).max(y1 - y0).max(1.0);
        let (size, pad) = (560.0, 20.0);
        let k = (size - 2.0 * pad) / span;
        let px = |x: f64, y: f64| (pad + (x - x0) * k, size - pad - (y - y0) * k);
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{size}\" height=\"{size}\" \
             viewBox=\"0 0 {size} {size}\"><rect width=\"100%\" height=\"100%\" fill=\"#fafafa\"/>"
        );
        let palette = [
            "#1f77b4", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf",
        ];
        let path = |pts: &[(f64, f64)]| {
            pts.iter()
                .map(|&(x, y)| {
                    let (u, v) = px(x, y);
                    format!("{u:.1},{v:.1}")
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        for (i, (id, pts)) in self.trails.iter().enumerate() {
            let target = self.target_ids.contains(id);
            let color = if target {
                "#d62728"
            } else {
                palette[i % palette.len()]
            };
            let width = if target { 2.5 } else { 1.2 };
            let _ = write!(
                s,
                "<polyline fill=\"none\" stroke=\"{color}\" stroke-width=\"{width}\" points=\"{}\"><title>track {id}</title></polyline>",
                path(pts)
            );
        }
        let _ = write!(
            s,
            "<polyline fill=\"none\" stroke=\"#333\" stroke-dasharray=\"4 3\" points=\"{}\"><title>robot</title></polyline>",
            path(&self.robot_path)
        );
        let _ = write!(
            s,
            "<text x=\"{pad}\" y=\"14\" font-size=\"12\">{:.1} m across; red: the target's tracks, dashed: the robot</text></svg>",
            span
        );
        s
    }

    fn html(&self, recording: &Path, frame: &str, counts: TargetStats) -> String {
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
        let sections = vec![
            ("Map".to_string(), self.map_svg()),
            (
                "Target: locks, losses and why".to_string(),
                self.target.html(counts),
            ),
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
    let config = super::track::load_config(args.config.as_ref())?;
    let mut camera = match &args.image_topic {
        Some(_) => Some(Camera::new(&args.detector)?),
        None => None,
    };
    let mut config = config;
    config.fusion.use_vision = camera.is_some();
    let intrinsics = config.camera.intrinsics;
    let source = args
        .ego_motion
        .resolve(args.odom_topic.is_some())
        .map_err(anyhow::Error::msg)?;
    let mut scan_odometry = (source == PoseSource::Scans).then(|| {
        ScanOdometry::new(
            ScanMatcherConfig::default(),
            config.laser.robot_from_laser(),
        )
    });
    let mut pipeline = Pipeline::new(config, None)?;
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
    let mut summary = Summary::default();
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
                    let people = tether::ego::moving_people(pipeline.tracker().tracks());
                    pose = Some(odometry.update(&scan, MotionPrior::ConstantVelocity, people));
                }
                let Some(p) = pose else {
                    summary.waiting_for_odom += 1;
                    return Ok(());
                };
                (pipeline.on_scan(&scan, p), p)
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
        summary.record(&tick, world_from_robot);
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
        std::fs::write(&report, summary.html(&args.recording, frame, target_counts))
            .with_context(|| format!("writing {}", report.display()))?;
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
