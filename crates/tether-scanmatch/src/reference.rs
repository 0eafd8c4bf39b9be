//! A reference scan (the keyframe) searchable by beam direction: nearest points without a
//! k-d tree, and the line segments between neighbouring returns.

use std::f64::consts::{PI, TAU};

use serde::{Deserialize, Serialize};
use tether_core::{Laser, Point2, Pose2, Robot};

use crate::points::ScanPoints;

/// How the nearest reference point of a query point is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum NeighbourSearch {
    /// Walk outwards from the query's beam direction and stop as soon as no farther beam
    /// can hold a closer point ([`Reference::nearest`]). Exact, and a few beams per query.
    #[default]
    AngularWindow,
    /// Try every reference point ([`Reference::nearest_brute_force`]): the slow, obvious
    /// reference the fast search is tested against.
    BruteForce,
}

/// Returns on each side of a return whose mean places its line across the surface.
const ANCHOR_HALF_WIDTH: usize = 1;

/// Bins per radian of the direction look-up table (about one per URG-04LX beam).
const BINS_PER_RAD: f64 = 200.0;

/// How the reference's surfaces are estimated around each return.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct LineFit {
    /// Neighbouring returns farther apart than this are on different surfaces (a jump
    /// edge), m.
    #[config(range = "> 0")]
    pub max_gap_m: f64,
    /// Half the length of surface around a return that its line is fitted to, m.
    #[config(range = "> 0")]
    pub half_span_m: f64,
    /// A fit is a line only when the spread across it is at most this share of the
    /// spread along it (ratio of the eigenvalues of the points' covariance).
    #[config(range = "> 0")]
    pub max_flatness: f64,
}

impl Default for LineFit {
    fn default() -> Self {
        LineFit {
            max_gap_m: 0.2,
            half_span_m: 0.1,
            max_flatness: 0.1,
        }
    }
}

/// The line of the reference surface at one return: unit normal and a point on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    /// Unit normal, robot frame.
    pub normal: (f64, f64),
    /// A point of the line, where the surface is at this return (see [`Reference`]),
    /// robot frame.
    pub anchor: Point2<Robot>,
}

/// A keyframe scan prepared for matching: its returns in its own robot frame and in its
/// laser frame, their beam directions, and at each return the line of the surface it
/// lies on.
///
/// PL-ICP (Censi, ICRA 2008) matches a point to the segment between its two nearest
/// reference returns. With the URG-04LX that segment is noise near the scanner: beams
/// are 6 mm apart at 1 m and ranges scatter by about 1 cm (design 2.1), so the line
/// through two neighbours points anywhere. Here the line at return `k` is fitted (total
/// least squares: the principal axis of the points' covariance) to the returns of the
/// same surface within [`LineFit::half_span_m`] of it on either side — the same
/// point-to-line model, with a line that noise does not turn. The line is placed across
/// the surface at the mean of this return and its two neighbours, not at the fit's
/// centroid: on a curved surface the centroid lies behind it by the sagitta, which moves
/// with the viewpoint (on a sparse scene of trunks and posts the drift was 2.1 % through
/// the centroid, 0.65 % so; at the return alone, the nearest return's own noise, chosen by
/// being nearest, biased single matches fivefold). Sums over returns are kept as prefix
/// sums, so every fit costs the same whatever its width.
#[derive(Debug, Clone)]
pub struct Reference {
    laser_from_robot: Pose2<Laser, Robot>,
    bearings_rad: Vec<f64>,
    /// Per return, what the search reads, side by side (one cache line):
    /// `(u_x, u_y, p_x, p_y)`, the unit vector of its beam and the return, laser frame.
    search: Vec<[f64; 4]>,
    in_robot: Vec<Point2<Robot>>,
    ranges_m: Vec<f64>,
    /// `(n_x, n_y, anchor_x, anchor_y)` of the line at each return, NaN when the
    /// neighbourhood is not a line.
    lines: Vec<[f64; 4]>,
    /// `bin_first[b]`: the first return whose direction is at or after the start of bin
    /// `b`.
    bin_first: Vec<u32>,
    bin_origin_rad: f64,
    /// Middle of the directions: a query's direction is taken within half a turn of it.
    centre_rad: f64,
    /// The directions span less than 3 pi / 2, so that every beam more than a right
    /// angle from a query inside the span is at least the query's range from it (see
    /// [`Reference::nearest_from`]).
    hint_ok: bool,
    /// The directions span more than half a turn.
    wide: bool,
    /// Scratch: first and last index of each return's surface run, prefix sums.
    run_start: Vec<u32>,
    run_end: Vec<u32>,
    prefix: Vec<[f64; 5]>,
}

impl Default for Reference {
    fn default() -> Self {
        Reference {
            laser_from_robot: Pose2::IDENTITY,
            bearings_rad: Vec::new(),
            search: Vec::new(),
            in_robot: Vec::new(),
            ranges_m: Vec::new(),
            lines: Vec::new(),
            bin_first: Vec::new(),
            bin_origin_rad: 0.0,
            centre_rad: 0.0,
            hint_ok: false,
            wide: false,
            run_start: Vec::new(),
            run_end: Vec::new(),
            prefix: Vec::new(),
        }
    }
}

/// The result of a nearest-point search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Index of the reference return.
    pub index: usize,
    /// Squared distance to it, m^2.
    pub distance_sq_m2: f64,
}

/// `atan2(y, x)` to within 1.2e-5 rad, without a library call: Hastings' odd polynomial for
/// atan on [-1, 1] (Abramowitz and Stegun 4.4.49; |error| <= 1.2e-5 as measured here) and the octant
/// identities. Only used to choose where a search starts, so its error never changes a
/// result (the search is exact whatever its start).
#[inline]
pub(crate) fn fast_atan2(y: f64, x: f64) -> f64 {
    use std::f64::consts::{FRAC_PI_2, PI};
    let ax = x.abs();
    let ay = y.abs();
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    let swap = ay > ax;
    let z = if swap { ax / ay } else { ay / ax };
    let z2 = z * z;
    let mut a = z
        * (0.999_866_0
            + z2 * (-0.330_299_5 + z2 * (0.180_141_0 + z2 * (-0.085_133_0 + z2 * 0.020_835_1))));
    if swap {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 { -a } else { a }
}

/// A lower bound of `sin(d)` for `d >= 0` that never needs a library call: `d - d^3/6`
/// (the Taylor series of sine alternates, so its first two terms stay below it), held at
/// its value at 1.4 rad beyond (where `d - d^3/6` stops growing), which is below
/// `sin(d)` up to pi/2 and below 1 after.
#[inline]
fn sin_lower_bound(d: f64) -> f64 {
    let d = d.min(1.4);
    d - d * d * d / 6.0
}

impl Reference {
    /// Prepares the returns of `scan` for which `keep(i)` is true, fitting lines as
    /// `fit` says.
    pub fn build(scan: &ScanPoints, fit: &LineFit, keep: impl Fn(usize) -> bool) -> Self {
        let mut r = Reference::default();
        r.rebuild(scan, fit, keep);
        r
    }

    /// Like [`Reference::build`], reusing the buffers.
    pub fn rebuild(&mut self, scan: &ScanPoints, fit: &LineFit, keep: impl Fn(usize) -> bool) {
        let laser_from_robot = scan.robot_from_laser().inverse();
        self.laser_from_robot = laser_from_robot;
        self.bearings_rad.clear();
        self.search.clear();
        self.in_robot.clear();
        self.ranges_m.clear();
        self.lines.clear();
        self.bin_first.clear();
        let (ls, lc) = laser_from_robot.yaw.sin_cos();
        for (i, (((&b, &p), &r), &u)) in scan
            .bearings_rad()
            .iter()
            .zip(scan.points())
            .zip(scan.ranges_m())
            .zip(scan.directions())
            .enumerate()
        {
            if keep(i) {
                self.bearings_rad.push(b);
                self.in_robot.push(p);
                self.search.push([
                    u.0,
                    u.1,
                    lc * p.x - ls * p.y + laser_from_robot.x,
                    ls * p.x + lc * p.y + laser_from_robot.y,
                ]);
                self.ranges_m.push(r);
            }
        }
        let n = self.in_robot.len();
        self.fit_lines(fit);
        if n == 0 {
            return;
        }
        self.hint_ok = self.bearings_rad[n - 1] - self.bearings_rad[0] < 1.5 * PI - 1e-3;
        self.wide = self.bearings_rad[n - 1] - self.bearings_rad[0] > PI;
        self.bin_origin_rad = self.bearings_rad[0];
        self.centre_rad = 0.5 * (self.bearings_rad[0] + self.bearings_rad[n - 1]);
        let span = self.bearings_rad[n - 1] - self.bin_origin_rad;
        let bins = (span * BINS_PER_RAD).floor() as usize + 2;
        let mut k = 0usize;
        for b in 0..bins {
            let start = self.bin_origin_rad + b as f64 / BINS_PER_RAD;
            while k < n && self.bearings_rad[k] < start {
                k += 1;
            }
            self.bin_first.push(k as u32);
        }
    }

    /// Fits the line at every return to its surface neighbours (see [`Reference`]).
    ///
    /// The neighbourhood of return `k` (range `r_k`) is `m = ceil(half_span / (r_k db))`
    /// returns on each side (`db` the beam spacing there: the returns a surface facing
    /// the scanner puts within `half_span`), clipped to `k`'s surface run. Its mean
    /// `mu` and covariance `C` come from prefix sums of `x, y, x^2, xy, y^2`; the line's
    /// normal is the eigenvector of `C`'s smaller eigenvalue `lambda_min` (it solves
    /// `(C - lambda_min I) n = 0`); it is a line when
    /// `lambda_min <= max_flatness * lambda_max`.
    fn fit_lines(&mut self, fit: &LineFit) {
        let n = self.in_robot.len();
        self.run_start.clear();
        self.run_end.clear();
        self.prefix.clear();
        let gap_sq = fit.max_gap_m * fit.max_gap_m;
        let mut start = 0u32;
        let mut acc = [0.0f64; 5];
        self.prefix.push(acc);
        for k in 0..n {
            if k > 0 {
                let d = self.in_robot[k] - self.in_robot[k - 1];
                if d.x * d.x + d.y * d.y > gap_sq {
                    start = k as u32;
                }
            }
            self.run_start.push(start);
            let p = self.in_robot[k];
            acc[0] += p.x;
            acc[1] += p.y;
            acc[2] += p.x * p.x;
            acc[3] += p.x * p.y;
            acc[4] += p.y * p.y;
            self.prefix.push(acc);
        }
        // Run ends, walking back.
        self.run_end.resize(n, 0);
        let mut end = n.saturating_sub(1) as u32;
        for k in (0..n).rev() {
            self.run_end[k] = end;
            if k > 0 && self.run_start[k] == k as u32 {
                end = k as u32 - 1;
            }
        }
        self.lines.clear();
        self.lines.resize(n, [f64::NAN; 4]);
        let (pre, starts, ends) = (&self.prefix[..], &self.run_start[..], &self.run_end[..]);
        let (bearings, ranges) = (&self.bearings_rad[..], &self.ranges_m[..]);
        for (k, line) in self.lines.iter_mut().enumerate() {
            let spacing = if n > 1 {
                let kk = k.min(n - 2);
                (bearings[kk + 1] - bearings[kk]).abs()
            } else {
                1.0
            };
            // ceil, as floor + 1 (no library call; one more return at most).
            let m = fit.half_span_m / (ranges[k] * spacing).max(1e-6);
            let m = (m.clamp(0.0, 63.0) as usize) + 1;
            let lo = k.saturating_sub(m).max(starts[k] as usize);
            let hi = (k + m).min(ends[k] as usize);
            if hi < lo + 2 {
                continue;
            }
            let inv_count = 1.0 / (hi + 1 - lo) as f64;
            let (a, b) = (&pre[lo], &pre[hi + 1]);
            let (mx, my) = ((b[0] - a[0]) * inv_count, (b[1] - a[1]) * inv_count);
            let cxx = (b[2] - a[2]) * inv_count - mx * mx;
            let cxy = (b[3] - a[3]) * inv_count - mx * my;
            let cyy = (b[4] - a[4]) * inv_count - my * my;
            let half_trace = 0.5 * (cxx + cyy);
            let root = (0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy).sqrt();
            let (l_max, l_min) = (half_trace + root, (half_trace - root).max(0.0));
            if !(l_max > 0.0 && l_min <= fit.max_flatness * l_max) {
                continue;
            }
            // The eigenvector of lambda_min, from whichever row of `C - lambda_min I` is
            // the larger (the better conditioned).
            let (ra, rb) = (cxx - l_min, cyy - l_min);
            let (nx, ny) = if ra >= rb { (-cxy, ra) } else { (rb, -cxy) };
            let norm_sq = nx * nx + ny * ny;
            if norm_sq > 0.0 {
                let inv = 1.0 / norm_sq.sqrt();
                let (nx, ny) = (nx * inv, ny * inv);
                // Anchored where the surface is at this return, not at the centroid: on a
                // curved surface (a trunk, a pillar) the centroid lies behind the surface
                // by the sagitta, which moves with the viewpoint and biases the match.
                // The offset across the line is the mean over the returns within
                // ANCHOR_HALF_WIDTH of this one (less noise than the return alone).
                let (slo, shi) = (
                    k.saturating_sub(ANCHOR_HALF_WIDTH).max(lo),
                    (k + ANCHOR_HALF_WIDTH).min(hi),
                );
                let inv_small = 1.0 / (shi + 1 - slo) as f64;
                let (sa, sb) = (&pre[slo], &pre[shi + 1]);
                let (sx, sy) = ((sb[0] - sa[0]) * inv_small, (sb[1] - sa[1]) * inv_small);
                let offset = nx * (sx - mx) + ny * (sy - my);
                *line = [nx, ny, mx + offset * nx, my + offset * ny];
            }
        }
    }

    /// Number of returns.
    pub fn len(&self) -> usize {
        self.in_robot.len()
    }

    /// True without returns.
    pub fn is_empty(&self) -> bool {
        self.in_robot.is_empty()
    }

    /// The keyframe's laser frame from its robot frame.
    pub fn laser_from_robot(&self) -> Pose2<Laser, Robot> {
        self.laser_from_robot
    }

    /// The returns in the keyframe's robot frame.
    pub fn points(&self) -> &[Point2<Robot>] {
        &self.in_robot
    }

    /// The surface line at return `k`, or `None` where the returns around it are not a
    /// line (a small post, a corner, a lone return).
    #[inline]
    pub fn line(&self, k: usize) -> Option<Line> {
        self.lines
            .get(k)
            .filter(|l| l[0].is_finite())
            .map(|l| Line {
                normal: (l[0], l[1]),
                anchor: Point2::new(l[2], l[3]),
            })
    }

    /// First index whose direction is at or after `bearing_rad`.
    fn lower_bound(&self, bearing_rad: f64) -> usize {
        let n = self.bearings_rad.len();
        let rel = (bearing_rad - self.bin_origin_rad) * BINS_PER_RAD;
        if !(rel >= 0.0) {
            return 0;
        }
        let bin = rel as usize;
        let Some(&first) = self.bin_first.get(bin) else {
            return n;
        };
        let mut k = first as usize;
        while k < n && self.bearings_rad[k] < bearing_rad {
            k += 1;
        }
        k
    }

    /// The nearest return to `q` (keyframe laser frame) within `max_distance_m`, found by
    /// direction.
    ///
    /// A return on the beam at direction `b` lies on the ray from the scanner at `b`; the
    /// distance from `q` (range `r`, direction `a`) to any point of that ray is
    /// `r sin|b - a|` when `|b - a| <= pi/2` and at least `r` beyond. Walking the beams
    /// outwards from `a` on both sides, that bound only grows, so each side stops at the
    /// first beam whose bound exceeds the best distance found: the result is exactly the
    /// nearest return (the same as [`Reference::nearest_brute_force`]), in a handful of
    /// beams when the nearest is close.
    pub fn nearest(&self, q: Point2<Laser>, max_distance_m: f64) -> Option<Nearest> {
        let n = self.bearings_rad.len();
        if n == 0 {
            return None;
        }
        let r = (q.x * q.x + q.y * q.y).sqrt();
        let a = fast_atan2(q.y, q.x) - self.centre_rad;
        let a = self.centre_rad + a - TAU * (a / TAU).round();
        // Margin for the approximate direction (1.2e-5 rad) and rounding.
        let slack = 2e-5;
        let mut best_sq = max_distance_m * max_distance_m;
        let mut best: Option<usize> = None;
        let start = self.lower_bound(a);
        // Directions differ by at most a turn; a beam `d` ahead on one side is `TAU - d`
        // behind on the other, so on each side no remaining beam is closer in angle than
        // `TAU` minus that side's largest difference.
        let up_floor = TAU - (self.bearings_rad[n - 1] - a + slack);
        let down_floor = TAU - (a - self.bearings_rad[0] + slack);
        for k in start..n {
            let d = (self.bearings_rad[k] - a - slack).min(up_floor).max(0.0);
            let lb = r * sin_lower_bound(d);
            if lb * lb >= best_sq {
                break;
            }
            let e = &self.search[k];
            let (dx, dy) = (e[2] - q.x, e[3] - q.y);
            let dsq = dx * dx + dy * dy;
            if dsq < best_sq {
                best_sq = dsq;
                best = Some(k);
            }
        }
        for k in (0..start).rev() {
            let d = (a - self.bearings_rad[k] - slack).min(down_floor).max(0.0);
            let lb = r * sin_lower_bound(d);
            if lb * lb >= best_sq {
                break;
            }
            let e = &self.search[k];
            let (dx, dy) = (e[2] - q.x, e[3] - q.y);
            let dsq = dx * dx + dy * dy;
            if dsq < best_sq {
                best_sq = dsq;
                best = Some(k);
            }
        }
        best.map(|index| Nearest {
            index,
            distance_sq_m2: best_sq,
        })
    }

    /// [`Reference::nearest`], starting from a guess `hint` of where `q`'s direction
    /// falls among the beams (the answer for a nearby point: the previous point of the
    /// same scan, or this point in the previous iteration). Same result, cheaper: no
    /// trigonometry, no square root.
    ///
    /// With `u_k` the unit vector of beam `k`, `q x u_k` is `r sin(d)` (`d` the angle
    /// from `q` to the beam) and `q . u_k` is `r cos(d)`. From the hint the beams are
    /// walked both ways; on each side, once the walk has passed `q`'s direction (the sign
    /// of the cross product says so), it stops as in [`Reference::nearest`] at the first
    /// beam whose bound, `(q x u_k)^2` within a right angle and `r^2` beyond, exceeds the
    /// best squared distance. The bound beyond a right angle holds when the beams span
    /// less than 3 pi / 2 (the URG-04LX's 240 deg do) and, when they span more than half
    /// a turn, `q` lies within them (else a walk could go the long way round). Otherwise,
    /// or when the hint is more than a right angle or 16 beams from `q`, it falls back to
    /// [`Reference::nearest`].
    pub fn nearest_from(
        &self,
        q: Point2<Laser>,
        max_distance_m: f64,
        hint: usize,
    ) -> Option<Nearest> {
        let n = self.search.len();
        if !self.hint_ok || n == 0 {
            return self.nearest(q, max_distance_m);
        }
        if self.wide {
            // Beams over more than half a turn: q must lie within them (clockwise of the
            // last and counter-clockwise of the first is the gap between them), or a
            // walk could take the long way round.
            let (f, l) = (&self.search[0], &self.search[n - 1]);
            if f[0] * q.y - f[1] * q.x < 0.0 && l[0] * q.y - l[1] * q.x > 0.0 {
                return self.nearest(q, max_distance_m);
            }
        }
        let h = hint.min(n - 1);
        let e = &self.search[h];
        if e[0] * q.x + e[1] * q.y <= 0.0 {
            // The hint is more than a right angle away.
            return self.nearest(q, max_distance_m);
        }
        let r_sq = q.x * q.x + q.y * q.y;
        let mut best_sq = max_distance_m * max_distance_m;
        let mut best: Option<usize> = None;
        // Counter-clockwise from the hint. Until the walk has passed q's direction
        // (`q x u <= 0`, or a right angle beyond) the bound does not grow: visit.
        let mut before = 0;
        for k in h..n {
            let e = &self.search[k];
            let c = e[0] * q.y - e[1] * q.x;
            let d = e[0] * q.x + e[1] * q.y;
            let passed = c <= 0.0 || d <= 0.0;
            if passed {
                let lb_sq = if d > 0.0 { c * c } else { r_sq };
                if lb_sq >= best_sq {
                    break;
                }
            } else {
                before += 1;
                if before > 16 {
                    return self.nearest(q, max_distance_m);
                }
            }
            let (dx, dy) = (e[2] - q.x, e[3] - q.y);
            let dsq = dx * dx + dy * dy;
            if dsq < best_sq {
                best_sq = dsq;
                best = Some(k);
            }
        }
        // Clockwise from just below the hint, likewise. Parallel to the walk above on
        // purpose: this is the matcher's inner loop, and the two differ in the side test.
        let mut before = 0;
        for k in (0..h).rev() {
            let e = &self.search[k];
            let c = e[0] * q.y - e[1] * q.x;
            let d = e[0] * q.x + e[1] * q.y;
            let passed = c > 0.0 || d <= 0.0;
            if passed {
                let lb_sq = if d > 0.0 { c * c } else { r_sq };
                if lb_sq >= best_sq {
                    break;
                }
            } else {
                before += 1;
                if before > 16 {
                    return self.nearest(q, max_distance_m);
                }
            }
            let (dx, dy) = (e[2] - q.x, e[3] - q.y);
            let dsq = dx * dx + dy * dy;
            if dsq < best_sq {
                best_sq = dsq;
                best = Some(k);
            }
        }
        best.map(|index| Nearest {
            index,
            distance_sq_m2: best_sq,
        })
    }

    /// The nearest return to `q` within `max_distance_m`, by trying every return.
    pub fn nearest_brute_force(&self, q: Point2<Laser>, max_distance_m: f64) -> Option<Nearest> {
        let mut best_sq = max_distance_m * max_distance_m;
        let mut best = None;
        for (k, e) in self.search.iter().enumerate() {
            let (dx, dy) = (e[2] - q.x, e[3] - q.y);
            let dsq = dx * dx + dy * dy;
            if dsq < best_sq {
                best_sq = dsq;
                best = Some(k);
            }
        }
        best.map(|index| Nearest {
            index,
            distance_sq_m2: best_sq,
        })
    }

    /// The nearest return by the chosen method (`hint` as in
    /// [`Reference::nearest_from`]; brute force ignores it).
    #[inline]
    pub fn nearest_by(
        &self,
        search: NeighbourSearch,
        q: Point2<Laser>,
        max_distance_m: f64,
        hint: Option<usize>,
    ) -> Option<Nearest> {
        match search {
            NeighbourSearch::AngularWindow => match hint {
                Some(h) => self.nearest_from(q, max_distance_m, h),
                None => self.nearest(q, max_distance_m),
            },
            NeighbourSearch::BruteForce => self.nearest_brute_force(q, max_distance_m),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn fast_atan2_is_within_its_bound_everywhere() {
        for i in 0..10_000 {
            let t = i as f64 / 10_000.0 * TAU;
            for r in [1e-3, 1.0, 7.0] {
                let (y, x) = (r * t.sin(), r * t.cos());
                let e = tether_core::wrap_angle_rad(fast_atan2(y, x) - y.atan2(x));
                assert!(e.abs() < 1.2e-5, "{t}: {e}");
            }
        }
    }

    #[test]
    fn sine_bound_stays_below_sine() {
        for i in 0..3000 {
            let d = i as f64 * 1e-3;
            let s = if d < std::f64::consts::FRAC_PI_2 {
                d.sin()
            } else {
                1.0
            };
            assert!(sin_lower_bound(d) <= s + 1e-15, "{d}");
        }
    }

    fn scan_of(ranges: &[f64], mount: Pose2<Robot, Laser>) -> ScanPoints {
        let n = ranges.len();
        let angles: Vec<f64> = (0..n)
            .map(|i| -2.0862 + i as f64 * 4.1785 / (n - 1) as f64)
            .collect();
        ScanPoints::from_polar(&angles, ranges, mount).unwrap()
    }

    proptest! {
        /// The direction search finds exactly the point brute force finds, for any
        /// scan (ranges from 2 cm to 6 m, with gaps), any mount and any query.
        #[test]
        fn angular_search_equals_brute_force(
            ranges in prop::collection::vec(prop_oneof![3 => 0.02f64..6.0, 1 => Just(f64::INFINITY)], 2..200),
            mount in (-0.3f64..0.3, -0.3f64..0.3, -3.0f64..3.0),
            queries in prop::collection::vec((-7.0f64..7.0, -7.0f64..7.0), 1..40),
            max_distance_m in 0.01f64..3.0,
        ) {
            let mount = Pose2::new(mount.0, mount.1, mount.2);
            let reference = Reference::build(&scan_of(&ranges, mount), &LineFit::default(), |_| true);
            for (i, (x, y)) in queries.into_iter().enumerate() {
                let q = Point2::new(x, y);
                let slow = reference.nearest_brute_force(q, max_distance_m);
                let hint = (i * 37) % reference.len().max(1);
                for fast in [reference.nearest(q, max_distance_m), reference.nearest_from(q, max_distance_m, hint)] {
                    match (fast, slow) {
                        (Some(f), Some(s)) => prop_assert!(
                            f.index == s.index || (f.distance_sq_m2 - s.distance_sq_m2).abs() < 1e-12,
                            "{f:?} vs {s:?}"
                        ),
                        (None, None) => {}
                        other => prop_assert!(false, "{other:?}"),
                    }
                }
            }
        }
    }

    proptest! {
        /// Queries near the returns (where matching asks), from any hint.
        #[test]
        fn hinted_search_near_returns_equals_brute_force(
            ranges in prop::collection::vec(prop_oneof![4 => 0.3f64..5.6, 1 => Just(f64::INFINITY)], 10..700),
            offsets in prop::collection::vec((0usize..10_000, -0.05f64..0.05, -0.05f64..0.05, 0usize..10_000), 1..60),
        ) {
            let s = scan_of(&ranges, Pose2::new(0.1, 0.0, 0.0));
            prop_assume!(s.len() > 2);
            let reference = Reference::build(&s, &LineFit::default(), |_| true);
            for (i, dx, dy, h) in offsets {
                let p = reference.search[i % reference.len()];
                let q = Point2::new(p[2] + dx, p[3] + dy);
                let hint = (i % reference.len()).saturating_sub(h % 5) + h % 3;
                let fast = reference.nearest_from(q, 0.3, hint);
                let slow = reference.nearest_brute_force(q, 0.3);
                match (fast, slow) {
                    (Some(f), Some(s)) => prop_assert!(
                        f.index == s.index || (f.distance_sq_m2 - s.distance_sq_m2).abs() < 1e-12,
                        "{f:?} vs {s:?}"
                    ),
                    (None, None) => {}
                    other => prop_assert!(false, "{other:?}"),
                }
            }
        }
    }

    #[test]
    fn lines_follow_surfaces_and_stop_at_jump_edges() {
        // A wall at x = 1 for beams 0..40, then a jump to 3 m.
        let angles: Vec<f64> = (0..60).map(|i| -0.3 + 0.01 * i as f64).collect();
        let ranges: Vec<f64> = angles
            .iter()
            .enumerate()
            .map(|(i, a)| if i < 40 { 1.0 / a.cos() } else { 3.0 })
            .collect();
        let s = ScanPoints::from_polar(&angles, &ranges, Pose2::IDENTITY).unwrap();
        let r = Reference::build(&s, &LineFit::default(), |_| true);
        for k in [0, 20, 39] {
            let l = r.line(k).unwrap();
            assert!(
                l.normal.0.abs() > 0.9999 && l.normal.1.abs() < 1e-6,
                "{k}: {l:?}"
            );
            assert!((l.anchor.x - 1.0).abs() < 1e-9, "{k}: {l:?}");
        }
        // Beyond the edge, the 3 m arc is fitted on its own.
        let l = r.line(45).unwrap();
        assert!((l.anchor.x.hypot(l.anchor.y) - 3.0).abs() < 0.01, "{l:?}");
        // A single return is no line.
        let one = ScanPoints::from_polar(&[0.0], &[1.0], Pose2::IDENTITY).unwrap();
        assert!(
            Reference::build(&one, &LineFit::default(), |_| true)
                .line(0)
                .is_none()
        );
    }
}
