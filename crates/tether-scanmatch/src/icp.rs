//! Point-to-line ICP (Censi, "An ICP variant using a point-to-line metric", ICRA 2008)
//! solved by Gauss-Newton in SE(2), with trimming, Huber weights, a covariance from the
//! Hessian and degeneracy handled by solution remapping.

use serde::{Deserialize, Serialize};
use tether_core::{Laser, Point2, Pose2, Robot};

use crate::linalg::{Mat3, ZERO3, symmetric_eigen3};
use crate::reference::{LineFit, NeighbourSearch, Reference};

/// Settings of one scan-to-keyframe match.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct IcpConfig {
    /// Most Gauss-Newton iterations (each re-finds the correspondences).
    #[config(range = ">= 1")]
    pub max_iterations: u32,
    /// Converged when a step moves less than this, m...
    #[config(range = "> 0")]
    pub translation_tolerance_m: f64,
    /// ...and turns less than this, rad.
    #[config(range = "> 0")]
    pub rotation_tolerance_rad: f64,
    /// A point whose nearest reference return is farther than this has no match, m.
    #[config(range = "> 0")]
    pub max_correspondence_m: f64,
    /// How the keyframe's surface lines are fitted.
    pub lines: LineFit,
    /// Share of the matched points with the largest residuals left out of each step
    /// (trimmed least squares: a moving person or a new object must not pull).
    #[config(range = ">= 0, < 1")]
    pub trim_fraction: f64,
    /// Huber threshold on the point-to-line residual, m: larger residuals are weighted
    /// by `huber_m / |r|`.
    #[config(range = "> 0")]
    pub huber_m: f64,
    /// After a step shorter than this (and turning less than
    /// `reuse_correspondences_below_rad`) the next iteration keeps the nearest returns
    /// instead of searching again: they no longer change, m. 0 searches every time.
    #[config(range = ">= 0")]
    pub reuse_correspondences_below_m: f64,
    /// See `reuse_correspondences_below_m`, rad.
    #[config(range = ">= 0")]
    pub reuse_correspondences_below_rad: f64,
    /// Fewer matched points than this and the match has failed.
    #[config(range = ">= 3")]
    pub min_matches: usize,
    /// Length that turns a rotation into a distance when the Hessian is judged
    /// (`yaw * rotation_scale_m`), m: about the distance of the scene.
    #[config(range = "> 0")]
    pub rotation_scale_m: f64,
    /// A direction of the normalised Hessian (per unit weight, rotation scaled) whose
    /// eigenvalue is below this is degenerate: the scene does not constrain the motion
    /// along it (a corridor along its axis). Dimensionless: 1 would be a direction that
    /// every residual measures fully.
    #[config(range = "> 0")]
    pub degeneracy_min_eigenvalue: f64,
}

impl Default for IcpConfig {
    fn default() -> Self {
        IcpConfig {
            max_iterations: 25,
            translation_tolerance_m: 1e-3,
            rotation_tolerance_rad: 1e-3,
            max_correspondence_m: 0.3,
            lines: LineFit::default(),
            trim_fraction: 0.05,
            huber_m: 0.03,
            reuse_correspondences_below_m: 0.02,
            reuse_correspondences_below_rad: 0.02,
            min_matches: 12,
            rotation_scale_m: 1.0,
            degeneracy_min_eigenvalue: 0.005,
        }
    }
}

/// Why a match gave no estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatchFailure {
    /// The reference or the scan has too few points.
    TooFewPoints,
    /// Too few points found a reference surface within reach.
    TooFewMatches,
    /// The estimate is not a finite number (never expected; guarded).
    NotFinite,
}

/// The outcome of matching a scan against a keyframe.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchResult {
    /// The scan's robot frame in the keyframe's robot frame.
    pub keyframe_from_robot: Pose2<Robot, Robot>,
    /// Covariance of `(x, y, yaw)` of `keyframe_from_robot`: `sigma^2 H^-1` in the
    /// constrained directions (`sigma^2` the weighted residual variance), the prior's
    /// variance along degenerate ones.
    pub covariance: Mat3,
    /// Points that found a reference surface in the last iteration.
    pub matched: usize,
    /// Residual rows used after trimming (one per point matched to a line, two per
    /// point matched to a point).
    pub used: usize,
    /// Points offered to the match.
    pub candidates: usize,
    /// Mean absolute point-to-line residual of the used points, m.
    pub mean_residual_m: f64,
    /// Iterations run.
    pub iterations: u32,
    /// The last step was within the tolerances.
    pub converged: bool,
    /// Eigenvalues of the normalised Hessian, ascending (see
    /// [`IcpConfig::degeneracy_min_eigenvalue`]).
    pub eigenvalues: [f64; 3],
    /// Unit eigenvectors over `(x, y, yaw * rotation_scale_m)`, with `eigenvalues`.
    pub eigenvectors: [[f64; 3]; 3],
    /// How many directions were degenerate (taken from the guess, not the scan).
    pub degenerate_directions: usize,
}

/// Bins of the residual histogram that trimming reads its quantile from.
const TRIM_BINS: usize = 512;

/// Reusable buffers of [`match_scan`], so that matching does not allocate.
#[derive(Debug, Clone, Default)]
pub struct IcpScratch {
    rows: Vec<[f64; 4]>,
    /// Per point: the reference index its search found last iteration.
    hints: Vec<usize>,
    /// Per point: its reference return (`u32::MAX`: none) from the last search.
    matches: Vec<u32>,
    histogram: Vec<u32>,
}

/// The residual above which a row is trimmed so that `keep` rows remain: the
/// `keep`-th smallest `|r|` read off a histogram of `|r|` (bins of
/// `max_correspondence / TRIM_BINS`; a residual is never trimmed for less than a bin's
/// width), infinite when the last bin is reached.
fn trim_threshold(
    rows: &[[f64; 4]],
    keep: usize,
    config: &IcpConfig,
    histogram: &mut Vec<u32>,
) -> f64 {
    let top = config.max_correspondence_m.max(1e-6);
    let per_bin = TRIM_BINS as f64 / top;
    histogram.clear();
    histogram.resize(TRIM_BINS + 1, 0);
    for row in rows {
        let b = ((row[3].abs() * per_bin) as usize).min(TRIM_BINS);
        histogram[b] += 1;
    }
    let mut count = 0usize;
    let mut threshold = f64::INFINITY;
    for (b, &c) in histogram.iter().enumerate() {
        count += c as usize;
        if count >= keep {
            threshold = if b == TRIM_BINS {
                f64::INFINITY
            } else {
                (b + 1) as f64 / per_bin
            };
            break;
        }
    }
    threshold
}

/// The Gauss-Newton system of one iteration, from the rows kept.
struct NormalEquations {
    /// `sum w J^T J` (scaled yaw column).
    h: Mat3,
    /// `sum w J^T r`.
    g: [f64; 3],
    /// `sum w`.
    weight_sum: f64,
    /// `sum w r^2`.
    weighted_sq: f64,
    /// `sum |r|`.
    abs_sum: f64,
    /// Rows kept.
    used: usize,
}

/// [`NormalEquations`] over `rows` (`[J_x, J_y, J_yaw, r]`) whose `|r|` is at most
/// `threshold`, each weighted by Huber's rule with `huber_m` (`w = 1` up to it,
/// `huber_m / |r|` beyond).
fn normal_equations(rows: &[[f64; 4]], threshold: f64, huber_m: f64) -> NormalEquations {
    let mut h = ZERO3;
    let mut g = [0.0; 3];
    let mut weight_sum = 0.0;
    let mut weighted_sq = 0.0;
    let mut abs_sum = 0.0;
    let mut used = 0usize;
    for row in rows {
        let r = row[3];
        let ar = r.abs();
        if ar > threshold {
            continue;
        }
        let w = if ar <= huber_m { 1.0 } else { huber_m / ar };
        for i in 0..3 {
            for k in i..3 {
                h[i][k] += w * row[i] * row[k];
            }
            g[i] += w * row[i] * r;
        }
        weight_sum += w;
        weighted_sq += w * r * r;
        abs_sum += ar;
        used += 1;
    }
    h[1][0] = h[0][1];
    h[2][0] = h[0][2];
    h[2][1] = h[1][2];
    NormalEquations {
        h,
        g,
        weight_sum,
        weighted_sq,
        abs_sum,
        used,
    }
}

/// Matches `points` (the new scan, its robot frame) against `reference` (the keyframe),
/// starting from `guess` (`keyframe_from_robot`), with `prior_covariance` (the guess's
/// uncertainty, used along degenerate directions).
///
/// Each iteration, for every point `q` at the current estimate `T = (t, yaw)`:
/// 1. find its nearest reference return `p_j` (exactly, by direction: see
///    [`Reference::nearest`]); the line of the surface there (unit normal `n`, point
///    `a`, fitted to the returns around `p_j`: see [`Reference`]) is what it is matched
///    to (PL-ICP: the point is matched to the line through its nearest returns);
/// 2. residual `r = n . (R q + t - a)`, Jacobian over `(x, y, yaw)`
///    `J = [n_x, n_y, n . perp(R q)]` with `perp(v) = (-v_y, v_x)`; where the reference
///    has no line (a chair or table leg, a corner) the point is matched to `p_j` itself
///    by two such rows with `n = (1, 0)` and `(0, 1)`;
/// 3. the worst `trim_fraction` of `|r|` are dropped, the rest weighted by Huber;
/// 4. Gauss-Newton: `H = sum w J^T J`, `g = sum w J^T r`, step `d = -H^-1 g`, taken only
///    along eigenvectors of `H` whose normalised eigenvalue passes the degeneracy
///    threshold; along the others the estimate keeps the guess (solution remapping,
///    Zhang, Kaess and Singh, ICRA 2016).
pub fn match_scan(
    reference: &Reference,
    points: &[Point2<Robot>],
    guess: Pose2<Robot, Robot>,
    prior_covariance: &Mat3,
    config: &IcpConfig,
    search: NeighbourSearch,
    scratch: &mut IcpScratch,
) -> Result<MatchResult, MatchFailure> {
    let min_points = config.min_matches.max(3);
    if reference.len() < 2 || points.len() < min_points {
        return Err(MatchFailure::TooFewPoints);
    }
    let laser_from_robot = reference.laser_from_robot();
    let scale = config.rotation_scale_m.max(1e-6);
    let inv_scale = 1.0 / scale;
    let mut estimate = guess;
    let mut converged = false;
    let mut iterations = 0;
    let mut stats = Stats::default();
    let mut last_step = (f64::INFINITY, f64::INFINITY);
    scratch.hints.clear();
    for _ in 0..config.max_iterations.max(1) {
        iterations += 1;
        let laser_from_scan = laser_from_robot * estimate;
        // Sines and cosines once per iteration, not once per point.
        let (s, c) = estimate.yaw.sin_cos();
        let (ls, lc) = laser_from_scan.yaw.sin_cos();
        // Once the steps are small the nearest returns no longer change: keep them.
        let fresh = iterations == 1
            || last_step.0 >= config.reuse_correspondences_below_m
            || last_step.1 >= config.reuse_correspondences_below_rad;
        if fresh {
            scratch.matches.clear();
        }
        scratch.rows.clear();
        let mut matched = 0usize;
        let mut previous = 0usize;
        for (i, &q) in points.iter().enumerate() {
            let rq = (c * q.x - s * q.y, s * q.x + c * q.y);
            let qr = Point2::<Robot>::new(rq.0 + estimate.x, rq.1 + estimate.y);
            let index = if fresh {
                let ql = Point2::<Laser>::new(
                    lc * q.x - ls * q.y + laser_from_scan.x,
                    ls * q.x + lc * q.y + laser_from_scan.y,
                );
                // Where this point's direction fell last time, or where the previous
                // point's fell: points come in beam order.
                let hint = scratch.hints.get(i).copied().unwrap_or(previous);
                let found =
                    reference.nearest_by(search, ql, config.max_correspondence_m, Some(hint));
                let next_hint = found.map_or(hint, |n| n.index);
                if let Some(slot) = scratch.hints.get_mut(i) {
                    *slot = next_hint;
                } else {
                    scratch.hints.push(next_hint);
                }
                previous = next_hint;
                let index = found.map_or(u32::MAX, |n| n.index as u32);
                scratch.matches.push(index);
                index
            } else {
                scratch.matches.get(i).copied().unwrap_or(u32::MAX)
            };
            if index == u32::MAX {
                continue;
            }
            let near_index = index as usize;
            matched += 1;
            match reference.line(near_index) {
                Some(line) => {
                    let (nx, ny) = line.normal;
                    let p = line.anchor;
                    let r = nx * (qr.x - p.x) + ny * (qr.y - p.y);
                    let j_yaw = nx * -rq.1 + ny * rq.0;
                    scratch.rows.push([nx, ny, j_yaw * inv_scale, r]);
                }
                None => {
                    // No line there (a chair leg, a corner): point to point, as two
                    // rows with normals x and y.
                    let p = reference.points()[near_index];
                    scratch.rows.push([1.0, 0.0, -rq.1 * inv_scale, qr.x - p.x]);
                    scratch.rows.push([0.0, 1.0, rq.0 * inv_scale, qr.y - p.y]);
                }
            }
        }
        let rows = scratch.rows.len();
        if matched < min_points {
            return Err(MatchFailure::TooFewMatches);
        }
        // Trimming: keep residuals up to the (1 - trim) quantile, read off a histogram
        // of |r| (bins of max_correspondence / TRIM_BINS; a residual is never
        // trimmed for less than a bin's width).
        let keep = ((rows as f64) * (1.0 - config.trim_fraction.clamp(0.0, 0.9))).ceil() as usize;
        let keep = keep.clamp(min_points.min(rows), rows);
        let threshold = if keep < rows {
            trim_threshold(&scratch.rows, keep, config, &mut scratch.histogram)
        } else {
            f64::INFINITY
        };
        let NormalEquations {
            h,
            g,
            weight_sum,
            weighted_sq,
            abs_sum,
            used,
        } = normal_equations(&scratch.rows, threshold, config.huber_m);
        let normalised = h.map(|row| row.map(|v| v / weight_sum.max(1e-12)));
        let (values, vectors) = symmetric_eigen3(&normalised);
        // Step along the constrained eigenvectors only: d = -sum_k (v_k . g) / l_k v_k,
        // with l_k the eigenvalue of H (not normalised).
        let mut step = [0.0; 3];
        let mut degenerate = 0;
        for k in 0..3 {
            if values[k] < config.degeneracy_min_eigenvalue {
                degenerate += 1;
                continue;
            }
            let v = vectors[k];
            let vg = v[0] * g[0] + v[1] * g[1] + v[2] * g[2];
            let lambda = values[k] * weight_sum;
            for i in 0..3 {
                step[i] -= vg / lambda * v[i];
            }
        }
        let step_yaw = step[2] / scale;
        estimate = Pose2::new(
            estimate.x + step[0],
            estimate.y + step[1],
            estimate.yaw + step_yaw,
        );
        stats = Stats {
            matched,
            used,
            weight_sum,
            weighted_sq,
            abs_sum,
            values,
            vectors,
            degenerate,
        };
        last_step = (
            (step[0] * step[0] + step[1] * step[1]).sqrt(),
            step_yaw.abs(),
        );
        if last_step.0 < config.translation_tolerance_m
            && last_step.1 < config.rotation_tolerance_rad
        {
            converged = true;
            break;
        }
    }
    if !estimate.is_finite() {
        return Err(MatchFailure::NotFinite);
    }
    let covariance = covariance(&stats, prior_covariance, config);
    Ok(MatchResult {
        keyframe_from_robot: estimate.normalized(),
        covariance,
        matched: stats.matched,
        used: stats.used,
        candidates: points.len(),
        mean_residual_m: stats.abs_sum / stats.used.max(1) as f64,
        iterations,
        converged,
        eigenvalues: stats.values,
        eigenvectors: stats.vectors,
        degenerate_directions: stats.degenerate,
    })
}

#[derive(Debug, Clone, Default)]
struct Stats {
    matched: usize,
    used: usize,
    weight_sum: f64,
    weighted_sq: f64,
    abs_sum: f64,
    values: [f64; 3],
    vectors: [[f64; 3]; 3],
    degenerate: usize,
}

/// `Sigma = sum_k c_k v_k v_k^T` over the eigenvectors of the Hessian (in the scaled
/// parameters `z = (x, y, yaw * L)`): `c_k = sigma^2 / lambda_k` where the scan
/// constrains the motion, with `sigma^2 = sum w r^2 / (sum w - 3)` the residual variance
/// (Bengtsson and Baerveldt's Hessian estimate); `c_k = v_k^T P_z v_k` (the prior's
/// variance) along degenerate directions. Mapped back to `(x, y, yaw)` by
/// `D Sigma_z D`, `D = diag(1, 1, 1/L)`.
///
/// The Hessian estimate assumes independent residuals and right correspondences; it is
/// optimistic for real scans (a known limitation of ICP covariances, Censi ICRA 2007).
fn covariance(stats: &Stats, prior: &Mat3, config: &IcpConfig) -> Mat3 {
    let scale = config.rotation_scale_m.max(1e-6);
    let d = [1.0, 1.0, 1.0 / scale];
    let prior_z: Mat3 =
        std::array::from_fn(|i| std::array::from_fn(|k| prior[i][k] / (d[i] * d[k])));
    let dof = (stats.weight_sum - 3.0).max(1.0);
    // Residuals are never exactly zero in a real sensor; keep a floor of 1 mm.
    let sigma_sq = (stats.weighted_sq / dof).max(1e-6);
    let mut cov_z = ZERO3;
    for k in 0..3 {
        let v = stats.vectors[k];
        let c = if stats.values[k] >= config.degeneracy_min_eigenvalue {
            sigma_sq / (stats.values[k] * stats.weight_sum)
        } else {
            let pv: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| prior_z[i][j] * v[j]).sum());
            (0..3).map(|i| v[i] * pv[i]).sum()
        };
        for i in 0..3 {
            for j in 0..3 {
                cov_z[i][j] += c * v[i] * v[j];
            }
        }
    }
    std::array::from_fn(|i| std::array::from_fn(|k| cov_z[i][k] * d[i] * d[k]))
}
