//! Range calibration (the paper's Fig. 9, design 2.1): from ranges measured at known
//! distances, fit the bias `bias(r)` and the noise `sigma(r)` of the scanner as
//! low-order polynomials, the [`RangeNoiseModel`] that pre-processing and every
//! covariance use.
//!
//! With errors `e_i = measured_i - true_i` at true ranges `r_i`:
//!
//! 1. `bias(r)` is the least-squares polynomial of degree `bias_degree` through
//!    `(r_i, e_i)`: the conditional mean of the error.
//! 2. `sigma(r)` is the least-squares polynomial of degree `sigma_degree` through
//!    `(r_i, sqrt(pi / 2) |e_i - bias(r_i)|)`: for a normal error `E|e - mu| = sigma
//!    sqrt(2 / pi)`, so this is an unbiased fit of the standard deviation that needs no
//!    grouping of the samples (grouped samples, as the paper took 1000 at each of six
//!    distances, work the same).

use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use tether_core::{Polynomial, RangeNoiseModel};
use thiserror::Error;

/// One measurement at a known distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationSample {
    /// The distance to the target, m.
    pub true_range_m: f64,
    /// What the scanner measured, m.
    pub measured_range_m: f64,
}

/// Fit parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationConfig {
    /// Degree of `bias(r)` (default 2).
    pub bias_degree: usize,
    /// Degree of `sigma(r)` (default 1: the datasheet's "+-1 % of range").
    pub sigma_degree: usize,
    /// Floor of `sigma(r)` written to the model, m (default 0.001, the scanner's
    /// resolution): keeps `sigma` positive outside the calibrated ranges.
    pub sigma_floor_m: f64,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        CalibrationConfig {
            bias_degree: 2,
            sigma_degree: 1,
            sigma_floor_m: 0.001,
        }
    }
}

/// Why a calibration cannot be fitted.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// Too few distinct distances for the polynomial degree.
    #[error(
        "a degree-{degree} fit needs samples at {needed} or more distinct distances, got {got}; \
         measure at more distances or lower the degree"
    )]
    TooFewDistances {
        /// Polynomial degree asked for.
        degree: usize,
        /// Distances needed.
        needed: usize,
        /// Distinct distances present.
        got: usize,
    },
    /// Degrees beyond 4 are ill-conditioned and never needed.
    #[error("polynomial degree {0} is too high; use 0 to 4")]
    DegreeTooHigh(usize),
    /// The floor is not a positive number.
    #[error("sigma_floor_m must be > 0, got {0}")]
    BadFloor(f64),
    /// The normal equations are singular.
    #[error("the least-squares system is singular: the distances do not determine the polynomial")]
    Singular,
}

/// The statistics at one measured distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeStats {
    /// True distance, m.
    pub true_range_m: f64,
    /// Samples taken there.
    pub count: usize,
    /// Mean error `mean(measured - true)`, m.
    pub mean_error_m: f64,
    /// Standard deviation of the error, m.
    pub std_error_m: f64,
    /// The fitted `bias(r)`, m.
    pub fitted_bias_m: f64,
    /// The fitted `sigma(r)` (with the floor), m.
    pub fitted_sigma_m: f64,
}

/// A fitted calibration and how well it fits.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFit {
    /// The noise model: `[noise]` of a `LaserModel` config.
    pub noise: RangeNoiseModel,
    /// Per distinct distance, ascending (only when the samples come at 100 or fewer
    /// distinct distances, as calibration measurements do).
    pub per_range: Vec<RangeStats>,
    /// RMS of `e_i - bias(r_i)` over all samples, m: the noise left after the bias.
    pub residual_rms_m: f64,
    /// RMS over the distances of `mean_error - bias(r)`, m: how well the bias curve
    /// follows the measured means.
    pub bias_fit_rms_m: f64,
    /// RMS over the distances of `std_error - sigma(r)`, m.
    pub sigma_fit_rms_m: f64,
    /// Samples used.
    pub used: usize,
    /// Samples skipped: non-finite values or a true range that is not positive.
    pub skipped: usize,
}

/// Least-squares polynomial of `degree` through `(x, y)`, by the normal equations on
/// `x / scale` (scale = largest |x|) for conditioning, solved by Gaussian elimination
/// with partial pivoting; coefficients are returned for unscaled `x`, lowest first.
fn poly_fit(xs: &[f64], ys: &[f64], degree: usize) -> Result<Polynomial, CalibrationError> {
    let m = degree + 1;
    let scale = xs
        .iter()
        .fold(0.0f64, |a, x| a.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    let mut a = vec![vec![0.0; m + 1]; m];
    for (&x, &y) in xs.iter().zip(ys) {
        let t = x / scale;
        let mut powers = vec![1.0; 2 * m];
        for k in 1..2 * m {
            powers[k] = powers[k - 1] * t;
        }
        for (i, row) in a.iter_mut().enumerate() {
            for (j, cell) in row.iter_mut().enumerate().take(m) {
                *cell += powers[i + j];
            }
            row[m] += powers[i] * y;
        }
    }
    for col in 0..m {
        let pivot = (col..m)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        let p = a[col][col];
        if p.is_nan() || p.abs() <= 1e-12 * xs.len() as f64 {
            return Err(CalibrationError::Singular);
        }
        let pivot_row = a[col].clone();
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / p;
            for (cell, &above) in row.iter_mut().zip(&pivot_row).skip(col) {
                *cell -= f * above;
            }
        }
    }
    let mut coef = vec![0.0; m];
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|k| a[i][k] * coef[k]).sum();
        coef[i] = (a[i][m] - s) / a[i][i];
    }
    Ok(Polynomial(
        coef.iter()
            .enumerate()
            .map(|(k, c)| c / scale.powi(k as i32))
            .collect(),
    ))
}

/// Fits `bias(r)` and `sigma(r)` to the samples (see the module docs).
pub fn fit_range_noise(
    samples: &[CalibrationSample],
    config: &CalibrationConfig,
) -> Result<CalibrationFit, CalibrationError> {
    for degree in [config.bias_degree, config.sigma_degree] {
        if degree > 4 {
            return Err(CalibrationError::DegreeTooHigh(degree));
        }
    }
    if !(config.sigma_floor_m.is_finite() && config.sigma_floor_m > 0.0) {
        return Err(CalibrationError::BadFloor(config.sigma_floor_m));
    }
    let good: Vec<CalibrationSample> = samples
        .iter()
        .copied()
        .filter(|s| {
            s.true_range_m.is_finite() && s.true_range_m > 0.0 && s.measured_range_m.is_finite()
        })
        .collect();
    let skipped = samples.len() - good.len();
    let mut distinct: Vec<f64> = good.iter().map(|s| s.true_range_m).collect();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let needed = config.bias_degree.max(config.sigma_degree) + 1;
    if distinct.len() < needed {
        return Err(CalibrationError::TooFewDistances {
            degree: config.bias_degree.max(config.sigma_degree),
            needed,
            got: distinct.len(),
        });
    }
    let rs: Vec<f64> = good.iter().map(|s| s.true_range_m).collect();
    let es: Vec<f64> = good
        .iter()
        .map(|s| s.measured_range_m - s.true_range_m)
        .collect();
    let bias = poly_fit(&rs, &es, config.bias_degree)?;
    let abs_dev: Vec<f64> = rs
        .iter()
        .zip(&es)
        .map(|(&r, &e)| std::f64::consts::FRAC_PI_2.sqrt() * (e - bias.eval(r)).abs())
        .collect();
    let sigma = poly_fit(&rs, &abs_dev, config.sigma_degree)?;
    let noise = RangeNoiseModel {
        bias_m: bias,
        sigma_m: sigma,
        sigma_floor_m: config.sigma_floor_m,
    };
    let residual_rms_m = (rs
        .iter()
        .zip(&es)
        .map(|(&r, &e)| (e - noise.bias_m(r)).powi(2))
        .sum::<f64>()
        / rs.len() as f64)
        .sqrt();
    let mut per_range = Vec::new();
    if distinct.len() <= 100 {
        for &r in &distinct {
            let errs: Vec<f64> = good
                .iter()
                .filter(|s| s.true_range_m == r)
                .map(|s| s.measured_range_m - s.true_range_m)
                .collect();
            let n = errs.len() as f64;
            let mean = errs.iter().sum::<f64>() / n;
            let var = if errs.len() > 1 {
                errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)
            } else {
                0.0
            };
            per_range.push(RangeStats {
                true_range_m: r,
                count: errs.len(),
                mean_error_m: mean,
                std_error_m: var.sqrt(),
                fitted_bias_m: noise.bias_m(r),
                fitted_sigma_m: noise.sigma_m(r),
            });
        }
    }
    let rms = |f: &dyn Fn(&RangeStats) -> f64| {
        if per_range.is_empty() {
            0.0
        } else {
            (per_range.iter().map(|s| f(s).powi(2)).sum::<f64>() / per_range.len() as f64).sqrt()
        }
    };
    let bias_fit_rms_m = rms(&|s| s.mean_error_m - s.fitted_bias_m);
    let sigma_fit_rms_m = rms(&|s| s.std_error_m - s.fitted_sigma_m);
    Ok(CalibrationFit {
        noise,
        per_range,
        residual_rms_m,
        bias_fit_rms_m,
        sigma_fit_rms_m,
        used: good.len(),
        skipped,
    })
}

/// Simulated calibration measurements: `per_range` samples at each true range `r` of
/// `measured = r + bias(r) + sigma(r) z`, `z ~ N(0, 1)`, from `model` (the range error
/// model of design 2.1) and the caller's seeded generator.
pub fn simulate_samples<R: Rng + ?Sized>(
    model: &RangeNoiseModel,
    true_ranges_m: &[f64],
    per_range: usize,
    rng: &mut R,
) -> Vec<CalibrationSample> {
    let mut out = Vec::with_capacity(true_ranges_m.len() * per_range);
    for &r in true_ranges_m {
        for _ in 0..per_range {
            let z: f64 = rng.sample(StandardNormal);
            out.push(CalibrationSample {
                true_range_m: r,
                measured_range_m: r + model.bias_m(r) + model.sigma_m(r) * z,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    /// The paper's protocol: 1000 samples at 0.5, 1.0, ... 3.0 m.
    const PAPER_RANGES_M: [f64; 6] = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0];

    #[test]
    fn polynomial_fit_is_exact_on_a_polynomial() {
        let xs: Vec<f64> = (0..20).map(|i| 0.3 * i as f64).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 0.5 - 0.2 * x + 0.03 * x * x).collect();
        let p = poly_fit(&xs, &ys, 2).unwrap();
        for (got, want) in p.0.iter().zip([0.5, -0.2, 0.03]) {
            assert!((got - want).abs() < 1e-10, "{p:?}");
        }
        assert_eq!(
            poly_fit(&[1.0, 1.0, 1.0], &[0.0, 1.0, 2.0], 1),
            Err(CalibrationError::Singular)
        );
    }

    /// The demonstration: samples from a known injected bias curve give back
    /// that curve and the noise level.
    #[test]
    fn recovers_an_injected_bias_curve() {
        let truth = RangeNoiseModel {
            bias_m: Polynomial(vec![0.004, 0.006, -0.0015]),
            sigma_m: Polynomial(vec![0.003, 0.008]),
            sigma_floor_m: 0.001,
        };
        let mut rng = Pcg64Mcg::seed_from_u64(9);
        let samples = simulate_samples(&truth, &PAPER_RANGES_M, 1000, &mut rng);
        let fit = fit_range_noise(&samples, &CalibrationConfig::default()).unwrap();
        assert_eq!(fit.used, 6000);
        assert_eq!(fit.per_range.len(), 6);
        for r in [0.5, 1.25, 2.0, 3.0] {
            assert!(
                (fit.noise.bias_m(r) - truth.bias_m(r)).abs() < 0.0015,
                "bias at {r}: {} vs {}",
                fit.noise.bias_m(r),
                truth.bias_m(r)
            );
            let rel = fit.noise.sigma_m(r) / truth.sigma_m(r);
            assert!((0.93..1.07).contains(&rel), "sigma at {r}: ratio {rel}");
        }
        assert!(fit.bias_fit_rms_m < 0.001, "{}", fit.bias_fit_rms_m);
        for s in &fit.per_range {
            assert_eq!(s.count, 1000);
        }
        // Correcting with the fitted model removes the bias.
        let mean_corrected_error = samples
            .iter()
            .map(|s| fit.noise.corrected_m(s.measured_range_m) - s.true_range_m)
            .sum::<f64>()
            / samples.len() as f64;
        assert!(mean_corrected_error.abs() < 5e-4, "{mean_corrected_error}");
    }

    #[test]
    fn skips_bad_samples_and_refuses_too_few_distances() {
        let mut samples = vec![
            CalibrationSample {
                true_range_m: 1.0,
                measured_range_m: 1.01,
            },
            CalibrationSample {
                true_range_m: 2.0,
                measured_range_m: f64::NAN,
            },
            CalibrationSample {
                true_range_m: -1.0,
                measured_range_m: 1.0,
            },
        ];
        assert_eq!(
            fit_range_noise(&samples, &CalibrationConfig::default()),
            Err(CalibrationError::TooFewDistances {
                degree: 2,
                needed: 3,
                got: 1
            })
        );
        samples.push(CalibrationSample {
            true_range_m: 2.0,
            measured_range_m: 2.02,
        });
        samples.push(CalibrationSample {
            true_range_m: 3.0,
            measured_range_m: 3.03,
        });
        let fit = fit_range_noise(&samples, &CalibrationConfig::default()).unwrap();
        assert_eq!((fit.used, fit.skipped), (3, 2));
        assert!((fit.noise.bias_m(2.5) - 0.025).abs() < 1e-9);
        assert!(matches!(
            fit_range_noise(
                &samples,
                &CalibrationConfig {
                    bias_degree: 7,
                    ..CalibrationConfig::default()
                }
            ),
            Err(CalibrationError::DegreeTooHigh(7))
        ));
    }
}
