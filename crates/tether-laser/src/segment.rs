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

/// Reusable buffers of [`cluster_into`]: after the first scans of a size, clustering
/// allocates nothing.
#[derive(Debug, Clone, Default)]
pub struct ClusterScratch {
    /// Index of the first point of each run of consecutive joined points, and one
    /// past the last run's end.
    run_start: Vec<u32>,
    /// Smallest and largest range of each run.
    run_range: Vec<(f64, f64)>,
    /// The grid of the Euclidean rule.
    grid: GridScratch,
    /// Chain of each point: a run, or a chain of the grid (either way a set of
    /// points known to be connected).
    chain_of: Vec<u32>,
    /// Union-find parents of the chains.
    parent: Vec<u32>,
    /// Cluster of each chain root, and points per cluster.
    root_cluster: Vec<u32>,
    fill: Vec<u32>,
    cluster_of: Vec<u32>,
}

/// The buffers of the grid of [`Breakpoint::Euclidean`] clustering.
#[derive(Debug, Clone, Default)]
struct GridScratch {
    /// Beam index past the last beam each point joins: `beam + window(range)`
    /// (saturating; `usize::MAX` for an unbounded window).
    reach: Vec<usize>,
    /// Each point's computed distance from the sensor.
    norm: Vec<f64>,
    /// `(cell key, point index)` of every point, sorted: each cell's points together,
    /// in beam order (then each chain's points in the order of its k-d tree). The
    /// fallback sorts them by `x` instead.
    by_cell: Vec<(u64, u32)>,
    /// The grid's cells in key order.
    cells: Vec<Cell>,
    /// The root node of each chain's k-d tree.
    roots: Vec<u32>,
    /// The nodes of the k-d trees.
    nodes: Vec<Node>,
    /// Nodes still to split, pairs of nodes still to compare.
    work: Vec<(u32, u32)>,
    stack: Vec<(u32, u32)>,
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

/// Joins the sets of `a` and `b`; the lower root becomes the root.
fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb) as usize] = ra.min(rb);
    }
}

/// Groups `points` (in beam order, at most one return a beam, as [`preprocess`] gives
/// them) into clusters by `rule`. Writes to `order` the indices of the points, cluster
/// after cluster, and to `out` each cluster's range of `order`: cluster `k` is
/// `points[order[i]]` for `i` in `out[k].start..out[k].end`. Clusters come in the order
/// of their first point, and each lists its points in beam order.
///
/// The rules of consecutive returns give runs (`order` is `0..n`).
/// [`Breakpoint::Euclidean`] gives exactly the connected components its definition
/// states: a return `a` at range `r` and a later return `b` are joined when
///
/// ```text
/// b.beam - a.beam < window(r)  and  (b.x - a.x)^2 + (b.y - a.y)^2 < distance_m^2
/// window(r) = floor(asin(distance_m / r) / |angle_increment_rad|)  if r > distance_m
/// ```
///
/// and the window is unbounded when `r <= distance_m` or when it would reach `n`, the
/// number of returns. Clusters are the connected components of these joins. On
/// leg_tracker's recordings this reproduces its clusters, hence the labels' leg
/// positions, to float rounding.
///
/// The components come from the run-based pass of the first implementation while it
/// stays within 8 visits of a run per point (as on every real scan measured), else
/// from a grid of cells with k-d trees, whose cost grows near-linearly with the
/// points on every scan measured up to a million beams (the crate's README has the
/// figures, and the case that costs more). Both give exactly the components above.
///
/// [`preprocess`]: crate::preprocess::preprocess
pub fn cluster_into(
    points: &[ScanPoint],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    rule: Breakpoint,
    scratch: &mut ClusterScratch,
    order: &mut Vec<usize>,
    out: &mut Vec<Segment>,
) {
    cluster_with(
        points,
        angle_increment_rad,
        noise,
        rule,
        RUNS_WORK_PER_POINT,
        scratch,
        order,
        out,
    );
}

/// Visits of a run by a point that the run-based pass may make, per point, before the
/// grid takes over. The real scans of leg_tracker's recordings (every topic, 3,773
/// scans) need 1.1-2.3 a point on average and 3.7 at most; the budget only decides
/// which exact way is taken, never the clusters.
const RUNS_WORK_PER_POINT: usize = 8;

/// [`cluster_into`] with the run-based pass given `work_per_point` (0: the grid alone;
/// `usize::MAX`: the runs alone).
#[allow(clippy::too_many_arguments, reason = "cluster_into's, and the budget")]
fn cluster_with(
    points: &[ScanPoint],
    angle_increment_rad: f64,
    noise: &RangeNoiseModel,
    rule: Breakpoint,
    work_per_point: usize,
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
    let by_runs = euclidean_components(
        points,
        angle_increment_rad.abs(),
        distance_m,
        work_per_point,
        scratch,
    );
    // Number the clusters in the order of their first point and count their points.
    const NONE: u32 = u32::MAX;
    let ClusterScratch {
        run_start,
        parent,
        chain_of,
        root_cluster,
        fill: sizes,
        cluster_of,
        ..
    } = scratch;
    root_cluster.clear();
    root_cluster.resize(parent.len(), NONE);
    sizes.clear();
    // The next `len` points belong to `chain`; neighbouring points mostly share one.
    let mut last = (NONE, 0);
    let mut label = |chain: u32, len: u32| {
        if chain != last.0 {
            let root = find(parent, chain) as usize;
            if root_cluster[root] == NONE {
                root_cluster[root] = sizes.len() as u32;
                sizes.push(0);
            }
            last = (chain, root_cluster[root]);
        }
        let k = last.1;
        sizes[k as usize] += len;
        cluster_of.extend(std::iter::repeat_n(k, len as usize));
    };
    if by_runs {
        for (r, w) in run_start.windows(2).enumerate() {
            label(r as u32, w[1] - w[0]);
        }
    } else {
        for &chain in chain_of.iter() {
            label(chain, 1);
        }
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
    for (i, &k) in cluster_of.iter().enumerate() {
        order[sizes[k as usize] as usize] = i;
        sizes[k as usize] += 1;
    }
}

/// Most points in a leaf of a chain's k-d tree.
const LEAF: usize = 8;

/// Deepest split of a k-d tree: far more than balanced trees need (`2^40` points); it
/// bounds the work on degenerate point sets (say ranges halving towards the sensor),
/// whose last nodes stay as larger leaves.
const MAX_DEPTH: u32 = 40;

/// Grid coordinates stay within `+-2^30` cells, so that they are computed to well
/// under a cell and fit 32 bits.
const GRID_LIMIT: f64 = (1u64 << 30) as f64;
const GRID_BIAS: i64 = (1 << 30) + 2;

/// What a pair of point sets is pruned by: the bounding box, the distances from the
/// sensor, the beams and how far their windows reach.
#[derive(Debug, Clone, Copy)]
struct Bounds {
    min_x: f64,
    max_x: f64,
    min_y: f64,
    max_y: f64,
    /// Smallest and largest distance from the sensor, as computed from the points.
    min_r: f64,
    max_r: f64,
    /// First and last beam, and the farthest reach of a window.
    min_beam: usize,
    max_beam: usize,
    max_reach: usize,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min_x: f64::INFINITY,
        max_x: f64::NEG_INFINITY,
        min_y: f64::INFINITY,
        max_y: f64::NEG_INFINITY,
        min_r: f64::INFINITY,
        max_r: f64::NEG_INFINITY,
        min_beam: usize::MAX,
        max_beam: 0,
        max_reach: 0,
    };

    fn add(&mut self, p: &ScanPoint, norm: f64, reach: usize) {
        self.min_beam = self.min_beam.min(p.beam);
        self.max_beam = self.max_beam.max(p.beam);
        self.max_reach = self.max_reach.max(reach);
        let p = p.point_in_laser;
        self.min_x = self.min_x.min(p.x);
        self.max_x = self.max_x.max(p.x);
        self.min_y = self.min_y.min(p.y);
        self.max_y = self.max_y.max(p.y);
        self.min_r = self.min_r.min(norm);
        self.max_r = self.max_r.max(norm);
    }

    /// The least squared distance that the rule computes for any pair of points of
    /// `self` and `o`, or less. Floating-point subtraction, squaring and addition are
    /// monotone, so `fl(b.x - a.x) >= fl(o.min_x - self.max_x)` and so on: if this
    /// reaches `d_sq`, so does every pair's computed distance.
    fn gap_sq(&self, o: &Bounds) -> f64 {
        let gx = (o.min_x - self.max_x).max(self.min_x - o.max_x).max(0.0);
        let gy = (o.min_y - self.max_y).max(self.min_y - o.max_y).max(0.0);
        gx * gx + gy * gy
    }

    /// The largest squared distance computed for any pair, or more (monotone as above).
    fn span_sq(&self, o: &Bounds) -> f64 {
        let sx = (o.max_x - self.min_x).max(self.max_x - o.min_x);
        let sy = (o.max_y - self.min_y).max(self.max_y - o.min_y);
        sx * sx + sy * sy
    }

    /// Whether no point of `self` joins a point of `o`: they lie `d` or more apart by
    /// the boxes, or by the distances from the sensor (which differ by no more than the
    /// distance between the points; the slack covers rounding many times over), or
    /// the beams of one all come after the other's windows.
    fn apart(&self, o: &Bounds, d: f64, d_sq: f64) -> bool {
        if self.gap_sq(o) >= d_sq || self.windows_apart(o) {
            return true;
        }
        let gap_r = (o.min_r - self.max_r).max(self.min_r - o.max_r);
        gap_r > d + 1e-9 * (d + self.max_r.max(o.max_r)) + 1e-150
    }

    /// Whether the beams of one set all come after those of the other and past all
    /// their windows: then no pair is within a window.
    fn windows_apart(&self, o: &Bounds) -> bool {
        (self.max_beam < o.min_beam && o.min_beam >= self.max_reach)
            || (o.max_beam < self.min_beam && self.min_beam >= o.max_reach)
    }

    /// Whether the beams of one set all come before those of the other: then some pair
    /// is within a window exactly when [`Bounds::windows_apart`] is false.
    fn beams_apart(&self, o: &Bounds) -> bool {
        self.max_beam < o.min_beam || o.max_beam < self.min_beam
    }
}

/// A cell of the grid: its key and its chains.
#[derive(Debug, Clone, Copy)]
struct Cell {
    key: u64,
    first_chain: u32,
    end_chain: u32,
}

/// A node of a chain's k-d tree: the points `by_cell[start..end]` and their bounds;
/// children at `first_child` and `first_child + 1` (0 for a leaf: the first node is a
/// root).
#[derive(Debug, Clone, Copy)]
struct Node {
    bounds: Bounds,
    start: u32,
    end: u32,
    first_child: u32,
}

impl Node {
    fn len(&self) -> usize {
        (self.end - self.start) as usize
    }

    fn range(&self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }
}

/// What chains are compared with.
struct Grid<'a> {
    points: &'a [ScanPoint],
    reach: &'a [usize],
    by_cell: &'a [(u64, u32)],
    nodes: &'a [Node],
    distance_m: f64,
    d_sq: f64,
}

impl Grid<'_> {
    /// The rule for points `i < j` (indices into the points).
    fn joined(&self, i: usize, j: usize) -> bool {
        let (a, b) = (&self.points[i], &self.points[j]);
        let d = b.point_in_laser - a.point_in_laser;
        b.beam < self.reach[i] && d.x * d.x + d.y * d.y < self.d_sq
    }

    /// Whether a point of the chain whose tree is rooted at `a` joins a point of the
    /// one rooted at `b`: a dual descent of their k-d trees, leaving out pairs of nodes
    /// whose points are all `distance_m` or more apart, nearer pairs first.
    fn chains_joined(&self, a: u32, b: u32, stack: &mut Vec<(u32, u32)>) -> bool {
        stack.clear();
        let (d, d_sq) = (self.distance_m, self.d_sq);
        if self.nodes[a as usize]
            .bounds
            .apart(&self.nodes[b as usize].bounds, d, d_sq)
        {
            return false;
        }
        stack.push((a, b));
        while let Some((a, b)) = stack.pop() {
            let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
            if na.bounds.span_sq(&nb.bounds) < d_sq && na.bounds.beams_apart(&nb.bounds) {
                // Every pair is close enough and the beams of one come before the
                // other's: the first beam of the later set is within the earlier set's
                // farthest window (not apart, as the pair was pushed).
                return true;
            }
            if na.first_child == 0 && nb.first_child == 0 {
                for &(_, i) in &self.by_cell[na.range()] {
                    for &(_, j) in &self.by_cell[nb.range()] {
                        if self.joined(i.min(j) as usize, i.max(j) as usize) {
                            return true;
                        }
                    }
                }
                continue;
            }
            // Split the node with more points (a leaf is not split); push the farther
            // child first.
            let split_a = nb.first_child == 0 || (na.first_child != 0 && na.len() >= nb.len());
            let (parent, other) = if split_a { (na, nb) } else { (nb, na) };
            let mut children = [(0.0, 0u32); 2];
            let mut count = 0;
            for child in [parent.first_child, parent.first_child + 1] {
                let bounds = &self.nodes[child as usize].bounds;
                if !bounds.apart(&other.bounds, d, d_sq) {
                    children[count] = (bounds.gap_sq(&other.bounds), child);
                    count += 1;
                }
            }
            if count == 2 && children[0].0 < children[1].0 {
                children.swap(0, 1);
            }
            for &(_, child) in &children[..count] {
                stack.push(if split_a { (child, b) } else { (a, child) });
            }
        }
        false
    }
}

/// The connected components of [`Breakpoint::Euclidean`]'s graph, as union-find
/// parents (`scratch.parent`) of sets of points known to be connected: the runs of
/// `scratch.run_start` when this returns true, else the grid's chains
/// (`scratch.chain_of` of each point).
///
/// First the run-based pass ([`runs_components`]), quickest on real scans, within a
/// budget of `work_per_point` visits a point (0: not at all). Past it, the grid: the
/// points go into square cells of side just under `distance_m / sqrt 2`, so that any
/// two points of a cell are closer than `distance_m` (each cell's bounding box is
/// checked for it). Within a cell, in beam order, a point therefore joins exactly the
/// later points of the cell whose beams are inside its window, a prefix; one pass over
/// the cell, carrying the farthest reach so far, cuts it into chains of consecutive
/// points, each connected, with no join between them inside the cell. Two points
/// closer than `distance_m` lie at most two cells apart in each direction, so the
/// chains of each cell are compared with those of the 12 cells after it in a 5 x 5
/// block (and no others), skipping pairs already in one component. A comparison
/// descends the two chains' k-d trees, leaving out pairs of nodes whose boxes, ranges
/// from the sensor or beam windows keep them apart, and deciding a pair of nodes
/// whose every pair of points is close and whose beams do not interleave by the
/// windows alone. Every bound is computed with the rule's own rounded operations, in
/// the direction that keeps it sound, so the components are exactly the rule's. A
/// scan whose coordinates are too large for the grid (beyond `2^30` cells) takes an
/// exact sweep along `x` instead, whose cost is not bounded.
fn euclidean_components(
    points: &[ScanPoint],
    dphi: f64,
    distance_m: f64,
    work_per_point: usize,
    scratch: &mut ClusterScratch,
) -> bool {
    let n = points.len();
    let d_sq = distance_m * distance_m;
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
    let ClusterScratch {
        run_start,
        run_range,
        grid,
        chain_of,
        parent,
        ..
    } = scratch;
    let budget = work_per_point.saturating_mul(n);
    if work_per_point > 0
        && runs_components(
            points, dphi, distance_m, &window, budget, run_start, run_range, parent,
        )
        .is_some()
    {
        return true;
    }
    grid.reach.clear();
    grid.reach.extend(
        points
            .iter()
            .map(|p| p.beam.saturating_add(window(p.range_m))),
    );
    chain_of.clear();
    chain_of.resize(n, 0);
    parent.clear();
    if !grid.chain_cells(points, distance_m, chain_of) {
        sweep_components(
            points,
            &grid.reach,
            distance_m,
            &mut grid.by_cell,
            chain_of,
            parent,
        );
        return false;
    }
    let GridScratch {
        reach,
        by_cell,
        cells,
        roots,
        nodes,
        stack,
        ..
    } = grid;
    parent.extend(0..roots.len() as u32);
    let grid = Grid {
        points,
        reach,
        by_cell,
        nodes,
        distance_m,
        d_sq,
    };
    // The cells after a cell in key order (x, then y) within two cells each way.
    const FORWARD: [(u64, i64); 12] = [
        (0, 1),
        (0, 2),
        (1, -2),
        (1, -1),
        (1, 0),
        (1, 1),
        (1, 2),
        (2, -2),
        (2, -1),
        (2, 0),
        (2, 1),
        (2, 2),
    ];
    // Keys grow with the cell, so each neighbour's position only moves forward.
    let mut next = [0usize; FORWARD.len()];
    for cell in cells.iter() {
        let (cx, cy) = (cell.key >> 32, (cell.key & 0xffff_ffff) as i64);
        for (&(dx, dy), at) in FORWARD.iter().zip(&mut next) {
            let target = ((cx + dx) << 32) | (cy + dy) as u64;
            while *at < cells.len() && cells[*at].key < target {
                *at += 1;
            }
            let Some(other) = cells.get(*at).filter(|c| c.key == target) else {
                continue;
            };
            for ca in cell.first_chain..cell.end_chain {
                for cb in other.first_chain..other.end_chain {
                    if find(parent, ca) != find(parent, cb)
                        && grid.chains_joined(roots[ca as usize], roots[cb as usize], stack)
                    {
                        union(parent, ca, cb);
                    }
                }
            }
        }
    }
    false
}

/// The run-based pass (tether's first implementation, quadratic in the worst case):
/// consecutive joined points form runs, and runs are merged by union-find wherever a
/// point of one joins a point of a later run. A later run is visited while it starts
/// within the beam window of the run's nearest return, and skipped when its ranges
/// all differ from the point's by `distance_m` or more (or when the two are in one
/// component already). On real scans, whose surfaces make long runs, this is the
/// quickest exact way; it gives up (`None`, leaving nothing usable) after `budget`
/// visits of a run by a point, and otherwise returns how many it made.
#[allow(
    clippy::too_many_arguments,
    reason = "the disjoint buffers of one scratch"
)]
fn runs_components(
    points: &[ScanPoint],
    dphi: f64,
    distance_m: f64,
    window: &impl Fn(f64) -> usize,
    budget: usize,
    runs: &mut Vec<u32>,
    span: &mut Vec<(f64, f64)>,
    parent: &mut Vec<u32>,
) -> Option<usize> {
    let n = points.len();
    let d_sq = distance_m * distance_m;
    let joined = |a: &ScanPoint, b: &ScanPoint, window_a: usize| {
        let d = b.point_in_laser - a.point_in_laser;
        b.beam < a.beam.saturating_add(window_a) && d.x * d.x + d.y * d.y < d_sq
    };
    // Runs of consecutive joined returns: connected already. Each run's range
    // interval lets whole runs be passed over.
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
        let w = if points[k].beam == a.beam + 1 && a.range_m < adjacent_below_m {
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
    parent.clear();
    parent.extend(0..n_runs as u32);
    let mut work = 0usize;
    for r in 0..n_runs {
        // No return of the run reaches farther than the window of its nearest range.
        let reach = window(span[r].0);
        for i in runs[r] as usize..runs[r + 1] as usize {
            let a = &points[i];
            let mut window_a = None;
            for other in r + 1..n_runs {
                work += 1;
                if work > budget {
                    return None;
                }
                let (lo, hi) = (runs[other] as usize, runs[other + 1] as usize);
                if points[lo].beam - a.beam >= reach {
                    break;
                }
                // Returns closer than `distance_m` differ by less than that in range.
                let (near, far) = span[other];
                if a.range_m <= near - distance_m || a.range_m >= far + distance_m {
                    continue;
                }
                if find(parent, r as u32) == find(parent, other as u32) {
                    continue;
                }
                let w = *window_a.get_or_insert_with(|| window(a.range_m));
                if points[lo..hi]
                    .iter()
                    .take_while(|b| b.beam - a.beam < w)
                    .any(|b| joined(a, b, w))
                {
                    union(parent, r as u32, other as u32);
                }
            }
        }
    }
    Some(work)
}

impl GridScratch {
    /// Sorts the points into the grid's cells, cuts each cell into chains and builds
    /// their k-d trees (`chain_of` gets each point's chain). False if the grid cannot
    /// be used: coordinates beyond it, or a cell whose points are not all closer than
    /// `distance_m` (which the cell size rules out but rounding is checked for).
    fn chain_cells(&mut self, points: &[ScanPoint], distance_m: f64, chain_of: &mut [u32]) -> bool {
        let GridScratch {
            reach,
            norm,
            by_cell,
            cells,
            roots,
            nodes,
            work,
            ..
        } = self;
        let d_sq = distance_m * distance_m;
        let side = distance_m * std::f64::consts::FRAC_1_SQRT_2 * (1.0 - 1.0 / 1024.0);
        let inv_side = 1.0 / side;
        by_cell.clear();
        cells.clear();
        roots.clear();
        nodes.clear();
        if !(d_sq.is_normal() && inv_side.is_normal()) {
            return false;
        }
        norm.clear();
        for (i, p) in points.iter().enumerate() {
            let p = p.point_in_laser;
            let (u, v) = (p.x * inv_side, p.y * inv_side);
            if !(u.abs() <= GRID_LIMIT && v.abs() <= GRID_LIMIT) {
                return false;
            }
            let cx = (u.floor() as i64 + GRID_BIAS) as u64;
            let cy = (v.floor() as i64 + GRID_BIAS) as u64;
            by_cell.push(((cx << 32) | cy, i as u32));
            norm.push((p.x * p.x + p.y * p.y).sqrt());
        }
        by_cell.sort_unstable();
        let n = by_cell.len();
        let mut start = 0;
        while start < n {
            let key = by_cell[start].0;
            let end = by_cell[start..]
                .iter()
                .position(|&(k, _)| k != key)
                .map_or(n, |len| start + len);
            // Every pair of the cell must be joined by distance: the computed spans
            // bound every pair's computed differences (monotone rounding).
            let mut b = Bounds::EMPTY;
            for &(_, i) in &by_cell[start..end] {
                b.add(&points[i as usize], 0.0, 0);
            }
            let (w, h) = (b.max_x - b.min_x, b.max_y - b.min_y);
            if !(w * w + h * h < d_sq) {
                return false;
            }
            let first_chain = roots.len() as u32;
            // A point joins the later points of its cell before its reach, so a point
            // past the farthest reach so far joins nothing before it: a new chain.
            let mut chain_start = start;
            let mut far = 0;
            for k in start..=end {
                let cut = k == end || {
                    let i = by_cell[k].1 as usize;
                    let cut = k > start && points[i].beam >= far;
                    far = far.max(reach[i]);
                    cut
                };
                if !cut {
                    continue;
                }
                let chain = roots.len() as u32;
                let mut b = Bounds::EMPTY;
                for &(_, i) in &by_cell[chain_start..k] {
                    chain_of[i as usize] = chain;
                    b.add(&points[i as usize], norm[i as usize], reach[i as usize]);
                }
                roots.push(nodes.len() as u32);
                nodes.push(Node {
                    bounds: b,
                    start: chain_start as u32,
                    end: k as u32,
                    first_child: 0,
                });
                build_tree(points, norm, reach, by_cell, nodes, work);
                chain_start = k;
            }
            cells.push(Cell {
                key,
                first_chain,
                end_chain: roots.len() as u32,
            });
            start = end;
        }
        true
    }
}

/// Splits the last node of `nodes` into a k-d tree: each node across the longer side
/// of its box at the middle, its points partitioned in place, until [`LEAF`] points or
/// fewer (or [`MAX_DEPTH`]).
fn build_tree(
    points: &[ScanPoint],
    norm: &[f64],
    reach: &[usize],
    by_cell: &mut [(u64, u32)],
    nodes: &mut Vec<Node>,
    work: &mut Vec<(u32, u32)>,
) {
    work.clear();
    work.push((nodes.len() as u32 - 1, 0));
    while let Some((id, depth)) = work.pop() {
        let node = nodes[id as usize];
        if node.len() <= LEAF || depth >= MAX_DEPTH {
            continue;
        }
        let b = node.bounds;
        let split_x = b.max_x - b.min_x >= b.max_y - b.min_y;
        let mid = if split_x {
            0.5 * (b.min_x + b.max_x)
        } else {
            0.5 * (b.min_y + b.max_y)
        };
        let (mut low, mut high) = (Bounds::EMPTY, Bounds::EMPTY);
        let (mut k, mut end) = (node.start as usize, node.end as usize);
        while k < end {
            let i = by_cell[k].1 as usize;
            let (p, r) = (&points[i], norm[i]);
            let c = if split_x {
                p.point_in_laser.x
            } else {
                p.point_in_laser.y
            };
            if c < mid {
                low.add(p, r, reach[i]);
                k += 1;
            } else {
                high.add(p, r, reach[i]);
                end -= 1;
                by_cell.swap(k, end);
            }
        }
        if k == node.start as usize || k == node.end as usize {
            continue;
        }
        let first = nodes.len() as u32;
        nodes.push(Node {
            bounds: low,
            start: node.start,
            end: k as u32,
            first_child: 0,
        });
        nodes.push(Node {
            bounds: high,
            start: k as u32,
            end: node.end,
            first_child: 0,
        });
        nodes[id as usize].first_child = first;
        work.push((first, depth + 1));
        work.push((first + 1, depth + 1));
    }
}

/// The exact fallback: every point its own chain, and the pairs found by a sweep in
/// `x` order (a pair whose computed `x` difference reaches `distance_m` is not joined,
/// nor is any pair farther along).
fn sweep_components(
    points: &[ScanPoint],
    reach: &[usize],
    distance_m: f64,
    by_cell: &mut Vec<(u64, u32)>,
    chain_of: &mut [u32],
    parent: &mut Vec<u32>,
) {
    let n = points.len();
    let d_sq = distance_m * distance_m;
    for (i, c) in chain_of.iter_mut().enumerate() {
        *c = i as u32;
    }
    parent.clear();
    parent.extend(0..n as u32);
    // `x` as a key in its total order.
    by_cell.clear();
    by_cell.extend(points.iter().enumerate().map(|(i, p)| {
        let bits = p.point_in_laser.x.to_bits();
        let key = if bits >> 63 == 1 {
            !bits
        } else {
            bits | 1 << 63
        };
        (key, i as u32)
    }));
    by_cell.sort_unstable();
    for (k, &(_, a)) in by_cell.iter().enumerate() {
        let pa = points[a as usize].point_in_laser;
        for &(_, b) in &by_cell[k + 1..] {
            let pb = points[b as usize].point_in_laser;
            if !(pb.x - pa.x < distance_m) {
                break;
            }
            let (i, j) = (a.min(b) as usize, a.max(b) as usize);
            let d = points[j].point_in_laser - points[i].point_in_laser;
            if points[j].beam < reach[i] && d.x * d.x + d.y * d.y < d_sq {
                union(parent, i as u32, j as u32);
            }
        }
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

    /// Clusters as [`cluster_into`] lists them, with `cluster_of` checked against them,
    /// for any angle increment and rule, with the run-based pass given `work_per_point`
    /// (0: the grid; `usize::MAX`: the runs).
    fn clusters_with(
        points: &[ScanPoint],
        inc: f64,
        rule: Breakpoint,
        work_per_point: usize,
        scratch: &mut ClusterScratch,
    ) -> Vec<Vec<usize>> {
        let (mut order, mut out) = (Vec::new(), Vec::new());
        let noise = RangeNoiseModel::default();
        cluster_with(
            points,
            inc,
            &noise,
            rule,
            work_per_point,
            scratch,
            &mut order,
            &mut out,
        );
        assert_eq!(scratch.cluster_of().len(), points.len());
        assert_eq!(order.len(), points.len());
        for (k, s) in out.iter().enumerate() {
            for &i in &order[s.start..s.end] {
                assert_eq!(scratch.cluster_of()[i], k as u32);
            }
        }
        out.iter().map(|s| order[s.start..s.end].to_vec()).collect()
    }

    /// The rule of [`Breakpoint::Euclidean`] as documented, pair by pair: the window of
    /// `a` as `floor(asin(d / r) / |inc|)` (unbounded for `r <= d` or from `n` beams on),
    /// the distance compared squared. Components by union-find over every pair;
    /// clusters numbered by their first point, points in beam order.
    fn reference(points: &[ScanPoint], inc: f64, d: f64) -> Vec<Vec<usize>> {
        let n = points.len();
        let unbounded = |a: &ScanPoint| {
            !(a.range_m > d && inc != 0.0) || (d / a.range_m).asin() / inc.abs() >= n as f64
        };
        let windows: Vec<f64> = points
            .iter()
            .map(|a| {
                if unbounded(a) {
                    f64::INFINITY
                } else {
                    ((d / a.range_m).asin() / inc.abs()).floor()
                }
            })
            .collect();
        let mut label: Vec<usize> = (0..n).collect();
        fn root(label: &mut [usize], mut i: usize) -> usize {
            while label[i] != i {
                i = label[i];
            }
            i
        }
        for i in 0..n {
            for j in i + 1..n {
                let (a, b) = (&points[i], &points[j]);
                let (dx, dy) = (
                    b.point_in_laser.x - a.point_in_laser.x,
                    b.point_in_laser.y - a.point_in_laser.y,
                );
                if ((b.beam - a.beam) as f64) < windows[i] && dx * dx + dy * dy < d * d {
                    let (ri, rj) = (root(&mut label, i), root(&mut label, j));
                    label[ri.max(rj)] = ri.min(rj);
                }
            }
        }
        let mut out: Vec<Vec<usize>> = Vec::new();
        let mut number = vec![usize::MAX; n];
        for i in 0..n {
            let r = root(&mut label, i);
            if number[r] == usize::MAX {
                number[r] = out.len();
                out.push(Vec::new());
            }
            out[number[r]].push(i);
        }
        out
    }

    /// A pseudo-random scan: `n` beams of one of several patterns, some beams without
    /// a return (NaN, infinite, beyond the range limits).
    fn random_ranges(n: usize, pattern: u8, drop: f64, d: f64, seed: u64) -> Vec<f32> {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (a, b) = (0.01 + 0.8 * next(), 0.01 + 0.8 * next());
        let mut walks = [0.3 + 3.0 * next(), 0.3 + 3.0 * next(), 0.3 + 3.0 * next()];
        let mut object = (0.0, 0usize);
        (0..n)
            .map(|i| {
                let r = match pattern {
                    // Anywhere within the limits.
                    0 => 0.01 + 6.0 * next(),
                    // Near the sensor, some within the clustering distance.
                    1 => 0.003 + 3.0 * d * next(),
                    // Two ranges alternating beam by beam, slightly jittered.
                    2 => (if i % 2 == 0 { a } else { b }) + 0.002 * next(),
                    // Objects of a few beams at random ranges.
                    3 => {
                        if object.1 == 0 {
                            object = (0.02 + 4.0 * next(), 1 + (12.0 * next()) as usize);
                        }
                        object.1 -= 1;
                        object.0 + 0.05 * (next() - 0.5)
                    }
                    // Three surfaces seen in turn, beam by beam or in short runs.
                    _ => {
                        let w = if next() < 0.5 { i % 3 } else { (i / 4) % 3 };
                        walks[w] = (walks[w] + 0.03 * (next() - 0.5)).clamp(0.02, 8.0);
                        walks[w]
                    }
                };
                let u = next();
                if u < drop {
                    [f32::NAN, f32::INFINITY, 50.0, 0.001][(4.0 * u / drop) as usize % 4]
                } else {
                    r as f32
                }
            })
            .collect()
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config {
            cases: std::env::var("PROPTEST_CASES")
                .ok()
                .and_then(|c| c.parse().ok())
                .unwrap_or(48),
            ..proptest::test_runner::Config::default()
        })]

        /// Both ways of clustering (the runs, the grid) and the default mix give the
        /// rule's components, numbered and ordered as the reference, on random scans:
        /// beam counts, missing beams, patterns near the sensor and interleaved, angle
        /// increments up to half a radian either way (wide scans whose beams come
        /// round again).
        #[test]
        fn euclidean_clustering_matches_the_rule(
            n in proptest::prop_oneof![1usize..60, 1usize..3000],
            pattern in 0u8..5,
            drop in proptest::prop_oneof![proptest::strategy::Just(0.0), 0.0f64..0.4],
            log_inc in -4.0f64..-0.3,
            clockwise: bool,
            angle_min in -3.2f64..3.2,
            d in proptest::prop_oneof![
                proptest::strategy::Just(0.13),
                proptest::strategy::Just(0.05),
                0.01f64..0.6,
            ],
            seed: u64,
        ) {
            let inc = if clockwise { -1.0 } else { 1.0 } * 10f64.powf(log_inc);
            let ranges = random_ranges(n, pattern, drop, d, seed);
            let scan = LaserScan::new(Stamp::ZERO, "l", angle_min, inc, 0.002, 10.0, ranges)
                .unwrap();
            let pts = preprocess(&scan, &RangeNoiseModel::default());
            let rule = Breakpoint::Euclidean { distance_m: d };
            let want = reference(&pts, inc, d);
            let half = &pts[..pts.len() / 2];
            let want_half = reference(half, inc, d);
            for work in [0, usize::MAX, RUNS_WORK_PER_POINT] {
                let mut scratch = ClusterScratch::default();
                let got = clusters_with(&pts, inc, rule, work, &mut scratch);
                proptest::prop_assert_eq!(&got, &want, "work {}", work);
                // The same buffers again, after a scan of another size: same result.
                let again = clusters_with(half, inc, rule, work, &mut scratch);
                proptest::prop_assert_eq!(&again, &want_half, "work {}", work);
                let again = clusters_with(&pts, inc, rule, work, &mut scratch);
                proptest::prop_assert_eq!(&again, &want, "work {}", work);
            }
        }
    }

    #[test]
    fn coordinates_beyond_the_grid_take_the_exact_sweep() {
        // Returns 10^9 m away: beyond 2^30 cells of 9 cm, so the grid is not used.
        // Runs of ten beams at one of three ranges 512 m apart, a beam in 37 missing;
        // then a return every 100 beams (0.1 m apart, joined only at that distance).
        let mut ranges: Vec<f32> = (0..2000)
            .map(|i| {
                if i % 37 == 5 || (i >= 400 && i % 100 != 0) {
                    f32::NAN
                } else if i < 400 {
                    1e9 + 512.0 * ((i / 10) % 3) as f32
                } else {
                    1e9 + 2048.0
                }
            })
            .collect();
        ranges[7] = 0.5;
        let inc = 1e-12;
        let scan = LaserScan::new(Stamp::ZERO, "l", 1.2, inc, 0.002, 1e10, ranges).unwrap();
        let pts = preprocess(&scan, &RangeNoiseModel::default());
        for (d, count) in [(0.13, 6), (1.0, 5), (1e3, 3)] {
            let rule = Breakpoint::Euclidean { distance_m: d };
            let got = clusters_with(&pts, inc, rule, 0, &mut ClusterScratch::default());
            assert_eq!(got, reference(&pts, inc, d), "d = {d}");
            assert_eq!(got.len(), count, "d = {d}");
        }
        // A distance whose square underflows joins nothing.
        let pts = points(random_ranges(300, 3, 0.1, 0.13, 8));
        let rule = Breakpoint::Euclidean { distance_m: 1e-200 };
        let got = clusters_with(&pts, INC, rule, 0, &mut ClusterScratch::default());
        assert_eq!(got, reference(&pts, INC, 1e-200));
        assert_eq!(got.len(), pts.len());
    }

    #[test]
    fn dense_scans_match_the_rule() {
        // The benchmark's adversaries at a few thousand beams: ranges alternating
        // 0.03 / 0.25 m, and interleaved surfaces 0.13-0.14 m apart.
        for (n, pattern) in [(4000, 0), (4000, 1), (3000, 2)] {
            let inc = 1.5 * std::f64::consts::PI / n as f64;
            let ranges = (0..n)
                .map(|i| match pattern {
                    0 => [0.03, 0.25][i % 2],
                    1 => [1.0, 1.13, 1.2601][i % 3],
                    _ => 0.2 + 0.1 * ((i * 7919) % 101) as f32 / 101.0,
                })
                .collect();
            let scan = LaserScan::new(Stamp::ZERO, "l", -2.36, inc, 0.002, 10.0, ranges).unwrap();
            let pts = preprocess(&scan, &RangeNoiseModel::default());
            let rule = Breakpoint::default();
            let want = reference(&pts, inc, 0.13);
            for work in [0, usize::MAX, RUNS_WORK_PER_POINT] {
                let got = clusters_with(&pts, inc, rule, work, &mut ClusterScratch::default());
                assert_eq!(got, want, "pattern {pattern}, work {work}");
            }
        }
    }

    #[test]
    fn the_grid_compares_cells_two_apart_either_way() {
        // Two returns at the facing corners of two cells (of the grid's size) at
        // every offset up to two cells each way: even two apart diagonally, they are
        // closer than the distance, and are joined.
        let d = 0.13;
        let side = d * std::f64::consts::FRAC_1_SQRT_2 * (1.0 - 1.0 / 1024.0);
        let eps = 1e-5;
        // A coordinate of the first return, in cell 10 (or 7), towards cell `k` away,
        // and of the second, in that cell, towards the first.
        let first = |cell: f64, k: i32| match k {
            0 => (cell + 0.5) * side,
            k if k > 0 => (cell + 1.0) * side - eps,
            _ => cell * side + eps,
        };
        let second = |cell: f64, k: i32| match k {
            0 => (cell + 0.5) * side,
            k if k > 0 => (cell + f64::from(k)) * side + eps,
            _ => (cell + f64::from(k) + 1.0) * side - eps,
        };
        let point = |beam: usize, x: f64, y: f64| {
            let p = tether_core::Point2::new(x, y);
            ScanPoint {
                beam,
                range_m: x.hypot(y),
                bearing_rad: y.atan2(x),
                point_in_laser: p,
            }
        };
        let rule = Breakpoint::Euclidean { distance_m: d };
        for dx in -2..=2 {
            for dy in -2..=2 {
                if (dx, dy) == (0, 0) {
                    continue;
                }
                let a = point(0, first(10.0, dx), first(7.0, dy));
                let b = point(1, second(10.0, dx), second(7.0, dy));
                assert!(a.point_in_laser.distance_m(b.point_in_laser) < d);
                for pts in [
                    [a, b],
                    [ScanPoint { beam: 0, ..b }, ScanPoint { beam: 1, ..a }],
                ] {
                    let got = clusters_with(&pts, 1e-4, rule, 0, &mut ClusterScratch::default());
                    assert_eq!(got, vec![vec![0, 1]], "offset ({dx}, {dy})");
                    assert_eq!(got, reference(&pts, 1e-4, d));
                }
            }
        }
    }

    #[test]
    fn the_grid_and_the_runs_agree_on_the_real_recordings() {
        // Every scan of every laser topic of leg_tracker's recordings (3,773 scans),
        // at the default distance and at 0.3 m, clustered both ways.
        let Some(dir) = tether_testkit::shared("data/laser/leg_tracker") else {
            return;
        };
        let mut topics: Vec<(String, &str)> = (1..=7)
            .filter(|k| *k != 5)
            .map(|k| (format!("positive_{k}_extracted.bag"), "/training_scan"))
            .collect();
        for topic in ["/left_scan", "/rear_scan", "/right_scan"] {
            topics.push(("negative_2.bag".into(), topic));
        }
        topics.push(("demo_stationary_simple_environment.bag".into(), "/scan"));
        let (mut by_grid, mut by_runs) = (ClusterScratch::default(), ClusterScratch::default());
        let mut scans = 0;
        for (bag, topic) in &topics {
            let read = tether_recording::rosbag::read_scans(dir.join(bag), topic).unwrap();
            for m in &read.scans {
                let pts = preprocess(&m.scan, &RangeNoiseModel::default());
                let inc = m.scan.angle_increment_rad;
                for d in [0.13, 0.3] {
                    let rule = Breakpoint::Euclidean { distance_m: d };
                    assert_eq!(
                        clusters_with(&pts, inc, rule, 0, &mut by_grid),
                        clusters_with(&pts, inc, rule, usize::MAX, &mut by_runs),
                        "{bag} {topic}, d = {d}"
                    );
                }
                scans += 1;
            }
        }
        assert_eq!(scans, 3773);
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
