//! `tether sim`: run a scenario and write its sensor data, ground truth, a picture and,
//! with tether's pipeline driving, the measures of the run.

use std::path::PathBuf;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether::closed_loop::{self, RunError};
use tether::metrics::measure;
use tether_sim::record::RunRecorder;
use tether_sim::{Scenario, StaticWorld, run_to_dir};

/// Who drives the simulated robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DriverChoice {
    /// tether's full pipeline (laser legs, camera model, fusion, tracking, spring,
    /// safety), with laser-only and vision-only pipelines riding along for comparison;
    /// writes `metrics.json`.
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

/// Runs the simulation.
pub fn run(args: Args) -> anyhow::Result<()> {
    let (mut scenario, source) = Scenario::resolve(&args.scenario)?;
    if let Some(duration) = args.duration {
        anyhow::ensure!(
            duration.is_finite() && duration > 0.0 && duration <= 86_400.0,
            "--duration must be between 0 and 86400 s, got {duration}"
        );
        scenario.duration_s = duration;
    }
    let bar = progress_bar(&scenario.name);
    let end_ns = (scenario.duration_s * 1e9) as i64;
    let show = |ns: i64| {
        if end_ns > 0 {
            bar.set_position((1000 * ns / end_ns).clamp(0, 1000) as u64);
        }
    };
    let context = || format!("simulating `{}` into {}", scenario.name, args.out.display());
    let summary = match args.driver {
        DriverChoice::Scenario => run_to_dir(&scenario, &source, args.seed, &args.out, |now, _| {
            show(now.ns())
        })
        .with_context(context)?,
        DriverChoice::Tether => {
            let (driver, passengers) = super::demo::variants(&scenario);
            let mut recorder =
                RunRecorder::create(&args.out, &scenario, args.seed).with_context(context)?;
            let log = closed_loop::run_observed(
                &scenario,
                args.seed,
                &driver,
                &passengers,
                &[],
                &mut |event, _| {
                    show(event.truth.stamp.ns());
                    recorder.record(event).map_err(RunError::from)
                },
            )
            .with_context(context)?;
            let world = StaticWorld::from_scenario(&scenario);
            let summary = recorder
                .finish(&scenario, &world, log.collisions, &source)
                .with_context(context)?;
            let metrics = measure(&log);
            let path = args.out.join("metrics.json");
            std::fs::write(&path, serde_json::to_string_pretty(&metrics)? + "\n")
                .with_context(|| format!("writing {}", path.display()))?;
            summary
        }
    };
    bar.finish_and_clear();
    println!(
        "{}: {:.1} s simulated, seed {}, {} scans, {} camera frames ({} boxes), {} collisions -> {}",
        summary.scenario,
        summary.duration_s,
        summary.seed,
        summary.scans,
        summary.camera_frames,
        summary.camera_boxes,
        summary.collisions,
        args.out.display()
    );
    Ok(())
}
