//! `tether sim`: run a scenario and write its sensor data, ground truth, a picture and,
//! with tether's pipeline driving, the measures of the run.

use std::path::PathBuf;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether_core::Stamp;
use tether_eval::closed_loop::{self, RunError};
use tether_eval::metrics::measure;
#[cfg(feature = "ros2")]
use tether_eval::ros2_sim::SimTime;
use tether_live::pipeline_file;
use tether_live::results::ResultWriter;
use tether_msgs::{Header, LaserScanMsg, OdometryMsg, PersonArrayMsg, PersonMsg, Pose3};
use tether_pipeline::Tick;
use tether_recording::mcap::McapError;
use tether_recording::rosbag::{BagWriteError, BagWriter, ConnectionId};
use tether_sim::record::{RunRecorder, RunSummary};
use tether_sim::{Event, Scenario, SensorData, Simulation, StaticWorld, run_to_dir};

/// Who drives the simulated robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DriverChoice {
    /// tether's full pipeline (laser legs, camera model, fusion, tracking, spring,
    /// safety), with laser-only and vision-only pipelines riding along for comparison;
    /// writes `metrics.json` and the demo's `report.html` for the run.
    Tether,
    /// The scenario's own `robot.driver` (still, scripted, or the ground-truth oracle).
    Scenario,
}

/// Options of `tether sim`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in scenario name (see `tether scenarios`) or a scenario .toml file.
    #[arg(long)]
    pub scenario: String,
    /// Seed of every random draw; the same scenario and seed give identical files.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Simulated time in seconds (default: the scenario's own duration).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Who drives the robot.
    #[arg(long, value_enum, default_value_t = DriverChoice::Tether)]
    pub driver: DriverChoice,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also record the run (tether driving) as ROS 2 messages in an MCAP file, for
    /// `tether replay` and Foxglove: `/scan` (LaserScan), `/odom` (Odometry, perfect),
    /// `/truth/people` (PoseArray), the pipeline's `/tether/...` topics (tracks,
    /// observations, target, commands; see `tether_live::results`).
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<PathBuf>,
    /// The camera off: the simulated camera is not run and tether's laser-only
    /// pipeline drives the robot alone (no passengers); the run is named
    /// `NAME-laser-only`, as in `tether demo`.
    #[arg(long)]
    pub laser_only: bool,
    /// The ideal laser (`[laser_sim] realistic = false`): no phantoms, weak legs or
    /// dark spells.
    #[arg(long)]
    pub ideal_laser: bool,
    /// Put this scanner of `tether scanners` on the robot (its geometry, rate, range,
    /// noise, no-returns and mount height replace the scenario's).
    #[arg(long, value_name = "NAME")]
    pub scanner: Option<String>,
    /// A pipeline configuration for tether's pipeline (TOML, every table optional: the
    /// keys of `tether config defaults`, or a robot file of `tether run`, whose
    /// pipeline keys are taken). The scenario's robot keeps its own laser, camera,
    /// follow distance, wheel limits and radius. Only with `--driver tether`.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// Also write the run as a ROS 1 bag in leg_tracker's annotation format, for
    /// `tether eval-track` and any other tracker: `/scan` (sensor_msgs/LaserScan, frame
    /// `laser`), `/odom` (nav_msgs/Odometry, perfect; see `--bag-without-odom`) and
    /// `/people_truth` (leg_tracker/PersonArray, frame `laser`, stamped like the scan and
    /// recorded right after it): the people at least one beam of the scan hits, with
    /// their simulated ids (the target's id is printed; it is the scenario's person
    /// marked `target`). An extra laser's scans go on `/FRAME/scan` (frame `FRAME`).
    #[arg(long, value_name = "FILE.bag")]
    pub record_bag: Option<PathBuf>,
    /// Put the simulated robot on the ROS 2 graph, in real time: `/scan` and `/odom` out,
    /// `/cmd_vel` in (follow it with `tether ros2 --scenario NAME`); writes
    /// `OUT/ros2_run.json` with how well it followed.
    #[arg(long, conflicts_with_all = ["record", "record_bag", "driver"])]
    pub ros2: bool,
    /// With `--ros2`: publish the simulated time on `/clock` (`rosgraph_msgs/msg/Clock`,
    /// from 0) and stamp everything with it, as Gazebo does for nodes with
    /// `use_sim_time:=true` (`tether ros2 --ros-args -p use_sim_time:=true`).
    #[arg(long, requires = "ros2")]
    pub use_sim_time: bool,
    /// With `--ros2`: take the commands as `geometry_msgs/msg/TwistStamped` (Jazzy's
    /// diff-drive controller's type; `tether ros2 --ros-args -p cmd_vel_stamped:=true`) instead of
    /// `Twist`.
    #[arg(long, requires = "ros2")]
    pub cmd_vel_stamped: bool,
    /// With `--use-sim-time`: run this many times faster than real time (1 to 10).
    #[arg(
        long,
        value_name = "X",
        default_value_t = 1.0,
        requires = "use_sim_time"
    )]
    pub rate: f64,
    /// Leave `/odom` out of `--record-bag` (a recording without odometry).
    #[arg(long, requires = "record_bag")]
    pub bag_without_odom: bool,
}

/// Writes a simulated run as a ROS 1 bag (see `--record-bag`).
struct BagRecorder {
    writer: BagWriter<std::io::BufWriter<std::fs::File>>,
    scan: ConnectionId,
    /// `/FRAME/scan` of each extra laser, by frame.
    extra_scans: Vec<(String, ConnectionId)>,
    odom: Option<ConnectionId>,
    people: ConnectionId,
    seq: u32,
    /// The first write error; nothing more is written after it.
    error: Option<BagWriteError>,
    target_id: Option<u32>,
}

/// The frame of the recorded scans and labels.
const BAG_LASER_FRAME: &str = "laser";

impl BagRecorder {
    fn create(
        path: &std::path::Path,
        with_odom: bool,
        extra_frames: &[String],
    ) -> Result<Self, BagWriteError> {
        let mut writer = BagWriter::create(path)?;
        let odom = if with_odom {
            Some(writer.add_connection::<OdometryMsg>("/odom")?)
        } else {
            None
        };
        let scan = writer.add_connection::<LaserScanMsg>("/scan")?;
        let mut extra_scans = Vec::new();
        for frame in extra_frames {
            let topic = format!("/{frame}/scan");
            extra_scans.push((
                frame.clone(),
                writer.add_connection::<LaserScanMsg>(&topic)?,
            ));
        }
        let people = writer.add_connection::<PersonArrayMsg>("/people_truth")?;
        Ok(BagRecorder {
            writer,
            scan,
            extra_scans,
            odom,
            people,
            seq: 0,
            error: None,
            target_id: None,
        })
    }

    fn record(&mut self, event: &Event) {
        if self.error.is_none()
            && let Err(e) = self.try_record(event)
        {
            self.error = Some(e);
        }
    }

    /// Per scan: odometry (so that a reader knows the pose at the scan), the scan, then
    /// the people it sees in the laser frame, `p_laser = laser_from_world * p_world`,
    /// heading less the laser's yaw, recorded 1 us after the scan.
    fn try_record(&mut self, event: &Event) -> Result<(), BagWriteError> {
        // The labels are the first laser's (leg_tracker's bags label one scanner);
        // another laser's scans go on their own topic, unlabelled.
        let Some(scan) = event.data.first_laser_scan() else {
            if let SensorData::Scan(scan) = &event.data
                && let Some((_, id)) = self.extra_scans.iter().find(|(f, _)| *f == scan.frame_id)
            {
                let raw = tether_msgs::RawLaserScan::from_scan(self.seq, scan, 0.1 / 1024.0, 0.1);
                self.writer.write(*id, scan.stamp, &raw)?;
            }
            return Ok(());
        };
        let truth = &event.truth;
        let stamp = scan.stamp;
        if let Some(odom) = self.odom {
            let msg = OdometryMsg::planar(
                Header::new(stamp, "odom"),
                "base_link",
                truth.world_from_robot,
                truth.robot_velocity.v_mps,
                truth.robot_velocity.w_radps,
            );
            self.writer.write(odom, stamp, &msg)?;
        }
        let mut scan = scan.clone();
        scan.frame_id = BAG_LASER_FRAME.to_string();
        let raw = tether_msgs::RawLaserScan::from_scan(self.seq, &scan, 0.1 / 1024.0, 0.1);
        self.writer.write(self.scan, stamp, &raw)?;
        let laser_from_world = truth.world_from_laser.inverse();
        let people = truth
            .people
            .iter()
            .filter(|p| p.laser_beams.is_some_and(|b| b > 0))
            .map(|p| {
                let q = laser_from_world * p.position;
                PersonMsg {
                    pose: Pose3::planar(q.x, q.y, p.heading_rad - truth.world_from_laser.yaw),
                    id: p.id,
                }
            })
            .collect();
        if let Some(t) = truth.target() {
            self.target_id = Some(t.id);
        }
        let msg = PersonArrayMsg {
            header: Header {
                seq: self.seq,
                stamp,
                frame_id: BAG_LASER_FRAME.to_string(),
            },
            people,
        };
        self.writer
            .write(self.people, Stamp::from_ns(stamp.ns() + 1_000), &msg)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// Finishes the bag; the target's id, if the scenario has a target.
    fn finish(self) -> Result<Option<u32>, BagWriteError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        self.writer.finish()?;
        Ok(self.target_id)
    }
}

/// Writes a simulated event (odometry and ground truth first, then the sensor data, so
/// that a replay knows the robot's pose at each scan) and the driving pipeline's tick.
/// A scenario without odometry (`[robot] odometry = false`) records no `/odom`, as a
/// robot without odometry would.
fn record_event(
    out: &mut ResultWriter<std::io::BufWriter<std::fs::File>>,
    event: &Event,
    tick: Option<&Tick>,
    with_odometry: bool,
) -> Result<(), McapError> {
    let truth = &event.truth;
    let stamp = truth.stamp;
    if !matches!(event.data, SensorData::Timer) {
        if with_odometry {
            let odom = OdometryMsg::planar(
                Header::new(stamp, out.frame()),
                "base_link",
                truth.world_from_robot,
                truth.robot_velocity.v_mps,
                truth.robot_velocity.w_radps,
            );
            out.mcap().write("/odom", stamp, &odom)?;
        }
        let people = out.poses(
            stamp,
            truth.people.iter().map(|p| (p.position.x, p.position.y)),
        );
        out.mcap().write("/truth/people", stamp, &people)?;
    }
    if let SensorData::Scan(scan) = &event.data {
        // URG-04LX timing: 100 ms a turn of 1,024 steps. The first laser on `/scan`,
        // an extra one on `/FRAME/scan`.
        let msg = LaserScanMsg::new(scan.clone(), 0.1 / 1024.0, 0.1);
        let topic = match event.data.first_laser_scan() {
            Some(_) => "/scan".to_owned(),
            None => format!("/{}/scan", scan.frame_id),
        };
        out.mcap().write(&topic, stamp, &msg)?;
    }
    if let Some(tick) = tick {
        out.write_tick(tick)?;
    }
    Ok(())
}

fn progress_bar(name: &str) -> ProgressBar {
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {percent}% ({elapsed} < {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating {name}"));
    bar
}

/// `--driver tether`: tether's pipeline drives the simulated robot (the closed loop of
/// [`closed_loop::run_observed`]); the run's files, `metrics.json`, `report.html` and,
/// when asked, its MCAP recording, and every event to the bag.
fn run_tether(
    args: &Args,
    scenario: &Scenario,
    source: &str,
    base: &tether_pipeline::PipelineConfig,
    bag: &mut Option<BagRecorder>,
    show: &dyn Fn(i64),
) -> anyhow::Result<RunSummary> {
    let context = || format!("simulating `{}` into {}", scenario.name, args.out.display());
    let (mut driver, mut passengers) = if args.laser_only {
        closed_loop::laser_only_variants_from(scenario, base)
    } else {
        closed_loop::variants_from(scenario, base)
    };
    args.leg_model
        .apply_all(std::iter::once(&mut driver).chain(&mut passengers));
    // A configuration the pipeline refuses is refused before anything is written.
    for config in std::iter::once(&driver).chain(&passengers) {
        tether_live::leg_model::pipeline(config.clone())
            .context("tether's pipeline refuses this configuration")?;
    }
    let with_odometry = scenario.odometry_available();
    let mut recorder = RunRecorder::create(&args.out, scenario, args.seed).with_context(context)?;
    let mut mcap = match &args.record {
        Some(path) => Some(
            ResultWriter::create(path, "odom")
                .with_context(|| format!("cannot create {}", path.display()))?,
        ),
        None => None,
    };
    let log = closed_loop::run_observed(
        scenario,
        args.seed,
        &driver,
        &passengers,
        &[],
        &mut |event, tick| {
            show(event.truth.stamp.ns());
            if let Some(out) = mcap.as_mut() {
                record_event(out, event, tick, with_odometry)?;
            }
            if let Some(bag) = bag.as_mut() {
                bag.record(event);
            }
            recorder.record(event).map_err(RunError::from)
        },
    )
    .with_context(context)?;
    if let (Some(out), Some(path)) = (mcap, &args.record) {
        out.finish()
            .with_context(|| format!("writing {}", path.display()))?;
    }
    let world = StaticWorld::from_scenario(scenario);
    let summary = recorder
        .finish(scenario, &world, log.collisions, source)
        .with_context(context)?;
    let metrics = measure(&log);
    let path = args.out.join("metrics.json");
    std::fs::write(&path, serde_json::to_string_pretty(&metrics)? + "\n")
        .with_context(|| format!("writing {}", path.display()))?;
    // The demo's report, for this one run.
    let runs = [tether_report::sim_report::ScenarioRun {
        scenario,
        log: &log,
        metrics: &metrics,
    }];
    let intro = format!(
        "<p><code>tether sim --scenario {}</code>, seed {}: tether's pipeline drives \
         the simulated robot.</p>",
        tether_sim::svg::xml_escape(&scenario.name),
        args.seed
    );
    let html = tether_report::sim_report::html(
        &format!("tether sim: {}", scenario.name),
        &intro,
        &runs,
        &[],
    );
    let path = args.out.join("report.html");
    std::fs::write(&path, html).with_context(|| format!("writing {}", path.display()))?;
    Ok(summary)
}

/// Runs the simulation.
pub fn run(args: Args) -> anyhow::Result<()> {
    let (mut scenario, source) = Scenario::resolve(&args.scenario)?;
    if let Some(name) = &args.scanner {
        scenario = scenario.with_scanner(name)?;
    }
    if args.ideal_laser {
        scenario.laser_sim.realistic = false;
    }
    if let Some(duration) = args.duration {
        anyhow::ensure!(
            duration.is_finite() && duration > 0.0 && duration <= 86_400.0,
            "--duration must be more than 0 s and at most 86400 s (a day), got {duration}"
        );
        scenario.duration_s = duration;
    }
    if args.laser_only {
        scenario = closed_loop::laser_only(&scenario);
    }
    anyhow::ensure!(
        args.config.is_none() || (args.driver == DriverChoice::Tether && !args.ros2),
        "--config configures tether's pipeline, which `--driver scenario` and `--ros2` do \
         not run"
    );
    let base = pipeline_file::load(args.config.as_deref())?;
    #[cfg(not(feature = "ros2"))]
    anyhow::ensure!(
        !args.ros2,
        "--ros2: this tether was built without ROS 2 (cargo feature `jazzy` or `humble`, \
         on by default)"
    );
    #[cfg(feature = "ros2")]
    if args.ros2 {
        anyhow::ensure!(
            args.rate.is_finite() && (1.0..=10.0).contains(&args.rate),
            "--rate must be between 1 and 10 (times real time), got {}",
            args.rate
        );
        let time = if args.use_sim_time {
            SimTime::Published { rate: args.rate }
        } else {
            SimTime::Wall
        };
        return run_on_graph(&scenario, args.seed, time, args.cmd_vel_stamped, &args.out);
    }
    let bar = progress_bar(&scenario.name);
    let end_ns = (scenario.duration_s * 1e9) as i64;
    let show = |ns: i64| {
        if end_ns > 0 {
            bar.set_position((1000 * ns / end_ns).clamp(0, 1000) as u64);
        }
    };
    let context = || format!("simulating `{}` into {}", scenario.name, args.out.display());
    let mut bag = match &args.record_bag {
        Some(path) => Some(
            BagRecorder::create(
                path,
                !args.bag_without_odom,
                &scenario
                    .extra_lasers
                    .iter()
                    .map(|l| l.frame_id.clone())
                    .collect::<Vec<_>>(),
            )
            .with_context(|| format!("cannot create {}", path.display()))?,
        ),
        None => None,
    };
    let summary = match args.driver {
        DriverChoice::Scenario if bag.is_some() => {
            // run_to_dir, with every event also going to the bag.
            let mut sim = Simulation::new(&scenario, args.seed).with_context(context)?;
            let mut driver = tether_sim::driver::driver_for(&scenario);
            let mut recorder =
                RunRecorder::create(&args.out, &scenario, args.seed).with_context(context)?;
            tether_sim::record::run(&mut sim, driver.as_mut(), |event, _| {
                show(event.truth.stamp.ns());
                if let Some(bag) = bag.as_mut() {
                    bag.record(event);
                }
                recorder.record(event)
            })
            .with_context(context)?;
            recorder
                .finish(&scenario, sim.world(), sim.collisions(), &source)
                .with_context(context)?
        }
        DriverChoice::Scenario => run_to_dir(&scenario, &source, args.seed, &args.out, |now, _| {
            show(now.ns())
        })
        .with_context(context)?,
        DriverChoice::Tether => run_tether(&args, &scenario, &source, &base, &mut bag, &show)?,
    };
    bar.finish_and_clear();
    if let (Some(bag), Some(path)) = (bag, &args.record_bag) {
        let target = bag
            .finish()
            .with_context(|| format!("writing {}", path.display()))?;
        match target {
            Some(id) => tether::outln!(
                "bag -> {} (/scan, {}/people_truth; the target is person {id})",
                path.display(),
                if args.bag_without_odom { "" } else { "/odom, " }
            )?,
            None => tether::outln!("bag -> {} (the scenario has no target)", path.display())?,
        }
    }
    tether::outln!(
        "{}: {:.1} s simulated, seed {}, {} scans, {} camera frames ({} boxes), {} collisions -> {}",
        summary.scenario,
        summary.duration_s,
        summary.seed,
        summary.scans,
        summary.camera_frames,
        summary.camera_boxes,
        summary.collisions,
        args.out.display()
    )?;
    Ok(())
}

/// `--ros2`: the simulated robot on the graph until the scenario's end or Ctrl-C
/// ([`tether_eval::ros2_sim`]), then what it measured, printed and written to
/// `OUT/ros2_run.json`.
#[cfg(feature = "ros2")]
fn run_on_graph(
    scenario: &Scenario,
    seed: u64,
    time: SimTime,
    cmd_vel_stamped: bool,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C")?;
    let summary = tether_eval::ros2_sim::run(scenario, seed, time, cmd_vel_stamped, &stop)?;
    let d0 = summary.follow_distance_m;
    let path = out.join("ros2_run.json");
    let json = serde_json::to_string_pretty(&summary)?;
    std::fs::write(&path, json + "\n").with_context(|| format!("writing {}", path.display()))?;
    tether::outln!(
        "{}: {:.1} s simulated {}, {} scans, {} odometry messages and {} camera frames \
         published, {} commands received, first motion at {}, mean |d - d0| {} (d0 = {d0} m), {} collisions, \
         {:.1} m driven -> {}",
        scenario.name,
        summary.simulated_s,
        match time {
            SimTime::Wall => "in real time".to_owned(),
            SimTime::Published { rate } => format!("on /clock at {rate} x real time"),
        },
        summary.scans_published,
        summary.odometry_published,
        summary.camera_frames_published,
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
    )?;
    Ok(())
}
