//! `tether scanners`: the catalogue of laser scanners the simulator can play
//! (`tether_sim::scanners`), with their figures.

use tether_sim::person::leg_girth_scale;
use tether_sim::scanners::{Ranging, Rotation, Scanner, catalogue};

/// Options of `tether scanners`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print the catalogue as JSON (every figure, both noise models, the sources).
    #[arg(long)]
    pub json: bool,
}

/// One row of the table.
fn row(s: &Scanner) -> Vec<String> {
    let l = &s.laser;
    let sim = &s.sim;
    vec![
        s.name.to_owned(),
        s.model.to_owned(),
        match s.ranging {
            Ranging::TimeOfFlight => "ToF",
            Ranging::Triangulation => "triang.",
        }
        .to_owned(),
        match s.rotation {
            Rotation::CounterClockwise => "ccw",
            Rotation::Clockwise => "cw",
        }
        .to_owned(),
        format!("{:.1}", s.field_of_view_deg()),
        format!("{:.3}", s.step_deg()),
        l.beam_count().to_string(),
        format!("{:.1}", s.rate_hz()),
        format!("{}-{}", l.range_min_m, l.range_max_m),
        format!(
            "{:.0}/{:.0}",
            1000.0 * sim.noise.sigma_m(1.0),
            1000.0 * sim.noise.sigma_m(3.0)
        ),
        format!("{:.3}", sim.dropout_prob),
        format!("{:.2}", sim.object_beam_loss_prob),
        format!(
            "{:.2} from {:.1} m",
            sim.long_range_dropout_prob, sim.long_range_start_m
        ),
        format!("{:.2}", l.mount.height_m),
        format!("{:.2}", leg_girth_scale(l.mount.height_m)),
    ]
}

/// Prints the catalogue: a table, or JSON with `--json`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let all = catalogue();
    if args.json {
        tether::outln!("{}", serde_json::to_string_pretty(&all)?)?;
        return Ok(());
    }
    let header: Vec<String> = [
        "name",
        "model",
        "ranging",
        "turns",
        "fov deg",
        "step deg",
        "beams",
        "rate Hz",
        "range m",
        "sigma mm @1/3 m",
        "dropout",
        "no-return in objects",
        "far flicker",
        "mount m",
        "leg width x",
    ]
    .map(str::to_owned)
    .to_vec();
    let rows: Vec<Vec<String>> = std::iter::once(header).chain(all.iter().map(row)).collect();
    let widths: Vec<usize> = (0..rows[0].len())
        .map(|c| rows.iter().map(|r| r[c].chars().count()).max().unwrap_or(0))
        .collect();
    for r in &rows {
        let line: Vec<String> = r
            .iter()
            .zip(&widths)
            .map(|(cell, w)| format!("{cell:<w$}"))
            .collect();
        tether::outln!("{}", line.join("  ").trim_end())?;
    }
    tether::outln!(
        "\nsigma: the simulated scanner's range spread; the estimator assumes the \
         datasheet's bound (--json: laser.noise). Scans are published counter-clockwise \
         (as the drivers do); `[laser.geometry] clockwise = true` lists them clockwise. \
         leg width x: a leg's width at the mount height against at 0.30 m. \
         Use one: tether sim --scanner NAME, or [laser_sim] scanner = \"NAME\"."
    )?;
    Ok(())
}
