//! Real recordings (issue 3): leg_tracker's labelled scans in
//! `../shared/data/laser/leg_tracker/`, read with tether-io.
//!
//! - The committed default model is exactly what training on the training split gives.
//! - Precision and recall of both detectors on the test split, which nothing was
//!   trained or tuned on; the bounds guard against regressions of the measured values
//!   (see the crate README for the figures).
//!
//! Without `../shared` the tests print why and pass, unless `TETHER_REQUIRE_SHARED=1`
//! (set in CI) makes that a failure.

#![allow(
    clippy::unwrap_used,
    reason = "test code: a failed unwrap is a failed test"
)]

use std::path::{Path, PathBuf};

use tether_core::{Laser, LaserScan, Point2, RangeNoiseModel};
use tether_io::rosbag::{read_labelled_scans, read_scans};
use tether_laser::classifier::DEFAULT_MODEL_JSON;
use tether_laser::training::*;
use tether_laser::{DetectorConfig, LegClassifier, LegDetector};

fn data_dir() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/laser/leg_tracker");
    if dir.is_dir() {
        return Some(dir);
    }
    let reason = format!(
        "{} is absent (it sits beside the checkout for developers and CI)",
        dir.display()
    );
    if std::env::var("TETHER_REQUIRE_SHARED").is_ok_and(|v| v == "1") {
        panic!("{reason}; TETHER_REQUIRE_SHARED=1 demands that this test runs");
    }
    eprintln!("SKIPPED: {reason}");
    None
}

type Labelled = Vec<(LaserScan, Vec<Point2<Laser>>)>;

fn labelled(dir: &Path, bags: &[&str]) -> Labelled {
    bags.iter()
        .flat_map(|b| {
            let read = read_labelled_scans(dir.join(b), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)
                .unwrap();
            assert_eq!(read.bad_count, 0, "{b}");
            assert_eq!(read.unlabelled, 0, "{b}");
            read.scans
                .into_iter()
                .map(|s| (s.scan.scan, s.legs_in_laser))
        })
        .collect()
}

fn negatives(dir: &Path, topics: &[&str]) -> Vec<LaserScan> {
    topics
        .iter()
        .flat_map(|t| {
            let read = read_scans(dir.join(NEGATIVE_BAG), t).unwrap();
            assert_eq!(read.bad_count, 0, "{t}");
            read.scans.into_iter().map(|m| m.scan)
        })
        .collect()
}

#[test]
fn training_reproduces_the_committed_model() {
    let Some(dir) = data_dir() else { return };
    let positives = labelled(&dir, &TRAIN_POSITIVE_BAGS);
    let negatives = negatives(&dir, &TRAIN_NEGATIVE_TOPICS);
    assert_eq!(positives.len(), 197 + 83 + 175 + 295);
    assert_eq!(negatives.len(), 435 + 434);
    let config = default_adaboost_config();
    let mut detector =
        LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap();
    let (model, set) = train_from_scans(
        &mut detector,
        positives.iter().map(|(s, l)| (s, l.as_slice())),
        negatives.iter(),
        &config,
        provenance(&config),
    )
    .unwrap();
    println!(
        "{} positives ({} labels unmatched), {} negatives",
        set.positives(),
        set.unmatched_labels,
        set.negatives()
    );
    assert!(
        model.to_json() == DEFAULT_MODEL_JSON,
        "the committed model differs from what training gives; rerun `{DEFAULT_TRAIN_COMMAND}`"
    );
}

#[test]
fn precision_and_recall_on_the_test_split() {
    let Some(dir) = data_dir() else { return };
    let positives = labelled(&dir, &TEST_POSITIVE_BAGS);
    let negatives = negatives(&dir, &TEST_NEGATIVE_TOPICS);
    let labels: usize = positives.iter().map(|(_, l)| l.len()).sum();
    assert_eq!((positives.len(), labels, negatives.len()), (454, 688, 435));
    let region = LabelledRegion::leg_tracker();
    let noise = RangeNoiseModel::default();
    let run = |detector: &mut LegDetector| {
        evaluate(
            detector,
            positives.iter().map(|(s, l)| (s, l.as_slice())),
            negatives.iter(),
            &region,
        )
    };
    let arc = run(&mut LegDetector::arc(DetectorConfig::default(), noise.clone()).unwrap());
    let learned = run(&mut LegDetector::learned(
        DetectorConfig::default(),
        noise,
        LegClassifier::default_model().unwrap(),
    )
    .unwrap());
    for (name, e) in [("arc", &arc), ("learned", &learned)] {
        let t = e.total();
        println!(
            "{name}: TP {} FP {} + {} FN {} precision {:.3} recall {:.3}",
            t.true_positives,
            e.labelled.false_positives,
            e.negative_false_positives,
            t.false_negatives,
            t.precision(),
            t.recall()
        );
        assert_eq!(t.true_positives + t.false_negatives, labels);
    }
    // Measured: arc 0.156 / 0.336, learned 0.634 / 0.724 (issue 3 asks 0.90 / 0.90 of
    // the learned one; see the README for why these recordings do not allow it).
    let (a, l) = (arc.total(), learned.total());
    assert!(
        l.precision() >= 0.60 && l.recall() >= 0.70,
        "learned: {l:?}"
    );
    assert!(a.recall() >= 0.30, "arc: {a:?}");
    // SPEC 4.6: furniture fools the arc test; the classifier is the cure.
    assert!(learned.negative_false_positives * 3 < arc.negative_false_positives);
    assert!(l.precision() > 3.0 * a.precision());
}
