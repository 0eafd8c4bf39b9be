//! Camera calibration for monocular ranging (`tether calibrate camera`): from boxes of a
//! person standing at known distances, estimate the camera tilt `t` (and the fraction `m`
//! of the box above the head) that make the paper's eq. 1 fit, and report the residuals.
//!
//! For each sample `i` with measured floor distance `D_i` and box `(x, y, w, h)`, the model
//! of [`crate::monocular`] predicts the floor distance `d_i(t, m)` from the reference point
//! `(x + w/2, y + m h)`. Least squares, `min sum (d_i - D_i)^2`, is solved by
//! Gauss-Newton with a Levenberg-Marquardt damping; the start is the mean of the per-sample
//! tilts that eq. 1 gives exactly with `m = 0`:
//! `t_i = atan((Hm - Hc) / D_i) - atan((cy - v_i) / fy)`.
//! The margin is only identifiable when the boxes have different heights (a person at
//! different distances); with `fit_margin = false` it is held at the given value.
//! Standard errors come from `s^2 (J^T J)^-1` with `s^2 = sum r^2 / (n - p)`.

use thiserror::Error;

use tether_core::{CameraModel, PixelBox};

use crate::monocular::{MonocularError, MonocularParams, locate};

/// One observation: a box of the person and the true floor distance from the camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationSample {
    /// Horizontal distance from the camera lens to the person, m.
    pub distance_m: f64,
    /// The detector's box of the person's upper body, px.
    pub bbox: PixelBox,
}

/// The fitted tilt and margin.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationResult {
    /// Camera tilt (upward pitch), rad.
    pub tilt_rad: f64,
    /// Standard error of the tilt, rad (0 when there are no spare samples).
    pub tilt_sigma_rad: f64,
    /// Fraction of the box above the head.
    pub margin_frac: f64,
    /// Standard error of the margin (0 when not fitted).
    pub margin_sigma: f64,
    /// Whether the margin was fitted (else held).
    pub margin_fitted: bool,
    /// Predicted minus measured distance for each sample, m.
    pub residuals_m: Vec<f64>,
    /// Root mean square of the residuals, m.
    pub rms_m: f64,
    /// Gauss-Newton iterations used.
    pub iterations: usize,
}

/// Why a calibration cannot be computed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CalibrationError {
    /// Not enough samples for the unknowns.
    #[error(
        "{have} samples are too few to fit {what}: give at least {need}, with the person at \
         clearly different distances (e.g. 1.5, 2, 3 and 4 m)"
    )]
    TooFewSamples {
        /// Samples given.
        have: usize,
        /// Samples needed.
        need: usize,
        /// The unknowns.
        what: &'static str,
    },
    /// A sample is unusable.
    #[error("sample {index}: {why}")]
    BadSample {
        /// 0-based index.
        index: usize,
        /// What is wrong.
        why: String,
    },
    /// The data do not determine the unknowns.
    #[error(
        "the samples cannot separate the tilt from the box margin (the boxes have nearly the \
         same height); add distances closer and farther, or hold the margin fixed"
    )]
    Degenerate,
    /// The model could not be evaluated near the solution.
    #[error(
        "no consistent tilt found: {0}; check the distances, the camera height and the head height"
    )]
    Model(#[from] MonocularError),
}

/// Floor distance predicted for one sample at tilt `t` and margin `m`.
fn predicted(
    camera: &CameraModel,
    params: &MonocularParams,
    s: &CalibrationSample,
    tilt: f64,
    margin: f64,
) -> Result<f64, MonocularError> {
    let mut cam = *camera;
    cam.mount.tilt_rad = tilt;
    let p = MonocularParams {
        margin_frac: margin.clamp(0.0, 0.99),
        ..*params
    };
    let fix = locate(&cam, &s.bbox, &p)?;
    Ok(fix.forward_m.hypot(fix.left_m))
}

/// The tilt to start the fit from: the mean over the samples of the tilt that puts each
/// box's reference row at its distance (`atan(a / d) - atan((cy - v) / fy)`, `a` the head
/// above the camera); each sample is checked on the way.
fn start_tilt(
    camera: &CameraModel,
    params: &MonocularParams,
    samples: &[CalibrationSample],
) -> Result<f64, CalibrationError> {
    let i = &camera.intrinsics;
    let a = params.head_height_m - camera.mount.height_m;
    let mut start_tilts = Vec::with_capacity(samples.len());
    for (index, s) in samples.iter().enumerate() {
        let b = &s.bbox;
        if !(s.distance_m.is_finite() && s.distance_m > 0.0) {
            return Err(CalibrationError::BadSample {
                index,
                why: format!("distance {} m must be positive", s.distance_m),
            });
        }
        if !(b.x.is_finite()
            && b.y.is_finite()
            && b.w > 0.0
            && b.h > 0.0
            && b.w.is_finite()
            && b.h.is_finite())
        {
            return Err(CalibrationError::BadSample {
                index,
                why: format!("box {b:?} is not a finite box of positive size"),
            });
        }
        let (_, v) = b.reference_point(params.margin_frac);
        start_tilts.push((a / s.distance_m).atan() - ((i.cy_px - v) / i.fy_px).atan());
    }
    Ok(start_tilts.iter().sum::<f64>() / start_tilts.len() as f64)
}

/// The standard errors of the tilt and the margin from the Jacobian `j` at the fit and
/// the residuals' sum of squares `sse` (`s^2 = sse / (n - unknowns)`, the diagonal of
/// `s^2 (J^T J)^-1`); [`CalibrationError::Degenerate`] when the margin cannot be told from
/// the tilt.
fn standard_errors(
    j: &[[f64; 2]],
    sse: f64,
    unknowns: usize,
) -> Result<(f64, f64), CalibrationError> {
    let n = j.len() as f64;
    let s2 = if j.len() > unknowns {
        sse / (n - unknowns as f64)
    } else {
        0.0
    };
    if unknowns == 1 {
        let jtj: f64 = j.iter().map(|c| c[0] * c[0]).sum();
        return Ok(((s2 / jtj).sqrt(), 0.0));
    }
    let (mut a00, mut a01, mut a11) = (0.0, 0.0, 0.0);
    for c in j {
        a00 += c[0] * c[0];
        a01 += c[0] * c[1];
        a11 += c[1] * c[1];
    }
    let det = a00 * a11 - a01 * a01;
    // The two columns nearly parallel (correlation above 0.9995): the margin cannot be
    // told from the tilt.
    if det.is_nan() || det <= 1e-3 * a00 * a11 {
        return Err(CalibrationError::Degenerate);
    }
    Ok(((s2 * a11 / det).sqrt(), (s2 * a00 / det).sqrt()))
}

/// Fits the tilt (and the margin when `fit_margin`) to the samples. `camera` gives the
/// intrinsics and mounting height (its tilt is ignored); `params` the head height and the
/// margin to hold when `fit_margin` is false.
pub fn calibrate_camera(
    camera: &CameraModel,
    params: &MonocularParams,
    samples: &[CalibrationSample],
    fit_margin: bool,
) -> Result<CalibrationResult, CalibrationError> {
    params.validate()?;
    let unknowns = if fit_margin { 2 } else { 1 };
    let need = unknowns + 1;
    if samples.len() < need {
        return Err(CalibrationError::TooFewSamples {
            have: samples.len(),
            need,
            what: if fit_margin {
                "the tilt and the box margin"
            } else {
                "the tilt"
            },
        });
    }
    let mut theta = [start_tilt(camera, params, samples)?, params.margin_frac];

    let residuals = |t: &[f64; 2]| -> Result<Vec<f64>, MonocularError> {
        samples
            .iter()
            .map(|s| Ok(predicted(camera, params, s, t[0], t[1])? - s.distance_m))
            .collect()
    };
    let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
    let jacobian = |t: &[f64; 2]| -> Result<Vec<[f64; 2]>, MonocularError> {
        let steps = [1e-6, 1e-5];
        let mut cols = vec![[0.0; 2]; samples.len()];
        for (k, h) in steps.iter().enumerate().take(unknowns) {
            let mut up = *t;
            let mut down = *t;
            up[k] += h;
            down[k] -= h;
            for ((c, s), _) in cols.iter_mut().zip(samples).zip(0..) {
                c[k] = (predicted(camera, params, s, up[0], up[1])?
                    - predicted(camera, params, s, down[0], down[1])?)
                    / (2.0 * h);
            }
        }
        Ok(cols)
    };

    let mut r = residuals(&theta)?;
    let mut lambda = 1e-3;
    let mut iterations = 0;
    for _ in 0..100 {
        iterations += 1;
        let j = jacobian(&theta)?;
        // Normal equations (J^T J + lambda diag) delta = -J^T r, 1x1 or 2x2.
        let mut jtj = [[0.0f64; 2]; 2];
        let mut jtr = [0.0f64; 2];
        for (row, res) in j.iter().zip(&r) {
            for p in 0..unknowns {
                jtr[p] += row[p] * res;
                for q in 0..unknowns {
                    jtj[p][q] += row[p] * row[q];
                }
            }
        }
        let solve = |l: f64| -> Option<[f64; 2]> {
            let m00 = jtj[0][0] * (1.0 + l);
            if unknowns == 1 {
                return (m00 > 0.0).then(|| [-jtr[0] / m00, 0.0]);
            }
            let m11 = jtj[1][1] * (1.0 + l);
            let det = m00 * m11 - jtj[0][1] * jtj[1][0];
            (det.abs() > 1e-300).then(|| {
                [
                    -(m11 * jtr[0] - jtj[0][1] * jtr[1]) / det,
                    -(m00 * jtr[1] - jtj[1][0] * jtr[0]) / det,
                ]
            })
        };
        let Some(delta) = solve(lambda) else {
            return Err(CalibrationError::Degenerate);
        };
        let candidate = [theta[0] + delta[0], (theta[1] + delta[1]).clamp(0.0, 0.99)];
        match residuals(&candidate) {
            Ok(rc) if cost(&rc) <= cost(&r) => {
                let converged = (delta[0].abs() < 1e-12 && delta[1].abs() < 1e-10)
                    || cost(&r) - cost(&rc) < 1e-18;
                theta = candidate;
                r = rc;
                lambda = (lambda * 0.3).max(1e-12);
                if converged {
                    break;
                }
            }
            _ => {
                lambda *= 10.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
    }

    // Standard errors and the identifiability of the margin.
    let j = jacobian(&theta)?;
    let n = samples.len() as f64;
    let (tilt_sigma, margin_sigma) = standard_errors(&j, cost(&r), unknowns)?;
    let rms = (cost(&r) / n).sqrt();
    Ok(CalibrationResult {
        tilt_rad: theta[0],
        tilt_sigma_rad: tilt_sigma,
        margin_frac: theta[1],
        margin_sigma,
        margin_fitted: fit_margin,
        residuals_m: r,
        rms_m: rms,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Point3, Robot};

    /// Boxes of a person of head height `hm` at the given distances, seen by `cam`, with a
    /// box whose top is `margin` of its height above the head, and `noise_px` added to the
    /// top row (a fixed pattern, so the test is deterministic).
    fn samples(
        cam: &CameraModel,
        hm: f64,
        margin: f64,
        distances: &[f64],
        noise_px: &[f64],
    ) -> Vec<CalibrationSample> {
        distances
            .iter()
            .zip(noise_px.iter().cycle())
            .map(|(&d, &noise)| {
                let lens = Point3::<Robot>::new(cam.mount.x_m + d, 0.0, hm);
                let (u, v_head) = cam.project(lens).unwrap();
                // Box height shrinks with distance (a 0.6 m tall upper body).
                let h = cam.intrinsics.fy_px * 0.6 / d;
                CalibrationSample {
                    distance_m: d,
                    bbox: PixelBox {
                        x: u - 0.4 * h,
                        y: v_head - margin * h + noise,
                        w: 0.8 * h,
                        h,
                    },
                }
            })
            .collect()
    }

    #[test]
    fn recovers_tilt_and_margin_from_clean_data() {
        let mut cam = CameraModel::default();
        cam.mount.tilt_rad = 0.31;
        let truth_margin = 0.12;
        let data = samples(
            &cam,
            1.72,
            truth_margin,
            &[1.2, 1.6, 2.0, 2.5, 3.0, 4.0, 5.0],
            &[0.0],
        );
        let mut guess = cam;
        guess.mount.tilt_rad = 0.0;
        let params = MonocularParams {
            head_height_m: 1.72,
            ..MonocularParams::default()
        };
        let fit = calibrate_camera(&guess, &params, &data, true).unwrap();
        assert!((fit.tilt_rad - 0.31).abs() < 1e-6, "{fit:?}");
        assert!((fit.margin_frac - truth_margin).abs() < 1e-5, "{fit:?}");
        assert!(fit.rms_m < 1e-6);
    }

    #[test]
    fn noisy_rows_give_small_residuals_and_honest_errors() {
        let mut cam = CameraModel::default();
        cam.mount.tilt_rad = 0.25;
        let noise = [1.0, -1.5, 0.5, 2.0, -0.5, -1.0, 1.5];
        let data = samples(
            &cam,
            1.75,
            0.0,
            &[1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5],
            &noise,
        );
        let params = MonocularParams {
            head_height_m: 1.75,
            ..MonocularParams::default()
        };
        let fit = calibrate_camera(&cam, &params, &data, false).unwrap();
        assert!(
            (fit.tilt_rad - 0.25).abs() < 3.0 * fit.tilt_sigma_rad + 1e-4,
            "{fit:?}"
        );
        assert!(fit.tilt_sigma_rad > 0.0 && fit.tilt_sigma_rad < 0.01);
        assert!(fit.rms_m > 0.0 && fit.rms_m < 0.1, "{fit:?}");
        assert_eq!(fit.residuals_m.len(), data.len());
    }

    #[test]
    fn refuses_what_cannot_be_fitted() {
        let cam = CameraModel::default();
        let params = MonocularParams::default();
        let data = samples(&cam, 1.7, 0.0, &[2.0, 3.0], &[0.0]);
        assert!(matches!(
            calibrate_camera(&cam, &params, &data, true),
            Err(CalibrationError::TooFewSamples { need: 3, .. })
        ));
        let mut bad = data.clone();
        bad[0].distance_m = -1.0;
        assert!(matches!(
            calibrate_camera(&cam, &params, &bad, false),
            Err(CalibrationError::BadSample { index: 0, .. })
        ));
        // Same box height at every distance: margin and tilt cannot be separated.
        let mut same = samples(&cam, 1.7, 0.0, &[2.0, 3.0, 4.0, 5.0], &[0.0]);
        for s in &mut same {
            s.bbox.h = 100.0;
        }
        assert!(matches!(
            calibrate_camera(&cam, &params, &same, true),
            Err(CalibrationError::Degenerate)
        ));
    }
}
