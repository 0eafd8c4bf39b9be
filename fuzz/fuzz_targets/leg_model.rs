//! The leg classifier's JSON model loader (`tether legs --model`, `tether track` with a
//! learned detector) on arbitrary text: it must never panic; a model it accepts writes
//! back to JSON that reads back equal, its margin is a number in [-1, 1], the compiled
//! layout the detector uses decides as the model does, and a detector with it runs.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_core::{LaserScan, RangeNoiseModel, Stamp};
use tether_laser::{
    CompiledClassifier, DetectorConfig, FeatureVector, LegClassifier, LegDetector, N_FEATURES,
};

/// A 180-beam scan of a wall at 3 m with two legs at 1.5 m.
fn scan() -> LaserScan {
    let ranges = (0..180)
        .map(|i| match i {
            85..=88 | 92..=95 => 1.5,
            _ => 3.0,
        })
        .collect();
    LaserScan::new(Stamp::from_ns(0), "laser", -1.57, 0.0175, 0.02, 5.6, ranges)
        .expect("a valid scan")
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(model) = LegClassifier::from_json(text) else {
        return;
    };
    let again = LegClassifier::from_json(&model.to_json()).expect("a model's JSON reads back");
    assert_eq!(again, model, "the JSON written does not read back equal");

    // Feature vectors around the model's own thresholds, and plain ones.
    let mut xs: Vec<FeatureVector> =
        vec![[0.0; N_FEATURES], [1.0; N_FEATURES], [f64::NAN; N_FEATURES]];
    for (i, t) in model.trees.iter().take(8).enumerate() {
        let mut x = [0.0; N_FEATURES];
        for (k, node) in t.nodes.iter().enumerate() {
            if let tether_laser::Node::Split {
                feature, threshold, ..
            } = node
                && let Some(slot) = x.get_mut(*feature)
            {
                *slot = if (i + k) % 2 == 0 {
                    *threshold
                } else {
                    threshold + 1.0
                };
            }
        }
        xs.push(x);
    }
    let compiled = CompiledClassifier::new(&model);
    for x in &xs {
        let margin = model.margin(x);
        assert!(
            margin.is_finite() && (-1.0 - 1e-9..=1.0 + 1e-9).contains(&margin),
            "margin {margin}"
        );
        let fast = compiled.margin_if_leg(x);
        assert_eq!(
            fast.is_some(),
            model.is_leg(x),
            "compiled {fast:?}, model {margin} against {}",
            model.decision_margin
        );
        if let Some(m) = fast {
            assert!((m - margin).abs() <= 1e-9, "compiled {m}, model {margin}");
        }
    }
    let mut detector =
        LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model)
            .expect("a model that loaded makes a detector");
    let _ = detector.detect(&scan());
});
