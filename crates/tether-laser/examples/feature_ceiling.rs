//! How far one scan's features can go on the test recordings themselves.
//!
//! The learned detector is trained on the training split and measured on the test split
//! (issue 3). This asks a different question: if the model could learn from the test
//! recordings, how well would the same features and the same boosting separate their
//! legs from their furniture? It cross-validates within the test split, four folds:
//! the first and second halves of `positive_6_extracted.bag` and of
//! `positive_7_extracted.bag`, each with a quarter of the scans of `/rear_scan` of
//! `negative_2.bag` (consecutive blocks; the robot's own body kept among the negatives,
//! as the test counts it). Held-out scans come from the same person, place and moments
//! as the training ones, so this is an optimistic bound, not a measurement of the
//! shipped model, and nothing from it goes into the model.
//!
//! Run from the checkout's root, with `../shared` beside it:
//! `cargo run --release -p tether-laser --example feature_ceiling`

use std::error::Error;
use std::path::Path;

use tether_core::RangeNoiseModel;
use tether_laser::training::{
    LabelledRegion, NEGATIVE_BAG, POSITIVE_LABEL_TOPIC, POSITIVE_SCAN_TOPIC, ScanSample,
    TEST_NEGATIVE_TOPICS, TEST_POSITIVE_BAGS, cross_validate, default_adaboost_config,
    training_folds,
};
use tether_laser::{DetectorConfig, LegDetector};
use tether_recording::rosbag::{read_labelled_scans, read_scans};

fn main() -> Result<(), Box<dyn Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/laser/leg_tracker");
    if !dir.is_dir() {
        return Err(format!("{} is absent: this needs leg_tracker's bags", dir.display()).into());
    }
    let mut detector = LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default())?;
    let mut halves = Vec::new();
    for bag in TEST_POSITIVE_BAGS {
        let read = read_labelled_scans(dir.join(bag), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)?;
        let region = LabelledRegion::of_bag(bag);
        let mut first: Vec<ScanSample> = read
            .scans
            .iter()
            .map(|s| ScanSample::labelled(&mut detector, &s.scan.scan, &s.legs_in_laser, region))
            .collect();
        let second = first.split_off(first.len() / 2);
        halves.push(first);
        halves.push(second);
    }
    let mut negatives = Vec::new();
    for topic in TEST_NEGATIVE_TOPICS {
        let read = read_scans(dir.join(NEGATIVE_BAG), topic)?;
        negatives.push(
            read.scans
                .iter()
                .map(|m| ScanSample::without_people(&mut detector, &m.scan))
                .collect(),
        );
    }
    let folds = training_folds(halves, negatives);
    let config = default_adaboost_config();
    let cv = cross_validate(&folds, &config)?;
    let best = cv.best_counts();
    println!(
        "cross-validation within the test split ({} trees of depth {}, {} folds):",
        config.rounds,
        config.max_depth,
        folds.len()
    );
    println!(
        "  highest F1 {:.3}: precision {:.3}, recall {:.3} (decision margin {})",
        best.f1(),
        best.precision(),
        best.recall(),
        cv.margin()
    );
    // The best the other figure can be where one of them reaches 0.90.
    let at_least = |pick: fn(&tether_laser::training::MatchCounts) -> f64,
                    other: fn(&tether_laser::training::MatchCounts) -> f64| {
        cv.counts
            .iter()
            .filter(|c| pick(c) >= 0.9)
            .map(other)
            .fold(0.0, f64::max)
    };
    println!(
        "  at recall >= 0.90 the precision is at most {:.3}; at precision >= 0.90 the \
         recall is at most {:.3}",
        at_least(|c| c.recall(), |c| c.precision()),
        at_least(|c| c.precision(), |c| c.recall())
    );
    Ok(())
}
