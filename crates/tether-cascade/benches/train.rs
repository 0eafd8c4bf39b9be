//! The trainer's inner loops on a stage of the default size (16x32 window, 2,000
//! positives and 3,000 negatives, 20,000 features): valuing and sorting every feature on
//! every sample (once per stage), and one boosting round (once per weak classifier).
//! Synthetic patches, so that it runs without `../shared`.
//!
//! `cargo bench -p tether-cascade --bench train`. The whole per-stage time of the real
//! trainings is in the report `tether train-cascade` writes (see the crate README).

use divan::Bencher;
use tether_cascade::boost::{SortedValues, train_stage};
use tether_cascade::features::{FeatureMode, enumerate};
use tether_cascade::rng::SplitMix;
use tether_cascade::sample::SampleSet;
use tether_cascade::{BoostType, StageParams};

fn main() {
    divan::main();
}

const POSITIVES: usize = 2000;
const NEGATIVES: usize = 3000;
const FEATURES: usize = 20_000;

/// Positives: a dark upright blob on a lighter background; negatives: texture.
fn samples() -> SampleSet {
    let mut r = SplitMix::new(1);
    let mut set = SampleSet::new(16, 32);
    while set.len() < POSITIVES + NEGATIVES {
        let positive = set.len() < POSITIVES;
        let patch: Vec<u8> = (0..16 * 32)
            .map(|i| {
                let (x, y) = ((i % 16) as f64, (i / 16) as f64);
                let base = if positive && (x - 8.0).abs() < 4.0 && y > 3.0 && y < 30.0 {
                    60.0
                } else {
                    150.0 + 50.0 * ((x + r.unit() * 3.0) * 0.7).sin()
                };
                (base + r.unit() * 40.0).clamp(0.0, 255.0) as u8
            })
            .collect();
        set.push(&patch, positive);
    }
    set
}

fn features() -> Vec<tether_cascade::features::Feature> {
    let pool = enumerate(16, 32, FeatureMode::Basic);
    let step = pool.len() / FEATURES;
    pool.into_iter()
        .step_by(step.max(1))
        .take(FEATURES)
        .collect()
}

#[divan::bench(sample_count = 3)]
fn value_and_sort_features(bencher: Bencher) {
    let set = samples();
    let features = features();
    bencher.bench_local(|| SortedValues::build(&set, &features, &|_| {}));
}

#[divan::bench(sample_count = 5)]
fn one_boosting_round(bencher: Bencher) {
    let set = samples();
    let features = features();
    let sorted = SortedValues::build(&set, &features, &|_| {});
    let params = StageParams {
        boost: BoostType::Gentle,
        min_hit_rate: 0.995,
        max_false_alarm: 1e-9,
        max_weak_count: 1,
    };
    bencher.bench_local(|| train_stage(&set, &features, &sorted, &params, &|_, _, _| {}));
}
