//! The connected components of the Euclidean rule of [`super::cluster_into`]: the
//! run-based pass within its budget, else a grid of cells with a k-d tree a chain.

use super::{ClusterScratch, find, union};
use crate::preprocess::ScanPoint;

/// The buffers of the grid of [`Breakpoint::Euclidean`] clustering.
#[derive(Debug, Clone, Default)]
pub(super) struct GridScratch {
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

/// leg_tracker's beam window: a return at range `r` joins returns fewer than
/// `floor(asin(distance_m / r) / dphi)` beams after it (every later beam, `usize::MAX`,
/// when that reaches the `n` beams of the scan or `r` is within `distance_m`).
fn beam_window(r: f64, distance_m: f64, dphi: f64, n: usize) -> usize {
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
pub(super) fn euclidean_components(
    points: &[ScanPoint],
    dphi: f64,
    distance_m: f64,
    work_per_point: usize,
    scratch: &mut ClusterScratch,
) -> bool {
    let n = points.len();
    let d_sq = distance_m * distance_m;
    let window = |r: f64| beam_window(r, distance_m, dphi, n);
    let ClusterScratch {
        run_start,
        run_range,
        grid,
        chain_of,
        parent,
        windows,
        ..
    } = scratch;
    let budget = work_per_point.saturating_mul(n);
    windows.update(distance_m, dphi);
    let window_of = Window {
        exact: &window,
        table: windows,
        n,
    };
    if work_per_point > 0
        && runs_components(
            points, distance_m, &window_of, budget, run_start, run_range, parent,
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

/// The beam window of a range: the rule's own computation, `exact`, and a table that
/// answers most questions about it without the `asin`.
pub(super) struct Window<'a> {
    /// The window of a return at a range, in beams (`usize::MAX`: unbounded).
    pub(super) exact: &'a dyn Fn(f64) -> usize,
    pub(super) table: &'a WindowTable,
    /// The number of returns of the scan (a window as wide is unbounded).
    pub(super) n: usize,
}

impl Window<'_> {
    /// Whether a return `gap` beams after one at `range_m` lies inside the latter's
    /// window: `gap < exact(range_m)`, from the table where it decides, else from
    /// `exact(range_m)`, computed once into `cache` (which must belong to `range_m`).
    fn inside(&self, range_m: f64, gap: usize, cache: &mut Option<usize>) -> bool {
        self.table
            .decides(range_m, gap, self.n)
            .unwrap_or_else(|| gap < *cache.get_or_insert_with(|| (self.exact)(range_m)))
    }
}

/// Ranges at which the beam window `floor(asin(d / r) / dphi)` crosses each width `m`,
/// for one `d` and `dphi`: the window is at least `m` beams exactly when
/// `r <= T_m = d / sin(m dphi)` (for `m dphi <= pi / 2`; the window only narrows as
/// the range grows). Kept between scans; [`WindowTable::decides`] answers from it
/// away from the crossings, and leaves the rest to the computation.
#[derive(Debug, Clone, Default)]
pub(super) struct WindowTable {
    /// `d` and `dphi`, as bits, that the table is for (`None`: none yet).
    key: Option<(u64, u64)>,
    /// For each `m`: `T_m (1 - 1e-6)` and `T_m (1 + 1e-6)`.
    crossings: Vec<(f64, f64)>,
}

/// Widest window [`WindowTable`] holds the crossing of, beams.
const TABLE_BEAMS: usize = 256;

/// Widest angle `m dphi` that [`WindowTable`] holds the crossing of, rad: below pi / 2
/// with room, so that `sin` is well away from its maximum and `T_m` from `d`.
const TABLE_ANGLE_RAD: f64 = 1.4;

impl WindowTable {
    /// Makes the table fit `distance_m` and `dphi` (recomputing it only if they
    /// changed).
    pub(super) fn update(&mut self, distance_m: f64, dphi: f64) {
        let key = (distance_m.to_bits(), dphi.to_bits());
        if self.key == Some(key) {
            return;
        }
        self.key = Some(key);
        self.crossings.clear();
        if !(distance_m > 0.0 && distance_m.is_finite() && dphi > 0.0 && dphi.is_finite()) {
            return;
        }
        for m in 0..=TABLE_BEAMS {
            let angle = m as f64 * dphi;
            if angle > TABLE_ANGLE_RAD {
                break;
            }
            let t = distance_m / angle.sin();
            // (`m = 0` crosses nowhere: an infinite `t` decides nothing.)
            self.crossings.push((t * (1.0 - 1e-6), t * (1.0 + 1e-6)));
        }
    }

    /// `Some(gap < window(range_m))` where the table decides it, for a scan of `n`
    /// returns. With `m = gap + 1`: below `T_m (1 - 1e-6)`, `d / r` exceeds
    /// `sin(m dphi)` by a relative 1e-6, so (`asin' >= 1`, `sin x >= 2 x / pi`) the
    /// window's quotient exceeds `m` by a relative 6e-7, far past the rounding of the
    /// division, the `asin` (within an ulp) and the quotient; and `r <= d` gives the
    /// unbounded window. Above `T_m (1 + 1e-6)` the quotient falls short of `m` by as
    /// much, so the window is below `m`, unless `m > n` (a quotient of `n` or more is
    /// unbounded). `None` in between and beyond the table.
    fn decides(&self, range_m: f64, gap: usize, n: usize) -> Option<bool> {
        let m = gap.checked_add(1)?;
        let &(below, above) = self.crossings.get(m)?;
        if range_m < below {
            Some(true)
        } else if range_m > above && m <= n {
            Some(false)
        } else {
            None
        }
    }
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
    distance_m: f64,
    window: &Window<'_>,
    budget: usize,
    runs: &mut Vec<u32>,
    span: &mut Vec<(f64, f64)>,
    parent: &mut Vec<u32>,
) -> Option<usize> {
    let n = points.len();
    let d_sq = distance_m * distance_m;
    let close = |a: &ScanPoint, b: &ScanPoint| {
        let d = b.point_in_laser - a.point_in_laser;
        d.x * d.x + d.y * d.y < d_sq
    };
    // Runs of consecutive joined returns: connected already. Each run's range
    // interval lets whole runs be passed over.
    runs.clear();
    span.clear();
    runs.push(0);
    span.push((points[0].range_m, points[0].range_m));
    for k in 1..n {
        let (a, b) = (&points[k - 1], &points[k]);
        if window.inside(a.range_m, b.beam - a.beam, &mut None) && close(a, b) {
            let last = span.len() - 1;
            span[last] = (span[last].0.min(b.range_m), span[last].1.max(b.range_m));
        } else {
            runs.push(k as u32);
            span.push((b.range_m, b.range_m));
        }
    }
    let n_runs = runs.len();
    runs.push(n as u32);
    parent.clear();
    parent.extend(0..n_runs as u32);
    let mut work = 0usize;
    for r in 0..n_runs {
        // No return of the run reaches farther than the window of its nearest range.
        let mut reach = None;
        for i in runs[r] as usize..runs[r + 1] as usize {
            let a = &points[i];
            let mut window_a = None;
            for other in r + 1..n_runs {
                work += 1;
                if work > budget {
                    return None;
                }
                let (lo, hi) = (runs[other] as usize, runs[other + 1] as usize);
                if !window.inside(span[r].0, points[lo].beam - a.beam, &mut reach) {
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
                if points[lo..hi]
                    .iter()
                    .take_while(|b| window.inside(a.range_m, b.beam - a.beam, &mut window_a))
                    .any(|b| close(a, b))
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
    use super::{WindowTable, beam_window};

    /// Wherever the table decides, it says what the computation says: ranges spread
    /// over the scanner's reach and packed around every crossing, for the common beam
    /// steps, every gap the table holds and scans of a few sizes.
    #[test]
    fn the_window_table_decides_as_the_computation() {
        let (mut decided, mut asked) = (0usize, 0usize);
        for step_deg in [0.25, 0.352, 0.5, 1.0] {
            let dphi = f64::to_radians(step_deg);
            for distance_m in [0.13, 0.2] {
                let mut table = WindowTable::default();
                table.update(distance_m, dphi);
                for n in [40usize, 500, 5000] {
                    let exact = |r: f64| beam_window(r, distance_m, dphi, n);
                    let mut ranges: Vec<f64> =
                        (0..4000).map(|k| 0.01 * 1.0025f64.powi(k)).collect();
                    for &(below, above) in &table.crossings {
                        let t = 0.5 * (below + above);
                        for r in [below, above, t, t.next_up(), t.next_down()] {
                            ranges.extend([r, r.next_up(), r.next_down(), r * (1.0 + 1e-7)]);
                        }
                    }
                    for &r in ranges.iter().filter(|r| r.is_finite()) {
                        for gap in 1..table.crossings.len() + 2 {
                            let held = gap + 1 < table.crossings.len() && gap < n;
                            asked += usize::from(held);
                            if let Some(inside) = table.decides(r, gap, n) {
                                decided += usize::from(held);
                                assert_eq!(inside, gap < exact(r), "r {r} gap {gap} n {n}");
                            }
                        }
                    }
                }
            }
        }
        // It must decide nearly everything it holds to be worth having.
        assert!(decided as f64 > 0.99 * asked as f64, "{decided} of {asked}");
    }

    #[test]
    fn no_table_for_a_geometry_without_windows() {
        for (d, dphi) in [(0.13, 0.0), (0.13, -0.01), (0.0, 0.01), (f64::NAN, 0.01)] {
            let mut table = WindowTable::default();
            table.update(d, dphi);
            assert_eq!(table.decides(1.0, 1, 100), None);
        }
    }
}
