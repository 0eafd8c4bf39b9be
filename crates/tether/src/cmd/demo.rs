//! `tether demo`: every built-in scenario with the full pipeline in the loop, a table
//! of the following measures and `report.html`.

use std::path::PathBuf;

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use tether_control::SpringVariant;
use tether_eval::closed_loop::{self, RunLog, laser_only, laser_only_variants, variants};
use tether_eval::metrics::{RunMetrics, measure};
use tether_pipeline::PipelineConfig;
use tether_report::sim_report::{self, Driver, ScenarioRun};
use tether_sim::{BUILTIN_NAMES, Scenario};

/// The id of the report's section on the controller as printed in the paper.
pub const PRINTED_ID: &str = "printed-controller";

/// Options of `tether demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder for `report.html` and each scenario's `metrics.json`.
    #[arg(long, value_name = "DIR", default_value = "out/demo")]
    pub out: PathBuf,
    /// Seed of the simulated world.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only these scenarios (built-in names or .toml files).
    #[arg(long = "scenario", value_name = "NAME")]
    pub scenarios: Vec<String>,
    /// Put this scanner of `tether scanners` on the robot (its geometry, rate, range,
    /// noise, no-returns and mount height replace the scenario's).
    #[arg(long, value_name = "NAME")]
    pub scanner: Option<String>,
    /// The leg model (`--leg-model`).
    #[command(flatten)]
    pub leg_model: tether::args::LegModelArg,
}

/// Runs the demo.
pub fn run(args: Args) -> anyhow::Result<()> {
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
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let bar = ProgressBar::new(scenarios.len() as u64 + 1);
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg:24} [{bar:30}] {pos}/{len} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    // Every scenario twice: driven by the fused pipeline, then by the laser alone (the
    // camera off), as a robot without a camera, or whose camera is blinded, follows.
    let mut runs_to_do: Vec<(Scenario, PipelineConfig, Vec<PipelineConfig>)> = Vec::new();
    for scenario in &scenarios {
        let (driver, passengers) = variants(scenario);
        runs_to_do.push((scenario.clone(), driver, passengers));
    }
    for scenario in &scenarios {
        let (laser_driver, passengers) = laser_only_variants(scenario);
        runs_to_do.push((laser_only(scenario), laser_driver, passengers));
    }
    bar.set_length(runs_to_do.len() as u64 + 1);
    let mut logs: Vec<(RunLog, RunMetrics)> = Vec::new();
    for (_, driver, passengers) in &mut runs_to_do {
        args.leg_model
            .apply_all(std::iter::once(driver).chain(passengers.iter_mut()));
    }
    for (scenario, driver, passengers) in &runs_to_do {
        bar.set_message(scenario.name.clone());
        let log = closed_loop::run(scenario, args.seed, driver, passengers, &[])
            .with_context(|| format!("running `{}`", scenario.name))?;
        let metrics = measure(&log);
        let dir = args.out.join(&scenario.name);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join("metrics.json");
        std::fs::write(&path, serde_json::to_string_pretty(&metrics)? + "\n")
            .with_context(|| format!("writing {}", path.display()))?;
        logs.push((log, metrics));
        bar.inc(1);
    }
    let scenarios: Vec<Scenario> = runs_to_do.into_iter().map(|(s, _, _)| s).collect();

    // Why the controller as printed in the paper cannot follow anyone.
    bar.set_message("printed controller");
    let corridor = Scenario::builtin("corridor")?;
    let (mut printed, _) = variants(&corridor);
    printed.follower.variant = SpringVariant::PaperAsPrinted;
    args.leg_model.apply(&mut printed);
    let printed_log = closed_loop::run(&corridor, args.seed, &printed, &[], &[])?;
    let printed_metrics = measure(&printed_log);
    bar.inc(1);
    bar.finish_and_clear();

    tether::outln!(
        "{:<24} {:>10} {:>9} {:>8} {:>8} {:>9} {:>6} {:>5} {:>22}",
        "scenario",
        "mean|d-d0|",
        "RMS d-d0",
        "min d",
        "in band",
        "lost (s)",
        "swaps",
        "coll.",
        "RMSE fused/laser/vis"
    )?;
    let f = |v: Option<f64>| v.map_or("-".to_owned(), |x| format!("{x:.3}"));
    let rows = logs
        .iter()
        .zip(&scenarios)
        .map(|((_, m), s)| (m.scenario.clone(), m, Driver::of(s)))
        .chain(std::iter::once((
            "printed*".to_owned(),
            &printed_metrics,
            Driver::Fused,
        )));
    for (name, m, driver) in rows {
        let [fused, laser, vision] = driver.rmse_columns(m);
        tether::outln!(
            "{:<24} {:>10} {:>9} {:>8.2} {:>8} {:>9.1} {:>6} {:>5} {:>22}",
            name,
            f(m.mean_abs_distance_error_m),
            f(m.rms_distance_error_m),
            m.min_distance_m,
            m.time_in_band_frac
                .map_or("-".to_owned(), |x| format!("{:.0}%", 100.0 * x)),
            m.target_lost_s,
            m.target_swaps,
            m.collisions,
            format!("{}/{}/{}", f(fused), f(laser), f(vision))
        )?;
    }
    tether::outln!(
        "(printed*: the corridor with the controller as the paper prints it, see the report)"
    )?;

    let runs: Vec<ScenarioRun<'_>> = logs
        .iter()
        .zip(&scenarios)
        .map(|((log, metrics), scenario)| ScenarioRun {
            scenario,
            log,
            metrics,
        })
        .collect();
    let intro = format!(
        "<p>tether's full pipeline (laser legs, upper-body camera model, Covariance Intersection, tracking, \
         virtual spring, safety) in the loop of every built-in scenario, seed {}. The robot is driven by tether's \
         own estimates; laser-only and vision-only pipelines ride along on the same data for comparison. Then \
         every scenario again, driven by the laser alone (<code>-laser-only</code>).</p>",
        args.seed
    );
    let html = sim_report::html(
        "tether demo",
        &intro,
        &runs,
        &[printed_section(&printed_log, &printed_metrics)],
    );
    let path = args.out.join("report.html");
    std::fs::write(&path, html).with_context(|| format!("writing {}", path.display()))?;
    tether::outln!("report: {}", path.display())?;
    Ok(())
}

/// The report's section on the controller as printed in the paper: why it cannot
/// follow anyone, its distance to the target, and its row of measures (in the
/// section and in the summary).
fn printed_section<'a>(log: &RunLog, metrics: &'a RunMetrics) -> sim_report::Extra<'a> {
    let mut body = String::from(
        "<p>As printed, the paper's spring has no free length (its equilibrium is at d = 0, inside the person) \
         and its forces point the wrong way (a person ahead pushes the robot backwards: positive feedback). \
         Here it runs in the corridor with every safety limit on: it never approaches the target, it backs \
         away (reverse is not allowed, so it stands still) while the person walks off.</p>",
    );
    for plot in sim_report::run_plots(log).into_iter().take(1) {
        body.push_str(&format!("<div class=\"figure\">{}</div>", plot.svg()));
    }
    let row = sim_report::Row {
        name: "corridor, controller as printed".to_owned(),
        anchor: Some(PRINTED_ID.to_owned()),
        driver: Driver::Fused,
        metrics,
    };
    body.push_str(&sim_report::metrics_table(std::slice::from_ref(&row)));
    sim_report::Extra {
        id: PRINTED_ID.to_owned(),
        title: "The controller as printed in the paper".to_owned(),
        body,
        row: Some(row),
    }
}
