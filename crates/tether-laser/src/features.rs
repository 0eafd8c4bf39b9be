//! Features of a cluster of returns for the learned leg classifier, in three groups:
//!
//! - 18 of the cluster and the beams beside it ([`segment_features`]): those of Arras,
//!   Mozos and Burgard, "Using Boosted Features for the Detection of People in 2D Range
//!   Data" (ICRA 2007), plus the inscribed angle of Xavier et al. ("Fast line,
//!   arc/circle and leg detection from laser scan data", ICRA 2005) and the depth of the
//!   neighbouring returns. leg_tracker's (Leigh et al., ICRA 2015) are among them or
//!   carried by them (its occlusion flags are the signs of the depths).
//! - 4 of the free space around the cluster, from the whole scan ([`segment_features`]).
//! - 3 of the other candidates ([`add_context`]): a person shows two legs within a
//!   stride of each other, a post or a table leg stands alone or in a furniture
//!   pattern.
//!
//! On the training split of leg_tracker's recordings, cross-validation (four folds,
//! one recording of legs each) gives the learned detector an F1 of 0.81 with all of
//! them, 0.74 without the free-space group, 0.76 without the other candidates and 0.57
//! without both. Free space measured out to 1.5 and 2 m lowered it (0.69 against 0.79
//! in an exploration with 200 trees of depth 2): the layout of the room, which
//! differs between recordings, then outweighs the leg (the crate's README has the
//! table).
//!
//! Notation: the cluster's returns are `q_0 .. q_{n-1}` in beam order, `c` their
//! centroid; "the neighbour before" is the return of the beam just before `q_0` (none
//! if that beam has no return or `q_0` is the first beam), likewise after `q_{n-1}`.
//! Distances and depths are clamped to [`FEATURE_CAP_M`], which also stands for "no
//! neighbour": open space is as far as anything gets.

use tether_core::{Laser, Point2};

use crate::fit::{centroid, eigen_sym2, fit_circle, scatter};
use crate::preprocess::ScanPoint;
use crate::segment::Segment;

/// Number of features.
pub const N_FEATURES: usize = 25;

/// Features computed from the segment alone (its returns and the returns of the beams
/// next to it); the next [`N_SCAN_FEATURES`] look at the rest of the scan, the last
/// three at the other candidates.
pub const N_SEGMENT_FEATURES: usize = 18;

/// Number of free-space features (the returns of the scan around the segment).
pub const N_SCAN_FEATURES: usize = 4;

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
    "nearest_return_m",
    "surface_within_0_3_m",
    "surface_within_0_5_m",
    "surface_within_1_0_m",
    "nearest_candidate_m",
    "nearest_leg_sized_candidate_m",
    "candidates_within_stride",
];

/// Radii of the `surface_within_*` features, m.
pub const SURFACE_RADII_M: [f64; 3] = [0.3, 0.5, 1.0];

/// Widest first-to-last extent of a segment that can be one leg, m: the widest leg
/// cross-section (0.20 m, design 4.3) plus range noise.
pub const LEG_SIZED_MAX_WIDTH_M: f64 = 0.25;

/// The stride radius of the context features, m: the default largest separation of
/// two legs of one person (design 4.4).
pub const STRIDE_M: f64 = 0.6;

/// A segment that may be a leg, with its features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// The cluster (a range of the detector's clustered points).
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
    const FIRST: usize = N_SEGMENT_FEATURES + N_SCAN_FEATURES;
    const WIDTH: usize = 5;
    // Each pair once: `a - b` is exactly `-(b - a)`, so both see the same squared
    // distance. The nearest distances are kept squared: `sqrt` is correctly rounded,
    // hence monotone, and the square root of the least square is the least distance.
    // Only squares near the stride need the distance itself.
    let stride_sq_above = 1.01 * STRIDE_M * STRIDE_M;
    for f in candidates.iter_mut().map(|c| &mut c.features) {
        f[FIRST] = f64::INFINITY;
        f[FIRST + 1] = f64::INFINITY;
        f[FIRST + 2] = 0.0;
    }
    for i in 0..candidates.len() {
        let (head, tail) = candidates.split_at_mut(i + 1);
        let a = &mut head[i];
        let a_leg_sized = a.features[WIDTH] <= LEG_SIZED_MAX_WIDTH_M;
        // `a`'s own in locals, not read back from memory pair after pair.
        let [mut nearest, mut nearest_leg, mut within] =
            [FIRST, FIRST + 1, FIRST + 2].map(|k| a.features[k]);
        for b in tail {
            let v = a.centroid_in_laser - b.centroid_in_laser;
            let d_sq = v.x * v.x + v.y * v.y;
            nearest = nearest.min(d_sq);
            b.features[FIRST] = b.features[FIRST].min(d_sq);
            // A select, not a branch on widths the CPU cannot predict (the minimum
            // with infinity changes nothing).
            let leg_sized = b.features[WIDTH] <= LEG_SIZED_MAX_WIDTH_M;
            nearest_leg = nearest_leg.min(if leg_sized { d_sq } else { f64::INFINITY });
            if a_leg_sized {
                b.features[FIRST + 1] = b.features[FIRST + 1].min(d_sq);
            }
            if d_sq < stride_sq_above && d_sq.sqrt() <= STRIDE_M {
                within += 1.0;
                b.features[FIRST + 2] += 1.0;
            }
        }
        (
            a.features[FIRST],
            a.features[FIRST + 1],
            a.features[FIRST + 2],
        ) = (nearest, nearest_leg, within);
    }
    for f in candidates.iter_mut().map(|c| &mut c.features) {
        f[FIRST] = FEATURE_CAP_M.min(f[FIRST].sqrt());
        f[FIRST + 1] = FEATURE_CAP_M.min(f[FIRST + 1].sqrt());
    }
}

/// The whole scan, as the features of one cluster see it.
#[derive(Debug, Clone, Copy)]
pub struct ScanView<'a> {
    /// The pre-processed returns, in beam order.
    pub points: &'a [ScanPoint],
    /// The cluster of each of `points` (by index).
    pub cluster_of: &'a [u32],
    /// The scan's angle increment, rad.
    pub angle_increment_rad: f64,
}

impl ScanView<'_> {
    /// The return of beam `beam`, if it has one.
    fn at_beam(&self, beam: Option<usize>) -> Option<&ScanPoint> {
        let beam = beam?;
        let k = self.points.partition_point(|p| p.beam < beam);
        self.points.get(k).filter(|p| p.beam == beam)
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

/// Angle at `b` between `a - b` and `c - b`, rad in `[0, pi]`:
/// `atan2(|u x v|, u . v)` ([`atan2_upper`]).
fn angle_at(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    let (ux, uy) = (a.0 - b.0, a.1 - b.1);
    let (vx, vy) = (c.0 - b.0, c.1 - b.1);
    atan2_upper((ux * vy - uy * vx).abs(), ux * vx + uy * vy)
}

/// `atan2(y, x)` for `y >= 0`, in `[0, pi]`, within 4e-8 rad: the octant is reduced
/// to `t = min / max` of `|x|`, `y` in `[0, 1]`, and `atan(t)` is Abramowitz and
/// Stegun's polynomial 4.4.47 (odd, degree 15). Several times cheaper than the
/// library's `atan2`; the features need no more precision (unit test
/// `fast_atan2_matches_the_library`). 0 when both are 0, NaN for NaN input.
pub(crate) fn atan2_upper(y: f64, x: f64) -> f64 {
    const A: [f64; 8] = [
        0.999_999_332_9,
        -0.333_298_560_5,
        0.199_465_359_9,
        -0.139_085_335_1,
        0.096_420_044_1,
        -0.055_909_886_1,
        0.021_861_228_8,
        -0.004_054_058_0,
    ];
    let ax = x.abs();
    let (num, den, swap) = if y <= ax {
        (y, ax, false)
    } else {
        (ax, y, true)
    };
    if den == 0.0 {
        return 0.0;
    }
    let t = num / den;
    let t2 = t * t;
    let mut p = A[7];
    for &a in A[..7].iter().rev() {
        p = p * t2 + a;
    }
    let mut angle = p * t;
    if swap {
        angle = std::f64::consts::FRAC_PI_2 - angle;
    }
    if x < 0.0 {
        std::f64::consts::PI - angle
    } else {
        angle
    }
}

/// +1 when `b` bulges towards the sensor from the chord `a c` (convex, as a leg seen
/// from the sensor), -1 otherwise.
fn bulge_sign(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> f64 {
    let mid = (0.5 * (a.0 + c.0), 0.5 * (a.1 + c.1));
    if mid.0 * mid.0 + mid.1 * mid.1 > b.0 * b.0 + b.1 * b.1 {
        1.0
    } else {
        -1.0
    }
}

/// Computes the features of one cluster, `seg` (its returns in beam order, cluster
/// number `cluster` of `view`):
///
/// | feature | definition |
/// |---|---|
/// | `n_points` | `n` |
/// | `std_dev_m` | `sqrt(sum |q_i - c|^2 / (n - 1))` |
/// | `mean_abs_dev_from_median_m` | `mean |q_i - med|`, `med` the component-wise median |
/// | `jump_prev_m`, `jump_next_m` | distance from `q_0` (`q_{n-1}`) to the return of the beam before (after) it |
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
/// | `depth_prev_m`, `depth_next_m` | range of the return of the beam before `q_0` (after `q_{n-1}`) minus that of `q_0` (`q_{n-1}`): positive when the background is behind |
/// | `nearest_return_m` | distance from `c` to the nearest return of another cluster, at most the largest of [`SURFACE_RADII_M`] (also when there is none) |
/// | `surface_within_R_m` | length of surface, m, that the returns of other clusters within `R` of `c` stand for: the sum of their footprints `r_j |dphi|` (`R` in [`SURFACE_RADII_M`]) |
///
/// The last two look at the free space around the segment: a person stands in the
/// open, a chair or table leg among other furniture and near walls. Arras et al. use
/// the jump distances to the neighbouring beams for the same purpose, leg_tracker
/// (Leigh et al., ICRA 2015) an occupancy grid in its tracker; these measure it in one
/// scan, without a map. Other lengths are clamped to [`FEATURE_CAP_M`], which also
/// stands for "no neighbour". The context features
/// are left at zero (see [`add_context`]). `seg` must not be empty.
pub fn segment_features(
    view: &ScanView<'_>,
    cluster: u32,
    seg: &[ScanPoint],
    scratch: &mut FeatureScratch,
) -> FeatureVector {
    let n = seg.len();
    let nf = n as f64;
    let xy = |p: &ScanPoint| (p.point_in_laser.x, p.point_in_laser.y);
    // `sqrt` of the sum of squares: these lengths are far from overflow, and `hypot`
    // costs several times more.
    let dist = |a: (f64, f64), b: (f64, f64)| {
        let (dx, dy) = (a.0 - b.0, a.1 - b.1);
        (dx * dx + dy * dy).sqrt()
    };
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
    let before = view.at_beam(first.beam.checked_sub(1));
    let after = view.at_beam(last.beam.checked_add(1));
    let jump = |q: &ScanPoint, nb: Option<&ScanPoint>| {
        nb.map_or(FEATURE_CAP_M, |nb| cap(dist(xy(q), xy(nb))))
    };
    let depth = |q: &ScanPoint, nb: Option<&ScanPoint>| {
        nb.map_or(FEATURE_CAP_M, |nb| cap(nb.range_m - q.range_m))
    };
    let (nearest_return, surface) = free_space(view, cluster, first.beam, last.beam, c);
    // "Before" and "after" in angle, counter-clockwise, whichever way the beams run: a
    // clockwise scanner (negative increment) lists the same points the other way round
    // and must give the same features.
    let (mut jumps, mut depths) = (
        [jump(first, before), jump(last, after)],
        [depth(first, before), depth(last, after)],
    );
    if view.angle_increment_rad < 0.0 {
        jumps.swap(0, 1);
        depths.swap(0, 1);
    }

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
        jumps[0],
        jumps[1],
        cap(dist(xy(first), xy(last))),
        linearity.min(FEATURE_CAP_M),
        circularity.min(FEATURE_CAP_M),
        radius,
        cap(boundary),
        cap(regularity),
        (curvature / interior).clamp(-1e3, 1e3),
        turning / interior,
        cap((c.x * c.x + c.y * c.y).sqrt()),
        ia_mean,
        ia_std,
        depths[0],
        depths[1],
        nearest_return,
        surface[0],
        surface[1],
        surface[2],
        0.0,
        0.0,
        0.0,
    ]
}

/// `nearest_return_m` and `surface_within_R_m` of the cluster `cluster`, whose returns
/// span the beams `first_beam..=last_beam` and whose centroid is `c`. A return within
/// `R` of `c`, at range `r_c > R`, lies within `asin(R / r_c)` of `c`'s bearing, which
/// lies between the cluster's first and last beams: only those beams are visited.
fn free_space(
    view: &ScanView<'_>,
    cluster: u32,
    first_beam: usize,
    last_beam: usize,
    c: Point2<Laser>,
) -> (f64, [f64; SURFACE_RADII_M.len()]) {
    let r_max = SURFACE_RADII_M[SURFACE_RADII_M.len() - 1];
    let dphi = view.angle_increment_rad.abs();
    let rc = (c.x * c.x + c.y * c.y).sqrt();
    let window = if rc > r_max && dphi > 0.0 {
        let beams = (r_max / rc).asin() / dphi;
        if beams < view.points.len() as f64 {
            beams as usize + 1
        } else {
            usize::MAX
        }
    } else {
        usize::MAX
    };
    let lo_beam = first_beam.saturating_sub(window);
    let hi_beam = last_beam.saturating_add(window);
    let lo = view.points.partition_point(|p| p.beam < lo_beam);
    let hi = lo + view.points[lo..].partition_point(|p| p.beam <= hi_beam);
    let mut nearest_sq = f64::INFINITY;
    let mut surface = [0.0; SURFACE_RADII_M.len()];
    let radii_sq = SURFACE_RADII_M.map(|r| r * r);
    for (p, &k) in view.points[lo..hi].iter().zip(&view.cluster_of[lo..hi]) {
        if k == cluster {
            continue;
        }
        let d = p.point_in_laser - c;
        let d_sq = d.x * d.x + d.y * d.y;
        // A select, not `f64::min`: the same for these non-NaN sums (a NaN keeps the
        // nearest so far either way) and without `min`'s NaN handling.
        if d_sq < nearest_sq {
            nearest_sq = d_sq;
        }
        // Adding 0 to a non-negative sum leaves it as it is: every return adds, with
        // no branch on whether it lies within a radius (which the CPU cannot predict).
        let footprint = p.range_m * dphi;
        for (s, r_sq) in surface.iter_mut().zip(radii_sq) {
            *s += if d_sq < r_sq { footprint } else { 0.0 };
        }
    }
    (nearest_sq.sqrt().min(r_max), surface)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::tests::points_at;

    fn idx(name: &str) -> usize {
        FEATURE_NAMES.iter().position(|n| *n == name).unwrap()
    }

    #[test]
    fn fast_atan2_matches_the_library() {
        let mut worst: f64 = 0.0;
        for i in 0..=2000 {
            let phi = std::f64::consts::PI * f64::from(i) / 2000.0;
            for r in [1e-6, 0.01, 1.0, 37.0] {
                let (y, x) = (r * phi.sin(), r * phi.cos());
                let y = y.max(0.0);
                worst = worst.max((atan2_upper(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 4e-8, "{worst}");
        assert_eq!(atan2_upper(0.0, 0.0), 0.0);
        assert_eq!(atan2_upper(0.0, -1.0), std::f64::consts::PI);
        assert!(atan2_upper(f64::NAN, 1.0).is_nan());
    }

    #[test]
    fn median_of_even_and_odd() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
    }

    /// Features of `points[start..end]` (cluster 0; every other point in cluster 1).
    fn feats(points: &[ScanPoint], start: usize, end: usize, dphi: f64) -> FeatureVector {
        let cluster_of: Vec<u32> = (0..points.len())
            .map(|i| u32::from(!(start..end).contains(&i)))
            .collect();
        let view = ScanView {
            points,
            cluster_of: &cluster_of,
            angle_increment_rad: dphi,
        };
        segment_features(
            &view,
            0,
            &points[start..end],
            &mut FeatureScratch::default(),
        )
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
        let fa = feats(&points_at(&arc), 0, 11, 0.0);
        let fl = feats(&points_at(&line), 0, 11, 0.0);
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
        assert!((fl[idx("inscribed_angle_mean_rad")] - std::f64::consts::PI).abs() < 1e-7);
        assert!(fa[idx("inscribed_angle_mean_rad")] < 2.5);
        assert!(
            fa[idx("inscribed_angle_std_rad")] < 1e-6,
            "constant on an arc"
        );
        assert!((fl[idx("width_m")] - 0.12).abs() < 1e-9);
        assert!((fl[idx("boundary_length_m")] - 0.12).abs() < 1e-9);
        assert!(fl[idx("boundary_regularity_m")] < 1e-9);
        assert_eq!(fa[idx("jump_prev_m")], FEATURE_CAP_M, "no neighbour");
        // Alone in the scan: nothing around it.
        assert_eq!(fa[idx("nearest_return_m")], 1.0);
        assert_eq!(fa[idx("surface_within_1_0_m")], 0.0);
    }

    #[test]
    fn neighbours_give_jumps_and_depths() {
        // Wall at 3 m, leg-ish bump at 2 m, wall again.
        let mut xy = vec![(3.0, -0.1), (3.0, -0.09)];
        xy.extend((0..5).map(|i| (2.0, -0.02 + 0.01 * i as f64)));
        xy.extend([(3.0, 0.1), (3.0, 0.11)]);
        let pts = points_at(&xy);
        let f = feats(&pts, 2, 7, 0.0);
        assert!((f[idx("depth_prev_m")] - (3.0f64.hypot(0.09) - 2.0f64.hypot(0.02))).abs() < 1e-9);
        assert!(f[idx("depth_next_m")] > 0.9);
        assert!(f[idx("jump_prev_m")] > 0.9 && f[idx("jump_next_m")] > 0.9);
        // A gap in beam numbers means no neighbour.
        let mut gappy = pts.clone();
        gappy[1].beam = 0;
        gappy[0].beam = 0;
        let f = feats(&gappy, 2, 7, 0.0);
        assert_eq!(f[idx("depth_prev_m")], FEATURE_CAP_M);
    }

    #[test]
    fn free_space_counts_the_surface_of_other_clusters_nearby() {
        // A wall at 2.5 m across 400 beams with a 10-beam leg at 2 m in front of it.
        let dphi = 0.006_135_92;
        let points: Vec<ScanPoint> = (0..400)
            .map(|beam| {
                let bearing = (beam as f64 - 200.0) * dphi;
                let r = if (195..205).contains(&beam) { 2.0 } else { 2.5 };
                ScanPoint {
                    beam,
                    range_m: r,
                    bearing_rad: bearing,
                    point_in_laser: Point2::new(r * bearing.cos(), r * bearing.sin()),
                }
            })
            .collect();
        let f = feats(&points, 195, 205, dphi);
        // The definitions, by brute force over the whole scan.
        let c = centroid(&points[195..205]);
        let others = points
            .iter()
            .enumerate()
            .filter(|(i, _)| !(195..205).contains(i));
        let (mut nearest, mut surface) = (f64::INFINITY, [0.0; 3]);
        for (_, p) in others {
            let d = p.point_in_laser.distance_m(c);
            nearest = nearest.min(d);
            for (s, r) in surface.iter_mut().zip(SURFACE_RADII_M) {
                if d < r {
                    *s += p.range_m * dphi;
                }
            }
        }
        assert!((f[idx("nearest_return_m")] - nearest).abs() < 1e-12);
        assert!(nearest > 0.49 && nearest < 0.51, "{nearest}");
        assert_eq!(f[idx("surface_within_0_3_m")], 0.0);
        assert!((f[idx("surface_within_0_5_m")] - surface[1]).abs() < 1e-12);
        assert!((f[idx("surface_within_1_0_m")] - surface[2]).abs() < 1e-12);
        // About 2 * acos(0.925) / dphi - 10 beams of wall, 15 mm each.
        assert!(
            (f[idx("surface_within_1_0_m")] - 1.79).abs() < 0.03,
            "{}",
            f[idx("surface_within_1_0_m")]
        );
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

    /// The definitions of [`add_context`], pair by pair in both directions.
    fn context_by_definition(candidates: &mut [Candidate]) {
        const FIRST: usize = N_SEGMENT_FEATURES + N_SCAN_FEATURES;
        for i in 0..candidates.len() {
            let (mut nearest, mut nearest_leg, mut within) = (FEATURE_CAP_M, FEATURE_CAP_M, 0.0);
            for (j, other) in candidates.iter().enumerate() {
                if i == j {
                    continue;
                }
                let v = candidates[i].centroid_in_laser - other.centroid_in_laser;
                let d_computed = (v.x * v.x + v.y * v.y).sqrt();
                nearest = nearest.min(d_computed);
                if other.features[idx("width_m")] <= LEG_SIZED_MAX_WIDTH_M {
                    nearest_leg = nearest_leg.min(d_computed);
                }
                if d_computed <= STRIDE_M {
                    within += 1.0;
                }
            }
            let f = &mut candidates[i].features;
            (f[FIRST], f[FIRST + 1], f[FIRST + 2]) = (nearest, nearest_leg, within);
        }
    }

    proptest::proptest! {
        /// Bit for bit the definitions, with centroids on and around the stride and
        /// widths on both sides of the leg-sized bound.
        #[test]
        fn context_is_the_definition_bit_for_bit(
            raw in proptest::collection::vec((-3.0..3.0f64, -3.0..3.0f64, 0.0..0.5f64, 0u8..4), 0..40),
        ) {
            let mut cands: Vec<Candidate> = Vec::new();
            for (k, &(x, y, width, snap)) in raw.iter().enumerate() {
                // Some centroids exactly a stride or nearly from an earlier one.
                let (x, y) = match (snap, cands.last()) {
                    (1, Some(c)) => (c.centroid_in_laser.x + STRIDE_M, c.centroid_in_laser.y),
                    (2, Some(c)) => (c.centroid_in_laser.x, (c.centroid_in_laser.y + STRIDE_M).next_up()),
                    _ => (x, y),
                };
                let mut features = [0.0; N_FEATURES];
                features[idx("width_m")] = if k % 5 == 0 { LEG_SIZED_MAX_WIDTH_M } else { width };
                cands.push(Candidate {
                    segment: Segment { start: 0, end: 1 },
                    centroid_in_laser: Point2::new(x, y),
                    features,
                });
            }
            let mut expected = cands.clone();
            context_by_definition(&mut expected);
            add_context(&mut cands);
            for (a, b) in cands.iter().zip(&expected) {
                let (fa, fb) = (a.features.map(f64::to_bits), b.features.map(f64::to_bits));
                proptest::prop_assert_eq!(fa, fb);
            }
        }
    }

    #[test]
    fn tiny_segments_are_finite() {
        for n in 1..4 {
            let xy: Vec<(f64, f64)> = (0..n).map(|i| (1.0, 0.01 * i as f64)).collect();
            let f = feats(&points_at(&xy), 0, n, 0.006);
            assert!(f.iter().all(|v| v.is_finite()), "{n}: {f:?}");
        }
    }
}
