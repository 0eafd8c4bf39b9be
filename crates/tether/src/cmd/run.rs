//! `tether run --config robot.toml`: the live robot. The laser (serial or TCP), an
//! optional camera, the full pipeline, and the commands: JSON lines on stdout, an MCAP
//! recording, a base adapter (iRobot Create, wheel-speed lines).
//!
//! The runtime is `tether_live::robot`: the laser driver and the camera (frames, then
//! the cascade detector) each send their data over one channel to the main loop
//! (`tether_live::run_loop`), which runs the pipeline on every scan and frame and on a
//! 20 Hz timer. This command reads the options, starts it, and says how the run went.
//! Ctrl-C (or SIGTERM) ends the loop; every output then gets a final stop.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Context;
use tether::ego_motion::EgoMotion;
use tether_live::Ending;
use tether_live::config::RobotConfig;
use tether_live::robot::{self, RobotReport, RobotSettings};

/// Options of `tether run`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot's configuration (TOML; see configs/robot.example.toml).
    #[arg(long, value_name = "robot.toml")]
    pub config: PathBuf,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long, value_name = "S")]
    pub duration: Option<f64>,
    /// Where the robot's motion comes from: `auto` or `scans` (the dead reckoning of
    /// the commands corrected by matching each scan against the static scene), `odom`
    /// (dead reckoning of the commands alone). `none` is refused: a robot that drives
    /// cannot be taken to stand still.
    #[arg(long, value_enum, default_value_t = EgoMotion::Auto)]
    pub ego_motion: EgoMotion,
}

/// Runs the robot.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = RobotConfig::load(&args.config)?;
    let duration = match args.duration {
        Some(s) if s.is_finite() && s > 0.0 && s <= 1e6 => Some(Duration::from_secs_f64(s)),
        Some(s) => anyhow::bail!("--duration must be a positive number of seconds, got {s}"),
        None => None,
    };
    // The base reports no odometry: the commands' dead reckoning, corrected by the scans
    // unless asked not to be.
    let with_scans = match args.ego_motion {
        EgoMotion::Auto | EgoMotion::Scans | EgoMotion::Commands => true,
        EgoMotion::Odom => false,
        EgoMotion::None => anyhow::bail!(
            "--ego-motion none: a robot that drives cannot be taken to stand still; use \
             scans (the default) or odom (dead reckoning of the commands)"
        ),
    };
    let mut pipeline_config = config
        .pipeline_config()
        .map_err(|e| anyhow::anyhow!("config {}: {e}", args.config.display()))?;
    args.leg_model.apply(&mut pipeline_config);
    // The scan matcher's settings are the configuration's (`[pipeline.scan_matcher]`).
    let scan_odometry = with_scans.then(|| pipeline_config.scan_matcher.clone());
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .context("cannot catch Ctrl-C, so the robot could not be stopped cleanly")?;
    let settings = RobotSettings {
        duration,
        scan_odometry,
    };
    let RobotReport {
        summary,
        pipeline,
        recording_error,
    } = robot::run(&config, pipeline_config, &settings, &stop).map_err(|e| {
        let hint = start_hint(&e, &config);
        anyhow::Error::new(e).context(hint)
    })?;
    let mut problems = Vec::new();
    if let Some(e) = recording_error {
        problems.push(format!("finishing the recording: {e}"));
    }
    let stats = pipeline.stats();
    tracing::info!(
        "{}: {} scans, {} camera frames, {} ticks ({} with a target), {:.1} m driven by dead \
         reckoning, {} laser faults recovered, {} laser reconnects, {} camera frames skipped",
        summary.ending.name(),
        summary.scans,
        summary.frames,
        summary.ticks,
        summary.ticks_with_target,
        summary.distance_m,
        summary.laser_faults,
        summary.laser_reconnects,
        summary.bad_frames,
    );
    if summary.clamped_stamps > 0 {
        tracing::info!(
            "{} scans or frames were stamped before the loop's last tick (a sensor thread a \
             little late, a busy machine) and were processed at that tick's time instead: \
             nothing to do, unless it is most of them on a robot whose laser is not \
             emulated (then the machine is too slow for the scan rate)",
            summary.clamped_stamps
        );
    }
    if stats.out_of_order_ticks > 0 {
        tracing::warn!(
            "{} inputs came out of order and were kept out of the tracks",
            stats.out_of_order_ticks
        );
    }
    tracing::info!("{}", summary.target.one_line(pipeline.selector().stats()));
    tracing::info!("{}", summary.holds.one_line());
    if summary.cannot_keep_up > 0 {
        tracing::warn!(
            "the robot could not keep up with the target {} times (at its speed limit, {:.2} \
             m/s, the target pulled away): raise [robot] max_speed_mps if the base allows",
            summary.cannot_keep_up,
            pipeline.config().limits.max_speed_mps
        );
    }
    for (output, error) in &summary.final_stop_failures {
        problems.push(format!("the final stop to {output} failed: {error}"));
    }
    match &summary.ending {
        Ending::Duration | Ending::Interrupted => {}
        Ending::LaserFailed(e) => problems.insert(
            0,
            format!("the laser failed (unplugged, powered off, or taken by another program?): {e}"),
        ),
        Ending::OutputFailed { output, error } => {
            problems.insert(
                0,
                format!("writing the commands to {output} failed: {error}"),
            );
        }
        Ending::InputsClosed => problems.insert(0, "every sensor thread ended".into()),
        Ending::Panicked(why) => {
            problems.insert(0, format!("the control loop panicked (a bug): {why}"))
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        anyhow::bail!(
            "{}; a final stop was sent to every output that still worked",
            problems.join("; ")
        )
    }
}

/// What to tell the user when the robot of `config` cannot start: where to look first.
fn start_hint(error: &robot::StartError, config: &RobotConfig) -> String {
    use robot::StartError;
    let serial = config.laser.serial.as_deref().unwrap_or("");
    match error {
        StartError::Laser(_) if serial.starts_with("/dev/pts/") => format!(
            "the laser at {serial} did not start: a pseudo-terminal is what `tether \
             urg-emulator` serves; put in [laser] serial the one it printed when it started \
             (\"URG-04LX emulator ... on /dev/pts/K\"), and start it first"
        ),
        StartError::Laser(_) => format!(
            "the laser did not start: is it plugged in and powered, is [laser] serial \
             ({serial}) or tcp its port, and is no other program using it?"
        ),
        StartError::Base(_) | StartError::Guard(_) => {
            "the base's device did not open: no command went to it and no recording was made".into()
        }
        _ => "tether run did not start: its outputs got a final stop and no recording was kept"
            .into(),
    }
}
