//! The lane-parallel scan: consecutive windows of a row evaluated together, two groups
//! of [`LANES`] with SSE2 through `wide` (or eight at once with AVX2, module `avx2`),
//! with exactly the arithmetic of the one-window evaluation lane by lane.

use wide::{f32x4, f64x2, i32x4};

use crate::group::Rect;

use super::ScaleLevel;
#[cfg(target_arch = "x86_64")]
use super::avx2;
use super::level::{LevelEval, LevelFeature, LevelStump, PAD, Planes, VIEW};
use super::plan::{KINDS, Kind, StagePlan, for_each_kind, passes};

/// Windows evaluated together by the lane-parallel scan: consecutive windows of a row,
/// whose corners are consecutive entries of the integral rows.
pub(super) const LANES: usize = 4;

/// A view of `LANES` consecutive windows, the first or second group of a block of
/// `2 LANES`: the masked offset plus the group shift plus the lane stays inside the array,
/// so no bounds check is needed.
#[derive(Clone, Copy)]
struct Wide<'a> {
    data: &'a [i32; PAD],
    shift: usize,
}

impl Wide<'_> {
    #[inline(always)]
    fn at(&self, offset: u32) -> i32x4 {
        let i = (offset as usize & (VIEW - 1)) + (self.shift & LANES);
        let mut lanes = [0; LANES];
        lanes.copy_from_slice(&self.data[i..i + LANES]);
        i32x4::new(lanes)
    }

    /// `CALC_SUM_OFS` for each lane (wrapping 32-bit arithmetic).
    #[inline(always)]
    fn box_sum(&self, o: &[u32; 4]) -> i32x4 {
        self.at(o[0]) - self.at(o[1]) - self.at(o[2]) + self.at(o[3])
    }
}

impl LevelFeature {
    /// [`LevelFeature::value`] for `LANES` consecutive windows, each with its own
    /// normalisation factor; lane by lane the same `f32` operations in the same order.
    /// `RECTS` is 2 or 3 when the caller knows how many rectangles have a weight, 0 to
    /// test it as OpenCV does.
    #[inline(always)]
    fn values<const RECTS: u8>(&self, v: &Wide<'_>, norm: f32x4) -> f32x4 {
        let w = &self.weight;
        let s0 = v.box_sum(&self.ofs[0]).round_float();
        let s1 = v.box_sum(&self.ofs[1]).round_float();
        let mut r = f32x4::splat(w[0]) * s0 + f32x4::splat(w[1]) * s1;
        if RECTS == 3 || (RECTS == 0 && w[2] != 0.0) {
            r += f32x4::splat(w[2]) * v.box_sum(&self.ofs[2]).round_float();
        }
        r * norm
    }
}

/// A stump as the lanes' quick path reads it: corner offsets in [`Kind`] order, constants
/// already broadcast to every lane.
#[derive(Debug, Clone, Copy)]
pub(super) struct LaneStump {
    pub(super) ofs: [u32; 12],
    pub(super) weight: [f32x4; 3],
    pub(super) threshold: f32x4,
    /// `f32(left - right)`.
    pub(super) diff: f32x4,
}

impl LaneStump {
    pub(super) fn new(s: &LevelStump, layout: &[u8; 12]) -> LaneStump {
        let flat = s.feature.ofs.as_flattened();
        let w = &s.feature.weight;
        LaneStump {
            ofs: std::array::from_fn(|i| flat[usize::from(layout[i]) % 12]),
            weight: [f32x4::splat(w[0]), f32x4::splat(w[1]), f32x4::splat(w[2])],
            threshold: f32x4::splat(s.threshold),
            diff: f32x4::splat((f64::from(s.left) - f64::from(s.right)) as f32),
        }
    }

    /// The feature value for the lanes of one group, for a stump of kind `K` (the index of
    /// a [`Kind`]): OpenCV's `f32` value, bit for bit.
    #[inline(always)]
    fn value<const K: u8>(&self, m: &Wide<'_>, norm: f32x4) -> f32x4 {
        let o = &self.ofs;
        let shared = K == Kind::Shared as u8 || K == Kind::SharedNeg as u8;
        let neg =
            K == Kind::TwoNeg as u8 || K == Kind::SharedNeg as u8 || K == Kind::ThreeNeg as u8;
        let three = K == Kind::Three as u8 || K == Kind::ThreeNeg as u8;
        let (s0, s1) = if shared {
            let d = m.at(o[0]) - m.at(o[1]);
            (d + (m.at(o[2]) - m.at(o[3])), d + (m.at(o[4]) - m.at(o[5])))
        } else {
            (
                m.box_sum(&[o[0], o[1], o[2], o[3]]),
                m.box_sum(&[o[4], o[5], o[6], o[7]]),
            )
        };
        let (s0, s1) = (s0.round_float(), s1.round_float());
        let mut r = if neg {
            self.weight[1] * s1 - s0
        } else {
            self.weight[0] * s0 + self.weight[1] * s1
        };
        if three {
            r += self.weight[2] * m.box_sum(&[o[8], o[9], o[10], o[11]]).round_float();
        }
        r * norm
    }
}

/// The quick `f32` stage sum of [`Approx`](super::plan::Approx) over stumps of kind `K`:
/// `sum += (value < threshold) & diff`.
#[inline(always)]
fn accumulate_approx<const K: u8>(
    stumps: &[LaneStump],
    main: &Wide<'_>,
    norm: f32x4,
    sum: &mut f32x4,
) {
    for s in stumps {
        *sum += s.value::<K>(main, norm).simd_lt(s.threshold) & s.diff;
    }
}

/// [`accumulate_approx`] for the two lane groups of a block at once: the stump's
/// offsets and constants are read once for both.
#[inline(always)]
fn accumulate_approx_pair<const K: u8>(
    stumps: &[LaneStump],
    main: [Wide<'_>; 2],
    norm: [f32x4; 2],
    sum: &mut [f32x4; 2],
) {
    for s in stumps {
        for g in 0..2 {
            sum[g] += s.value::<K>(&main[g], norm[g]).simd_lt(s.threshold) & s.diff;
        }
    }
}

/// A level's stumps for the lane scans; checked for the AVX2 scan's loads when all
/// their offsets fit its view.
#[derive(Debug)]
pub(super) enum LaneStumps {
    Plain(Vec<LaneStump>),
    #[cfg(target_arch = "x86_64")]
    Checked(avx2::Table),
}

impl LaneStumps {
    fn stumps(&self) -> &[LaneStump] {
        match self {
            LaneStumps::Plain(s) => s,
            #[cfg(target_arch = "x86_64")]
            LaneStumps::Checked(t) => t.stumps(),
        }
    }

    /// The checked table, if the stumps are checked.
    #[cfg(target_arch = "x86_64")]
    fn table8(&self) -> Option<&avx2::Table> {
        match self {
            LaneStumps::Checked(t) => Some(t),
            LaneStumps::Plain(_) => None,
        }
    }
}

impl LevelEval<'_> {
    /// Scans row `y` of a level `LANES` windows at a time (stump cascades whose offsets
    /// fit a view). Every window gets exactly the arithmetic of [`LevelEval::run`]; the
    /// lanes only share instructions. OpenCV's rule that a window rejected by stage 0
    /// skips the next one is resolved lane by lane after stage 0, which is computed for
    /// every lane (a skipped lane's result is discarded).
    pub(super) fn scan_row_lanes(
        &self,
        planes: &Planes,
        level: &ScaleLevel,
        y: usize,
        hits: &mut Vec<Rect>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(token), Some(stages), Some(table)) = (
            self.detector.avx2,
            self.detector.stages8.as_deref(),
            self.t.lane.table8(),
        ) {
            self.scan_row_8(token, stages, table, planes, level, y, hits);
            return;
        }
        const BLOCK: usize = 2 * LANES;
        let step = level.step;
        let mut skip_next = false;
        let mut x0 = 0;
        while x0 < level.scan_width {
            let Some((main, sq)) = planes.block_views(x0, y) else {
                // Unreachable: the buffers are padded by PAD.
                x0 += BLOCK * step;
                continue;
            };
            let main = [
                Wide {
                    data: main,
                    shift: 0,
                },
                Wide {
                    data: main,
                    shift: LANES,
                },
            ];
            let sq = [
                Wide { data: sq, shift: 0 },
                Wide {
                    data: sq,
                    shift: LANES,
                },
            ];
            let lanes_here = (level.scan_width - x0).div_ceil(step).min(BLOCK);
            let (norm0, ok0) = self.norm_lanes(&main[0], &sq[0]);
            let (norm1, ok1) = self.norm_lanes(&main[1], &sq[1]);
            let norm = [norm0, norm1];
            let mut alive: [bool; BLOCK] = std::array::from_fn(|l| {
                l < lanes_here && if l < LANES { ok0[l] } else { ok1[l - LANES] }
            });
            if !alive.iter().any(|&a| a) {
                // Every window is too flat: none is evaluated, none skips the next.
                if skip_next && lanes_here > 0 {
                    skip_next = false;
                }
                x0 += BLOCK * step;
                continue;
            }
            let pass = self.block_pass(0, main, norm, alive);
            // Resolve which lanes OpenCV evaluates, and their stage-0 verdicts.
            for l in 0..BLOCK {
                if l >= lanes_here {
                    alive[l] = false;
                } else if skip_next {
                    alive[l] = false;
                    skip_next = false;
                } else if alive[l] && !pass[l] {
                    alive[l] = false;
                    skip_next = true;
                }
            }
            let mut si = 1;
            while si < self.detector.plans.len() && alive.iter().any(|&a| a) {
                let pass = self.block_pass(si, main, norm, alive);
                for l in 0..BLOCK {
                    alive[l] &= pass[l];
                }
                si += 1;
            }
            for (l, &hit) in alive.iter().enumerate() {
                if hit {
                    hits.push(level.hit_box(x0 + l * step, y));
                }
            }
            x0 += BLOCK * step;
        }
    }

    /// [`LevelEval::scan_row_lanes`] with AVX2: eight windows per block
    /// ([`avx2::Avx2::block`]); a lane the quick sum cannot decide is decided by
    /// [`LevelEval::stage_pass_exact`].
    #[cfg(target_arch = "x86_64")]
    #[expect(clippy::too_many_arguments, reason = "the row and the AVX2 tables")]
    fn scan_row_8(
        &self,
        token: avx2::Avx2,
        stages: &[avx2::Stage8],
        table: &avx2::Table,
        planes: &Planes,
        level: &ScaleLevel,
        y: usize,
        hits: &mut Vec<Rect>,
    ) {
        // Parallel to scan_row_lanes' walk on purpose: the detector's hot loop, here over
        // blocks of eight AVX2 lanes, there over portable lanes it is checked against.
        const BLOCK: usize = avx2::LANES8;
        let step = level.step;
        let mut skip_next = false;
        let mut x0 = 0;
        while x0 < level.scan_width {
            let Some((main, sq)) = planes.block_views(x0, y) else {
                // Unreachable: the buffers are padded by PAD.
                x0 += BLOCK * step;
                continue;
            };
            let lanes = (level.scan_width - x0).div_ceil(step).min(BLOCK);
            let exact = |si: usize, norms: &avx2::Norms| -> u8 {
                let plan = &self.detector.plans[si];
                let mut bits = 0u8;
                for g in 0..BLOCK / LANES {
                    let view = Wide {
                        data: main,
                        shift: g * LANES,
                    };
                    let norm = f32x4::new(std::array::from_fn(|l| norms[g * LANES + l]));
                    let pass = self.stage_pass_exact(plan, &view, norm);
                    for (l, &p) in pass.iter().enumerate() {
                        bits |= u8::from(p) << (g * LANES + l);
                    }
                }
                bits
            };
            let mut hit = token.block(table, stages, main, sq, lanes, &mut skip_next, exact);
            while hit != 0 {
                let l = hit.trailing_zeros() as usize;
                hits.push(level.hit_box(x0 + l * step, y));
                hit &= hit - 1;
            }
            x0 += BLOCK * step;
        }
    }

    /// Stage `si` for the lanes of a block that `matter`: both groups together while both
    /// have such lanes, else only the group that does.
    #[inline(always)]
    fn block_pass(
        &self,
        si: usize,
        main: [Wide<'_>; 2],
        norm: [f32x4; 2],
        matter: [bool; 2 * LANES],
    ) -> [bool; 2 * LANES] {
        let first: [bool; LANES] = std::array::from_fn(|l| matter[l]);
        let second: [bool; LANES] = std::array::from_fn(|l| matter[LANES + l]);
        let (a, b) = (first.iter().any(|&m| m), second.iter().any(|&m| m));
        let (pa, pb) = match (a, b) {
            (true, true) => self.stage_pass_pair(si, main, norm, first, second),
            (true, false) => (
                self.stage_pass(si, &main[0], norm[0], first),
                [false; LANES],
            ),
            (false, true) => (
                [false; LANES],
                self.stage_pass(si, &main[1], norm[1], second),
            ),
            (false, false) => ([false; LANES], [false; LANES]),
        };
        std::array::from_fn(|l| if l < LANES { pa[l] } else { pb[l - LANES] })
    }

    /// [`LevelEval::stage_pass`] for both groups of a block.
    #[inline(always)]
    fn stage_pass_pair(
        &self,
        si: usize,
        main: [Wide<'_>; 2],
        norm: [f32x4; 2],
        first: [bool; LANES],
        second: [bool; LANES],
    ) -> ([bool; LANES], [bool; LANES]) {
        let plan = &self.detector.plans[si];
        if let (Some(approx), Some(runs)) = (plan.approx, plan.runs) {
            let stumps = &self.t.lane.stumps()[plan.first..plan.first + plan.count];
            let mut sum = [f32x4::splat(approx.start); 2];
            for_each_kind!(runs, stumps, |K, run| accumulate_approx_pair::<K>(
                run, main, norm, &mut sum
            ));
            let decide = |sum: f32x4, matter: [bool; LANES]| -> Option<[bool; LANES]> {
                let sums = sum.to_array();
                let mut verdict = [false; LANES];
                for l in 0..LANES {
                    match approx.verdict(sums[l], plan.threshold) {
                        Some(v) => verdict[l] = v,
                        None if matter[l] => return None,
                        None => {}
                    }
                }
                Some(verdict)
            };
            let pa = decide(sum[0], first)
                .unwrap_or_else(|| self.stage_pass_exact(plan, &main[0], norm[0]));
            let pb = decide(sum[1], second)
                .unwrap_or_else(|| self.stage_pass_exact(plan, &main[1], norm[1]));
            return (pa, pb);
        }
        (
            self.stage_pass_exact(plan, &main[0], norm[0]),
            self.stage_pass_exact(plan, &main[1], norm[1]),
        )
    }

    /// The normalisation factor of each lane and whether it passes the variance test
    /// ([`LevelEval::norm_factor`] lane by lane).
    #[inline(always)]
    fn norm_lanes(&self, main: &Wide<'_>, sq: &Wide<'_>) -> (f32x4, [bool; LANES]) {
        let sum = main.box_sum(&self.t.norm_main).to_array();
        let sqsum = sq.box_sum(&self.t.norm_sq).to_array();
        let mut norm = [1.0f32; LANES];
        let mut ok = [false; LANES];
        for l in 0..LANES {
            let s = f64::from(sum[l]);
            let nf = self.t.area * f64::from(sqsum[l] as u32) - s * s;
            if nf > 0.0 {
                norm[l] = (1.0 / nf.sqrt()) as f32;
                ok[l] = self.t.area * f64::from(norm[l]) < 0.1;
            }
        }
        (f32x4::new(norm), ok)
    }

    /// Whether each lane passes stage `si`: the leaf sum, accumulated in `f64` stump by
    /// stump, is not below the threshold (`predictOrderedStump`). Exact stages are first
    /// decided by the quick certified sum ([`Approx`](super::plan::Approx)); only when a lane that `matters`
    /// lies within the margin is the stage summed exactly.
    #[inline(always)]
    fn stage_pass(
        &self,
        si: usize,
        main: &Wide<'_>,
        norm: f32x4,
        matter: [bool; LANES],
    ) -> [bool; LANES] {
        let plan = &self.detector.plans[si];
        if let (Some(approx), Some(runs)) = (plan.approx, plan.runs) {
            let stumps = &self.t.lane.stumps()[plan.first..plan.first + plan.count];
            let mut sum = f32x4::splat(approx.start);
            for_each_kind!(runs, stumps, |K, run| accumulate_approx::<K>(
                run, main, norm, &mut sum
            ));
            let sums = sum.to_array();
            let mut verdict = [false; LANES];
            let mut certain = true;
            for l in 0..LANES {
                match approx.verdict(sums[l], plan.threshold) {
                    Some(v) => verdict[l] = v,
                    None => certain &= !matter[l],
                }
            }
            if certain {
                return verdict;
            }
        }
        self.stage_pass_exact(plan, main, norm)
    }

    /// [`LevelEval::stage_pass`] by OpenCV's own `f64` sum.
    #[inline(never)]
    fn stage_pass_exact(&self, plan: &StagePlan, main: &Wide<'_>, norm: f32x4) -> [bool; LANES] {
        let stumps = &self.t.stumps[plan.first..plan.first + plan.count];
        let mut sum = [f64x2::ZERO; 2];
        match plan.runs.map(|r| r[..4].iter().sum::<usize>()) {
            Some(two) => {
                accumulate::<2>(&stumps[..two], main, norm, &mut sum);
                accumulate::<3>(&stumps[two..], main, norm, &mut sum);
            }
            None => accumulate::<0>(stumps, main, norm, &mut sum),
        }
        let (lo, hi) = (sum[0].to_array(), sum[1].to_array());
        [lo[0], lo[1], hi[0], hi[1]].map(|total| passes(total, plan.threshold))
    }
}

/// Adds each stump's leaf (`value < threshold ? left : right`) to the lanes' `f64`
/// sums, in slice order.
#[inline(always)]
fn accumulate<const RECTS: u8>(
    stumps: &[LevelStump],
    main: &Wide<'_>,
    norm: f32x4,
    sum: &mut [f64x2; 2],
) {
    for s in stumps {
        let v = s.feature.values::<RECTS>(main, norm);
        let leaf = v
            .simd_lt(f32x4::splat(s.threshold))
            .bitselect(f32x4::splat(s.left), f32x4::splat(s.right))
            .to_array();
        sum[0] += f64x2::new([f64::from(leaf[0]), f64::from(leaf[1])]);
        sum[1] += f64x2::new([f64::from(leaf[2]), f64::from(leaf[3])]);
    }
}
