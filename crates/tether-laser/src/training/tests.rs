fn sample(v0: f64, v5: f64) -> FeatureVector {
    let mut x = [0.0; N_FEATURES];
    x[0] = v0;
    x[5] = v5;
    x
}

/// Legs: 5 <= n and width < 0.2; everything else is not.
fn and_rule() -> (Vec<FeatureVector>, Vec<bool>) {
    let mut samples = Vec::new();
    let mut labels = Vec::new();
    for n in 1..15 {
        for wi in 0..10 {
            let width = 0.05 * wi as f64;
            samples.push(sample(n as f64, width));
            labels.push(n >= 5 && width < 0.2);
        }
    }
    (samples, labels)
}

#[test]
fn learns_a_two_feature_rule_deterministically() {
    let (samples, labels) = and_rule();
    let config = AdaBoostConfig {
        rounds: 20,
        ..AdaBoostConfig::default()
    };
    let model = train_adaboost(&samples, &labels, &config, Provenance::default()).unwrap();
    for (x, &l) in samples.iter().zip(&labels) {
        assert_eq!(model.is_leg(x), l, "{x:?}");
    }
    // A depth-2 tree represents the rule alone: one round suffices.
    assert!(model.trees.len() <= 20);
    let again = train_adaboost(&samples, &labels, &config, Provenance::default()).unwrap();
    assert_eq!(model, again);
    let round_trip = LegClassifier::from_json(&model.to_json()).unwrap();
    assert_eq!(round_trip, model);
    assert_eq!(round_trip.to_json(), model.to_json());
    assert_eq!(
        model.provenance.positives,
        labels.iter().filter(|&&l| l).count()
    );
}

#[test]
fn boosted_stumps_learn_a_threshold() {
    let (samples, _) = and_rule();
    let labels: Vec<bool> = samples.iter().map(|x| x[5] < 0.2).collect();
    let config = AdaBoostConfig {
        rounds: 5,
        max_depth: 1,
        ..AdaBoostConfig::default()
    };
    let model = train_adaboost(&samples, &labels, &config, Provenance::default()).unwrap();
    assert!(matches!(
        model.trees[0].nodes[0],
        Node::Split { feature: 5, threshold, .. } if (threshold - 0.175).abs() < 1e-12
    ));
    for (x, &l) in samples.iter().zip(&labels) {
        assert_eq!(model.is_leg(x), l);
    }
}

#[test]
fn refuses_bad_training_data() {
    let x = [sample(1.0, 0.1)];
    let cfg = AdaBoostConfig::default();
    assert!(matches!(
        train_adaboost(&x, &[true], &cfg, Provenance::default()),
        Err(TrainError::OneClass { .. })
    ));
    let x = [sample(f64::NAN, 0.1), sample(1.0, 0.1)];
    assert!(matches!(
        train_adaboost(&x, &[true, false], &cfg, Provenance::default()),
        Err(TrainError::NotFinite {
            sample: 0,
            feature: "n_points"
        })
    ));
    let x = [sample(2.0, 0.1), sample(1.0, 0.1)];
    let deep = AdaBoostConfig {
        max_depth: 0,
        ..cfg
    };
    assert!(matches!(
        train_adaboost(&x, &[true, false], &deep, Provenance::default()),
        Err(TrainError::Config { .. })
    ));
}

#[test]
fn the_robot_body_is_what_stays_put_in_the_sensor_frame() {
    // Ten scans of a moving robot: a part of it at (0.2, 0.5) in every scan (a few
    // mm of noise), a post that drifts through the frame, and in three scans a
    // chair leg at (1, 0).
    let sample = |k: usize| {
        let mut s = ScanSample::default();
        let mut push = |x: f64, y: f64| {
            s.centroids.push(Point2::new(x, y));
            s.centres.push(Point2::new(x, y));
            s.features.push([k as f64; N_FEATURES]);
            s.positive.push(false);
        };
        push(0.2 + 0.003 * (k % 3) as f64, 0.5);
        push(2.0 + 0.3 * k as f64, -1.0);
        if k < 3 {
            push(1.0, 0.0);
        }
        s
    };
    let mut samples: Vec<ScanSample> = (0..10).map(sample).collect();
    assert_eq!(drop_robot_body(&mut samples), 10);
    for (k, s) in samples.iter().enumerate() {
        assert_eq!(s.centroids.len(), if k < 3 { 2 } else { 1 });
        assert!(s.centroids.iter().all(|c| c.x > 0.5));
        assert_eq!(s.features.len(), s.centroids.len());
        assert_eq!(s.positive.len(), s.centroids.len());
        assert_eq!(s.centres.len(), s.centroids.len());
    }
}

use super::*;
use crate::classifier::Node;
use crate::features::N_FEATURES;

fn p(x: f64, y: f64) -> Point2<Laser> {
    Point2::new(x, y)
}

#[test]
fn matches_one_to_one_within_the_radius() {
    let truth = [p(2.0, 0.0), p(2.0, 0.3)];
    // Two detections near the first leg, one near nothing inside, one outside.
    let det = [p(2.05, 0.0), p(1.95, 0.02), p(3.0, 0.1), p(1.0, 2.0)];
    let region = LabelledRegion::leg_tracker();
    let c = match_detections(&det, &truth, 0.15, Some(&region));
    assert_eq!(c.true_positives, 1);
    assert_eq!(
        c.false_positives, 2,
        "the duplicate and the one at 3 m; not the one outside"
    );
    assert_eq!(c.false_negatives, 1);
    assert!((c.precision() - 1.0 / 3.0).abs() < 1e-12);
    assert!((c.recall() - 0.5).abs() < 1e-12);
    assert!((c.f1() - 0.4).abs() < 1e-12);
    let all = match_detections(&det, &truth, 0.15, None);
    assert_eq!(all.false_positives, 3);
    assert_eq!(MatchCounts::default().precision(), 1.0);
    assert_eq!(MatchCounts::default().f1(), 0.0);
}

#[test]
fn the_region_test_looks_at_the_returns_not_the_centre() {
    // Two unmatched legs whose centres (pushed away from the sensor) both lie
    // beyond 5 m: the returns of the first lie beyond it too, those of the second
    // inside the region, where the labeller would have labelled them.
    let region = LabelledRegion::leg_tracker();
    let centres = [p(5.03, 0.0), p(5.08, 0.0)];
    let centroids = [p(5.01, 0.0), p(4.99, 0.0)];
    let c = count_detections(&centres, &centroids, &[], Some(&region));
    assert_eq!(
        c.false_positives, 1,
        "only the one whose returns are inside"
    );
    assert_eq!(
        count_detections(&centres, &centroids, &[], None).false_positives,
        2
    );
}

#[test]
fn regions_follow_the_labellers_launch_file() {
    let four = LabelledRegion::of_bag("positive_4_extracted.bag");
    let one = LabelledRegion::of_bag("positive_1_extracted.bag");
    let at = |deg: f64| p(2.0 * deg.to_radians().cos(), 2.0 * deg.to_radians().sin());
    assert!(one.contains(at(12.0)) && !four.contains(at(12.0)));
    assert!(four.contains(at(-14.0)) && four.contains(at(9.0)));
    assert!(!one.contains(at(15.5)) && !one.contains(p(5.0, 0.0)));
}

#[test]
fn folds_take_one_bag_and_a_block_of_each_topic() {
    let scan = |n: usize| ScanSample {
        features: vec![[n as f64; N_FEATURES]],
        ..ScanSample::default()
    };
    let bags = vec![vec![scan(0)], vec![scan(1)]];
    let topics = vec![(10..14).map(scan).collect(), (20..23).map(scan).collect()];
    let folds = training_folds(bags, topics);
    let ids = |f: &Vec<ScanSample>| -> Vec<usize> {
        f.iter().map(|s| s.features[0][0] as usize).collect()
    };
    assert_eq!(ids(&folds[0]), vec![0, 10, 11, 20, 21]);
    assert_eq!(ids(&folds[1]), vec![1, 12, 13, 22]);
}

#[test]
fn scan_samples_count_like_the_detector() {
    let s = ScanSample {
        centres: vec![p(2.0, 0.0), p(3.0, 0.0), p(1.0, 2.0)],
        centroids: vec![p(1.96, 0.0), p(2.96, 0.0), p(0.98, 1.96)],
        labels: vec![p(1.97, 0.0)],
        region: Some(LabelledRegion::leg_tracker()),
        ..ScanSample::default()
    };
    let margins = [0.5, 0.1, 0.9];
    assert_eq!(
        s.count(&margins, 0.0),
        MatchCounts {
            true_positives: 1,
            false_positives: 1,
            false_negatives: 0
        }
    );
    assert_eq!(
        s.count(&margins, 0.6),
        MatchCounts {
            true_positives: 0,
            false_positives: 0,
            false_negatives: 1
        }
    );
}
