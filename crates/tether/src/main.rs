//! `tether`: the command line of the person-following robot.
//!
//! Each subcommand lives in its own module under `cmd/` with a clap `Args` struct and a
//! `run` function; this file only dispatches.

mod cmd;

use clap::{Parser, Subcommand};

/// Track one person and follow them with a small mobile robot.
#[derive(Debug, Parser)]
#[command(name = "tether", version, about, long_about = None)]
struct Cli {
    /// More log output (-v: debug, -vv: trace, both with the DDS middleware's own log,
    /// which is silent by default). `RUST_LOG` overrides it.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// List the built-in simulation scenarios.
    Scenarios(cmd::scenarios::Args),
    /// List the laser scanners the simulator can play, with their figures.
    Scanners(cmd::scanners::Args),
    /// Run a simulation scenario and write its sensor data, ground truth and a picture.
    Sim(cmd::sim::Args),
    /// Run every built-in scenario with the full pipeline in the loop; write report.html.
    Demo(cmd::demo::Args),
    /// Detect legs and people in every scan of a ROS 1 bag (JSON lines).
    Legs(cmd::legs::Args),
    /// Train the learned leg classifier on leg_tracker's labelled recordings.
    TrainLegs(cmd::train_legs::Args),
    /// Precision and recall of the leg detectors by range: both on the test recordings,
    /// or one on any labelled recording.
    EvalLegs(cmd::eval_legs::Args),
    /// Detect, fuse and track people over a recording (one JSON line per scan).
    Track(cmd::track::Args),
    /// Run the pipeline over a recording (MCAP or ROS 1 bag); write results and a report.
    Replay(cmd::replay::Args),
    /// Measure fusion and tracking over many simulated seeds (RMSE, NEES, CLEAR MOT).
    EvalFusion(cmd::eval_fusion::Args),
    /// Measure tracking and the target on an annotated recording (CLEAR MOT, target share).
    EvalTrack(cmd::eval_track::Args),
    /// Show what a recording (ROS 1 bag or MCAP) holds: topics, types, counts, rates, frames, scan geometry.
    Info(cmd::info::Args),
    /// Measure the target lock over many simulated seeds, per sensor mode.
    EvalTarget(cmd::eval_target::Args),
    /// Detect objects with an OpenCV Haar cascade (prints opencv_reference.py's JSON).
    Detect(cmd::detect::Args),
    /// Train a boosted Haar cascade from an info.dat annotation file; write OpenCV XML.
    TrainCascade(cmd::train_cascade::Args),
    /// Precision, recall and F1 of a Haar cascade against an info.dat annotation file.
    EvalCascade(cmd::eval_cascade::Args),
    /// Run the live robot: laser, optional camera, pipeline, base (see configs/robot.example.toml).
    Run(cmd::run::Args),
    /// Run tether as a ROS 2 node: scans from `scan`, commands to `cmd_vel` (no ROS installation needed).
    #[cfg(feature = "ros2")]
    Ros2(cmd::ros2::Args),
    /// Emulate a Hokuyo URG-04LX (SCIP 2.0) on a pseudo-terminal or TCP, serving simulated scans.
    UrgEmulator(cmd::urg_emulator::Args),
    /// Calibrate a sensor from measurements.
    #[command(subcommand)]
    Calibrate(Calibrate),
    /// Show configuration: `tether config defaults` prints every pipeline parameter.
    #[command(subcommand)]
    Config(cmd::config::ConfigCommand),
    /// The process `tether run` starts beside itself to stop the base if tether dies.
    #[command(hide = true)]
    BaseGuard(cmd::base_guard::Args),
    /// The process `tether ros2` starts beside itself to stop the robot if the node dies.
    #[cfg(feature = "ros2")]
    #[command(hide = true)]
    CmdVelGuard(cmd::cmd_vel_guard::Args),
}

#[derive(Debug, Subcommand)]
enum Calibrate {
    /// Fit the laser's range bias and noise from samples at known distances.
    Laser(cmd::calibrate_laser::Args),
    /// Fit the camera tilt and box margin from boxes of a person at known distances.
    Camera(cmd::calibrate_camera::Args),
}

fn main() -> std::process::ExitCode {
    // `--ros-args ... [--]` is ROS 2's, not clap's: taken out before clap parses the rest.
    let raw: Vec<String> = std::env::args().collect();
    #[cfg(feature = "ros2")]
    let (ros, rest) = match tether_ros2::RosArgs::parse(&raw) {
        Ok(parsed) => parsed,
        Err(e) => {
            eprintln!("error: {e}");
            return std::process::ExitCode::FAILURE;
        }
    };
    #[cfg(not(feature = "ros2"))]
    let rest = {
        if raw.iter().any(|a| a == "--ros-args") {
            eprintln!(
                "error: --ros-args: this tether was built without ROS 2 (cargo feature `jazzy` \
                 or `humble`, on by default)"
            );
            return std::process::ExitCode::FAILURE;
        }
        raw.clone()
    };
    let had_ros_args = raw.len() != rest.len();
    let cli = Cli::parse_from(rest);
    // `tests/walkthroughs.rs` checks that every command the documents name parses: with
    // this variable set, parsing is all tether does.
    if std::env::var_os("TETHER_PARSE_ONLY").is_some() {
        return std::process::ExitCode::SUCCESS;
    }
    let logs = init_logging(cli.verbose);
    let result = match cli.command {
        #[cfg(feature = "ros2")]
        Command::Ros2(mut args) => {
            args.ros = ros;
            cmd::ros2::run(args)
        }
        _ if had_ros_args => Err(anyhow::anyhow!("--ros-args only applies to `tether ros2`")),
        Command::Scenarios(args) => cmd::scenarios::run(args),
        Command::Scanners(args) => cmd::scanners::run(args),
        Command::Sim(args) => cmd::sim::run(args),
        Command::Demo(args) => cmd::demo::run(args),
        Command::Legs(args) => cmd::legs::run(args),
        Command::TrainLegs(args) => cmd::train_legs::run(args),
        Command::EvalLegs(args) => cmd::eval_legs::run(args),
        Command::Track(args) => cmd::track::run(args),
        Command::Replay(args) => cmd::replay::run(args),
        Command::EvalFusion(args) => cmd::eval_fusion::run(args),
        Command::EvalTrack(args) => cmd::eval_track::run(args),
        Command::Info(args) => cmd::info::run(args),
        Command::EvalTarget(args) => cmd::eval_target::run(args),
        Command::Detect(args) => cmd::detect::run(args),
        Command::TrainCascade(args) => cmd::train_cascade::run(args),
        Command::EvalCascade(args) => cmd::eval_cascade::run(args),
        Command::Run(args) => cmd::run::run(args),
        Command::UrgEmulator(args) => cmd::urg_emulator::run(args),
        Command::BaseGuard(args) => cmd::base_guard::run(args),
        #[cfg(feature = "ros2")]
        Command::CmdVelGuard(args) => cmd::cmd_vel_guard::run(args),
        Command::Config(command) => cmd::config::run(command),
        Command::Calibrate(Calibrate::Camera(args)) => cmd::calibrate_camera::run(args),
        Command::Calibrate(Calibrate::Laser(args)) => cmd::calibrate_laser::run(args),
    };
    // What the log queue still holds goes out before the last word (a stalled stderr
    // gets a moment, not for ever).
    if let Some(logs) = &logs {
        logs.drain(std::time::Duration::from_secs(1));
        if logs.dropped() > 0 {
            eprintln!(
                "warning: {} log lines were dropped because nothing read stderr fast enough",
                logs.dropped()
            );
        }
    }
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // `tether demo | head -1`: the reader has what it wanted.
        Err(err) if tether::output::is_stdout_closed(&err) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_text(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// An error with its causes, `outer: inner: ...`, leaving out a cause whose text the
/// message before it already holds (many errors quote their source).
fn error_text(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let part = cause.to_string();
        if text.is_empty() {
            text = part;
        } else if !text.contains(&part) {
            text.push_str(": ");
            text.push_str(&part);
        }
    }
    text
}

/// Logs to stderr through [`tether::logs::LogQueue`] (directly if its thread cannot
/// start), which it returns.
fn init_logging(verbose: u8) -> Option<tether::logs::LogQueue> {
    let default = match verbose {
        // RustDDS and ros2-client log through `log`: their warnings are mostly
        // per-packet chatter, so they are heard only when asked for.
        0 => "warn,tether=info,rustdds=off,ros2_client=off",
        1 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_target(false)
        .without_time()
        // Colour codes only where a terminal shows them, not in a log file or a pipe.
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()));
    match tether::logs::LogQueue::start(std::io::stderr()) {
        Ok(queue) => {
            builder.with_writer(queue.clone()).init();
            Some(queue)
        }
        Err(_) => {
            builder.with_writer(std::io::stderr).init();
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::error_text;

    #[derive(Debug, thiserror::Error)]
    #[error("inner failure at byte 7")]
    struct Inner;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot decode: {0}")]
    struct Quoting(#[source] Inner);

    #[derive(Debug, thiserror::Error)]
    #[error("cannot decode")]
    struct Plain(#[source] Inner);

    #[test]
    fn causes_are_printed_once() {
        let quoting = anyhow::Error::new(Quoting(Inner)).context("reading a.jpg");
        assert_eq!(
            error_text(&quoting),
            "reading a.jpg: cannot decode: inner failure at byte 7"
        );
        let plain = anyhow::Error::new(Plain(Inner));
        assert_eq!(error_text(&plain), "cannot decode: inner failure at byte 7");
    }
}
