//! The lane scan on eight consecutive windows at once with 256-bit AVX2 registers,
//! chosen at run time when the CPU has AVX2.
//!
//! A block of eight windows goes through the variance test and the stages here, lane
//! masks as bits. Lane by lane the arithmetic is exactly that of the SSE2 path and of
//! OpenCV: the variance normalisation in `f64` (`A Q - S^2`, `1 / sqrt`, rounded to
//! `f32`), each feature's `f32` value (`LaneStump::value`: wrapping 32-bit corner sums,
//! `cvtdq2ps`, products and sums in the same order, no fused multiply-add), and the quick
//! certified stage sum of [`super::plan::Approx`] with its verdict; a lane that the quick sum
//! cannot decide is decided by the caller's exact `f64` sum. The property tests of
//! `detect` compare this path with the plain reference and with the SSE2 path.
//!
//! This module holds the crate's only `unsafe` code, two kinds of it:
//! - calling the `#[target_feature(enable = "avx2")]` functions, sound only on a CPU with
//!   AVX2: an [`Avx2`] token exists only after `is_x86_feature_detected!("avx2")` said so;
//! - unaligned 256-bit loads of eight integral entries at `data[offset..offset + 8]`
//!   without a bounds check (a checked or masked index costs the scan most of what the
//!   wider registers gain): every offset comes from a [`Table`], whose constructor
//!   checks that all its offsets are below `VIEW`, and every buffer is a `[i32; PAD]`
//!   with `PAD >= VIEW + 8`.

use std::arch::x86_64::{
    __m128, __m128i, __m256, __m256d, __m256i, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LT_OQ, _mm_cvtss_f32,
    _mm_movehdup_ps, _mm_movehl_ps, _mm_shuffle_ps, _mm256_add_epi32, _mm256_add_pd, _mm256_add_ps,
    _mm256_and_pd, _mm256_and_ps, _mm256_blendv_pd, _mm256_castsi256_si128, _mm256_cmp_pd,
    _mm256_cmp_ps, _mm256_cvtepi32_pd, _mm256_cvtepi32_ps, _mm256_cvtpd_ps, _mm256_cvtps_pd,
    _mm256_div_pd, _mm256_extracti128_si256, _mm256_loadu_si256, _mm256_movemask_pd,
    _mm256_movemask_ps, _mm256_mul_pd, _mm256_mul_ps, _mm256_set_m128, _mm256_set1_pd,
    _mm256_set1_ps, _mm256_sqrt_pd, _mm256_sub_epi32, _mm256_sub_pd, _mm256_sub_ps,
};

use super::lanes::LaneStump;
use super::level::{PAD, VIEW};
use super::plan::{KINDS, Kind, StagePlan, for_each_kind};

/// Windows evaluated together on this path.
pub(super) const LANES8: usize = 8;

/// Proof that the CPU has AVX2.
#[derive(Debug, Clone, Copy)]
pub(super) struct Avx2(());

/// A stage as this path evaluates it (an exact stage, see [`super::plan::StagePlan`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Stage8 {
    first: usize,
    runs: [usize; KINDS],
    /// `f32(sum(right))`, where the quick sum starts.
    start: f32,
    /// The quick sum is certainly below the threshold when below this (the smallest `f32`
    /// not below `threshold - margin`)...
    fail: f32,
    /// ...and certainly not below it when at least this (the smallest `f32` not below
    /// `threshold + margin`).
    pass: f32,
}

impl Stage8 {
    /// The plans of a cascade on this path; `None` when a stage is not exact.
    pub(super) fn for_plans(plans: &[StagePlan]) -> Option<Vec<Stage8>> {
        plans
            .iter()
            .map(|p| {
                let (approx, runs) = (p.approx?, p.runs?);
                Some(Stage8 {
                    first: p.first,
                    runs,
                    start: approx.start,
                    fail: f32_at_or_above(p.threshold - approx.margin),
                    pass: f32_at_or_above(p.threshold + approx.margin),
                })
            })
            .collect()
    }
}

#[cfg(test)]
impl Stage8 {
    /// The stage with no certain quick verdict: every lane that matters is summed
    /// exactly (to test that fallback).
    pub(super) fn undecided(self) -> Stage8 {
        Stage8 {
            fail: f32::NEG_INFINITY,
            pass: f32::INFINITY,
            ..self
        }
    }
}

/// The smallest `f32` that is not below `x`: for every `f32` `a`,
/// `f64(a) < x` exactly when `a < f32_at_or_above(x)`.
fn f32_at_or_above(x: f64) -> f32 {
    let c = x as f32;
    if f64::from(c) < x { c.next_up() } else { c }
}

/// A level's stumps and variance-window corners, with every offset checked below
/// `VIEW`: the loads of this module rely on it.
#[derive(Debug)]
pub(super) struct Table {
    stumps: Vec<LaneStump>,
    norm_main: [u32; 4],
    norm_sq: [u32; 4],
    area: f64,
}

impl Table {
    /// The table, or the stumps back when an offset is not below `VIEW`.
    pub(super) fn new(
        stumps: Vec<LaneStump>,
        norm_main: [u32; 4],
        norm_sq: [u32; 4],
        area: f64,
    ) -> Result<Table, Vec<LaneStump>> {
        let inside = |o: &u32| (*o as usize) < VIEW;
        let ok = stumps.iter().all(|s| s.ofs.iter().all(inside))
            && norm_main.iter().all(inside)
            && norm_sq.iter().all(inside);
        if !ok {
            return Err(stumps);
        }
        Ok(Table {
            stumps,
            norm_main,
            norm_sq,
            area,
        })
    }

    /// The stumps, in the detector's evaluation order.
    pub(super) fn stumps(&self) -> &[LaneStump] {
        &self.stumps
    }
}

/// The normalisation factors of a block's eight windows, as the exact fallback needs them.
pub(super) type Norms = [f32; LANES8];

impl Avx2 {
    /// The token when the CPU has AVX2.
    pub(super) fn detect() -> Option<Avx2> {
        std::arch::is_x86_feature_detected!("avx2").then_some(Avx2(()))
    }

    /// One block: the eight consecutive windows whose views of the sum and squared-sum
    /// buffers start at `main[0]` and `sq[0]`, of which the first `lanes` exist. Returns
    /// the windows that pass every stage as bits (lane `l` is bit `l`) and updates
    /// `skip_next`, OpenCV's rule that a window rejected by stage 0 skips the next one.
    /// `exact(stage, norms)` must return the exact verdicts of a stage as bits; it is
    /// called only when a lane that matters lies within the quick sum's margin.
    #[expect(clippy::too_many_arguments, reason = "one block's whole state")]
    pub(super) fn block<F: FnMut(usize, &Norms) -> u8>(
        self,
        table: &Table,
        stages: &[Stage8],
        main: &[i32; PAD],
        sq: &[i32; PAD],
        lanes: usize,
        skip_next: &mut bool,
        exact: F,
    ) -> u8 {
        #[allow(unsafe_code)]
        // SAFETY: `self` exists only when `is_x86_feature_detected!("avx2")` returned
        // true, so the CPU executes the AVX2 instructions of `block`.
        unsafe {
            block(table, stages, main, sq, lanes, skip_next, exact)
        }
    }
}

// Parallel to Avx2::block's signature on purpose: that is the safe entry point, this the
// AVX2 function it calls once the CPU is known to have AVX2.
#[target_feature(enable = "avx2")]
fn block<F: FnMut(usize, &Norms) -> u8>(
    table: &Table,
    stages: &[Stage8],
    main: &[i32; PAD],
    sq: &[i32; PAD],
    lanes: usize,
    skip_next: &mut bool,
    mut exact: F,
) -> u8 {
    let in_range = if lanes >= LANES8 {
        0xff
    } else {
        (1u8 << lanes) - 1
    };
    let (norm, mut alive) = norms(table, main, sq);
    alive &= in_range;
    let mut norms_array = None;
    let mut stage = |si: usize, matter: u8| -> u8 {
        let Some(s) = stages.get(si) else {
            return 0;
        };
        let stumps = &table.stumps[s.first..];
        let mut sum = _mm256_set1_ps(s.start);
        for_each_kind!(s.runs, stumps, |K, run| accumulate::<K>(
            run, main, norm, &mut sum
        ));
        let fail = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(sum, _mm256_set1_ps(s.fail)));
        let pass = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(sum, _mm256_set1_ps(s.pass)));
        let (fail, pass) = (fail as u8, pass as u8);
        let unsure = !(fail | pass) & matter;
        if unsure == 0 {
            return pass;
        }
        let norms = norms_array.get_or_insert_with(|| lanes_of(norm));
        (pass & !unsure) | (exact(si, norms) & unsure)
    };
    // Stage 0 for every window that passed the variance test, then OpenCV's skip rule
    // lane by lane: a skipped window's stage-0 verdict is discarded.
    let pass0 = if alive != 0 { stage(0, alive) } else { 0 };
    let mut evaluated = 0u8;
    for l in 0..lanes.min(LANES8) {
        let bit = 1u8 << l;
        if *skip_next {
            *skip_next = false;
        } else if alive & bit != 0 {
            if pass0 & bit != 0 {
                evaluated |= bit;
            } else {
                *skip_next = true;
            }
        }
    }
    let mut alive = evaluated;
    let mut si = 1;
    while alive != 0 && si < stages.len() {
        alive &= stage(si, alive);
        si += 1;
    }
    alive
}

/// `HaarEvaluator::setWindow` for the eight windows: the normalisation factors and, as
/// bits, the windows that pass the variance test (`nf > 0` and `A * norm < 0.1`), with
/// `nf = A Q - S^2` in `f64` and `norm = f32(1 / sqrt(nf))` as in `norm_lanes`.
#[target_feature(enable = "avx2")]
fn norms(table: &Table, main: &[i32; PAD], sq: &[i32; PAD]) -> (__m256, u8) {
    let s = box_sum(main, table.norm_main);
    let q = box_sum(sq, table.norm_sq);
    let area = _mm256_set1_pd(table.area);
    let half = |s: __m128i, q: __m128i| -> (__m128, i32) {
        let s = _mm256_cvtepi32_pd(s);
        // The squared sum is read as `u32`: add 2^32 where the signed reading is negative.
        let q_signed = _mm256_cvtepi32_pd(q);
        let wrap = _mm256_cmp_pd::<_CMP_LT_OQ>(q_signed, _mm256_set1_pd(0.0));
        let q = _mm256_add_pd(
            q_signed,
            _mm256_and_pd(wrap, _mm256_set1_pd(4_294_967_296.0)),
        );
        let nf = _mm256_sub_pd(_mm256_mul_pd(area, q), _mm256_mul_pd(s, s));
        let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(nf, _mm256_set1_pd(0.0));
        let inv = _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_sqrt_pd(nf));
        let inv: __m256d = _mm256_blendv_pd(_mm256_set1_pd(1.0), inv, positive);
        let norm = _mm256_cvtpd_ps(inv);
        let flat_enough = _mm256_cmp_pd::<_CMP_LT_OQ>(
            _mm256_mul_pd(area, _mm256_cvtps_pd(norm)),
            _mm256_set1_pd(0.1),
        );
        let ok = _mm256_movemask_pd(_mm256_and_pd(positive, flat_enough));
        (norm, ok)
    };
    let (n_lo, ok_lo) = half(_mm256_castsi256_si128(s), _mm256_castsi256_si128(q));
    let (n_hi, ok_hi) = half(
        _mm256_extracti128_si256::<1>(s),
        _mm256_extracti128_si256::<1>(q),
    );
    (_mm256_set_m128(n_hi, n_lo), (ok_lo | (ok_hi << 4)) as u8)
}

/// The eight lanes of a vector as an array.
#[target_feature(enable = "avx2")]
fn lanes_of(v: __m256) -> [f32; LANES8] {
    let lo = std::arch::x86_64::_mm256_castps256_ps128(v);
    let hi = std::arch::x86_64::_mm256_extractf128_ps::<1>(v);
    let lane = |v, i: usize| match i {
        0 => _mm_cvtss_f32(v),
        1 => _mm_cvtss_f32(_mm_movehdup_ps(v)),
        2 => _mm_cvtss_f32(_mm_movehl_ps(v, v)),
        _ => _mm_cvtss_f32(_mm_shuffle_ps::<0b11>(v, v)),
    };
    std::array::from_fn(|i| if i < 4 { lane(lo, i) } else { lane(hi, i - 4) })
}

/// The entries `data[offset..offset + 8]`: the integral value at one corner for eight
/// consecutive windows.
#[target_feature(enable = "avx2")]
#[inline]
fn at(data: &[i32; PAD], offset: u32) -> __m256i {
    let i = offset as usize;
    debug_assert!(i < VIEW);
    #[allow(unsafe_code)]
    // SAFETY: `offset` comes from a `Table`, which holds only offsets below `VIEW`, so
    // `i + 8 <= VIEW + 7 < PAD`: the eight entries lie inside `data`. The load is
    // unaligned.
    unsafe {
        _mm256_loadu_si256(data.as_ptr().add(i).cast())
    }
}

/// `CALC_SUM_OFS` for each lane: `p0 - p1 - p2 + p3`, wrapping.
#[target_feature(enable = "avx2")]
#[inline]
fn box_sum(data: &[i32; PAD], o: [u32; 4]) -> __m256i {
    _mm256_add_epi32(
        _mm256_sub_epi32(
            _mm256_sub_epi32(at(data, o[0]), at(data, o[1])),
            at(data, o[2]),
        ),
        at(data, o[3]),
    )
}

/// A lane constant of the stump, broadcast to eight lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn splat(v: &wide::f32x4) -> __m256 {
    _mm256_set1_ps(v.as_array()[0])
}

/// `sum += (value < threshold) & diff` over stumps of kind `K` (`LaneStump::value`).
#[target_feature(enable = "avx2")]
#[inline]
fn accumulate<const K: u8>(
    stumps: &[LaneStump],
    data: &[i32; PAD],
    norm: __m256,
    sum: &mut __m256,
) {
    let shared = K == Kind::Shared as u8 || K == Kind::SharedNeg as u8;
    let neg = K == Kind::TwoNeg as u8 || K == Kind::SharedNeg as u8 || K == Kind::ThreeNeg as u8;
    let three = K == Kind::Three as u8 || K == Kind::ThreeNeg as u8;
    for s in stumps {
        let o = &s.ofs;
        let (s0, s1) = if shared {
            let d = _mm256_sub_epi32(at(data, o[0]), at(data, o[1]));
            (
                _mm256_add_epi32(d, _mm256_sub_epi32(at(data, o[2]), at(data, o[3]))),
                _mm256_add_epi32(d, _mm256_sub_epi32(at(data, o[4]), at(data, o[5]))),
            )
        } else {
            (
                box_sum(data, [o[0], o[1], o[2], o[3]]),
                box_sum(data, [o[4], o[5], o[6], o[7]]),
            )
        };
        let (s0, s1) = (_mm256_cvtepi32_ps(s0), _mm256_cvtepi32_ps(s1));
        let mut r = if neg {
            _mm256_sub_ps(_mm256_mul_ps(splat(&s.weight[1]), s1), s0)
        } else {
            _mm256_add_ps(
                _mm256_mul_ps(splat(&s.weight[0]), s0),
                _mm256_mul_ps(splat(&s.weight[1]), s1),
            )
        };
        if three {
            let s2 = _mm256_cvtepi32_ps(box_sum(data, [o[8], o[9], o[10], o[11]]));
            r = _mm256_add_ps(r, _mm256_mul_ps(splat(&s.weight[2]), s2));
        }
        r = _mm256_mul_ps(r, norm);
        let below = _mm256_cmp_ps::<_CMP_LT_OQ>(r, splat(&s.threshold));
        *sum = _mm256_add_ps(*sum, _mm256_and_ps(below, splat(&s.diff)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_bounds_match_the_f64_comparison() {
        let xs = [
            0.1f64,
            -0.1,
            1.0,
            -3.25,
            1e-30,
            f64::from(0.7f32),
            f64::from(0.7f32) + 1e-12,
            f64::from(0.7f32) - 1e-12,
        ];
        for x in xs {
            let c = f32_at_or_above(x);
            for a in [c.next_down(), c, c.next_up(), x as f32] {
                assert_eq!(f64::from(a) < x, a < c, "x {x} a {a}");
            }
        }
    }
}
