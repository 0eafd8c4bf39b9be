//! `tether eval-target`: the target lock measured over many seeds of the simulator, in
//! each sensor mode (issue 14): the share of the time the target is visible to the
//! laser during which the locked track is the true person, scans on a bystander,
//! re-acquisition after the person was hidden, target swaps.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether_eval::closed_loop;
use tether_eval::metrics::measure;
use tether_eval::target_metrics::measure_target_lock;
use tether_live::pipeline_file;
use tether_pipeline::PipelineConfig;
use tether_sim::{BUILTIN_NAMES, Scenario};

/// Which sensors drive the robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Laser and camera fused.
    Fused,
    /// The laser alone (the camera off).
    Laser,
    /// The camera alone (the laser off for tracking; still used for the obstacle stop).
    Camera,
}

impl Mode {
    /// The driving configuration of `scenario` in this mode, from `base`.
    pub fn config(self, scenario: &Scenario, base: &PipelineConfig) -> PipelineConfig {
        let mut c = closed_loop::config_for(scenario, base);
        match self {
            Mode::Fused => {}
            Mode::Laser => c.fusion.use_vision = false,
            Mode::Camera => {
                c.fusion.use_laser = false;
                c.fusion.vision_spawns_tracks = true;
            }
        }
        c
    }
}

/// Options of `tether eval-target`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Seeds 0..N of each scenario.
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// Scenarios to run (default: every built-in one).
    #[arg(long = "scenario", value_name = "NAME")]
    pub scenarios: Vec<String>,
    /// Sensor modes to drive with.
    #[arg(long = "mode", value_enum, default_values_t = [Mode::Fused, Mode::Laser])]
    pub modes: Vec<Mode>,
    /// A pipeline configuration (TOML) to start from instead of the defaults (the
    /// scenario's sensors and robot are set on top of it).
    #[arg(long, value_name = "FILE")]
    pub config: Option<std::path::PathBuf>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
    /// The ideal laser (`[laser_sim] realistic = false`): no phantoms, weak legs or dark
    /// spells, to compare with.
    #[arg(long)]
    pub ideal_laser: bool,
    /// Put this scanner of `tether scanners` on the robot (its geometry, rate, range,
    /// noise, no-returns and mount height replace the scenario's).
    #[arg(long, value_name = "NAME")]
    pub scanner: Option<String>,
    /// Also write the pooled figures as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<std::path::PathBuf>,
}

/// Pooled target figures of one scenario and mode over the seeds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Pooled {
    /// Scenario.
    pub scenario: String,
    /// Sensor mode.
    pub mode: Mode,
    /// Runs.
    pub runs: u64,
    /// Runs in which a target was ever locked.
    pub runs_locked: u64,
    /// Scans with the target visible to the laser after the first lock.
    pub visible_scans: u64,
    /// Share of those with the locked track on the target.
    pub on_target_frac: f64,
    /// Scans locked on somebody else.
    pub wrong_scans: u64,
    /// Reappearances after at least 0.5 s hidden.
    pub reappearances: u64,
    /// Of those, taken up again within 1 s.
    pub reacquired_within_1s: u64,
    /// Longest re-acquisition over the runs, s.
    pub max_reacquire_s: f64,
    /// Target swaps (CLEAR MOT correspondence of the locked track changed person).
    pub target_swaps: u64,
    /// Mean |d - d0| over the runs, m.
    pub mean_abs_distance_error_m: f64,
    /// Mean share of the control ticks with the distance in the follower's band.
    pub time_in_band_frac: f64,
    /// Mean time without a locked target after the first lock, s.
    pub target_lost_s: f64,
    /// Seeds with a wrong scan or a swap (to rerun with `tether sim --seed`).
    pub bad_seeds: Vec<u64>,
}

/// Evaluates one scenario in one mode over seeds 0..n.
pub fn evaluate(
    scenario: &Scenario,
    mode: Mode,
    seeds: u64,
    base: &PipelineConfig,
    mut on_run: impl FnMut(),
) -> anyhow::Result<Pooled> {
    let driver = mode.config(scenario, base);
    // Laser only is the scenario with its camera off, as `tether sim --laser-only` and
    // the demo run it, so that a bad seed is rerun as it was measured.
    let laser_only;
    let run_scenario = if mode == Mode::Laser {
        laser_only = closed_loop::laser_only(scenario);
        &laser_only
    } else {
        scenario
    };
    let mut p = Pooled {
        scenario: scenario.name.clone(),
        mode,
        runs: 0,
        runs_locked: 0,
        visible_scans: 0,
        on_target_frac: f64::NAN,
        wrong_scans: 0,
        reappearances: 0,
        reacquired_within_1s: 0,
        max_reacquire_s: 0.0,
        target_swaps: 0,
        mean_abs_distance_error_m: f64::NAN,
        time_in_band_frac: f64::NAN,
        target_lost_s: 0.0,
        bad_seeds: Vec::new(),
    };
    let (mut on_target, mut d_err, mut band) = (0u64, Vec::new(), Vec::new());
    for seed in 0..seeds {
        let log = closed_loop::run(run_scenario, seed, &driver, &[], &[])
            .with_context(|| format!("{} seed {seed}", scenario.name))?;
        let m = measure(&log);
        let t = measure_target_lock(&log);
        p.runs += 1;
        p.runs_locked += u64::from(m.first_lock_s.is_some());
        p.visible_scans += t.visible_scans;
        on_target += t.on_target_scans;
        p.wrong_scans += t.wrong_scans;
        p.reappearances += u64::from(t.reappearances);
        p.reacquired_within_1s += u64::from(t.reacquired_within_1s);
        p.max_reacquire_s = p.max_reacquire_s.max(t.max_reacquire_s.unwrap_or(0.0));
        p.target_swaps += u64::from(m.target_swaps);
        d_err.extend(m.mean_abs_distance_error_m);
        band.extend(m.time_in_band_frac);
        p.target_lost_s += m.target_lost_s / seeds as f64;
        if t.wrong_scans > 0 || m.target_swaps > 0 {
            tracing::warn!(
                "{} ({mode:?}) seed {seed}: {} scans on somebody else, {} swaps",
                scenario.name,
                t.wrong_scans,
                m.target_swaps
            );
            p.bad_seeds.push(seed);
        }
        on_run();
    }
    if p.visible_scans > 0 {
        p.on_target_frac = on_target as f64 / p.visible_scans as f64;
    }
    if !d_err.is_empty() {
        p.mean_abs_distance_error_m = d_err.iter().sum::<f64>() / d_err.len() as f64;
    }
    if !band.is_empty() {
        p.time_in_band_frac = band.iter().sum::<f64>() / band.len() as f64;
    }
    Ok(p)
}

/// Runs the evaluation and prints a table.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.seeds > 0, "--seeds must be at least 1");
    anyhow::ensure!(!args.modes.is_empty(), "give at least one --mode");
    let names: Vec<String> = if args.scenarios.is_empty() {
        BUILTIN_NAMES.iter().map(|s| (*s).to_owned()).collect()
    } else {
        args.scenarios.clone()
    };
    let mut scenarios = names
        .iter()
        .map(|n| Scenario::resolve(n).map(|(s, _)| s))
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(name) = &args.scanner {
        for s in &mut scenarios {
            *s = s.clone().with_scanner(name)?;
        }
    }
    if args.ideal_laser {
        for s in &mut scenarios {
            s.laser_sim.realistic = false;
        }
    }
    let bar = ProgressBar::new(args.seeds * (scenarios.len() * args.modes.len()) as u64);
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{bar:30}] {pos}/{len} runs ({elapsed} < {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let mut base = pipeline_file::load(args.config.as_deref())?;
    args.leg_model.apply(&mut base);
    let mut rows = Vec::new();
    for scenario in &scenarios {
        for &mode in &args.modes {
            rows.push(evaluate(scenario, mode, args.seeds, &base, || bar.inc(1))?);
        }
    }
    bar.finish_and_clear();
    tether::outln!(
        "{:<16} {:<7} {:>5} {:>7} {:>8} {:>10} {:>6} {:>12} {:>9} {:>6} {:>9} {:>8} {:>8}",
        "scenario",
        "mode",
        "runs",
        "locked",
        "visible",
        "on target",
        "wrong",
        "reacq <=1 s",
        "max reacq",
        "swaps",
        "|d-d0|",
        "in band",
        "lost"
    )?;
    for p in &rows {
        tether::outln!(
            "{:<16} {:<7} {:>5} {:>7} {:>8} {:>9.2}% {:>6} {:>12} {:>8.1}s {:>6} {:>9.3} {:>7.0}% {:>7.1}s",
            p.scenario,
            format!("{:?}", p.mode).to_lowercase(),
            p.runs,
            p.runs_locked,
            p.visible_scans,
            100.0 * p.on_target_frac,
            p.wrong_scans,
            format!("{}/{}", p.reacquired_within_1s, p.reappearances),
            p.max_reacquire_s,
            p.target_swaps,
            p.mean_abs_distance_error_m,
            100.0 * p.time_in_band_frac,
            p.target_lost_s
        )?;
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&rows)? + "\n";
        std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(())
}
