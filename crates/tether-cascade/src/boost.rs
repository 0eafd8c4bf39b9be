//! One boosted stage: AdaBoost over decision stumps (Gentle, Discrete or Real; Friedman,
//! Hastie and Tibshirani 2000), adding weak classifiers until the stage rejects enough
//! negatives while keeping its hit rate, as `opencv_traincascade`'s `CvCascadeBoost`
//! does.
//!
//! Speed: every feature's value on every sample is computed once per stage and kept
//! sorted ([`SortedValues`]: values and sample indices, feature by feature); each boosting
//! round is then one pass over each feature's sorted samples (running weight sums give
//! every split's error), features shared among threads.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tether_vision::cascade::STAGE_THRESHOLD_EPS;

use crate::features::Feature;
use crate::model::{Stage, Stump};
use crate::sample::SampleSet;

/// The boosting algorithm (`opencv_traincascade -bt`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BoostType {
    /// Gentle AdaBoost (`GAB`, OpenCV's default): each leaf is the weighted mean label of
    /// its samples; the split minimises the weighted squared error.
    Gentle,
    /// Discrete AdaBoost (`DAB`): leaves `+-alpha`, `alpha = ln((1 - err) / err) / 2`;
    /// the split minimises the weighted classification error.
    Discrete,
    /// Real AdaBoost (`RAB`): each leaf is half the log-ratio of its positive and negative
    /// weights; the split minimises `sum over leaves of sqrt(W+ W-)`.
    Real,
}

impl BoostType {
    /// The name OpenCV writes in `stageParams/boostType`.
    pub fn opencv_name(self) -> &'static str {
        match self {
            BoostType::Gentle => "GAB",
            BoostType::Discrete => "DAB",
            BoostType::Real => "RAB",
        }
    }
}

/// What a stage must achieve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StageParams {
    /// Boosting algorithm.
    pub boost: BoostType,
    /// Share of the positives the stage must accept (e.g. 0.995).
    pub min_hit_rate: f64,
    /// Largest share of the negatives the stage may accept (e.g. 0.5).
    pub max_false_alarm: f64,
    /// Most weak classifiers in one stage (OpenCV's `maxWeakCount`, 100).
    pub max_weak_count: usize,
}

/// Every feature's values on every sample, sorted: feature `f` owns entries
/// `f n .. (f + 1) n` of both arrays.
#[derive(Debug)]
pub struct SortedValues {
    n: usize,
    values: Vec<f32>,
    index: Vec<u16>,
}

/// Most samples a stage can hold (indices are stored in 16 bits).
pub const MAX_SAMPLES: usize = u16::MAX as usize + 1;

/// A key whose unsigned order is the total order of `f32`.
#[inline]
fn ordered(v: f32) -> u32 {
    let b = v.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The value of an [`ordered`] key.
#[inline]
fn unordered(k: u32) -> f32 {
    f32::from_bits(if k & 0x8000_0000 != 0 {
        k & 0x7FFF_FFFF
    } else {
        !k
    })
}

impl SortedValues {
    /// Computes and sorts the values of `features` on all samples, in parallel over
    /// features. `progress` is called with the number of features done so far (from the
    /// calling thread only).
    ///
    /// # Panics
    /// If the set holds more than [`MAX_SAMPLES`] samples (the trainer checks it first).
    pub fn build(set: &SampleSet, features: &[Feature], progress: &dyn Fn(usize)) -> SortedValues {
        let n = set.len();
        assert!(n <= MAX_SAMPLES);
        let mut values = vec![0f32; features.len() * n];
        let mut index = vec![0u16; features.len() * n];
        let stride = set.stride();
        // Chunks of features so that progress can be reported between them.
        const CHUNK: usize = 2048;
        for (c, (vals, idx)) in values
            .chunks_mut(CHUNK * n.max(1))
            .zip(index.chunks_mut(CHUNK * n.max(1)))
            .enumerate()
        {
            let first = c * CHUNK;
            vals.par_chunks_mut(n.max(1))
                .zip(idx.par_chunks_mut(n.max(1)))
                .enumerate()
                .for_each_init(Vec::new, |keys, (k, (v, ix))| {
                    let f = features[first + k].compile(stride);
                    keys.clear();
                    keys.extend(
                        (0..n).map(|i| (u64::from(ordered(set.value(&f, i))) << 32) | i as u64),
                    );
                    keys.sort_unstable();
                    for (j, key) in keys.iter().enumerate() {
                        ix[j] = (key & 0xFFFF_FFFF) as u16;
                        v[j] = unordered((key >> 32) as u32);
                    }
                });
            progress((first + CHUNK).min(features.len()));
        }
        SortedValues { n, values, index }
    }

    /// Number of samples.
    pub fn samples(&self) -> usize {
        self.n
    }

    /// Feature `f`'s sorted values and the samples they belong to.
    pub fn feature(&self, f: usize) -> (&[f32], &[u16]) {
        let r = f * self.n..(f + 1) * self.n;
        (&self.values[r.clone()], &self.index[r])
    }
}

/// The best split of one feature.
#[derive(Debug, Clone, Copy)]
struct Split {
    score: f64,
    feature: usize,
    /// Samples `..=k` of the sorted order go left.
    k: usize,
}

impl Split {
    /// Higher score wins; equal scores go to the lower feature index (deterministic).
    fn better(self, other: Split) -> Split {
        if other.score > self.score || (other.score == self.score && other.feature < self.feature) {
            other
        } else {
            self
        }
    }
}

/// Per sample: weight and weight times label (`+-1`).
#[derive(Debug, Clone, Copy, Default)]
struct Wy {
    w: f64,
    wy: f64,
}

/// The score of a split (higher is better) from the left side's sums and the totals.
#[inline(always)]
fn score(boost: BoostType, wl: f64, yl: f64, wt: f64, yt: f64) -> f64 {
    let (wr, yr) = (wt - wl, yt - yl);
    match boost {
        BoostType::Gentle => yl * yl / wl + yr * yr / wr,
        BoostType::Discrete => {
            // Errors of "left positive" and of "left negative".
            let a = (wl - yl) * 0.5 + (wr + yr) * 0.5;
            let b = (wl + yl) * 0.5 + (wr - yr) * 0.5;
            -a.min(b)
        }
        BoostType::Real => {
            let pos = |w: f64, y: f64| ((w + y) * 0.5).max(0.0);
            let neg = |w: f64, y: f64| ((w - y) * 0.5).max(0.0);
            -((pos(wl, yl) * neg(wl, yl)).sqrt() + (pos(wr, yr) * neg(wr, yr)).sqrt())
        }
    }
}

/// The leaves of a split: `(left, right)`.
fn leaves(boost: BoostType, wl: f64, yl: f64, wt: f64, yt: f64, n: usize) -> (f64, f64) {
    let (wr, yr) = (wt - wl, yt - yl);
    match boost {
        BoostType::Gentle => (yl / wl, yr / wr),
        BoostType::Discrete => {
            let a = (wl - yl) * 0.5 + (wr + yr) * 0.5;
            let b = (wl + yl) * 0.5 + (wr - yr) * 0.5;
            let err = (a.min(b) / wt).clamp(1e-10, 1.0 - 1e-10);
            let alpha = 0.5 * ((1.0 - err) / err).ln();
            if a <= b {
                (alpha, -alpha)
            } else {
                (-alpha, alpha)
            }
        }
        BoostType::Real => {
            // Smoothed as Schapire and Singer suggest, eps = 1 / (2 n) of the total.
            let eps = wt / (2.0 * n as f64);
            let leaf = |w: f64, y: f64| {
                0.5 * (((w + y) * 0.5).max(0.0) + eps).ln()
                    - 0.5 * (((w - y) * 0.5).max(0.0) + eps).ln()
            };
            (leaf(wl, yl), leaf(wr, yr))
        }
    }
}

/// The best split of every feature for the current weights, best overall.
fn best_split(
    sorted: &SortedValues,
    weights: &[Wy],
    boost: BoostType,
    nfeat: usize,
) -> Option<Split> {
    let (wt, yt) = weights
        .iter()
        .fold((0.0, 0.0), |(w, y), s| (w + s.w, y + s.wy));
    (0..nfeat)
        .into_par_iter()
        .with_min_len(64)
        .filter_map(|f| {
            let (vals, idx) = sorted.feature(f);
            let mut wl = 0.0;
            let mut yl = 0.0;
            let mut best: Option<Split> = None;
            for k in 0..vals.len().saturating_sub(1) {
                let s = weights[usize::from(idx[k])];
                wl += s.w;
                yl += s.wy;
                if vals[k] < vals[k + 1] {
                    let sc = score(boost, wl, yl, wt, yt);
                    if best.is_none_or(|b| sc > b.score) {
                        best = Some(Split {
                            score: sc,
                            feature: f,
                            k,
                        });
                    }
                }
            }
            best
        })
        .reduce_with(Split::better)
}

/// A split point strictly above `a` and not above `b` (`a < b`): their midpoint in
/// `f32`, or `b` when the midpoint rounds down to `a`.
fn split_point(a: f32, b: f32) -> f32 {
    let mid = a + (b - a) * 0.5;
    if mid > a && mid <= b { mid } else { b }
}

/// The outcome of one stage.
#[derive(Debug, Clone, PartialEq)]
pub struct StageOutcome {
    /// The stage.
    pub stage: Stage,
    /// Share of the stage's positives it accepts (detector semantics).
    pub hit_rate: f64,
    /// Share of the stage's negatives it accepts.
    pub false_alarm: f64,
}

/// The stage threshold that keeps `min_hit_rate` of the positives: the positives' stage
/// sums sorted, the one at `floor((1 - min_hit_rate) n)`, as `f32` not above it (OpenCV's
/// `CvCascadeBoost::isErrDesired`). Ties keep every positive of the tied value.
pub fn stage_threshold(positive_sums: &mut [f64], min_hit_rate: f64) -> f32 {
    positive_sums.sort_unstable_by(f64::total_cmp);
    let n = positive_sums.len();
    if n == 0 {
        return 0.0;
    }
    let k = (((1.0 - min_hit_rate) * n as f64).floor() as usize).min(n - 1);
    let raw = positive_sums[k];
    let mut t = raw as f32;
    if f64::from(t) > raw {
        t = t.next_down();
    }
    t
}

/// The share of `sums` a stage with file threshold `threshold` accepts (the detector's
/// comparison, with the threshold lowered by `1e-5`).
pub fn accepted_share(sums: &[f64], threshold: f32) -> f64 {
    if sums.is_empty() {
        return 0.0;
    }
    let eff = f64::from(threshold - STAGE_THRESHOLD_EPS);
    sums.iter().filter(|&&s| s >= eff).count() as f64 / sums.len() as f64
}

/// Trains one stage on `set` with the given feature pool (already valued and sorted in
/// `sorted`). `on_weak` is called after each weak classifier with
/// `(weak count, hit rate, false-alarm rate)`.
pub fn train_stage(
    set: &SampleSet,
    features: &[Feature],
    sorted: &SortedValues,
    params: &StageParams,
    on_weak: &dyn Fn(usize, f64, f64),
) -> StageOutcome {
    let n = set.len();
    let npos = set.labels().iter().filter(|&&p| p).count();
    let nneg = n - npos;
    // Viola-Jones's start: each class holds half the weight.
    let mut w: Vec<f64> = set
        .labels()
        .iter()
        .map(|&p| {
            if p {
                0.5 / npos.max(1) as f64
            } else {
                0.5 / nneg.max(1) as f64
            }
        })
        .collect();
    let y: Vec<f64> = set
        .labels()
        .iter()
        .map(|&p| if p { 1.0 } else { -1.0 })
        .collect();
    let mut sums = vec![0.0f64; n];
    let mut stumps = Vec::new();
    let mut outcome = StageOutcome {
        stage: Stage {
            threshold: 0.0,
            stumps: Vec::new(),
        },
        hit_rate: 1.0,
        false_alarm: 1.0,
    };
    let mut leaf_of = vec![0.0f32; n];
    while stumps.len() < params.max_weak_count.max(1) {
        let weights: Vec<Wy> = w
            .iter()
            .zip(&y)
            .map(|(&w, &y)| Wy { w, wy: w * y })
            .collect();
        let Some(split) = best_split(sorted, &weights, params.boost, features.len()) else {
            // Every feature is constant on these samples: nothing more can be learnt.
            break;
        };
        let (vals, idx) = sorted.feature(split.feature);
        let (mut wl, mut yl) = (0.0, 0.0);
        for &i in &idx[..=split.k] {
            wl += weights[usize::from(i)].w;
            yl += weights[usize::from(i)].wy;
        }
        let (wt, yt) = weights
            .iter()
            .fold((0.0, 0.0), |(a, b), s| (a + s.w, b + s.wy));
        let (left, right) = leaves(params.boost, wl, yl, wt, yt, n);
        let (left, right) = (left as f32, right as f32);
        let threshold = split_point(vals[split.k], vals[split.k + 1]);
        for (k, &i) in idx.iter().enumerate() {
            let v = vals[k];
            leaf_of[usize::from(i)] = if v < threshold { left } else { right };
        }
        for i in 0..n {
            let h = f64::from(leaf_of[i]);
            sums[i] += h;
            w[i] *= (-y[i] * h).exp();
        }
        let total: f64 = w.iter().sum();
        if total > 0.0 && total.is_finite() {
            w.iter_mut().for_each(|v| *v /= total);
        }
        stumps.push(Stump {
            feature: features[split.feature],
            threshold,
            left,
            right,
        });
        let mut pos: Vec<f64> = (0..n).filter(|&i| y[i] > 0.0).map(|i| sums[i]).collect();
        let neg: Vec<f64> = (0..n).filter(|&i| y[i] < 0.0).map(|i| sums[i]).collect();
        let thr = stage_threshold(&mut pos, params.min_hit_rate);
        let hit_rate = accepted_share(&pos, thr);
        let false_alarm = accepted_share(&neg, thr);
        on_weak(stumps.len(), hit_rate, false_alarm);
        outcome = StageOutcome {
            stage: Stage {
                threshold: thr,
                stumps: stumps.clone(),
            },
            hit_rate,
            false_alarm,
        };
        if false_alarm <= params.max_false_alarm {
            break;
        }
    }
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::features::{FeatureMode, enumerate};

    /// Patches with a bright left half (positives) or a bright right half (negatives),
    /// plus noise.
    fn separable_set(n: usize) -> SampleSet {
        let mut set = SampleSet::new(6, 6);
        let mut state = 12345u64;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as u32
        };
        let mut added = 0;
        while added < n {
            let positive = added % 2 == 0;
            let patch: Vec<u8> = (0..36)
                .map(|i| {
                    let left = i % 6 < 3;
                    let base = if left == positive { 170 } else { 70 };
                    (base + (rnd() % 40) as i32 - 20) as u8
                })
                .collect();
            if set.push(&patch, positive) {
                added += 1;
            }
        }
        set
    }

    fn params(boost: BoostType) -> StageParams {
        StageParams {
            boost,
            min_hit_rate: 0.995,
            max_false_alarm: 0.5,
            max_weak_count: 10,
        }
    }

    #[test]
    fn every_boost_type_separates_a_separable_set_with_one_stump() {
        let set = separable_set(200);
        let features = enumerate(6, 6, FeatureMode::Basic);
        let sorted = SortedValues::build(&set, &features, &|_| {});
        for boost in [BoostType::Gentle, BoostType::Discrete, BoostType::Real] {
            let out = train_stage(&set, &features, &sorted, &params(boost), &|_, _, _| {});
            assert_eq!(out.stage.stumps.len(), 1, "{boost:?}");
            assert_eq!(out.hit_rate, 1.0, "{boost:?}");
            assert_eq!(out.false_alarm, 0.0, "{boost:?}");
            let s = &out.stage.stumps[0];
            // Positives (bright left) go to the leaf with the larger value.
            assert!(s.left != s.right, "{boost:?}");
        }
    }

    #[test]
    fn sorted_values_are_sorted_and_complete() {
        let set = separable_set(50);
        let features = enumerate(6, 6, FeatureMode::All);
        let sorted = SortedValues::build(&set, &features, &|_| {});
        for f in (0..features.len()).step_by(37) {
            let (vals, idx) = sorted.feature(f);
            assert!(vals.windows(2).all(|w| w[0] <= w[1]));
            let mut seen: Vec<u16> = idx.to_vec();
            seen.sort_unstable();
            assert_eq!(seen, (0..50u16).collect::<Vec<_>>());
            let c = features[f].compile(set.stride());
            for (k, &i) in idx.iter().enumerate() {
                assert_eq!(vals[k], set.value(&c, usize::from(i)));
            }
        }
    }

    #[test]
    fn ordered_keys_sort_floats_and_decode() {
        let vals = [-3.5f32, -0.0, 0.0, 1e-30, -1e-30, 7.25, f32::MAX, f32::MIN];
        for v in vals {
            assert_eq!(unordered(ordered(v)).to_bits(), v.to_bits());
        }
        let mut sorted = vals;
        sorted.sort_by(f32::total_cmp);
        let mut by_key = vals;
        by_key.sort_by_key(|v| ordered(*v));
        assert_eq!(sorted.map(f32::to_bits), by_key.map(f32::to_bits));
    }

    #[test]
    fn split_point_lies_between() {
        assert_eq!(split_point(1.0, 2.0), 1.5);
        let a = 1.0f32;
        let b = a.next_up();
        let t = split_point(a, b);
        assert!(a < t && t <= b);
    }

    proptest::proptest! {
        /// The stage threshold keeps at least the required hit rate under the detector's
        /// comparison, whatever the sums.
        #[test]
        fn stage_threshold_keeps_the_hit_rate(
            sums in proptest::collection::vec(-50.0f64..50.0, 1..400),
            rate in 0.5f64..1.0,
        ) {
            let mut s = sums.clone();
            let t = stage_threshold(&mut s, rate);
            let hit = accepted_share(&sums, t);
            proptest::prop_assert!(hit >= rate - 1e-12, "hit {hit} < {rate}");
            // Not needlessly low: at most floor((1 - rate) n) + ties below it are lost...
            // and the threshold is one of the sums (as f32, rounded down).
            proptest::prop_assert!(sums.iter().any(|&v| (v as f32 == t) || (v as f32).next_down() == t));
        }
    }
}
