//! The stage plan: the order in which the scan evaluates a cascade's weak classifiers
//! and what it knows about each stage. Stages whose leaf sums are exact in `f64` are
//! regrouped by feature [`Kind`] and get a quick, certified `f32` sum ([`Approx`]);
//! the others keep OpenCV's order.

use crate::cascade::Cascade;

/// How the scan evaluates a cascade, built once per detector.
#[derive(Debug)]
pub(super) struct Plan {
    /// Weak classifiers in evaluation order (see [`StagePlan`]).
    pub(super) order: Vec<usize>,
    /// One per stage.
    pub(super) stages: Vec<StagePlan>,
    /// Each feature's rectangle corners in window coordinates ([`rect_corners`]).
    pub(super) corners: Vec<[[(i32, i32); 4]; 3]>,
    /// For each entry of `order`: the corner slots in the order the lanes read them.
    pub(super) layouts: Vec<[u8; 12]>,
}

impl Plan {
    /// The plan of a cascade: the exact stages of a stump cascade regrouped by [`Kind`],
    /// the others in the file's order.
    pub(super) fn new(cascade: &Cascade) -> Plan {
        let stumps = cascade.is_stump_based();
        let leaves = |t: usize| {
            let first = cascade.trees()[t].first_leaf as usize;
            (cascade.leaves()[first], cascade.leaves()[first + 1])
        };
        let kinds: Vec<(Kind, [u8; 12])> = cascade
            .trees()
            .iter()
            .map(|t| {
                Kind::of(
                    &cascade.features()[cascade.nodes()[t.first_node as usize].feature as usize],
                )
            })
            .collect();
        let kind = |t: usize| kinds[t];
        let mut order = Vec::with_capacity(cascade.trees().len());
        let mut layouts = Vec::with_capacity(cascade.trees().len());
        let mut plans = Vec::with_capacity(cascade.stages().len());
        for stage in cascade.stages() {
            let first = stage.first_tree as usize;
            let mut trees: Vec<usize> = (first..first + stage.tree_count as usize).collect();
            let exact = stumps
                && leaf_sums_are_exact(&trees.iter().map(|&t| leaves(t)).collect::<Vec<_>>());
            let runs = exact.then(|| {
                trees.sort_by_key(|&t| (kind(t).0, t));
                Kind::ALL.map(|k| trees.iter().filter(|&&t| kind(t).0 == k).count())
            });
            layouts.extend(trees.iter().map(|&t| {
                if exact {
                    kind(t).1
                } else {
                    std::array::from_fn(|i| i as u8)
                }
            }));
            let approx = exact
                .then(|| Approx::for_stage(&trees.iter().map(|&t| leaves(t)).collect::<Vec<_>>()));
            plans.push(StagePlan {
                threshold: f64::from(stage.threshold),
                first: order.len(),
                count: trees.len(),
                runs,
                approx,
            });
            order.extend(trees);
        }
        let corners = cascade
            .features()
            .iter()
            .map(|f| f.rects.map(|r| rect_corners(&r, f.tilted)))
            .collect();
        Plan {
            order,
            stages: plans,
            corners,
            layouts,
        }
    }
}

/// Corners of a feature rectangle in window coordinates `(column, row)`, in OpenCV's
/// read order `p0 - p1 - p2 + p3`.
fn rect_corners(r: &crate::cascade::WeightedRect, tilted: bool) -> [(i32, i32); 4] {
    let (x, y, w, h) = (r.x, r.y, r.w, r.h);
    if r.weight == 0.0 {
        // An unused rectangle: one corner read four times (sum 0, times weight 0).
        return [(0, 0); 4];
    }
    if tilted {
        [
            (x, y),
            (x - h, y + h),
            (x + w, y + w),
            (x + w - h, y + w + h),
        ]
    } else {
        [(x, y), (x + w, y), (x, y + h), (x + w, y + h)]
    }
}

/// How the lanes' quick path computes a stump's feature; the stumps of an exact stage are
/// grouped by kind so that each group runs without per-stump tests.
///
/// The rectangle sums are integers and computed exactly in any association (wrapping
/// 32-bit arithmetic), so a two-rectangle feature whose rectangles share two corners (one
/// added, one subtracted, in both: a half or an edge of the other) reads them once:
/// `S0 = (sp - sm) + (p0 - m0)`, `S1 = (sp - sm) + (p1 - m1)`, six reads instead of
/// eight. When the first weight is -1 (the usual whole-window rectangle),
/// `w0 S0 + w1 S1` is computed as `w1 S1 - S0`: the same `f32` result, one
/// multiplication less.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Kind {
    Two,
    TwoNeg,
    Shared,
    SharedNeg,
    Three,
    ThreeNeg,
}

/// Number of [`Kind`]s.
pub(super) const KINDS: usize = 6;

impl Kind {
    const ALL: [Kind; KINDS] = [
        Kind::Two,
        Kind::TwoNeg,
        Kind::Shared,
        Kind::SharedNeg,
        Kind::Three,
        Kind::ThreeNeg,
    ];

    /// The kind of a feature and the order in which the lane path reads its twelve
    /// corner slots (`rect * 4 + corner`).
    fn of(f: &crate::cascade::HaarFeature) -> (Kind, [u8; 12]) {
        let natural: [u8; 12] = std::array::from_fn(|i| i as u8);
        let neg = f.rects[0].weight == -1.0;
        let pick = |plain: Kind, negative: Kind| if neg { negative } else { plain };
        if f.rects[2].weight != 0.0 {
            return (pick(Kind::Three, Kind::ThreeNeg), natural);
        }
        if f.rects[1].weight == 0.0 || f.rects[0].weight == 0.0 {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        }
        let c0 = rect_corners(&f.rects[0], f.tilted);
        let c1 = rect_corners(&f.rects[1], f.tilted);
        // Corners 0 and 3 are added, 1 and 2 subtracted (`p0 - p1 - p2 + p3`).
        let plus = |i: usize| i == 0 || i == 3;
        let shared: Vec<(usize, usize)> = (0..4)
            .flat_map(|i| (0..4).map(move |j| (i, j)))
            .filter(|&(i, j)| c0[i] == c1[j])
            .collect();
        let [(i1, j1), (i2, j2)] = shared.as_slice() else {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        };
        let (i1, j1, i2, j2) = (*i1, *j1, *i2, *j2);
        let proper = |r: &crate::cascade::WeightedRect| r.w > 0 && r.h > 0;
        if plus(i1) != plus(j1)
            || plus(i2) != plus(j2)
            || plus(i1) == plus(i2)
            || !proper(&f.rects[0])
            || !proper(&f.rects[1])
        {
            return (pick(Kind::Two, Kind::TwoNeg), natural);
        }
        let (sp, sm) = if plus(i1) { (i1, i2) } else { (i2, i1) };
        let (tp, tm) = if plus(j1) { (j1, j2) } else { (j2, j1) };
        let other = |a: usize, b: usize, want_plus: bool| {
            (0..4)
                .find(|&k| k != a && k != b && plus(k) == want_plus)
                .unwrap_or(0)
        };
        let layout = [
            sp,
            sm,
            other(sp, sm, true),
            other(sp, sm, false),
            4 + other(tp, tm, true),
            4 + other(tp, tm, false),
            0,
            0,
            0,
            0,
            0,
            0,
        ]
        .map(|v| v as u8);
        (pick(Kind::Shared, Kind::SharedNeg), layout)
    }
}

/// One stage as the scan evaluates it.
///
/// When the stage's leaf sums are **exact** in `f64` (every leaf is an `f32`, so every
/// partial sum is a multiple of the smallest leaf's unit in the last place; when the sum
/// of the largest leaves stays below 2^53 of those units, no addition rounds), the order
/// of the additions cannot change the sum, so the stumps can be evaluated in any order:
/// grouped by [`Kind`], two-rectangle features before three-rectangle ones. Stages that
/// are not exact keep OpenCV's order. Every Debian cascade is exact (at most 46 of the
/// 53 bits are needed).
#[derive(Debug, Clone, Copy)]
pub(super) struct StagePlan {
    /// Threshold as OpenCV compares it (already lowered by 1e-5).
    pub(super) threshold: f64,
    /// First stump in evaluation order.
    pub(super) first: usize,
    /// Number of stumps.
    pub(super) count: usize,
    /// In an exact stage, the number of stumps of each [`Kind`], which follow one another
    /// in that order; `None` when the stage keeps OpenCV's order.
    pub(super) runs: Option<[usize; KINDS]>,
    /// In an exact stage, the quick `f32` evaluation (see [`Approx`]).
    pub(super) approx: Option<Approx>,
}

/// A quick, certified evaluation of an exact stage for the lane scan.
///
/// The stage sum is `S = sum(right) + sum over stumps below threshold of (left - right)`.
/// The lanes compute it in `f32` from `start = f32(sum(right))` with
/// `diff = f32(left - right)`, one masked addition per stump (instead of a select,
/// two conversions to `f64` and two additions). Each rounding moves the result by at
/// most 2^-24 of a magnitude bounded by `|sum(right)| + sum |diff|`, so
/// `|approx - S| <= (n + 1) 2^-24 (|sum(right)| + sum |diff|)`; `margin` is twice that.
/// Outside `threshold +- margin` the verdict is certain and equal to OpenCV's (the
/// exact `f64` sum is `S`); inside it the stage is summed again exactly.
#[derive(Debug, Clone, Copy)]
pub(super) struct Approx {
    pub(super) start: f32,
    pub(super) margin: f64,
}

impl Approx {
    pub(super) fn for_stage(pairs: &[(f32, f32)]) -> Approx {
        let right: f64 = pairs.iter().map(|&(_, r)| f64::from(r)).sum();
        let spread: f64 = pairs
            .iter()
            .map(|&(l, r)| (f64::from(l) - f64::from(r)).abs())
            .sum();
        let n = pairs.len() as f64;
        Approx {
            start: right as f32,
            margin: 2.0 * (n + 1.0) * 2f64.powi(-24) * (right.abs() + spread),
        }
    }

    /// The verdict (`true`: passes) when `approx` is far enough from the threshold.
    pub(super) fn verdict(&self, approx: f32, threshold: f64) -> Option<bool> {
        let a = f64::from(approx);
        if a < threshold - self.margin {
            Some(false)
        } else if a >= threshold + self.margin {
            Some(true)
        } else {
            None
        }
    }
}

/// OpenCV's stage test: a window is rejected when `sum < threshold`, so it passes
/// otherwise (a NaN sum, impossible with finite leaves, would pass too).
#[expect(
    clippy::neg_cmp_op_on_partial_ord,
    reason = "OpenCV's test is `sum < threshold`; its negation is the pass condition"
)]
pub(super) fn passes(sum: f64, threshold: f64) -> bool {
    !(sum < threshold)
}

/// Whether every partial sum of these leaf pairs is exact in `f64`.
pub(super) fn leaf_sums_are_exact(pairs: &[(f32, f32)]) -> bool {
    // Unit in the last place of an f32, as a power of two.
    let ulp_exp = |v: f32| -> i32 {
        let biased = ((v.to_bits() >> 23) & 0xff) as i32;
        if biased == 0 { -149 } else { biased - 127 - 23 }
    };
    let finest = pairs
        .iter()
        .flat_map(|&(l, r)| [l, r])
        .filter(|v| *v != 0.0)
        .map(ulp_exp)
        .min();
    let Some(finest) = finest else {
        return true;
    };
    let bound: f64 = pairs
        .iter()
        .map(|&(l, r)| f64::from(l.abs().max(r.abs())))
        .sum();
    bound.is_finite() && bound < 2f64.powi(finest + 52)
}

/// Runs `f::<K>` over the consecutive runs of stumps of each kind (the caller has
/// [`Kind`] and [`KINDS`] in scope).
macro_rules! for_each_kind {
    ($runs:expr, $stumps:expr, |$k:ident, $slice:ident| $body:expr) => {{
        let runs: [usize; KINDS] = $runs;
        let stumps = $stumps;
        let mut start = 0;
        macro_rules! run {
            ($kind:expr) => {{
                const $k: u8 = $kind as u8;
                let end = start + runs[$kind as usize];
                let $slice = &stumps[start..end];
                $body;
                start = end;
            }};
        }
        run!(Kind::Two);
        run!(Kind::TwoNeg);
        run!(Kind::Shared);
        run!(Kind::SharedNeg);
        run!(Kind::Three);
        run!(Kind::ThreeNeg);
        let _ = start;
    }};
}

pub(super) use for_each_kind;
