//! Segmentation (design 4.2): split the returns of a scan into segments where two
//! consecutive returns are too far apart to lie on one surface.

use serde::{Deserialize, Serialize};
use tether_core::RangeNoiseModel;

use crate::preprocess::ScanPoint;

/// When two consecutive returns start a new segment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case", deny_unknown_fields)]
pub enum Breakpoint {
    /// Borges and Aldon's adaptive breakpoint ("Line extraction in 2D range images for
    /// mobile robotics", J. Intell. Robot. Syst. 40, 2004): returns `p[n-1]`, `p[n]`
    /// whose beams are `dphi` apart belong to one surface while
    ///
    /// ```text
    /// |p[n] - p[n-1]| <= D_max = r[n-1] * sin(dphi) / sin(lambda - dphi) + 3 sigma_r(r[n-1])
    /// ```
    ///
    /// where `lambda` is the shallowest incidence angle at which a surface still counts
    /// as one (the first term is the gap between returns on a surface seen at
    /// `lambda`) and `sigma_r` the range noise. Beams of no return between the two
    /// widen `dphi`; at `dphi >= lambda` the returns are always split.
    Adaptive {
        /// `lambda`, rad. Borges and Aldon use 10 deg.
        lambda_rad: f64,
    },
    /// A fixed jump: split where `|p[n] - p[n-1]| > jump_m` (design 4.2: 0.1-0.2 m; the
    /// leg_tracker clustering uses 0.13 m).
    FixedJump {
        /// The largest gap inside a segment, m.
        jump_m: f64,
    },
    /// Both rules: split where either says so, i.e. where the gap exceeds
    /// `min(D_max, jump_m)`. The adaptive threshold separates objects finely near the
    /// sensor; the fixed jump caps it far away, where `D_max` (growing as `r (1 /
    /// sin(lambda) + 3 sigma_r / r)`) would merge two legs one behind the other.
    AdaptiveOrJump {
        /// `lambda` of the adaptive rule, rad.
        lambda_rad: f64,
        /// The largest gap inside a segment, m.
        jump_m: f64,
    },
    /// Euclidean clustering, as leg_tracker's `ScanProcessor::splitConnected` (Leigh
    /// et al., ICRA 2015): the connected components of the graph joining a return at
    /// range `r` to every later return closer than `distance_m` and fewer than
    /// `floor(asin(distance_m / r) / dphi)` beams after it (leg_tracker's beam window;
    /// any beam if `r <= distance_m`). Unlike the rules above it looks past a stray
    /// return: a leg whose outline holds one return of the wall behind (a mixed pixel)
    /// stays one cluster, and the stray return forms its own. A cluster's returns need
    /// not be consecutive.
    Euclidean {
        /// Returns closer than this are in one cluster, m (leg_tracker: 0.13).
        distance_m: f64,
    },
}

/// The default: [`Breakpoint::Euclidean`] at 0.13 m, leg_tracker's clustering. A
/// leg's cross-section is 0.09-0.16 m wide, so neighbouring returns on one leg are
/// closer than that, while the gap between two legs in a stride (0.2-0.3 m along the
/// ray) or between a leg and what stands behind it is larger. The labels of the
/// leg_tracker recordings are the centroids of exactly these clusters. On their
/// training split, cross-validation (`tether train-legs`, see the crate's README)
/// gives the learned detector an F1 of 0.811 with this rule against 0.799 with
/// [`Breakpoint::FixedJump`] at 0.13 m and 0.792 with [`Breakpoint::AdaptiveOrJump`]
/// (`lambda` = 10 deg capped at 0.13 m), whose splits at stray returns leave fragments
/// of legs that count as false detections. The adaptive rule alone, with the default
/// noise model (`3 sigma_r` = 3 % of the range), merges the legs of a walker beyond
/// about 2.5 m.
impl Default for Breakpoint {
    fn default() -> Self {
        Breakpoint::Euclidean { distance_m: 0.13 }
    }
}

impl Breakpoint {
    /// Checks the parameter ranges; returns what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            Breakpoint::Adaptive { lambda_rad } => {
                if lambda_rad.is_finite() && lambda_rad > 0.0 && lambda_rad < 1.5 {
                    Ok(())
                } else {
                    Err(format!(
                        "breakpoint lambda_rad must be in (0, 1.5) rad, got {lambda_rad}"
                    ))
                }
            }
            Breakpoint::FixedJump { jump_m } => check_jump("jump_m", jump_m),
            Breakpoint::AdaptiveOrJump { lambda_rad, jump_m } => {
                Breakpoint::Adaptive { lambda_rad }.validate()?;
                check_jump("jump_m", jump_m)
            }
            Breakpoint::Euclidean { distance_m } => check_jump("distance_m", distance_m),
        }
    }
}

fn check_jump(name: &str, value_m: f64) -> Result<(), String> {
    if value_m.is_finite() && value_m > 0.0 {
        Ok(())
    } else {
        Err(format!("breakpoint {name} must be > 0 m, got {value_m}"))
    }
}

/// Borges and Aldon's `D_max` between a return at `range_m` and the next one `dphi`
/// later; infinite-free: `None` when `dphi >= lambda` (always split).
fn adaptive_max_gap_m(
    range_m: f64,
    dphi: f64,
    lambda_rad: f64,
    noise: &RangeNoiseModel,
) -> Option<f64> {
    (dphi < lambda_rad)
        .then(|| range_m * dphi.sin() / (lambda_rad - dphi).sin() + 3.0 * noise.sigma_m(range_m))
}

/// A segment or cluster: `points[start..end]` of the pre-processed returns as
/// [`segment_into`] leaves them, or of their reordering by [`cluster_into`] (`order`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// First point (index into the points).
    pub start: usize,
    /// One past the last point.
    pub end: usize,
}

impl Segment {
    /// Number of returns.
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    /// Always false: a segment has at least one return.
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }
}

/// Splits `points` (in beam order) into runs of consecutive returns by `rule`, writing
/// them to `out`. `angle_increment_rad` is the scan's; `noise` gives `sigma_r` for the
/// adaptive rule. [`Breakpoint::Euclidean`] here splits where consecutive returns are
/// `distance_m` or more apart; [`cluster_into`] gives its true clusters.
pub fn segment_into(
    points: &[ScanPoint],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    rule: Breakpoint,
    out: &mut Vec<Segment>,
) {
    out.clear();
    if points.is_empty() {
        return;
    }
    let dphi_one = angle_increment_rad.abs();
    let mut start = 0;
    for k in 1..points.len() {
        let (a, b) = (&points[k - 1], &points[k]);
        let gap_sq = {
            let d = b.point_in_laser - a.point_in_laser;
            d.x * d.x + d.y * d.y
        };
        let dphi = (b.beam - a.beam) as f64 * dphi_one;
        let max_gap_m = match rule {
            Breakpoint::FixedJump { jump_m } => Some(jump_m),
            Breakpoint::Adaptive { lambda_rad } => {
                adaptive_max_gap_m(a.range_m, dphi, lambda_rad, noise)
            }
            Breakpoint::AdaptiveOrJump { lambda_rad, jump_m } => {
                adaptive_max_gap_m(a.range_m, dphi, lambda_rad, noise).map(|d| d.min(jump_m))
            }
            Breakpoint::Euclidean { distance_m } => Some(distance_m.next_down()),
        };
        let split = max_gap_m.is_none_or(|d| gap_sq > d * d);
        if split {
            out.push(Segment { start, end: k });
            start = k;
        }
    }
    out.push(Segment {
        start,
        end: points.len(),
    });
}

/// Reusable buffers of [`cluster_into`].
#[derive(Debug, Clone, Default)]
pub struct ClusterScratch {
    /// Index of the first point of each run of consecutive points closer than the
    /// clustering distance, and one past the last run's end.
    run_start: Vec<u32>,
    /// Smallest and largest range of each run.
    run_range: Vec<(f64, f64)>,
    /// Union-find parents of the runs.
    parent: Vec<u32>,
    /// Cluster of each run, and points per cluster.
    run_cluster: Vec<u32>,
    fill: Vec<u32>,
    cluster_of: Vec<u32>,
}

impl ClusterScratch {
    /// The cluster of each point of the last [`cluster_into`] call (an index into its
    /// `out`), by the point's index.
    pub fn cluster_of(&self) -> &[u32] {
        &self.cluster_of
    }
}

/// Root of `i` in the union-find forest, halving paths on the way.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let grand = parent[parent[i as usize] as usize];
        parent[i as usize] = grand;
        i = grand;
    }
    i
}

/// Groups `points` (in beam order) into clusters by `rule`. Writes to `order` the
/// indices of the points, cluster after cluster, and to `out` each cluster's range of
/// `order`: cluster `k` is `points[order[i]]` for `i` in `out[k].start..out[k].end`.
/// Clusters come in the order of their first beam, and each lists its points in beam
/// order.
///
/// The rules of consecutive returns give runs (`order` is `0..n`).
/// [`Breakpoint::Euclidean`] gives exactly the components its definition states:
/// consecutive returns that are joined form runs, and runs are merged by union-find
/// wherever a return of one joins a return of a later run. Only the pairs that can be
/// joined are compared: a later run is visited while it starts within the beam window
/// of the run's nearest return, and skipped when its ranges all differ from the
/// return's by `distance_m` or more (`|r_a - r_b|` bounds the distance from below).
/// On leg_tracker's recordings this reproduces its clusters, hence the labels' leg
/// positions, to float rounding.
pub fn cluster_into(
    points: &[ScanPoint],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    rule: Breakpoint,
    scratch: &mut ClusterScratch,
    order: &mut Vec<usize>,
    out: &mut Vec<Segment>,
) {
    let n = points.len();
    order.clear();
    scratch.cluster_of.clear();
    let Breakpoint::Euclidean { distance_m } = rule else {
        segment_into(points, angle_increment_rad, noise, rule, out);
        order.extend(0..n);
        for (k, s) in out.iter().enumerate() {
            scratch
                .cluster_of
                .extend(std::iter::repeat_n(k as u32, s.len()));
        }
        return;
    };
    out.clear();
    if n == 0 {
        return;
    }
    let d_sq = distance_m * distance_m;
    let dphi = angle_increment_rad.abs();
    // leg_tracker's beam window: a return at range `r` joins returns fewer than
    // `floor(asin(distance_m / r) / dphi)` beams after it.
    let window = |r: f64| -> usize {
        if r > distance_m && dphi > 0.0 {
            let beams = (distance_m / r).asin() / dphi;
            if beams < n as f64 {
                beams as usize
            } else {
                usize::MAX
            }
        } else {
            usize::MAX
        }
    };
    let joined = |a: &ScanPoint, b: &ScanPoint, window_a: usize| {
        let d = b.point_in_laser - a.point_in_laser;
        b.beam - a.beam < window_a && d.x * d.x + d.y * d.y < d_sq
    };
    // Runs of consecutive joined returns: connected already. Each run's range
    // interval lets whole runs be passed over.
    let runs = &mut scratch.run_start;
    let span = &mut scratch.run_range;
    runs.clear();
    span.clear();
    runs.push(0);
    span.push((points[0].range_m, points[0].range_m));
    // Neighbouring beams are within the window of every range below this (a window of
    // 2 beams or more), with a margin for rounding; beyond it the window is computed.
    let adjacent_below_m = if 2.0 * dphi < std::f64::consts::FRAC_PI_2 {
        0.999 * distance_m / (2.0 * dphi).sin()
    } else {
        0.0
    };
    for k in 1..n {
        let (a, r) = (&points[k - 1], points[k].range_m);
        let w = if points[k].beam - a.beam == 1 && a.range_m < adjacent_below_m {
            2
        } else {
            window(a.range_m)
        };
        if joined(a, &points[k], w) {
            let last = span.len() - 1;
            span[last] = (span[last].0.min(r), span[last].1.max(r));
        } else {
            runs.push(k as u32);
            span.push((r, r));
        }
    }
    let n_runs = runs.len();
    runs.push(n as u32);
    let parent = &mut scratch.parent;
    parent.clear();
    parent.extend(0..n_runs as u32);
    for r in 0..n_runs {
        // No return of the run reaches farther than the window of its nearest range.
        let reach = window(span[r].0);
        for i in runs[r] as usize..runs[r + 1] as usize {
            let a = &points[i];
            let mut window_a = None;
            for other in r + 1..n_runs {
                let (lo, hi) = (runs[other] as usize, runs[other + 1] as usize);
                if points[lo].beam - a.beam >= reach {
                    break;
                }
                // Returns closer than `distance_m` differ by less than that in range.
                let (near, far) = span[other];
                if a.range_m <= near - distance_m || a.range_m >= far + distance_m {
                    continue;
                }
                let (ra, rb) = (find(parent, r as u32), find(parent, other as u32));
                if ra == rb {
                    continue;
                }
                let w = *window_a.get_or_insert_with(|| window(a.range_m));
                if points[lo..hi]
                    .iter()
                    .take_while(|b| b.beam - a.beam < w)
                    .any(|b| joined(a, b, w))
                {
                    // The lower run becomes the root: deterministic, and a root is its
                    // cluster's first run.
                    let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
                    parent[hi as usize] = lo;
                }
            }
        }
    }
    // Number the clusters in the order of their first run and count their points.
    const NONE: u32 = u32::MAX;
    let run_cluster = &mut scratch.run_cluster;
    run_cluster.clear();
    run_cluster.resize(n_runs, NONE);
    let sizes = &mut scratch.fill;
    sizes.clear();
    for r in 0..n_runs {
        let root = find(parent, r as u32) as usize;
        if run_cluster[root] == NONE {
            run_cluster[root] = sizes.len() as u32;
            sizes.push(0);
        }
        let k = run_cluster[root];
        run_cluster[r] = k;
        let len = runs[r + 1] - runs[r];
        sizes[k as usize] += len;
        scratch
            .cluster_of
            .extend(std::iter::repeat_n(k, len as usize));
    }
    let mut start = 0;
    for size in sizes.iter_mut() {
        let end = start + *size as usize;
        out.push(Segment { start, end });
        // From here on, `sizes[k]` is where cluster `k`'s next point goes.
        *size = start as u32;
        start = end;
    }
    order.resize(n, 0);
    for (i, &k) in scratch.cluster_of.iter().enumerate() {
        order[sizes[k as usize] as usize] = i;
        sizes[k as usize] += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{LaserScan, Stamp};

    use crate::preprocess::preprocess;

    const INC: f64 = 0.006_135_92;
    const ADAPTIVE: Breakpoint = Breakpoint::Adaptive {
        lambda_rad: 10.0 * std::f64::consts::PI / 180.0,
    };

    fn points(ranges: Vec<f32>) -> Vec<ScanPoint> {
        let scan = LaserScan::new(Stamp::ZERO, "l", 0.0, INC, 0.02, 5.6, ranges).unwrap();
        preprocess(&scan, &RangeNoiseModel::default())
    }

    fn clusters(points: &[ScanPoint], rule: Breakpoint) -> Vec<Vec<usize>> {
        let (mut order, mut out) = (Vec::new(), Vec::new());
        let mut scratch = ClusterScratch::default();
        let noise = RangeNoiseModel::default();
        cluster_into(
            points,
            INC,
            &noise,
            rule,
            &mut scratch,
            &mut order,
            &mut out,
        );
        for (k, s) in out.iter().enumerate() {
            for &i in &order[s.start..s.end] {
                assert_eq!(scratch.cluster_of()[i], k as u32);
            }
        }
        out.iter().map(|s| order[s.start..s.end].to_vec()).collect()
    }

    fn lens(points: &[ScanPoint], rule: Breakpoint) -> Vec<usize> {
        clusters(points, rule).iter().map(Vec::len).collect()
    }

    #[test]
    fn splits_at_range_jumps() {
        let mut ranges = vec![2.0f32; 10];
        ranges.extend(vec![1.5f32; 5]);
        ranges.extend(vec![2.0f32; 10]);
        let pts = points(ranges);
        assert_eq!(lens(&pts, ADAPTIVE), vec![10, 5, 10]);
        assert_eq!(
            lens(&pts, Breakpoint::FixedJump { jump_m: 0.13 }),
            vec![10, 5, 10]
        );
        assert_eq!(lens(&pts, Breakpoint::FixedJump { jump_m: 0.6 }), vec![25]);
        // Euclidean clustering joins the wall across the narrow object in front (its
        // two pieces are 7 cm apart), listed from its first beam.
        let default = clusters(&pts, Breakpoint::default());
        assert_eq!(default.len(), 2);
        assert_eq!(default[0], (0..10).chain(15..25).collect::<Vec<_>>());
        assert_eq!(default[1], (10..15).collect::<Vec<_>>());
    }

    #[test]
    fn adaptive_threshold_grows_with_range() {
        // A 7 cm step: the same surface at 4 m (D_max ~ 0.27 m), a new one at 0.5 m
        // (D_max ~ 0.048 m); one surface for the 0.13 m clustering.
        let far = points(vec![4.0, 4.0, 4.07, 4.07]);
        assert_eq!(lens(&far, ADAPTIVE), vec![4]);
        let near = points(vec![0.5, 0.5, 0.57, 0.57]);
        assert_eq!(lens(&near, ADAPTIVE), vec![2, 2]);
        assert_eq!(lens(&near, Breakpoint::default()), vec![4]);
    }

    #[test]
    fn euclidean_clustering_looks_past_a_stray_return() {
        // A leg at 1.5 m whose middle beam returned from the wall at 3 m (a mixed
        // pixel): the rules of consecutive returns cut the leg in two.
        let mut ranges = vec![1.5f32; 9];
        ranges[4] = 3.0;
        let pts = points(ranges);
        assert_eq!(
            lens(&pts, Breakpoint::FixedJump { jump_m: 0.13 }),
            vec![4, 1, 4]
        );
        let c = clusters(&pts, Breakpoint::default());
        assert_eq!(c, vec![vec![0, 1, 2, 3, 5, 6, 7, 8], vec![4]]);
    }

    /// Connected components of the definition of [`Breakpoint::Euclidean`], by
    /// comparing every pair.
    fn brute_force(points: &[ScanPoint], d: f64) -> Vec<Vec<usize>> {
        let n = points.len();
        let joined = |i: usize, j: usize| {
            let (a, b) = if i < j {
                (&points[i], &points[j])
            } else {
                (&points[j], &points[i])
            };
            let window = if a.range_m > d {
                ((d / a.range_m).asin() / INC).floor()
            } else {
                f64::INFINITY
            };
            ((b.beam - a.beam) as f64) < window && a.point_in_laser.distance_m(b.point_in_laser) < d
        };
        let mut label: Vec<usize> = (0..n).collect();
        loop {
            let mut changed = false;
            for i in 0..n {
                for j in 0..n {
                    if i != j && joined(i, j) && label[j] < label[i] {
                        label[i] = label[j];
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let mut out: Vec<Vec<usize>> = Vec::new();
        let mut seen = std::collections::BTreeMap::new();
        for (i, &l) in label.iter().enumerate() {
            let k = *seen.entry(l).or_insert_with(|| {
                out.push(Vec::new());
                out.len() - 1
            });
            out[k].push(i);
        }
        out
    }

    #[test]
    fn euclidean_clustering_is_exact() {
        // Cluttered scans: random objects at random ranges, some beams missing.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..40 {
            let mut ranges = Vec::new();
            while ranges.len() < 300 {
                let (r, len) = (0.05 + 4.0 * next(), 1 + (12.0 * next()) as usize);
                for _ in 0..len {
                    let jitter = 0.05 * (next() - 0.5);
                    ranges.push(if next() < 0.1 {
                        f32::NAN
                    } else {
                        (r + jitter) as f32
                    });
                }
            }
            let pts = points(ranges);
            for d in [0.05, 0.13, 0.3] {
                let rule = Breakpoint::Euclidean { distance_m: d };
                assert_eq!(clusters(&pts, rule), brute_force(&pts, d), "d = {d}");
            }
        }
    }

    #[test]
    fn the_jump_caps_the_adaptive_threshold_far_away() {
        // Two legs of a stride at 3 m, 0.15 m apart along the ray: D_max ~ 0.2 m merges
        // them, the 0.13 m cap does not.
        let stride = points(vec![3.0, 3.0, 3.0, 2.85, 2.85, 2.85]);
        assert_eq!(lens(&stride, ADAPTIVE), vec![6]);
        assert_eq!(lens(&stride, Breakpoint::default()), vec![3, 3]);
    }

    #[test]
    fn missing_beams_widen_the_gap_and_long_gaps_split() {
        let mut ranges = vec![2.0f32; 3];
        ranges.extend(vec![f32::INFINITY; 2]);
        ranges.extend(vec![2.0f32; 3]);
        assert_eq!(
            lens(&points(ranges.clone()), Breakpoint::default()),
            vec![6]
        );
        assert_eq!(lens(&points(ranges), ADAPTIVE), vec![6]);
        let mut ranges = vec![2.0f32; 3];
        ranges.extend(vec![f32::INFINITY; 40]); // 40 beams = 14 deg > lambda
        ranges.extend(vec![2.0f32; 3]);
        assert_eq!(lens(&points(ranges), Breakpoint::default()), vec![3, 3]);
    }

    #[test]
    fn empty_input_gives_no_segment() {
        assert!(lens(&[], Breakpoint::default()).is_empty());
    }

    #[test]
    fn validates_parameters() {
        assert!(Breakpoint::default().validate().is_ok());
        assert!(Breakpoint::Adaptive { lambda_rad: 0.0 }.validate().is_err());
        assert!(
            Breakpoint::AdaptiveOrJump {
                lambda_rad: 0.2,
                jump_m: 0.0
            }
            .validate()
            .is_err()
        );
        assert!(
            Breakpoint::FixedJump { jump_m: f64::NAN }
                .validate()
                .is_err()
        );
    }
}
