//! `tether sim`: run a scenario and write its sensor data, ground truth and picture.

use std::path::PathBuf;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether_sim::{Scenario, run_to_dir};

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
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
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
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {percent}% ({elapsed} < {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("simulating {}", scenario.name));
    let summary = run_to_dir(&scenario, &source, args.seed, &args.out, |now, end| {
        if end.ns() > 0 {
            bar.set_position((1000 * now.ns() / end.ns()).clamp(0, 1000) as u64);
        }
    })
    .with_context(|| format!("simulating `{}` into {}", scenario.name, args.out.display()))?;
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
