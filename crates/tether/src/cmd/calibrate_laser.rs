//! `tether calibrate laser`: fit the range bias `bias(r)` and noise `sigma(r)` of the
//! laser from measurements at known distances (the paper's Fig. 9) and write them into
//! a laser config.

use std::path::{Path, PathBuf};

use anyhow::Context;
use tether_laser::{CalibrationConfig, CalibrationSample, fit_range_noise};

use tether::args::laser_model;

/// Options of `tether calibrate laser`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV of measurements with the columns `true_range_m,measured_range_m` (a header
    /// line naming them; other columns, blank lines and `#` comments are ignored).
    #[arg(long, value_name = "FILE.csv")]
    pub samples: PathBuf,
    /// Where to write the laser config (TOML) with the fitted `[noise]`.
    #[arg(long, value_name = "FILE.toml")]
    pub out: PathBuf,
    /// A laser config to start from (its other fields are kept); default: URG-04LX.
    #[arg(long, value_name = "FILE.toml")]
    pub base: Option<PathBuf>,
    /// Degree of the bias polynomial.
    #[arg(long, default_value_t = CalibrationConfig::default().bias_degree)]
    pub bias_degree: usize,
    /// Degree of the sigma polynomial.
    #[arg(long, default_value_t = CalibrationConfig::default().sigma_degree)]
    pub sigma_degree: usize,
}

/// Reads `true_range_m,measured_range_m` samples from CSV text.
fn parse_samples(text: &str, path: &Path) -> anyhow::Result<Vec<CalibrationSample>> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let Some((_, header)) = lines.next() else {
        anyhow::bail!(
            "{} is empty; it needs a header `true_range_m,measured_range_m`",
            path.display()
        );
    };
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| {
        columns.iter().position(|c| *c == name).with_context(|| {
            format!(
                "{}: the header {header:?} has no column `{name}`; it needs \
                 `true_range_m,measured_range_m`",
                path.display()
            )
        })
    };
    let (t, m) = (find("true_range_m")?, find("measured_range_m")?);
    let mut out = Vec::new();
    for (number, line) in lines {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let value = |k: usize, name: &str| -> anyhow::Result<f64> {
            let text = fields.get(k).with_context(|| {
                format!("{} line {}: no `{name}` column", path.display(), number + 1)
            })?;
            text.parse().with_context(|| {
                format!(
                    "{} line {}: `{name}` = {text:?} is not a number",
                    path.display(),
                    number + 1
                )
            })
        };
        out.push(CalibrationSample {
            true_range_m: value(t, "true_range_m")?,
            measured_range_m: value(m, "measured_range_m")?,
        });
    }
    Ok(out)
}

/// Fits, prints the fit and its residuals, and writes the config.
pub fn run(args: Args) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.samples)
        .with_context(|| format!("cannot read {}", args.samples.display()))?;
    let samples = parse_samples(&text, &args.samples)?;
    let config = CalibrationConfig {
        bias_degree: args.bias_degree,
        sigma_degree: args.sigma_degree,
        ..CalibrationConfig::default()
    };
    let fit = fit_range_noise(&samples, &config)
        .with_context(|| format!("fitting {}", args.samples.display()))?;
    if fit.skipped > 0 {
        tracing::warn!(
            "skipped {} samples with a non-finite value or a true range <= 0",
            fit.skipped
        );
    }
    let poly = |c: &[f64]| {
        c.iter()
            .enumerate()
            .map(|(k, v)| match k {
                0 => format!("{v:+.6}"),
                1 => format!("{v:+.6} r"),
                _ => format!("{v:+.6} r^{k}"),
            })
            .collect::<Vec<_>>()
            .join(" ")
    };
    tether::outln!("{} samples used", fit.used)?;
    tether::outln!("bias(r)  = {} m", poly(&fit.noise.bias_m.0))?;
    tether::outln!(
        "sigma(r) = max({} m, {} m)",
        fit.noise.sigma_floor_m,
        poly(&fit.noise.sigma_m.0)
    )?;
    if !fit.per_range.is_empty() {
        tether::outln!()?;
        tether::outln!(
            "true r (m)      n   mean err (mm)  fit bias (mm)   std (mm)  fit sigma (mm)"
        )?;
        for s in &fit.per_range {
            tether::outln!(
                "{:>10.3} {:>6} {:>14.2} {:>14.2} {:>10.2} {:>15.2}",
                s.true_range_m,
                s.count,
                1e3 * s.mean_error_m,
                1e3 * s.fitted_bias_m,
                1e3 * s.std_error_m,
                1e3 * s.fitted_sigma_m
            )?;
        }
    }
    tether::outln!()?;
    tether::outln!(
        "residuals: bias curve vs means {:.2} mm RMS, sigma curve vs stds {:.2} mm RMS, \
         error after bias removal {:.2} mm RMS",
        1e3 * fit.bias_fit_rms_m,
        1e3 * fit.sigma_fit_rms_m,
        1e3 * fit.residual_rms_m
    )?;
    let mut laser = laser_model(args.base.as_ref())?;
    laser.noise = fit.noise;
    laser
        .validate()
        .context("the fitted noise model is not usable")?;
    let toml = toml::to_string(&laser).context("cannot write the laser config as TOML")?;
    let header = format!(
        "# Laser config written by `tether calibrate laser` from {} ({} samples).\n\
         # [noise]: bias_m and sigma_m are polynomial coefficients in range, lowest first.\n",
        args.samples.display(),
        fit.used
    );
    std::fs::write(&args.out, header + &toml)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    tether::outln!(
        "wrote {} (a laser config, for `--laser` of legs, eval-legs and train-legs)",
        args.out.display()
    )?;
    tether::outln!()?;
    tether::outln!(
        "For the robot's config (tether run, ros2, and track, replay --config), paste:"
    )?;
    tether::outln!()?;
    tether::outln!("{}", noise_block(&laser.noise)?)?;
    Ok(())
}

/// The `[pipeline.laser.noise]` table of a robot's config holding `noise`.
fn noise_block(noise: &tether_core::RangeNoiseModel) -> anyhow::Result<String> {
    let body = toml::to_string(noise).context("cannot write the noise model as TOML")?;
    Ok(format!("[pipeline.laser.noise]\n{}", body.trim_end()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_columns_by_name_and_reports_bad_lines() {
        let p = Path::new("s.csv");
        let s = parse_samples(
            "# comment\nmeasured_range_m,true_range_m,note\n1.01,1.0,a\n\n2.02, 2.0 ,b\n",
            p,
        )
        .unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[1].true_range_m, 2.0);
        assert_eq!(s[1].measured_range_m, 2.02);
        let err = parse_samples("true_range_m,measured_range_m\n1.0,x\n", p).unwrap_err();
        assert!(format!("{err:#}").contains("line 2"), "{err:#}");
        assert!(parse_samples("a,b\n1,2\n", p).is_err());
        assert!(parse_samples("", p).is_err());
    }
}
