//! Training of the leg classifier (design 4.6): discrete AdaBoost over small decision
//! trees ([`train_adaboost`]), its training data, its cross-validation, and the measure
//! of both detectors, on scans already in memory (reading them is the caller's I/O).
//! The model and its inference are [`crate::classifier`].
//!
//! AdaBoost (Freund and Schapire 1997) grows, round after round, the tree that best
//! separates the weighted training samples, gives it the weight
//! `alpha_t = 1/2 ln((1 - eps_t) / eps_t)` from its weighted error `eps_t`, and
//! re-weights the samples `w_i <- w_i exp(-alpha_t y_i h_t(x_i))`, normalised, so that
//! the next tree attends to the samples the ensemble gets wrong. Trees are grown
//! greedily on the weighted Gini impurity `sum_side (w_side - (w_pos^2 + w_neg^2) /
//! w_side)`; a leaf votes for its heavier class. Training draws nothing at random; ties
//! go to the lowest feature index and the lowest threshold, so the same samples give
//! the same model.
//!
//! The data are leg_tracker's (Leigh et al., ICRA 2015): scans with the labelled
//! centres of leg clusters, and scans of a room without people where every cluster is
//! a non-leg. The split is fixed by issue 3 and never mixed:
//!
//! - training: the labelled legs of [`TRAIN_POSITIVE_BAGS`] and every candidate of the
//!   [`TRAIN_NEGATIVE_TOPICS`] of [`NEGATIVE_BAG`] but the robot's own body
//!   ([`drop_robot_body`]);
//! - test: [`TEST_POSITIVE_BAGS`] and the [`TEST_NEGATIVE_TOPICS`] of [`NEGATIVE_BAG`],
//!   used for the reported precision and recall only, never for training or tuning.
//!
//! How the labels were made (leg_tracker's `extract_positive_training_clusters.cpp`
//! and its launch file for these bags): every scan was clustered (Euclidean, 0.13 m,
//! at least 3 returns) and *every* cluster whose centroid lay within a bearing window
//! ([`LabelledRegion::of_bag`]) and 5 m was written as a leg, with the cluster's
//! centroid as its position; scans with no such cluster were dropped. People walked
//! there alone, so the labels are the leg clusters (a leg, or two legs seen as one)
//! and nothing else lies in that region. Outside it, a labelled scan is unlabelled.
//!
//! Every choice made on the training split ([`cross_validate`]) is made on held-out
//! folds of the training split only.

use tether_core::{Laser, LaserScan, Point2};

use crate::augment::{backdrop_view, coarser_view, nearer_view};
use crate::classifier::{LegClassifier, Provenance};
use crate::detector::{Detection, LegDetector, learned_centre};
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

/// The command that makes the committed model for coarse scans, from the checkout's
/// root.
pub const DEFAULT_COARSE_TRAIN_COMMAND: &str = "tether train-legs --coarse --data ../shared/data/laser/leg_tracker --out crates/tether-laser/models/legs_coarse.json";

/// Largest distance from a labelled leg centre to the centroid of a candidate cluster
/// for that candidate to be a training positive, m. The labels are the centroids of
/// the labeller's own clusters, which the default clustering reproduces (to float
/// rounding); 0.1 m, half the closest spacing of two legs, also accepts a cluster cut
/// slightly differently but never one that merged two legs.
pub const TRAIN_MATCH_RADIUS_M: f64 = 0.1;

/// Largest distance from a detection to a labelled leg centre for the detection to
/// count as finding that leg, m (issue 3).
pub const EVAL_MATCH_RADIUS_M: f64 = 0.15;

/// Where the labeller labelled every cluster of a scan: centroids with a bearing in
/// `(min_bearing_rad, max_bearing_rad)` and a range below `max_range_m` (open bounds,
/// as leg_tracker's test `angle > min_angle and angle < max_angle and dist < max_dist`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelledRegion {
    /// Smallest bearing of a labelled cluster, rad (exclusive).
    pub min_bearing_rad: f64,
    /// Largest bearing of a labelled cluster, rad (exclusive).
    pub max_bearing_rad: f64,
    /// Largest range of a labelled cluster, m (exclusive).
    pub max_range_m: f64,
}

impl LabelledRegion {
    /// The region of leg_tracker's bags 1, 2, 3, 6 and 7: +-15 deg, 5 m.
    pub fn leg_tracker() -> Self {
        LabelledRegion {
            min_bearing_rad: (-15f64).to_radians(),
            max_bearing_rad: 15f64.to_radians(),
            max_range_m: 5.0,
        }
    }

    /// The region of the named bag, from leg_tracker's
    /// `extract_positive_training_clusters_res=0.33.launch`: -15 to +10 deg for
    /// `positive_4`, +-15 deg for the others; 5 m for all.
    pub fn of_bag(name: &str) -> Self {
        let mut region = Self::leg_tracker();
        if name.starts_with("positive_4") {
            region.max_bearing_rad = 10f64.to_radians();
        }
        region
    }

    /// A region that holds nothing: on a scan labelled this way no detection counts as
    /// false (the labeller's window is not known there).
    pub const NONE: LabelledRegion = LabelledRegion {
        min_bearing_rad: 0.0,
        max_bearing_rad: 0.0,
        max_range_m: 0.0,
    };

    /// Whether a point lies inside.
    pub fn contains(&self, p: Point2<Laser>) -> bool {
        let bearing = p.bearing_rad();
        self.min_bearing_rad < bearing
            && bearing < self.max_bearing_rad
            && p.range_m() < self.max_range_m
    }
}

/// One scan's leg candidates as the classifier sees them, with what is known of them.
#[derive(Debug, Clone, Default)]
pub struct ScanSample {
    /// Features of each candidate.
    pub features: Vec<FeatureVector>,
    /// Where the learned detector puts each candidate's leg ([`learned_centre`]).
    pub centres: Vec<Point2<Laser>>,
    /// Centroid of each candidate's returns.
    pub centroids: Vec<Point2<Laser>>,
    /// Whether each candidate is a labelled leg (always false on scans without people).
    pub positive: Vec<bool>,
    /// The labelled legs of the scan (none on scans without people).
    pub labels: Vec<Point2<Laser>>,
    /// Where the scan is labelled: `None` for a scan without people, where every
    /// cluster is a non-leg.
    pub region: Option<LabelledRegion>,
    /// Labelled legs that no candidate matched.
    pub unmatched_labels: usize,
    /// A view from nearer ([`nearer_view`]), or a view of one: trained on, but never
    /// judged in cross-validation. Only its moved legs are labelled and no window says
    /// where its other clusters are known not to be legs, so it could add found legs
    /// and missed ones but never a false detection, and would pull the decision margin
    /// toward accepting more than the recordings bear.
    pub view_from_nearer: bool,
}

impl ScanSample {
    /// A labelled scan: the candidate with the nearest centroid within
    /// [`TRAIN_MATCH_RADIUS_M`] of each label (each candidate at most once) is
    /// positive; the other candidates are unlabelled and never trained on.
    pub fn labelled(
        detector: &mut LegDetector,
        scan: &LaserScan,
        legs_in_laser: &[Point2<Laser>],
        region: LabelledRegion,
    ) -> Self {
        let mut out = Self::candidates(detector, scan);
        for &label in legs_in_laser {
            let nearest = out
                .centroids
                .iter()
                .enumerate()
                .filter(|(k, _)| !out.positive[*k])
                .map(|(k, c)| (k, c.distance_m(label)))
                .filter(|&(_, d)| d <= TRAIN_MATCH_RADIUS_M)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match nearest {
                Some((k, _)) => out.positive[k] = true,
                None => out.unmatched_labels += 1,
            }
        }
        out.labels = legs_in_laser.to_vec();
        out.region = Some(region);
        out
    }

    /// Keeps only the labels some candidate matched (for a synthesised view, where a
    /// hidden label is no labelled leg the detector missed).
    pub fn drop_unmatched_labels(&mut self) {
        let matched: Vec<Point2<Laser>> = self
            .labels
            .iter()
            .copied()
            .filter(|l| {
                self.centroids
                    .iter()
                    .zip(&self.positive)
                    .any(|(c, &p)| p && c.distance_m(*l) <= TRAIN_MATCH_RADIUS_M)
            })
            .collect();
        self.labels = matched;
        self.unmatched_labels = 0;
    }

    /// A scan without people: every candidate is a negative.
    pub fn without_people(detector: &mut LegDetector, scan: &LaserScan) -> Self {
        Self::candidates(detector, scan)
    }

    fn candidates(detector: &mut LegDetector, scan: &LaserScan) -> Self {
        let candidates = detector.candidates(scan);
        let config = *detector.config();
        let mut out = ScanSample::default();
        for c in candidates {
            out.centres
                .push(learned_centre(c.centroid_in_laser, c.features[5], &config).0);
            out.centroids.push(c.centroid_in_laser);
            out.features.push(c.features);
            out.positive.push(false);
        }
        out
    }

    /// Whether the scan has people (labels).
    pub fn is_labelled(&self) -> bool {
        self.region.is_some()
    }

    /// Counts the candidates whose `margins` reach `decision_margin` as detections,
    /// against the labels, as [`evaluate`] counts a detector's legs.
    pub fn count(&self, margins: &[f64], decision_margin: f64) -> MatchCounts {
        if self.view_from_nearer {
            return MatchCounts::default();
        }
        let mut centres = Vec::new();
        let mut centroids = Vec::new();
        for (k, &m) in margins.iter().enumerate() {
            if m >= decision_margin {
                centres.push(self.centres[k]);
                centroids.push(self.centroids[k]);
            }
        }
        count_detections(&centres, &centroids, &self.labels, self.region.as_ref())
    }
}

/// Feature vectors with labels.
#[derive(Debug, Clone, Default)]
pub struct TrainingSet {
    /// Features.
    pub samples: Vec<FeatureVector>,
    /// Whether each sample is a leg.
    pub labels: Vec<bool>,
    /// Labelled legs that no candidate matched.
    pub unmatched_labels: usize,
}

impl TrainingSet {
    /// The positives of labelled scans and every candidate of scans without people.
    pub fn from_scans<'a>(scans: impl IntoIterator<Item = &'a ScanSample>) -> Self {
        let mut set = TrainingSet::default();
        for s in scans {
            set.unmatched_labels += s.unmatched_labels;
            for (f, &positive) in s.features.iter().zip(&s.positive) {
                if positive || !s.is_labelled() {
                    set.samples.push(*f);
                    set.labels.push(positive);
                }
            }
        }
        set
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
    AdaBoostConfig {
        views: TrainingViews::FINE,
        ..AdaBoostConfig::default()
    }
}

/// The decision margins [`cross_validate`] tries: -0.300 to 0.300 in steps of 0.0025
/// (the margins of a few hundred boosted trees crowd near 0).
pub fn margin_grid() -> Vec<f64> {
    (-120..=120).map(|k| f64::from(k) / 400.0).collect()
}

/// The training split cut into folds for cross-validation: fold `k` holds the `k`-th
/// positive bag and the `k`-th of as many blocks of consecutive scans of each negative
/// topic. Held-out legs are then of a recording (a person, a place) the model never
/// saw, as the test bags are, and held-out furniture was seen by no scan of the same
/// moments.
pub fn training_folds(
    positive_bags: Vec<Vec<ScanSample>>,
    negative_topics: Vec<Vec<ScanSample>>,
) -> Vec<Vec<ScanSample>> {
    let k = positive_bags.len();
    let mut folds: Vec<Vec<ScanSample>> = positive_bags;
    for topic in negative_topics {
        let n = topic.len();
        for (i, scan) in topic.into_iter().enumerate() {
            folds[(i * k / n.max(1)).min(k - 1)].push(scan);
        }
    }
    folds
}

/// A scan with its labelled legs.
pub type LabelledScan = (LaserScan, Vec<Point2<Laser>>);

/// [`training_folds`] of scans in memory: `positive_bags` are (bag name, labelled
/// scans) in [`TRAIN_POSITIVE_BAGS`] order, each scan with its labelled legs (regions
/// by [`LabelledRegion::of_bag`]); `negative_topics` the scans of each topic of
/// [`TRAIN_NEGATIVE_TOPICS`]. `detector` gives the candidates (its classifier, if any,
/// is not used).
///
/// With `views.nearer > 0`, each scan is also shown that many times from nearer
/// ([`crate::augment::nearer_view`]), in the fold of its recording: a labelled scan
/// toward one of its legs (in turn), a scan without people toward one of its candidates.
/// In a view, a label the view hides (behind something, out of the field of view, or
/// now part of a larger cluster) is dropped, and no detection on a labelled view
/// counts as false ([`LabelledRegion::NONE`]): its labeller's window moved with it.
/// With `views.coarser > 0`, each scan and each nearer view is also shown that many
/// times as a coarser, noisier scanner would see it ([`crate::augment::coarser_view`]);
/// labels stay, and a labelled scan keeps its labeller's window.
pub fn folds_from_scans(
    detector: &mut LegDetector,
    positive_bags: &[(&str, &[LabelledScan])],
    negative_topics: &[&[LaserScan]],
    views: TrainingViews,
) -> Vec<Vec<ScanSample>> {
    let mut coarse_k = 0usize;
    let mut coarser = |scan: &LaserScan| -> Vec<LaserScan> {
        (0..views.coarser)
            .filter_map(|_| {
                coarse_k += 1;
                coarser_view(scan, coarse_k)
            })
            .collect()
    };
    let bags = positive_bags
        .iter()
        .map(|(name, scans)| {
            let region = LabelledRegion::of_bag(name);
            let mut bases: Vec<(LaserScan, Vec<Point2<Laser>>, LabelledRegion)> = Vec::new();
            let mut samples: Vec<ScanSample> = Vec::new();
            for (scan, legs) in scans.iter() {
                if !views.coarse_only {
                    samples.push(ScanSample::labelled(detector, scan, legs, region));
                }
                bases.push((scan.clone(), legs.clone(), region));
            }
            for v in 0..views.nearer {
                for (k, (scan, legs)) in scans.iter().enumerate() {
                    let j = k + v * scans.len();
                    let Some(&toward) = legs.get(j % legs.len().max(1)) else {
                        continue;
                    };
                    if let Some((view, moved)) = nearer_view(scan, toward, legs, j) {
                        if !views.coarse_only {
                            let mut sample =
                                ScanSample::labelled(detector, &view, &moved, LabelledRegion::NONE);
                            sample.drop_unmatched_labels();
                            sample.view_from_nearer = true;
                            samples.push(sample);
                        }
                        bases.push((view, moved, LabelledRegion::NONE));
                    }
                }
            }
            let mut backdrops = Vec::new();
            for v in 0..views.backdrop {
                for (k, (scan, legs, _)) in bases.iter().enumerate() {
                    let Some(view) = backdrop_view(scan, legs, k + v * bases.len()) else {
                        continue;
                    };
                    if !views.coarse_only {
                        let mut sample =
                            ScanSample::labelled(detector, &view, legs, LabelledRegion::NONE);
                        sample.drop_unmatched_labels();
                        sample.view_from_nearer = true;
                        samples.push(sample);
                    }
                    backdrops.push((view, legs.clone(), LabelledRegion::NONE));
                }
            }
            bases.extend(backdrops);
            for (scan, legs, region) in &bases {
                for view in coarser(scan) {
                    let mut sample = ScanSample::labelled(detector, &view, legs, *region);
                    sample.drop_unmatched_labels();
                    sample.view_from_nearer = *region == LabelledRegion::NONE;
                    samples.push(sample);
                }
            }
            samples
        })
        .collect();
    let topics = negative_topics
        .iter()
        .map(|scans| {
            let mut samples: Vec<ScanSample> = scans
                .iter()
                .map(|scan| ScanSample::without_people(detector, scan))
                .collect();
            drop_robot_body(&mut samples);
            // Coarser views of the robot's scans show its body at the same place too.
            let mut coarse: Vec<Vec<ScanSample>> = scans
                .iter()
                .map(|scan| {
                    coarser(scan)
                        .iter()
                        .map(|view| ScanSample::without_people(detector, view))
                        .collect()
                })
                .collect();
            for v in 0..views.coarser {
                let mut group: Vec<ScanSample> = coarse
                    .iter_mut()
                    .filter_map(|c| (v < c.len()).then(|| std::mem::take(&mut c[v])))
                    .collect();
                drop_robot_body(&mut group);
                let mut it = group.into_iter();
                for c in coarse.iter_mut().filter(|c| v < c.len()) {
                    if let Some(s) = it.next() {
                        c[v] = s;
                    }
                }
            }
            // Each scan's views right after it, so that the blocks of consecutive scans
            // that `training_folds` cuts keep a scan and its views in one fold.
            let per_scan = (1 + views.nearer) * (1 + views.coarser);
            let mut with_views = Vec::with_capacity(samples.len() * per_scan);
            for (k, ((sample, scan), coarse)) in samples
                .into_iter()
                .zip(scans.iter())
                .zip(coarse)
                .enumerate()
            {
                let centroids = sample.centroids.clone();
                if !views.coarse_only {
                    with_views.push(sample);
                }
                with_views.extend(coarse);
                for v in 0..views.nearer {
                    let j = k + v * scans.len();
                    let Some(&toward) = centroids.get(j % centroids.len().max(1)) else {
                        continue;
                    };
                    if let Some((view, _)) = nearer_view(scan, toward, &[], j) {
                        if !views.coarse_only {
                            with_views.push(ScanSample::without_people(detector, &view));
                        }
                        for c in coarser(&view) {
                            with_views.push(ScanSample::without_people(detector, &c));
                        }
                    }
                }
            }
            with_views
        })
        .collect();
    training_folds(bags, topics)
}

/// How many extra views of each training scan [`folds_from_scans`] makes (design 4.6).
/// The default is none; the built-in models are trained with [`TrainingViews::FINE`]
/// and [`TrainingViews::COARSE`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TrainingViews {
    /// Views from nearer ([`crate::augment::nearer_view`]).
    pub nearer: usize,
    /// Views by a coarser, noisier scanner ([`crate::augment::coarser_view`]), of the
    /// scan and of each view from nearer.
    pub coarser: usize,
    /// Views with a backdrop behind the people ([`crate::augment::backdrop_view`]), of
    /// each labelled scan and each view from nearer (scans without people keep the
    /// room they were recorded in).
    pub backdrop: usize,
    /// Train on the coarser views only (a model for coarse scanners), not on the
    /// recorded scans and the views from nearer themselves.
    pub coarse_only: bool,
}

impl TrainingViews {
    /// The built-in model for fine scans ([`crate::classifier::DEFAULT_MODEL_JSON`]): the
    /// recorded scans and one view from nearer of each.
    pub const FINE: TrainingViews = TrainingViews {
        nearer: 1,
        coarser: 0,
        backdrop: 0,
        coarse_only: false,
    };

    /// The built-in model for coarse scans ([`crate::classifier::DEFAULT_COARSE_MODEL_JSON`]): two
    /// views from nearer, one coarser view of the scan and of each of those, trained
    /// on the coarser views only.
    pub const COARSE: TrainingViews = TrainingViews {
        nearer: 2,
        coarser: 1,
        backdrop: 0,
        coarse_only: true,
    };
}

/// Two candidates of different scans of one sensor whose centroids lie within this
/// distance stand at the same place in the sensor's frame, m.
pub const ROBOT_BODY_RADIUS_M: f64 = 0.1;

/// Share of a recording's scans in which a place of the sensor's frame must hold a
/// candidate for that place to be the robot's own body.
pub const ROBOT_BODY_MIN_SHARE: f64 = 0.5;

/// Removes the robot's own body from the candidates of the scans of one sensor
/// (`samples`, one recording of a moving robot without people) and returns how many it
/// removed. A candidate is the robot's body when, in at least [`ROBOT_BODY_MIN_SHARE`]
/// of the scans, a candidate lies within [`ROBOT_BODY_RADIUS_M`] of its centroid: the
/// room moves through the sensor's frame as the robot drives, the robot's own body
/// does not.
///
/// Why: in `negative_2.bag` the side lasers see parts of their robot at the edges of
/// their field of view (0.1-0.7 m, about 130 deg to either side) in every scan, about
/// 2,300 of the 20,356 training negatives and most of the isolated ones closer than
/// 1.3 m. Trained on them, the classifier learns that a leg-sized cluster near the
/// sensor with open space around it is not a leg, which is what a person followed
/// in the open looks like (and the simulated robot, like tether's own mount, sees no
/// part of itself). A robot's own body is the job of a footprint filter, not of the
/// leg classifier, so it is neither a leg nor a non-leg to learn from. The test split
/// is measured as issue 3 defines it, robot body included.
pub fn drop_robot_body(samples: &mut [ScanSample]) -> usize {
    use std::collections::HashMap;
    let cell = |p: Point2<Laser>| {
        (
            (p.x / ROBOT_BODY_RADIUS_M).floor() as i64,
            (p.y / ROBOT_BODY_RADIUS_M).floor() as i64,
        )
    };
    /// The centroids in each cell, with the index of their scan.
    type Grid = HashMap<(i64, i64), Vec<(usize, Point2<Laser>)>>;
    let mut grid = Grid::new();
    for (k, s) in samples.iter().enumerate() {
        for &c in &s.centroids {
            if c.x.is_finite() && c.y.is_finite() {
                grid.entry(cell(c)).or_default().push((k, c));
            }
        }
    }
    let min_scans = (ROBOT_BODY_MIN_SHARE * samples.len() as f64)
        .ceil()
        .max(2.0) as usize;
    let mut seen: Vec<usize> = Vec::new();
    let mut removed = 0;
    let mut keep: Vec<bool> = Vec::new();
    // Decide for every scan before changing any, so that the counts see every scan.
    let mut decisions: Vec<Vec<bool>> = Vec::with_capacity(samples.len());
    for s in samples.iter() {
        keep.clear();
        for &c in &s.centroids {
            let (cx, cy) = cell(c);
            seen.clear();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    if let Some(v) = grid.get(&(cx + dx, cy + dy)) {
                        seen.extend(
                            v.iter()
                                .filter(|(_, p)| p.distance_m(c) <= ROBOT_BODY_RADIUS_M)
                                .map(|(k, _)| *k),
                        );
                    }
                }
            }
            seen.sort_unstable();
            seen.dedup();
            keep.push(seen.len() < min_scans);
        }
        decisions.push(keep.clone());
    }
    for (s, keep) in samples.iter_mut().zip(decisions) {
        let before = s.features.len();
        let mut k = keep.iter();
        s.features.retain(|_| *k.next().unwrap_or(&true));
        let mut k = keep.iter();
        s.centres.retain(|_| *k.next().unwrap_or(&true));
        let mut k = keep.iter();
        s.centroids.retain(|_| *k.next().unwrap_or(&true));
        let mut k = keep.iter();
        s.positive.retain(|_| *k.next().unwrap_or(&true));
        removed += before - s.features.len();
    }
    removed
}

/// What cross-validation found.
#[derive(Debug, Clone, PartialEq)]
pub struct CrossValidation {
    /// The decision margins tried ([`margin_grid`]).
    pub margins: Vec<f64>,
    /// Detection counts over all held-out folds together, one per margin.
    pub counts: Vec<MatchCounts>,
    /// Counts of each held-out fold at the chosen margin.
    pub fold_counts: Vec<MatchCounts>,
    /// Index of the chosen margin: the highest F1, the first of equals.
    pub best: usize,
}

impl CrossValidation {
    /// The cross-validation whose decision margin is the one of `margins` with the
    /// highest F1 of the held-out counts (`counts[i]` summed over the folds,
    /// `per_fold[f][i]` per fold; the lowest margin on a tie).
    pub fn best_f1(
        margins: Vec<f64>,
        counts: Vec<MatchCounts>,
        per_fold: &[Vec<MatchCounts>],
    ) -> Self {
        let mut best = 0;
        for (i, c) in counts.iter().enumerate() {
            if c.f1() > counts[best].f1() {
                best = i;
            }
        }
        CrossValidation {
            fold_counts: per_fold.iter().map(|f| f[best]).collect(),
            margins,
            counts,
            best,
        }
    }

    /// The chosen decision margin.
    pub fn margin(&self) -> f64 {
        self.margins[self.best]
    }

    /// The pooled counts at the chosen margin.
    pub fn best_counts(&self) -> MatchCounts {
        self.counts[self.best]
    }
}

/// K-fold cross-validation on the training split: for each fold, trains on the others
/// with `config` and counts detections on the held-out scans ([`ScanSample::count`])
/// at every margin of [`margin_grid`]; then picks the margin with the highest F1 of the
/// counts of all folds together.
pub fn cross_validate(
    folds: &[Vec<ScanSample>],
    config: &AdaBoostConfig,
) -> Result<CrossValidation, TrainError> {
    cross_validate_with(
        folds,
        config,
        |scans| TrainingSet::from_scans(scans.iter().copied()),
        |scan| &scan.features,
        ScanSample::count,
    )
}

/// K-fold cross-validation of scans of any labelling `T`: for each fold, trains on the
/// others' `training_set` with `config`, then counts each held-out scan (`count`, given
/// the margins of its candidates' `features` and a decision margin) at every margin of
/// [`margin_grid`]; picks the margin with the highest F1 of all folds' counts together
/// ([`CrossValidation::best_f1`]).
pub fn cross_validate_with<T>(
    folds: &[Vec<T>],
    config: &AdaBoostConfig,
    training_set: impl Fn(&[&T]) -> TrainingSet,
    features: impl Fn(&T) -> &[FeatureVector],
    count: impl Fn(&T, &[f64], f64) -> MatchCounts,
) -> Result<CrossValidation, TrainError> {
    let margins = margin_grid();
    let mut counts = vec![MatchCounts::default(); margins.len()];
    let mut per_fold = Vec::with_capacity(folds.len());
    for (k, held_out) in folds.iter().enumerate() {
        let others: Vec<&T> = folds
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .flat_map(|(_, f)| f.iter())
            .collect();
        let set = training_set(&others);
        let model = train_adaboost(&set.samples, &set.labels, config, Provenance::default())?;
        let mut fold = vec![MatchCounts::default(); margins.len()];
        for scan in held_out {
            let m: Vec<f64> = features(scan).iter().map(|f| model.margin(f)).collect();
            for (c, &margin) in fold.iter_mut().zip(&margins) {
                c.add(count(scan, &m, margin));
            }
        }
        for (c, f) in counts.iter_mut().zip(&fold) {
            c.add(*f);
        }
        per_fold.push(fold);
    }
    Ok(CrossValidation::best_f1(margins, counts, &per_fold))
}

/// What a model records about its making: the training options that differ from the
/// defaults (none for the default model, whose command is [`DEFAULT_TRAIN_COMMAND`]),
/// the training split and how the margin was chosen. Paths are left out, so that the
/// same data give the same file wherever they lie.
pub fn provenance(config: &AdaBoostConfig, cv: Option<&CrossValidation>) -> Provenance {
    let defaults = default_adaboost_config();
    let mut command = String::from("tether train-legs");
    if config.rounds != defaults.rounds {
        command.push_str(&format!(" --rounds {}", config.rounds));
    }
    if config.max_depth != defaults.max_depth {
        command.push_str(&format!(" --depth {}", config.max_depth));
    }
    let views = if config.views.coarse_only {
        command.push_str(" --coarse");
        TrainingViews::COARSE
    } else {
        defaults.views
    };
    if config.views.nearer != views.nearer {
        command.push_str(&format!(" --nearer-views {}", config.views.nearer));
    }
    if config.views.coarser != views.coarser {
        command.push_str(&format!(" --coarser-views {}", config.views.coarser));
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
    let margin_choice = match cv {
        None => format!("fixed at {}", config.decision_margin),
        Some(cv) => {
            let c = cv.best_counts();
            format!(
                "{}-fold cross-validation on the training split (a positive bag and a block of \
                 negative scans per fold): F(x) >= {} gives the highest F1 of the held-out \
                 detections, precision {:.3}, recall {:.3}",
                cv.fold_counts.len(),
                cv.margin(),
                c.precision(),
                c.recall()
            )
        }
    };
    Provenance {
        command,
        sources,
        margin_choice,
        ..Provenance::default()
    }
}

/// Trains the classifier on the scans of `folds` (all of them), with the decision
/// margin that cross-validation over the same folds chooses. Returns the model, the
/// training set and the cross-validation.
pub fn train_with_cross_validation(
    folds: &[Vec<ScanSample>],
    config: &AdaBoostConfig,
) -> Result<(LegClassifier, TrainingSet, CrossValidation), TrainError> {
    let cv = cross_validate(folds, config)?;
    let config = AdaBoostConfig {
        decision_margin: cv.margin(),
        ..*config
    };
    let set = TrainingSet::from_scans(folds.iter().flatten());
    let model = train_adaboost(
        &set.samples,
        &set.labels,
        &config,
        provenance(&config, Some(&cv)),
    )?;
    Ok((model, set, cv))
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
/// against the labels within [`EVAL_MATCH_RADIUS_M`], one to one
/// ([`count_detections`]). On labelled scans, a leg that finds no label counts as
/// false only if the centroid of its returns lies in `region` (the labeller labelled
/// every cluster there, and nothing outside it); on scans without people every leg
/// is false.
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
        let centroids: Vec<Point2<Laser>> =
            detection.legs.iter().map(|l| l.centroid_in_laser).collect();
        out.labelled.add(count_detections(
            &leg_positions(&detection),
            &centroids,
            legs,
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

    /// `2 tp / (2 tp + fp + fn)`, the harmonic mean of precision and recall; 0 when
    /// nothing was found.
    pub fn f1(&self) -> f64 {
        let d = 2 * self.true_positives + self.false_positives + self.false_negatives;
        if self.true_positives == 0 {
            0.0
        } else {
            2.0 * self.true_positives as f64 / d as f64
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
/// [`EVAL_MATCH_RADIUS_M`]. `centres[i]` is where detection `i` puts its leg and
/// `centroids[i]` the centroid of its returns. A detection that matches nothing is
/// false if `region` is `None` (a scan without people) or contains its centroid (the
/// labeller labelled every cluster there); otherwise it lies where nothing is labelled
/// and is not counted.
pub fn count_detections(
    centres: &[Point2<Laser>],
    centroids: &[Point2<Laser>],
    truth: &[Point2<Laser>],
    region: Option<&LabelledRegion>,
) -> MatchCounts {
    let (mut counts, used) = match_one_to_one(centres, truth, EVAL_MATCH_RADIUS_M);
    counts.false_positives = used
        .iter()
        .zip(centroids)
        .filter(|(used, c)| !**used && region.is_none_or(|r| r.contains(**c)))
        .count();
    counts
}

/// Matches detections to labelled legs one to one, closest pairs first, within
/// `radius_m`. Detections outside `region` that match nothing are not counted; pass
/// `None` to count every detection. (The region test is on the detection's position;
/// [`count_detections`] tests its returns' centroid, as the labeller did.)
pub fn match_detections(
    detected: &[Point2<Laser>],
    truth: &[Point2<Laser>],
    radius_m: f64,
    region: Option<&LabelledRegion>,
) -> MatchCounts {
    let (mut counts, used) = match_one_to_one(detected, truth, radius_m);
    counts.false_positives = detected
        .iter()
        .zip(&used)
        .filter(|(d, used)| !**used && region.is_none_or(|r| r.contains(**d)))
        .count();
    counts
}

/// True positives and false negatives of the greedy one-to-one matching (closest
/// pairs first, ties by index), and which detections matched.
fn match_one_to_one(
    detected: &[Point2<Laser>],
    truth: &[Point2<Laser>],
    radius_m: f64,
) -> (MatchCounts, Vec<bool>) {
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
    counts.false_negatives = used_t.iter().filter(|u| !**u).count();
    (counts, used_d)
}

/// The leg centres of a detection.
pub fn leg_positions(detection: &Detection) -> Vec<Point2<Laser>> {
    detection.legs.iter().map(|l| l.centre_in_laser).collect()
}

mod adaboost;
#[cfg(test)]
mod tests;

pub use adaboost::{AdaBoostConfig, TrainError, train_adaboost};
