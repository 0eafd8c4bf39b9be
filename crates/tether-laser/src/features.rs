//! Geometric features of a segment for the learned leg classifier, in the manner of
//! Arras, Mozos and Burgard, "Using Boosted Features for the Detection of People in 2D
//! Range Data" (ICRA 2007), plus the inscribed angle of Xavier et al. ("Fast line,
//! arc/circle and leg detection from laser scan data", ICRA 2005) and the depth of the
//! neighbouring returns.
//!
//! Three context features look beyond the segment, at the other candidate segments of
//! the scan: a person shows two legs within a stride of each other, a post or a table
//! leg stands alone or in a furniture pattern.
//!
//! Notation: the segment's points are `q_0 .. q_{n-1}` in beam order, `c` their
//! centroid; "the neighbour before" is the return of the beam just before `q_0` (none
//! if that beam has no return or `q_0` is the first beam), likewise after `q_{n-1}`.
//! Distances and depths are clamped to [`FEATURE_CAP_M`], which also stands for "no
//! neighbour": open space is as far as anything gets.

use tether_core::{Laser, Point2};

use crate::fit::{centroid, eigen_sym2, fit_circle, scatter};
use crate::preprocess::ScanPoint;
use crate::segment::Segment;

/// Number of features.
pub const N_FEATURES: usize = 21;

/// Features computed from the segment alone; the rest are context.
pub const N_SEGMENT_FEATURES: usize = 18;

/// A segment's features, in the order of [`FEATURE_NAMES`].
pub type FeatureVector = [f64; N_FEATURES];

/// Names of the features, as model files list them.
pub const FEATURE_NAMES: [&str; N_FEATURES] = [
    "n_points",
    "std_dev_m",
    "mean_abs_dev_from_median_m",
    "jump_prev_m",
    "jump_next_m",
    "width_m",
    "linearity_m2",
    "circularity_m2",
    "radius_m",
    "boundary_length_m",
    "boundary_regularity_m",
    "mean_curvature_per_m",
    "mean_angular_difference_rad",
    "range_m",
    "inscribed_angle_mean_rad",
    "inscribed_angle_std_rad",
    "depth_prev_m",
    "depth_next_m",
    "nearest_candidate_m",
    "nearest_leg_sized_candidate_m",
    "candidates_within_stride",
];

/// Widest first-to-last extent of a segment that can be one leg, m: the widest leg
/// cross-section (0.20 m, SPEC 4.3) plus range noise.
pub const LEG_SIZED_MAX_WIDTH_M: f64 = 0.25;

/// The stride radius of the context features, m: the default largest separation of
/// two legs of one person (SPEC 4.4).
pub const STRIDE_M: f64 = 0.6;

/// A segment that may be a leg, with its features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The segment (indices into the pre-processed points).
    pub segment: Segment,
    /// Mean of its returns, m.
    pub centroid_in_laser: Point2<Laser>,
    /// Its features ([`FEATURE_NAMES`]); the context ones are zero until
    /// [`add_context`] has run.
    pub features: FeatureVector,
}

/// Fills the context features of every candidate of one scan:
///
/// | feature | definition |
/// |---|---|
/// | `nearest_candidate_m` | distance from the centroid to the nearest other candidate's centroid |
/// | `nearest_leg_sized_candidate_m` | the same among candidates with `width_m <=` [`LEG_SIZED_MAX_WIDTH_M`] |
/// | `candidates_within_stride` | number of other candidates whose centroid is within [`STRIDE_M`] |
///
/// Distances are clamped to [`FEATURE_CAP_M`], which also stands for "none".
pub fn add_context(candidates: &mut [Candidate]) {
    let width = FEATURE_NAMES
        .iter()
        .position(|n| *n == "width_m")
        .unwrap_or(5);
    for i in 0..candidates.len() {
        let (mut nearest, mut nearest_leg, mut within) = (FEATURE_CAP_M, FEATURE_CAP_M, 0.0);
        let here = candidates[i].centroid_in_laser;
        for (j, other) in candidates.iter().enumerate() {
            if i == j {
                continue;
            }
            let d = here.distance_m(other.centroid_in_laser);
            nearest = nearest.min(d);
            if other.features[width] <= LEG_SIZED_MAX_WIDTH_M {
                nearest_leg = nearest_leg.min(d);
            }
            if d <= STRIDE_M {
                within += 1.0;
            }
        }
        let f = &mut candidates[i].features;
        f[N_SEGMENT_FEATURES] = nearest;
        f[N_SEGMENT_FEATURES + 1] = nearest_leg;
        f[N_SEGMENT_FEATURES + 2] = within;
    }
}

/// Largest distance a feature takes, m; also the value for "no neighbour".
pub const FEATURE_CAP_M: f64 = 5.0;

/// Reusable buffers for [`segment_features`].
#[derive(Debug, Default, Clone)]
pub struct FeatureScratch {
    xs: Vec<f64>,
    ys: Vec<f64>,
}

fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    let mid = n / 2;
    let (_, upper, _) = values.select_nth_unstable_by(mid, f64::total_cmp);
    let upper = *upper;
    if n % 2 == 1 {
        upper
    } else {
        let lower = values[..mid]
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        0.5 * (lower + upper)
    }
}

/// Angle at `b` between `a - b` and `c - b`, rad in `[0, pi]`.
fn angle_at(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    let (ux, uy) = (a.0 - b.0, a.1 - b.1);
    let (vx, vy) = (c.0 - b.0, c.1 - b.1);
    (ux * vy - uy * vx).abs().atan2(ux * vx + uy * vy)
}

/// +1 when `b` bulges towards the sensor from the chord `a c` (convex, as a leg seen
/// from the sensor), -1 otherwise.
fn bulge_sign(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    let mid = (0.5 * (a.0 + c.0), 0.5 * (a.1 + c.1));
    if mid.0.hypot(mid.1) > b.0.hypot(b.1) {
        1.0
    } else {
        -1.0
    }
}

/// The neighbour of `points[index]` on the beam `index_beam +- 1`, if it has a return.
fn neighbour(
    points: &[ScanPoint],
    index: Option<usize>,
    beam: Option<usize>,
) -> Option<&ScanPoint> {
    let p = points.get(index?)?;
    (Some(p.beam) == beam).then_some(p)
}

/// Computes the features of `segment` of the pre-processed `points`:
///
/// | feature | definition |
/// |---|---|
/// | `n_points` | `n` |
/// | `std_dev_m` | `sqrt(sum |q_i - c|^2 / (n - 1))` |
/// | `mean_abs_dev_from_median_m` | `mean |q_i - med|`, `med` the component-wise median |
/// | `jump_prev_m`, `jump_next_m` | distance from `q_0` (`q_{n-1}`) to the neighbour before (after) |
/// | `width_m` | `|q_{n-1} - q_0|` |
/// | `linearity_m2` | sum of squared distances to the total-least-squares line |
/// | `circularity_m2` | `sum (r - |q_i - o|)^2` for the least-squares circle `(o, r)` (the line's residual when there is no circle) |
/// | `radius_m` | `r` |
/// | `boundary_length_m` | `sum |q_{i+1} - q_i|` |
/// | `boundary_regularity_m` | standard deviation of `|q_{i+1} - q_i|` |
/// | `mean_curvature_per_m` | mean over interior `i` of `4 A / (|a| |b| |c|)`, the curvature of the circle through `q_{i-1}, q_i, q_{i+1}`, positive when `q_i` bulges towards the sensor |
/// | `mean_angular_difference_rad` | mean over interior `i` of the turn between `q_i - q_{i-1}` and `q_{i+1} - q_i`, signed as above |
/// | `range_m` | `|c|` |
/// | `inscribed_angle_mean_rad`, `_std_rad` | mean and standard deviation over interior `j` of the angle `q_0 q_j q_{n-1}` (constant on an arc, pi on a line) |
/// | `depth_prev_m`, `depth_next_m` | range of the neighbour before (after) minus that of `q_0` (`q_{n-1}`): positive when the background is behind |
///
/// Lengths are clamped to [`FEATURE_CAP_M`]. The context features are left at zero
/// (see [`add_context`]). `segment` must not be empty.
pub fn segment_features(
    points: &[ScanPoint],
    segment: Segment,
    scratch: &mut FeatureScratch,
) -> FeatureVector {
    let seg = &points[segment.start..segment.end];
    let n = seg.len();
    let nf = n as f64;
    let xy = |p: &ScanPoint| (p.point_in_laser.x, p.point_in_laser.y);
    let dist = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
    let cap = |v: f64| v.clamp(-FEATURE_CAP_M, FEATURE_CAP_M);

    let c = centroid(seg);
    let (sxx, sxy, syy) = scatter(seg, c);
    let std_dev_m = if n > 1 {
        ((sxx + syy) / (nf - 1.0)).sqrt()
    } else {
        0.0
    };

    scratch.xs.clear();
    scratch.ys.clear();
    scratch.xs.extend(seg.iter().map(|p| p.point_in_laser.x));
    scratch.ys.extend(seg.iter().map(|p| p.point_in_laser.y));
    let med = (median(&mut scratch.xs), median(&mut scratch.ys));
    let mean_abs_dev = seg.iter().map(|p| dist(xy(p), med)).sum::<f64>() / nf;

    let first = &seg[0];
    let last = &seg[n - 1];
    let before = neighbour(
        points,
        segment.start.checked_sub(1),
        first.beam.checked_sub(1),
    );
    let after = neighbour(points, Some(segment.end), Some(last.beam + 1));
    let jump = |q: &ScanPoint, nb: Option<&ScanPoint>| {
        nb.map_or(FEATURE_CAP_M, |nb| cap(dist(xy(q), xy(nb))))
    };
    let depth = |q: &ScanPoint, nb: Option<&ScanPoint>| {
        nb.map_or(FEATURE_CAP_M, |nb| cap(nb.range_m - q.range_m))
    };

    let linearity = eigen_sym2(sxx, sxy, syy).1.max(0.0);
    let (circularity, radius) = match fit_circle(seg, c) {
        Some(circle) => {
            let o = (circle.centre_in_laser.x, circle.centre_in_laser.y);
            let res: f64 = seg
                .iter()
                .map(|p| {
                    let e = circle.radius_m - dist(xy(p), o);
                    e * e
                })
                .sum();
            (res, circle.radius_m.min(FEATURE_CAP_M))
        }
        None => (linearity, FEATURE_CAP_M),
    };

    let (mut boundary, mut boundary_sq) = (0.0, 0.0);
    for w in seg.windows(2) {
        let d = dist(xy(&w[0]), xy(&w[1]));
        boundary += d;
        boundary_sq += d * d;
    }
    let regularity = if n > 2 {
        let k = nf - 1.0;
        ((boundary_sq - boundary * boundary / k) / (k - 1.0))
            .max(0.0)
            .sqrt()
    } else {
        0.0
    };

    let (mut curvature, mut turning) = (0.0, 0.0);
    for w in seg.windows(3) {
        let (a, b, cc) = (xy(&w[0]), xy(&w[1]), xy(&w[2]));
        let sign = bulge_sign(a, b, cc);
        let (la, lb, lc) = (dist(a, b), dist(b, cc), dist(a, cc));
        let twice_area = ((b.0 - a.0) * (cc.1 - a.1) - (b.1 - a.1) * (cc.0 - a.0)).abs();
        let denom = la * lb * lc;
        if denom > 0.0 {
            curvature += sign * 2.0 * twice_area / denom;
        }
        turning += sign * (std::f64::consts::PI - angle_at(a, b, cc));
    }
    let interior = n.saturating_sub(2).max(1) as f64;
    let (mut ia_sum, mut ia_sq) = (0.0, 0.0);
    for q in &seg[1..n.saturating_sub(1).max(1)] {
        let a = angle_at(xy(first), xy(q), xy(last));
        ia_sum += a;
        ia_sq += a * a;
    }
    let (ia_mean, ia_std) = if n > 2 {
        let mean = ia_sum / interior;
        (mean, (ia_sq / interior - mean * mean).max(0.0).sqrt())
    } else {
        (std::f64::consts::PI, 0.0)
    };

    [
        nf,
        cap(std_dev_m),
        cap(mean_abs_dev),
        jump(first, before),
        jump(last, after),
        cap(dist(xy(first), xy(last))),
        linearity.min(FEATURE_CAP_M),
        circularity.min(FEATURE_CAP_M),
        radius,
        cap(boundary),
        cap(regularity),
        (curvature / interior).clamp(-1e3, 1e3),
        turning / interior,
        cap(c.range_m()),
        ia_mean,
        ia_std,
        depth(first, before),
        depth(last, after),
        0.0,
        0.0,
        0.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::tests::points_at;

    fn idx(name: &str) -> usize {
        FEATURE_NAMES.iter().position(|n| *n == name).unwrap()
    }

    #[test]
    fn median_of_even_and_odd() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    #[test]
    fn arc_and_line_features_differ_as_expected() {
        // A leg-sized arc (convex towards the origin) and a straight wall piece.
        let arc: Vec<(f64, f64)> = (0..11)
            .map(|i| {
                let t = std::f64::consts::PI * (0.75 + 0.5 * i as f64 / 10.0);
                (2.0 + 0.06 * t.cos(), 0.06 * t.sin())
            })
            .rev()
            .collect();
        let line: Vec<(f64, f64)> = (0..11).map(|i| (2.0, -0.06 + 0.012 * i as f64)).collect();
        let mut scratch = FeatureScratch::default();
        let fa = segment_features(
            &points_at(&arc),
            Segment { start: 0, end: 11 },
            &mut scratch,
        );
        let fl = segment_features(
            &points_at(&line),
            Segment { start: 0, end: 11 },
            &mut scratch,
        );
        assert_eq!(fa[idx("n_points")], 11.0);
        assert!((fa[idx("radius_m")] - 0.06).abs() < 1e-9);
        assert!(fa[idx("circularity_m2")] < 1e-12);
        assert_eq!(fl[idx("radius_m")], FEATURE_CAP_M, "a line has no circle");
        assert!(fl[idx("linearity_m2")] < 1e-12 && fa[idx("linearity_m2")] > 1e-5);
        assert!(
            fa[idx("mean_curvature_per_m")] > 10.0,
            "convex towards the sensor"
        );
        assert!(fl[idx("mean_curvature_per_m")].abs() < 1e-6);
        assert!((fl[idx("inscribed_angle_mean_rad")] - std::f64::consts::PI).abs() < 1e-9);
        assert!(fa[idx("inscribed_angle_mean_rad")] < 2.5);
        assert!(
            fa[idx("inscribed_angle_std_rad")] < 1e-6,
            "constant on an arc"
        );
        assert!((fl[idx("width_m")] - 0.12).abs() < 1e-9);
        assert!((fl[idx("boundary_length_m")] - 0.12).abs() < 1e-9);
        assert!(fl[idx("boundary_regularity_m")] < 1e-9);
        assert_eq!(fa[idx("jump_prev_m")], FEATURE_CAP_M, "no neighbour");
    }

    #[test]
    fn neighbours_give_jumps_and_depths() {
        // Wall at 3 m, leg-ish bump at 2 m, wall again.
        let mut xy = vec![(3.0, -0.1), (3.0, -0.09)];
        xy.extend((0..5).map(|i| (2.0, -0.02 + 0.01 * i as f64)));
        xy.extend([(3.0, 0.1), (3.0, 0.11)]);
        let pts = points_at(&xy);
        let f = segment_features(
            &pts,
            Segment { start: 2, end: 7 },
            &mut FeatureScratch::default(),
        );
        assert!((f[idx("depth_prev_m")] - (3.0f64.hypot(0.09) - 2.0f64.hypot(0.02))).abs() < 1e-9);
        assert!(f[idx("depth_next_m")] > 0.9);
        assert!(f[idx("jump_prev_m")] > 0.9 && f[idx("jump_next_m")] > 0.9);
        // A gap in beam numbers means no neighbour.
        let mut gappy = pts.clone();
        gappy[1].beam = 0;
        let f = segment_features(
            &gappy,
            Segment { start: 2, end: 7 },
            &mut FeatureScratch::default(),
        );
        assert_eq!(f[idx("depth_prev_m")], FEATURE_CAP_M);
    }

    #[test]
    fn context_counts_neighbours_within_a_stride() {
        let cand = |x: f64, y: f64, width: f64| {
            let mut features = [0.0; N_FEATURES];
            features[idx("width_m")] = width;
            Candidate {
                segment: Segment { start: 0, end: 1 },
                centroid_in_laser: Point2::new(x, y),
                features,
            }
        };
        let mut c = vec![
            cand(2.0, 0.0, 0.1),
            cand(2.0, 0.3, 0.1),
            cand(2.0, -0.5, 1.0),
            cand(9.0, 0.0, 0.1),
        ];
        add_context(&mut c);
        assert!((c[0].features[idx("nearest_candidate_m")] - 0.3).abs() < 1e-12);
        assert_eq!(c[0].features[idx("candidates_within_stride")], 2.0);
        assert!((c[2].features[idx("nearest_leg_sized_candidate_m")] - 0.5).abs() < 1e-12);
        assert!((c[1].features[idx("nearest_leg_sized_candidate_m")] - 0.3).abs() < 1e-12);
        assert_eq!(c[3].features[idx("nearest_candidate_m")], FEATURE_CAP_M);
        assert_eq!(c[3].features[idx("candidates_within_stride")], 0.0);
    }

    #[test]
    fn tiny_segments_are_finite() {
        let mut scratch = FeatureScratch::default();
        for n in 1..4 {
            let xy: Vec<(f64, f64)> = (0..n).map(|i| (1.0, 0.01 * i as f64)).collect();
            let f = segment_features(&points_at(&xy), Segment { start: 0, end: n }, &mut scratch);
            assert!(f.iter().all(|v| v.is_finite()), "{n}: {f:?}");
        }
    }
}
