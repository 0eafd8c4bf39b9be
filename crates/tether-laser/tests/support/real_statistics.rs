//! The detector statistics of issue 14 on leg_tracker's real recordings, for the
//! training split (every `positive_*` but 6 and 7, and every scanner of every
//! `negative_*` bag) and the test split (`positive_6`, `positive_7`). Shared by
//! `#[path]` between tether-laser's test and tether-sim's realism test.
//!
//! The built-in leg model was trained on the training split's positives and on the
//! left and right scanners of `negative_2`: on those scans it detects every labelled
//! leg (it has learned them), which says nothing about a sensor. The training split's
//! honest figures are therefore *held out*: each positive bag is measured with a model
//! trained (same AdaBoost settings and decision margin as the built-in one) on the
//! other training bags and on the other blocks of the negatives, exactly the folds of
//! the built-in model's cross-validation ([`training_folds`]); the rear scanner, which
//! no model saw, is measured with the built-in model.

use std::path::{Path, PathBuf};

use tether_core::RangeNoiseModel;
use tether_laser::statistics::{DetectorStatistics, detected_legs, labelled_legs};
use tether_laser::training::{
    LabelledRegion, POSITIVE_LABEL_TOPIC, POSITIVE_SCAN_TOPIC, ScanSample, TRAIN_NEGATIVE_TOPICS,
    TrainingSet, default_adaboost_config, drop_robot_body, training_folds,
};
use tether_laser::{DetectorConfig, LegClassifier, LegDetector, Provenance, train_adaboost};
use tether_recording::rosbag::{read_labelled_scans, read_scans};

/// The scanners of the negative bags.
pub const NEGATIVE_TOPICS: [&str; 3] = ["/left_scan", "/right_scan", "/rear_scan"];

/// The shared data directory, or `None` with a printed reason (a failure with
/// `TETHER_REQUIRE_SHARED=1`).
pub fn shared_data_dir() -> Option<PathBuf> {
    tether_testkit::shared("data/laser/leg_tracker")
}

/// tether's default leg detector (the learned one with the built-in model).
pub fn default_detector() -> LegDetector {
    LegDetector::learned(
        DetectorConfig::default(),
        RangeNoiseModel::default(),
        LegClassifier::default_model().expect("the built-in model loads"),
    )
    .expect("the default configuration is valid")
}

/// Names of the bags in `dir` starting with `prefix`, sorted.
pub fn bags_with_prefix(dir: &Path, prefix: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("the data directory lists")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(prefix) && n.ends_with(".bag"))
        .collect();
    names.sort();
    names
}

/// Whether a positive bag belongs to the test split.
pub fn is_test_positive(name: &str) -> bool {
    name.starts_with("positive_6") || name.starts_with("positive_7")
}

/// Adds the labelled scans of `bag` to `stats`.
pub fn add_positive_bag(stats: &mut DetectorStatistics, dir: &Path, bag: &str) {
    let mut detector = default_detector();
    let read = read_labelled_scans(dir.join(bag), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)
        .unwrap_or_else(|e| panic!("{bag}: {e}"));
    for s in read.scans {
        let scan = s.scan.scan;
        let labels = labelled_legs(&mut detector, &scan, &s.legs_in_laser);
        let found = detected_legs(&mut detector, &scan);
        stats.add_labelled_scan(scan.stamp.secs_f64(), &labels, &found);
    }
    stats.end_sequence();
}

/// Adds every scan of every scanner of the negative bag `bag` to `stats`: all its
/// legs are false positives, in the scanner's frame.
pub fn add_negative_bag(stats: &mut DetectorStatistics, dir: &Path, bag: &str) {
    let mut detector = default_detector();
    for topic in NEGATIVE_TOPICS {
        let Ok(read) = read_scans(dir.join(bag), topic) else {
            continue;
        };
        for m in read.scans {
            let found: Vec<(f64, f64)> = detected_legs(&mut detector, &m.scan)
                .iter()
                .map(|p| (p.x, p.y))
                .collect();
            stats.add_false_positives(m.scan.stamp.secs_f64(), &found);
        }
        stats.end_sequence();
    }
}

/// The training and the test split's statistics, read from `dir`.
pub fn real_splits(dir: &Path) -> (DetectorStatistics, DetectorStatistics) {
    let mut train = DetectorStatistics::new();
    let mut test = DetectorStatistics::new();
    for bag in bags_with_prefix(dir, "positive_") {
        if is_test_positive(&bag) {
            add_positive_bag(&mut test, dir, &bag);
        } else {
            add_positive_bag(&mut train, dir, &bag);
        }
    }
    for bag in bags_with_prefix(dir, "negative_") {
        add_negative_bag(&mut train, dir, &bag);
    }
    (train, test)
}

/// A labelled recording in memory: stamps, scans and labels.
type Positive = Vec<(
    tether_core::LaserScan,
    Vec<tether_core::Point2<tether_core::Laser>>,
)>;

fn read_positive(dir: &Path, bag: &str) -> Positive {
    read_labelled_scans(dir.join(bag), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)
        .unwrap_or_else(|e| panic!("{bag}: {e}"))
        .scans
        .into_iter()
        .map(|s| (s.scan.scan, s.legs_in_laser))
        .collect()
}

fn add_positive_scans(
    stats: &mut DetectorStatistics,
    detector: &mut LegDetector,
    scans: &Positive,
) {
    for (scan, legs) in scans {
        let labels = labelled_legs(detector, scan, legs);
        let found = detected_legs(detector, scan);
        stats.add_labelled_scan(scan.stamp.secs_f64(), &labels, &found);
    }
    stats.end_sequence();
}

fn add_negative_scans(
    stats: &mut DetectorStatistics,
    detector: &mut LegDetector,
    scans: &[tether_core::LaserScan],
) {
    for scan in scans {
        let found: Vec<(f64, f64)> = detected_legs(detector, scan)
            .iter()
            .map(|p| (p.x, p.y))
            .collect();
        stats.add_false_positives(scan.stamp.secs_f64(), &found);
    }
    stats.end_sequence();
}

/// The training split measured on held-out folds (see the module's comment), and the
/// test split with the built-in model.
pub fn real_splits_held_out(dir: &Path) -> (DetectorStatistics, DetectorStatistics) {
    let mut train = DetectorStatistics::new();
    let mut test = DetectorStatistics::new();
    let positives: Vec<String> = bags_with_prefix(dir, "positive_");
    let train_bags: Vec<&String> = positives.iter().filter(|b| !is_test_positive(b)).collect();
    let train_scans: Vec<Positive> = train_bags.iter().map(|b| read_positive(dir, b)).collect();
    let negative_2 = dir.join("negative_2.bag");
    let negative_scans: Vec<Vec<tether_core::LaserScan>> = TRAIN_NEGATIVE_TOPICS
        .iter()
        .map(|t| {
            read_scans(&negative_2, t)
                .map(|r| r.scans.into_iter().map(|m| m.scan).collect())
                .unwrap_or_default()
        })
        .collect();
    // The folds of the built-in model's cross-validation, with the scans beside them.
    let mut candidates = default_detector();
    let bag_samples: Vec<Vec<ScanSample>> = train_bags
        .iter()
        .zip(&train_scans)
        .map(|(b, scans)| {
            let region = LabelledRegion::of_bag(b);
            scans
                .iter()
                .map(|(scan, legs)| ScanSample::labelled(&mut candidates, scan, legs, region))
                .collect()
        })
        .collect();
    let topic_samples: Vec<Vec<ScanSample>> = negative_scans
        .iter()
        .map(|scans| {
            let mut samples: Vec<ScanSample> = scans
                .iter()
                .map(|scan| ScanSample::without_people(&mut candidates, scan))
                .collect();
            drop_robot_body(&mut samples);
            samples
        })
        .collect();
    let folds = training_folds(bag_samples, topic_samples);
    let k = folds.len();
    let built_in = LegClassifier::default_model().expect("the built-in model loads");
    let config = tether_laser::AdaBoostConfig {
        decision_margin: built_in.decision_margin,
        ..default_adaboost_config()
    };
    for (held, held_scans) in train_scans.iter().enumerate().take(k) {
        let set = TrainingSet::from_scans(
            folds
                .iter()
                .enumerate()
                .filter(|(f, _)| *f != held)
                .flat_map(|(_, s)| s),
        );
        let model = train_adaboost(&set.samples, &set.labels, &config, Provenance::default())
            .expect("a fold trains");
        let mut detector =
            LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model)
                .expect("the default configuration is valid");
        add_positive_scans(&mut train, &mut detector, held_scans);
        for scans in &negative_scans {
            // The held-out block of each topic, as `training_folds` cuts it.
            let n = scans.len();
            let block: Vec<tether_core::LaserScan> = scans
                .iter()
                .enumerate()
                .filter(|(i, _)| (i * k / n.max(1)).min(k - 1) == held)
                .map(|(_, s)| s.clone())
                .collect();
            add_negative_scans(&mut train, &mut detector, &block);
        }
    }
    // Scanners of the negative bags that no model was trained on, with the built-in one.
    let mut detector = default_detector();
    for bag in bags_with_prefix(dir, "negative_") {
        for topic in NEGATIVE_TOPICS {
            if bag == "negative_2.bag" && TRAIN_NEGATIVE_TOPICS.contains(&topic) {
                continue;
            }
            if let Ok(read) = read_scans(dir.join(&bag), topic) {
                let scans: Vec<_> = read.scans.into_iter().map(|m| m.scan).collect();
                add_negative_scans(&mut train, &mut detector, &scans);
            }
        }
    }
    for bag in positives.iter().filter(|b| is_test_positive(b)) {
        add_positive_scans(&mut test, &mut detector, &read_positive(dir, bag));
    }
    (train, test)
}
