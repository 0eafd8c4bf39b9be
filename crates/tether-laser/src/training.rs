//! Training data for the leg classifier and the measure of both detectors, on scans
//! already in memory (reading them is the caller's I/O).
//!
//! The data are leg_tracker's (Leigh et al., ICRA 2015): scans with the labelled centres
//! of leg clusters, and scans of rooms without people where every cluster is a non-leg.
//! The split is fixed by issue 3 and never mixed:
//!
//! - training: the labelled legs of [`TRAIN_POSITIVE_BAGS`] and every candidate of the
//!   [`TRAIN_NEGATIVE_TOPICS`] of [`NEGATIVE_BAG`];
//! - test: [`TEST_POSITIVE_BAGS`] and the [`TEST_NEGATIVE_TOPICS`] of [`NEGATIVE_BAG`],
//!   used for the reported precision and recall only, never for training or tuning.

use tether_core::{Laser, LaserScan, Point2};

use crate::classifier::{AdaBoostConfig, LegClassifier, Provenance, TrainError, train_adaboost};
use crate::detector::{Detection, LegDetector};
use crate::features::FeatureVector;

/// Bags whose labelled legs are training positives.
pub const TRAIN_POSITIVE_BAGS: [&str; 4] = [
    "positive_1_extracted.bag",
    "positive_2_extracted.bag",
    "positive_3_extracted.bag",
    "positive_4_extracted.bag",
];
/// Bags whose labelled legs are test positives.
pub const TEST_POSITIVE_BAGS: [&str; 2] = ["positive_6_extracted.bag", "positive_7_extracted.bag"];
/// Scan topic of the positive bags.
pub const POSITIVE_SCAN_TOPIC: &str = "/training_scan";
/// Label topic of the positive bags (`geometry_msgs/PoseArray` of leg-cluster centres).
pub const POSITIVE_LABEL_TOPIC: &str = "/leg_cluster_positions";
/// The bag of scans without people.
pub const NEGATIVE_BAG: &str = "negative_2.bag";
/// Its topics used for training.
pub const TRAIN_NEGATIVE_TOPICS: [&str; 2] = ["/left_scan", "/right_scan"];
/// Its topic used for testing.
pub const TEST_NEGATIVE_TOPICS: [&str; 1] = ["/rear_scan"];

/// The command that makes the committed default model, from the checkout's root.
pub const DEFAULT_TRAIN_COMMAND: &str = "tether train-legs --data ../shared/data/laser/leg_tracker --out crates/tether-laser/models/legs_default.json";

/// Largest distance from a labelled leg centre to the centroid of a candidate segment
/// for that candidate to be a training positive, m. The labels are centroids of the
/// labeller's own clusters; 0.1 m is half the closest spacing of two legs, so a segment
/// that merged two legs (centroid between them) is not taken as one leg.
pub const TRAIN_MATCH_RADIUS_M: f64 = 0.1;

/// Largest distance from a detection to a labelled leg centre for the detection to
/// count as finding that leg, m (issue 3).
pub const EVAL_MATCH_RADIUS_M: f64 = 0.15;

/// Where the positive scans are labelled. leg_tracker's extraction labelled every
/// cluster within a bearing of +-15 deg and a range of 5 m (its launch file for these
/// bags); outside that, a scan's clusters are unlabelled, so detections there are
/// neither right nor wrong and are left out of the measure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelledRegion {
    /// Largest `|bearing|` of a labelled cluster, rad.
    pub max_abs_bearing_rad: f64,
    /// Largest range of a labelled cluster, m.
    pub max_range_m: f64,
}

impl LabelledRegion {
    /// The region of leg_tracker's test bags 6 and 7.
    pub fn leg_tracker() -> Self {
        LabelledRegion {
            max_abs_bearing_rad: 15f64.to_radians(),
            max_range_m: 5.0,
        }
    }

    /// Whether a point lies inside.
    pub fn contains(&self, p: Point2<Laser>) -> bool {
        p.bearing_rad().abs() < self.max_abs_bearing_rad && p.range_m() < self.max_range_m
    }
}

/// Feature vectors with labels.
#[derive(Debug, Clone, Default)]
pub struct TrainingSet {
    /// Features.
    pub samples: Vec<FeatureVector>,
    /// Whether each sample is a leg.
    pub labels: Vec<bool>,
    /// Labelled legs that no candidate segment matched.
    pub unmatched_labels: usize,
}

impl TrainingSet {
    /// Adds the candidates of `scan` that match a labelled leg as positives: for each
    /// label, the candidate with the nearest centroid within
    /// [`TRAIN_MATCH_RADIUS_M`] (each candidate at most once). Other candidates of the
    /// scan are unlabelled and left out.
    pub fn add_positive_scan(
        &mut self,
        detector: &mut LegDetector,
        scan: &LaserScan,
        legs_in_laser: &[Point2<Laser>],
    ) {
        let candidates = detector.candidates(scan);
        let mut taken = vec![false; candidates.len()];
        for &label in legs_in_laser {
            let nearest = candidates
                .iter()
                .enumerate()
                .filter(|(k, _)| !taken[*k])
                .map(|(k, c)| (k, c.centroid_in_laser.distance_m(label)))
                .filter(|&(_, d)| d <= TRAIN_MATCH_RADIUS_M)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match nearest {
                Some((k, _)) => {
                    taken[k] = true;
                    self.samples.push(candidates[k].features);
                    self.labels.push(true);
                }
                None => self.unmatched_labels += 1,
            }
        }
    }

    /// Adds every candidate of a scan without people as a negative.
    pub fn add_negative_scan(&mut self, detector: &mut LegDetector, scan: &LaserScan) {
        for c in detector.candidates(scan) {
            self.samples.push(c.features);
            self.labels.push(false);
        }
    }

    /// Number of positives.
    pub fn positives(&self) -> usize {
        self.labels.iter().filter(|&&l| l).count()
    }

    /// Number of negatives.
    pub fn negatives(&self) -> usize {
        self.labels.len() - self.positives()
    }
}

/// The training parameters of the default model.
pub fn default_adaboost_config() -> AdaBoostConfig {
    AdaBoostConfig::default()
}

/// What a model records about its making: the training options that differ from the
/// defaults (none for the default model, whose command is [`DEFAULT_TRAIN_COMMAND`])
/// and the training split. Paths are left out, so that the same data give the same
/// file wherever they lie.
pub fn provenance(config: &AdaBoostConfig) -> Provenance {
    let defaults = default_adaboost_config();
    let mut command = String::from("tether train-legs");
    if config.rounds != defaults.rounds {
        command.push_str(&format!(" --rounds {}", config.rounds));
    }
    if config.max_depth != defaults.max_depth {
        command.push_str(&format!(" --depth {}", config.max_depth));
    }
    let mut sources: Vec<String> = TRAIN_POSITIVE_BAGS
        .iter()
        .map(|b| format!("{b} {POSITIVE_SCAN_TOPIC} (labelled legs: positives)"))
        .collect();
    sources.extend(
        TRAIN_NEGATIVE_TOPICS
            .iter()
            .map(|t| format!("{NEGATIVE_BAG} {t} (every candidate: negatives)")),
    );
    Provenance {
        command,
        sources,
        margin_choice: "AdaBoost's own boundary, F(x) = 0".to_string(),
        ..Provenance::default()
    }
}

/// Builds the training set from labelled scans (positives) and scans without people
/// (negatives), with `detector`'s segmentation, and trains the classifier.
pub fn train_from_scans<'a>(
    detector: &mut LegDetector,
    positives: impl IntoIterator<Item = (&'a LaserScan, &'a [Point2<Laser>])>,
    negatives: impl IntoIterator<Item = &'a LaserScan>,
    config: &AdaBoostConfig,
    provenance: Provenance,
) -> Result<(LegClassifier, TrainingSet), TrainError> {
    let mut set = TrainingSet::default();
    for (scan, legs) in positives {
        set.add_positive_scan(detector, scan, legs);
    }
    for scan in negatives {
        set.add_negative_scan(detector, scan);
    }
    let model = train_adaboost(&set.samples, &set.labels, config, provenance)?;
    Ok((model, set))
}

/// The measure of a detector on a test split.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Evaluation {
    /// Counts on the labelled scans (false positives only inside the labelled region).
    pub labelled: MatchCounts,
    /// Detections on the scans without people (all false).
    pub negative_false_positives: usize,
    /// Labelled scans.
    pub labelled_scans: usize,
    /// Scans without people.
    pub negative_scans: usize,
}

impl Evaluation {
    /// Both parts together: precision counts every false detection.
    pub fn total(&self) -> MatchCounts {
        MatchCounts {
            false_positives: self.labelled.false_positives + self.negative_false_positives,
            ..self.labelled
        }
    }
}

/// Runs `detector` on labelled scans and on scans without people and counts its legs
/// against the labels within [`EVAL_MATCH_RADIUS_M`]; detections on labelled scans
/// outside `region` are not counted.
pub fn evaluate<'a>(
    detector: &mut LegDetector,
    positives: impl IntoIterator<Item = (&'a LaserScan, &'a [Point2<Laser>])>,
    negatives: impl IntoIterator<Item = &'a LaserScan>,
    region: &LabelledRegion,
) -> Evaluation {
    let mut out = Evaluation::default();
    let mut detection = Detection::default();
    for (scan, legs) in positives {
        detector.detect_into(scan, &mut detection);
        out.labelled.add(match_detections(
            &leg_positions(&detection),
            legs,
            EVAL_MATCH_RADIUS_M,
            Some(region),
        ));
        out.labelled_scans += 1;
    }
    for scan in negatives {
        detector.detect_into(scan, &mut detection);
        out.negative_false_positives += detection.legs.len();
        out.negative_scans += 1;
    }
    out
}

/// True and false detections and missed legs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MatchCounts {
    /// Detections that found a labelled leg.
    pub true_positives: usize,
    /// Detections that found none.
    pub false_positives: usize,
    /// Labelled legs that no detection found.
    pub false_negatives: usize,
}

impl MatchCounts {
    /// `tp / (tp + fp)`; 1 when nothing was detected.
    pub fn precision(&self) -> f64 {
        let d = self.true_positives + self.false_positives;
        if d == 0 {
            1.0
        } else {
            self.true_positives as f64 / d as f64
        }
    }

    /// `tp / (tp + fn)`; 1 when there was nothing to find.
    pub fn recall(&self) -> f64 {
        let d = self.true_positives + self.false_negatives;
        if d == 0 {
            1.0
        } else {
            self.true_positives as f64 / d as f64
        }
    }

    /// Adds another count.
    pub fn add(&mut self, other: MatchCounts) {
        self.true_positives += other.true_positives;
        self.false_positives += other.false_positives;
        self.false_negatives += other.false_negatives;
    }
}

/// Matches detections to labelled legs one to one, closest pairs first, within
/// `radius_m`. Detections outside `region` that match nothing are not counted (the
/// labels do not cover them); pass `None` to count every detection.
pub fn match_detections(
    detected: &[Point2<Laser>],
    truth: &[Point2<Laser>],
    radius_m: f64,
    region: Option<&LabelledRegion>,
) -> MatchCounts {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, d) in detected.iter().enumerate() {
        for (j, t) in truth.iter().enumerate() {
            let dist = d.distance_m(*t);
            if dist <= radius_m {
                pairs.push((dist, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    let mut used_d = vec![false; detected.len()];
    let mut used_t = vec![false; truth.len()];
    let mut counts = MatchCounts::default();
    for (_, i, j) in pairs {
        if !used_d[i] && !used_t[j] {
            used_d[i] = true;
            used_t[j] = true;
            counts.true_positives += 1;
        }
    }
    counts.false_positives = detected
        .iter()
        .zip(&used_d)
        .filter(|(d, used)| !**used && region.is_none_or(|r| r.contains(**d)))
        .count();
    counts.false_negatives = used_t.iter().filter(|u| !**u).count();
    counts
}

/// The leg centres of a detection.
pub fn leg_positions(detection: &Detection) -> Vec<Point2<Laser>> {
    detection.legs.iter().map(|l| l.centre_in_laser).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_one_to_one_within_the_radius() {
        let p = |x: f64, y: f64| Point2::<Laser>::new(x, y);
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
        let all = match_detections(&det, &truth, 0.15, None);
        assert_eq!(all.false_positives, 3);
        assert_eq!(MatchCounts::default().precision(), 1.0);
    }
}
