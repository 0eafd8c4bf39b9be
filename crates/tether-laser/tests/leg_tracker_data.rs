//! Real recordings (issue 3): leg_tracker's labelled scans in
//! `../shared/data/laser/leg_tracker/`, read with tether-recording.
//!
//! - The labels are the centroids of the default clustering's clusters (the protocol
//!   compares detections with exactly what the labeller labelled).
//! - The committed default model is exactly what training on the training split gives,
//!   with the decision margin its cross-validation chooses.
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
use tether_laser::classifier::{DEFAULT_COARSE_MODEL_JSON, DEFAULT_MODEL_JSON};
use tether_laser::training::*;
use tether_laser::{DetectorConfig, LegClassifier, LegDetector};
use tether_recording::rosbag::{read_labelled_scans, read_scans};

fn data_dir() -> Option<PathBuf> {
    tether_testkit::shared("data/laser/leg_tracker")
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
fn the_labels_are_the_centroids_of_the_default_clusters() {
    // leg_tracker labelled every cluster (Euclidean, 0.13 m, >= 3 returns) in a bearing
    // window within 5 m; the default clustering reproduces those clusters, so every
    // label is a candidate's centroid (to float rounding) and nothing in the window is
    // unlabelled.
    let Some(dir) = data_dir() else { return };
    let mut detector =
        LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap();
    let bags: Vec<&str> = TRAIN_POSITIVE_BAGS
        .iter()
        .chain(&TEST_POSITIVE_BAGS)
        .copied()
        .collect();
    let (mut labels, mut in_region) = (0, 0);
    for bag in bags {
        let region = LabelledRegion::of_bag(bag);
        for (scan, legs) in labelled(&dir, &[bag]) {
            let candidates = detector.candidates(&scan);
            for leg in &legs {
                let nearest = candidates
                    .iter()
                    .map(|c| c.centroid_in_laser.distance_m(*leg))
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    nearest < 1e-5,
                    "{bag}: label {leg:?} is {nearest} m from a cluster"
                );
            }
            labels += legs.len();
            in_region += candidates
                .iter()
                .filter(|c| region.contains(c.centroid_in_laser))
                .count();
        }
    }
    assert_eq!(labels, 1852);
    assert_eq!(
        in_region, labels,
        "every cluster in the labelled window is a label"
    );
}

/// Trains on the training split with the default options and `views`.
fn train_on_the_split(
    dir: &Path,
    views: TrainingViews,
) -> (LegClassifier, TrainingSet, CrossValidation) {
    let bags: Vec<(&str, Labelled)> = TRAIN_POSITIVE_BAGS
        .iter()
        .map(|b| (*b, labelled(dir, &[b])))
        .collect();
    let topics: Vec<Vec<LaserScan>> = TRAIN_NEGATIVE_TOPICS
        .iter()
        .map(|t| negatives(dir, &[t]))
        .collect();
    let scans: Vec<usize> = bags.iter().map(|(_, s)| s.len()).collect();
    assert_eq!(scans, vec![197, 83, 175, 295]);
    assert_eq!(topics.iter().map(Vec::len).sum::<usize>(), 435 + 434);
    let mut detector =
        LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap();
    let folds = folds_from_scans(
        &mut detector,
        &bags
            .iter()
            .map(|(b, s)| (*b, s.as_slice()))
            .collect::<Vec<_>>(),
        &topics.iter().map(Vec::as_slice).collect::<Vec<_>>(),
        views,
    );
    let config = AdaBoostConfig {
        views,
        ..default_adaboost_config()
    };
    let (model, set, cv) = train_with_cross_validation(&folds, &config).unwrap();
    let c = cv.best_counts();
    println!(
        "{} positives ({} labels unmatched), {} negatives; cross-validation: margin {}, \
         precision {:.3}, recall {:.3}, F1 {:.3}",
        set.positives(),
        set.unmatched_labels,
        set.negatives(),
        cv.margin(),
        c.precision(),
        c.recall(),
        c.f1()
    );
    (model, set, cv)
}

#[test]
fn training_reproduces_the_committed_model() {
    let Some(dir) = data_dir() else { return };
    let (model, set, cv) = train_on_the_split(&dir, default_adaboost_config().views);
    let c = cv.best_counts();
    assert_eq!(set.unmatched_labels, 0);
    // The labelled legs of the recorded scans and of one view from nearer of each.
    assert_eq!(set.positives(), 2107);
    // Measured on the recorded scans of the held-out folds (views are trained on, not
    // judged): precision 0.712, recall 0.766.
    assert!(c.precision() > 0.70 && c.recall() > 0.75, "{c:?}");
    assert!(
        model.to_json() == DEFAULT_MODEL_JSON,
        "the committed model differs from what training gives; rerun `{DEFAULT_TRAIN_COMMAND}`"
    );
}

#[test]
fn training_reproduces_the_committed_coarse_scan_model() {
    let Some(dir) = data_dir() else { return };
    let (model, set, cv) = train_on_the_split(&dir, TrainingViews::COARSE);
    let c = cv.best_counts();
    // The legs of the coarser views of the scans and of their views from nearer: a
    // label whose leg no longer makes a cluster of its own is dropped.
    assert_eq!(set.positives(), 2414);
    // Measured on the coarser views of the recorded scans of the held-out folds (the
    // views from nearer are trained on, not judged): precision 0.268, recall 0.643 at
    // the highest F1. A leg seen by a 1-degree scanner that lost a quarter of its beams
    // is much harder to tell from the furniture of negative_2's cluttered room.
    assert!(c.precision() > 0.25 && c.recall() > 0.62, "{c:?}");
    assert!(
        model.to_json() == DEFAULT_COARSE_MODEL_JSON,
        "the committed coarse-scan model differs from what training gives; rerun \
         `{DEFAULT_COARSE_TRAIN_COMMAND}`"
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
        // Parallel to eval-legs' table row (src/cmd/eval_legs.rs), which tests cannot call.
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
        // Every cluster in the labelled window is labelled and every detection is a
        // cluster's: none can be false there.
        assert_eq!(e.labelled.false_positives, 0, "{name}");
    }
    // Measured: arc 0.199 / 0.315, learned 0.726 / 0.874 (0.725 / 0.769 before the
    // model was trained on views from nearer, design 4.6; issue 3 asks 0.90 / 0.90 of
    // the learned one; see the README for what these recordings allow). Neither judges
    // the clusters at the edges of the field of view (the robot's own body there).
    let (a, l) = (arc.total(), learned.total());
    assert!(
        l.precision() >= 0.72 && l.recall() >= 0.86,
        "learned: {l:?}"
    );
    assert!(a.recall() >= 0.30 && a.precision() >= 0.19, "arc: {a:?}");
    // design 4.6: furniture fools the arc test; the classifier is the cure (measured:
    // 871 false legs against 227 on the rear scanner's 435 scans; 201 before the views).
    assert!(learned.negative_false_positives * 3 < arc.negative_false_positives);
    assert!(l.precision() > 3.5 * a.precision());
}
