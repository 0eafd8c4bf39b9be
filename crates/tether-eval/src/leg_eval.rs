//! Leg and person detection measured against labels, by range from the scanner
//! (`tether eval-legs`, issues 3 and 30).
//!
//! **Matching.** Detections and labels of one scan are matched one to one, closest
//! pairs first (ties by index), a pair only within the match radius (0.15 m for legs,
//! [`EVAL_MATCH_RADIUS_M`]): the rule of [`tether_laser::training::count_detections`],
//! whose totals these counts equal (checked by a property test below).
//!
//! **Range bins** ([`RANGE_BIN_UPPER_M`]: 0-0.5, 0.5-1.0, 1.0-1.5, 1.5-2, 2-3, 3+ m):
//! a label goes to the bin of its own range from the scanner, found or not, so the
//! recall of a bin is `found / labels` of the labels at that range. A detection that
//! matches nothing goes to the bin of its own range (there is no label to take one
//! from). A bin's precision is `found / (found + false)` with both counted in that bin.
//!
//! **Where detections count as false.** On a labelled scan, a detection that finds no
//! label is false if no region is given, or if its test point lies inside the region
//! where the labeller labelled everything ([`LabelledRegion`]; the test point is the
//! centroid of a leg's returns, as leg_tracker's labeller tested its clusters, or a
//! person's position); on a scan known to hold no people (leg_tracker's `negative_2`)
//! every detection is false.
//!
//! **Pairing** labels with scans ([`pair_labels`]): the rules of `tether eval-track`
//! ([`Pairing`]); header-less `leg_tracker/Person` messages go to the scan before them
//! ([`LabelSource::Person`]).

use serde::Serialize;
use tether_core::{Laser, Point2, Stamp};
use tether_laser::training::{LabelledRegion, MatchCounts};
use tether_laser::{Detection, LegDetector};

use crate::track_eval::Pairing;
use std::path::Path;

use tether_recording::samples::{self, LabelMessage, LabelSource, Sample, Topics};

pub use tether_laser::training::EVAL_MATCH_RADIUS_M;

/// Upper edges of the range bins, m (the last bin is open: 3 m and beyond). A label at
/// exactly an edge goes to the bin above it.
pub const RANGE_BIN_UPPER_M: [f64; 6] = [0.5, 1.0, 1.5, 2.0, 3.0, f64::INFINITY];

/// Number of range bins.
pub const BINS: usize = RANGE_BIN_UPPER_M.len();

/// The bin of a range, m.
pub fn bin_of(range_m: f64) -> usize {
    RANGE_BIN_UPPER_M
        .iter()
        .position(|&upper| range_m < upper)
        .unwrap_or(BINS - 1)
}

/// Counts by range bin.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RangeCounts {
    /// Labels in each bin (by the label's range).
    pub labels: [usize; BINS],
    /// Labels found in each bin (by the label's range).
    pub found: [usize; BINS],
    /// Detections that found no label and count as false, by the detection's range.
    pub false_positives: [usize; BINS],
}

/// One bin of a [`RangeCounts`], as reported.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BinReport {
    /// Lower edge, m (inclusive).
    pub from_m: f64,
    /// Upper edge, m (exclusive); `null` for the open last bin.
    pub to_m: Option<f64>,
    /// Labels at this range.
    pub labels: usize,
    /// Of those, labels a detection found.
    pub found: usize,
    /// Detections at this range that found no label and count as false.
    pub false_positives: usize,
    /// `found / labels`; `null` without labels.
    pub recall: Option<f64>,
    /// `found / (found + false_positives)`; `null` when both are zero.
    pub precision: Option<f64>,
}

impl RangeCounts {
    /// Scores one labelled scan: `detected[i]` is where detection `i` puts the leg or
    /// person, `test_points[i]` the point tested against `region` when it matches
    /// nothing (see the module's doc), `labels` the labelled positions.
    pub fn score_scan(
        &mut self,
        detected: &[Point2<Laser>],
        test_points: &[Point2<Laser>],
        labels: &[Point2<Laser>],
        radius_m: f64,
        region: Option<&LabelledRegion>,
    ) {
        let (found_label, used_detection) = match_one_to_one(detected, labels, radius_m);
        for (label, found) in labels.iter().zip(&found_label) {
            let b = bin_of(label.range_m());
            self.labels[b] += 1;
            self.found[b] += usize::from(*found);
        }
        for ((d, used), test) in detected.iter().zip(&used_detection).zip(test_points) {
            if !used && region.is_none_or(|r| r.contains(*test)) {
                self.false_positives[bin_of(d.range_m())] += 1;
            }
        }
    }

    /// Counts every detection of a scan without people as false.
    pub fn score_empty_scan(&mut self, detected: &[Point2<Laser>]) {
        for d in detected {
            self.false_positives[bin_of(d.range_m())] += 1;
        }
    }

    /// Adds other counts.
    pub fn add(&mut self, other: &RangeCounts) {
        for b in 0..BINS {
            self.labels[b] += other.labels[b];
            self.found[b] += other.found[b];
            self.false_positives[b] += other.false_positives[b];
        }
    }

    /// All bins together.
    pub fn total(&self) -> MatchCounts {
        let found: usize = self.found.iter().sum();
        let labels: usize = self.labels.iter().sum();
        MatchCounts {
            true_positives: found,
            false_positives: self.false_positives.iter().sum(),
            false_negatives: labels - found,
        }
    }

    /// The bins as reported.
    pub fn bins(&self) -> Vec<BinReport> {
        (0..BINS)
            .map(|b| {
                let upper = RANGE_BIN_UPPER_M[b];
                let (found, labels, fp) = (self.found[b], self.labels[b], self.false_positives[b]);
                BinReport {
                    from_m: if b == 0 {
                        0.0
                    } else {
                        RANGE_BIN_UPPER_M[b - 1]
                    },
                    to_m: upper.is_finite().then_some(upper),
                    labels,
                    found,
                    false_positives: fp,
                    recall: (labels > 0).then(|| found as f64 / labels as f64),
                    precision: (found + fp > 0).then(|| found as f64 / (found + fp) as f64),
                }
            })
            .collect()
    }

    /// The table for a person: one row a bin and the total.
    pub fn table(&self) -> String {
        let ratio = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
        let mut s = String::from("range (m)   labels  found  recall  false  precision\n");
        for b in self.bins() {
            let name = match b.to_m {
                Some(to) => format!("{}-{}", b.from_m, to),
                None => format!("{}+", b.from_m),
            };
            s += &format!(
                "{name:<10} {:>7} {:>6} {:>7} {:>6} {:>10}\n",
                b.labels,
                b.found,
                ratio(b.recall),
                b.false_positives,
                ratio(b.precision)
            );
        }
        let t = self.total();
        s += &format!(
            "{:<10} {:>7} {:>6} {:>7.3} {:>6} {:>10.3}\n",
            "all",
            t.true_positives + t.false_negatives,
            t.true_positives,
            t.recall(),
            t.false_positives,
            t.precision()
        );
        s
    }
}

/// Greedy one-to-one matching, closest pairs first (ties by detection, then label
/// index), pairs within `radius_m` only: which labels were found and which detections
/// found one.
fn match_one_to_one(
    detected: &[Point2<Laser>],
    labels: &[Point2<Laser>],
    radius_m: f64,
) -> (Vec<bool>, Vec<bool>) {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, d) in detected.iter().enumerate() {
        for (j, l) in labels.iter().enumerate() {
            let dist = d.distance_m(*l);
            if dist <= radius_m {
                pairs.push((dist, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
    let mut used = vec![false; detected.len()];
    let mut found = vec![false; labels.len()];
    for (_, i, j) in pairs {
        if !used[i] && !found[j] {
            used[i] = true;
            found[j] = true;
        }
    }
    (found, used)
}

/// Label messages paired with scans by [`pair_labels`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PairedLabels {
    /// For each scan, its labels (`None`: no label message went to it).
    pub per_scan: Vec<Option<Vec<Point2<Laser>>>>,
    /// Label messages with no scan to go to (before the first scan or after the last).
    pub unpaired: usize,
    /// Scans that got more than one stamped label message (the one nearest in stamp
    /// kept, the later on a tie; Person messages add up instead).
    pub doubly_labelled: usize,
}

/// Pairs label messages with scans. `scan_stamps` are the scans in log order;
/// `labels` the label messages, each with the number of scans read before it. The
/// rules are `tether eval-track`'s ([`Pairing`]); header-less Person messages join the
/// scan before them whatever `pairing` says.
pub fn pair_labels(
    scan_stamps: &[Stamp],
    labels: &[(usize, LabelMessage)],
    pairing: Pairing,
) -> PairedLabels {
    let n = scan_stamps.len();
    let mut out = PairedLabels {
        per_scan: vec![None; n],
        ..PairedLabels::default()
    };
    let mut kept_dt_ns: Vec<Option<u64>> = vec![None; n];
    for (before, message) in labels {
        let before = (*before).min(n);
        let previous = before.checked_sub(1);
        let next = (before < n).then_some(before);
        let positions = message.labels.iter().map(|(_, p)| *p);
        if message.source == LabelSource::Person {
            match previous {
                Some(k) => out.per_scan[k]
                    .get_or_insert_with(Vec::new)
                    .extend(positions),
                None => out.unpaired += 1,
            }
            continue;
        }
        let stamp = message.stamp.ns();
        let target = match pairing {
            Pairing::After => previous,
            Pairing::Before => next,
            Pairing::Auto => match (previous, next) {
                (Some(k), _) if scan_stamps[k].ns() == stamp => Some(k),
                (_, next) if stamp == 0 => next,
                (Some(k), Some(m)) => {
                    let d = |i: usize| (scan_stamps[i].ns() - stamp).abs();
                    Some(if d(k) <= d(m) { k } else { m })
                }
                // Stamped otherwise and no scan after it: as eval-track, unpaired.
                (_, next) => next,
            },
        };
        let Some(k) = target else {
            out.unpaired += 1;
            continue;
        };
        let dt_ns = (scan_stamps[k].ns() - stamp).unsigned_abs();
        if let Some(old) = kept_dt_ns[k] {
            out.doubly_labelled += 1;
            if dt_ns > old {
                continue;
            }
        }
        kept_dt_ns[k] = Some(dt_ns);
        out.per_scan[k] = Some(positions.collect());
    }
    out
}

/// One detector's counts on the test split.
pub struct SplitCounts {
    /// Labelled scans, every unmatched detection false (issue 30's measure).
    pub labelled: RangeCounts,
    /// Labelled scans, unmatched detections false only inside the labeller's window
    /// (issue 3's table).
    pub labelled_in_window: RangeCounts,
    /// Scans without people.
    pub negative: RangeCounts,
}

/// Runs one detector over the test split: `positives` the labelled scans (with their
/// legs in the laser frame), `negatives` the scans without people, `region` where the
/// labeller labelled every cluster.
pub fn test_split_counts(
    d: &mut LegDetector,
    positives: &[(tether_core::LaserScan, Vec<Point2<Laser>>)],
    negatives: &[tether_core::LaserScan],
    region: &LabelledRegion,
) -> SplitCounts {
    let mut c = SplitCounts {
        labelled: RangeCounts::default(),
        labelled_in_window: RangeCounts::default(),
        negative: RangeCounts::default(),
    };
    let mut detection = Detection::default();
    for (scan, legs) in positives {
        d.detect_into(scan, &mut detection);
        let centres: Vec<Point2<Laser>> =
            detection.legs.iter().map(|l| l.centre_in_laser).collect();
        let centroids: Vec<Point2<Laser>> =
            detection.legs.iter().map(|l| l.centroid_in_laser).collect();
        c.labelled
            .score_scan(&centres, &centroids, legs, EVAL_MATCH_RADIUS_M, None);
        c.labelled_in_window.score_scan(
            &centres,
            &centroids,
            legs,
            EVAL_MATCH_RADIUS_M,
            Some(region),
        );
    }
    for scan in negatives {
        d.detect_into(scan, &mut detection);
        let centres: Vec<Point2<Laser>> =
            detection.legs.iter().map(|l| l.centre_in_laser).collect();
        c.negative.score_empty_scan(&centres);
    }
    c
}

/// What the labels of a recording stand for and how they are matched
/// ([`score_recording`]).
#[derive(Debug, Clone, Copy)]
pub struct LabelChoice {
    /// `Some(true)`: each label is a person, matched against the detected people;
    /// `Some(false)`: a leg, against the detected legs; `None`: people unless the
    /// labels are a `PoseArray`.
    pub people: Option<bool>,
    /// The match radius, m; `None`: [`EVAL_MATCH_RADIUS_M`] for legs, `people_match_m`
    /// for people.
    pub match_m: Option<f64>,
    /// The default match radius for people, m.
    pub people_match_m: f64,
    /// How label messages are paired with scans.
    pub pairing: Pairing,
    /// Where unmatched detections count as false; `None`: everywhere.
    pub region: Option<LabelledRegion>,
}

/// One detector's counts on a labelled recording, with what was read.
#[derive(Debug, Clone)]
pub struct RecordingScore {
    /// Labels of people (`true`) or legs.
    pub people: bool,
    /// The match radius used, m.
    pub match_m: f64,
    /// The counts by range.
    pub counts: RangeCounts,
    /// Scans read.
    pub scans: usize,
    /// Scans with labels (scored).
    pub labelled_scans: usize,
    /// Scans without a label message (not scored).
    pub unlabelled_scans: usize,
    /// Label messages read.
    pub label_messages: usize,
    /// Label messages with no scan to go to.
    pub unpaired_label_messages: usize,
    /// Scans given more than one stamped label message.
    pub doubly_labelled_scans: usize,
    /// Messages that did not decode and were skipped.
    pub skipped_messages: usize,
    /// Beams that were NaN or negative, read as no return.
    pub malformed_beams: usize,
}

/// What a scan's detection leaves to score, kept until the labels are paired.
struct ScanDetections {
    legs: Vec<Point2<Laser>>,
    leg_centroids: Vec<Point2<Laser>>,
    people: Vec<Point2<Laser>>,
}

/// Runs detector `d` over the scans of `scan_topic` in the recording at `path` and
/// scores its legs (or people) against the labels of `labels_topic`, paired with the
/// scans as `choice` says (`tether eval-legs REC`).
pub fn score_recording(
    path: &Path,
    scan_topic: &str,
    labels_topic: &str,
    d: &mut LegDetector,
    choice: &LabelChoice,
) -> anyhow::Result<RecordingScore> {
    let topics = Topics {
        scan: scan_topic.to_owned(),
        images: Vec::new(),
        odom: None,
    };
    let mut stamps: Vec<Stamp> = Vec::new();
    let mut detections: Vec<ScanDetections> = Vec::new();
    let mut labels: Vec<(usize, LabelMessage)> = Vec::new();
    let mut malformed = 0usize;
    let mut detection = Detection::default();
    // Scans read so far, for the label callback (the scan callback holds `stamps`).
    let scans_read = std::cell::Cell::new(0usize);
    let stats = samples::read_with_labels(
        path,
        &topics,
        labels_topic,
        &mut |sample| {
            if let Sample::Scan(scan) = sample {
                malformed += scan.malformed_beams();
                d.detect_into(&scan, &mut detection);
                stamps.push(scan.stamp);
                scans_read.set(stamps.len());
                detections.push(ScanDetections {
                    legs: detection.legs.iter().map(|l| l.centre_in_laser).collect(),
                    leg_centroids: detection.legs.iter().map(|l| l.centroid_in_laser).collect(),
                    people: detection.people.iter().map(|p| p.estimate.mean).collect(),
                });
            }
            Ok(())
        },
        &mut |message| {
            labels.push((scans_read.get(), message));
            Ok(())
        },
    )?;
    let people = choice.people.unwrap_or_else(|| {
        labels
            .first()
            .is_some_and(|(_, m)| m.source != LabelSource::PoseArray)
    });
    let match_m = choice.match_m.unwrap_or(if people {
        choice.people_match_m
    } else {
        EVAL_MATCH_RADIUS_M
    });
    let paired = pair_labels(&stamps, &labels, choice.pairing);
    let mut score = RecordingScore {
        people,
        match_m,
        counts: RangeCounts::default(),
        scans: stamps.len(),
        labelled_scans: 0,
        unlabelled_scans: 0,
        label_messages: labels.len(),
        unpaired_label_messages: paired.unpaired,
        doubly_labelled_scans: paired.doubly_labelled,
        skipped_messages: stats.bad_messages + stats.unattributed,
        malformed_beams: malformed,
    };
    for (scan, truth) in detections.iter().zip(&paired.per_scan) {
        let Some(truth) = truth else {
            score.unlabelled_scans += 1;
            continue;
        };
        score.labelled_scans += 1;
        let (detected, test) = if people {
            (&scan.people, &scan.people)
        } else {
            (&scan.legs, &scan.leg_centroids)
        };
        score
            .counts
            .score_scan(detected, test, truth, match_m, choice.region.as_ref());
    }
    Ok(score)
}

#[cfg(test)]
mod tests {
    #![allow(
        clippy::unwrap_used,
        reason = "test code: a failed unwrap is a failed test"
    )]

    use super::*;
    use proptest::prelude::*;
    use tether_laser::training::count_detections;

    fn p(x: f64, y: f64) -> Point2<Laser> {
        Point2::new(x, y)
    }

    #[test]
    fn bins_by_range() {
        assert_eq!(bin_of(0.0), 0);
        assert_eq!(bin_of(0.49), 0);
        assert_eq!(bin_of(0.5), 1);
        assert_eq!(bin_of(1.99), 3);
        assert_eq!(bin_of(2.0), 4);
        assert_eq!(bin_of(3.0), 5);
        assert_eq!(bin_of(50.0), 5);
    }

    #[test]
    fn labels_bin_by_their_range_false_ones_by_theirs() {
        let mut c = RangeCounts::default();
        // A label at 0.4 m found by a detection at 0.52 m (0.12 m away): the find is
        // in the label's bin. A label at 2.5 m missed. A detection at 1.2 m false.
        c.score_scan(
            &[p(0.52, 0.0), p(1.2, 0.0)],
            &[p(0.52, 0.0), p(1.2, 0.0)],
            &[p(0.4, 0.0), p(2.5, 0.0)],
            0.15,
            None,
        );
        c.score_empty_scan(&[p(0.0, 3.5)]);
        assert_eq!(c.labels, [1, 0, 0, 0, 1, 0]);
        assert_eq!(c.found, [1, 0, 0, 0, 0, 0]);
        assert_eq!(c.false_positives, [0, 0, 1, 0, 0, 1]);
        let bins = c.bins();
        assert_eq!(bins[0].recall, Some(1.0));
        assert_eq!(bins[1].recall, None);
        assert_eq!(bins[2].precision, Some(0.0));
        assert_eq!(bins[5].to_m, None);
        let t = c.total();
        assert_eq!(
            (t.true_positives, t.false_positives, t.false_negatives),
            (1, 2, 1)
        );
    }

    #[test]
    fn a_false_detection_outside_the_region_is_not_counted() {
        let region = LabelledRegion::leg_tracker();
        let mut c = RangeCounts::default();
        // At 90 degrees: outside the +-15 degree window.
        c.score_scan(&[p(0.0, 1.0)], &[p(0.0, 1.0)], &[], 0.15, Some(&region));
        assert_eq!(c.total().false_positives, 0);
        c.score_scan(&[p(1.0, 0.0)], &[p(1.0, 0.0)], &[], 0.15, Some(&region));
        assert_eq!(c.total().false_positives, 1);
    }

    fn point() -> impl Strategy<Value = Point2<Laser>> {
        // A coarse grid makes ties and near pairs common.
        (-20i32..20, -20i32..20).prop_map(|(x, y)| p(f64::from(x) * 0.05, f64::from(y) * 0.05))
    }

    proptest! {
        /// The totals are those of tether-laser's own counting (issue 3's measure).
        #[test]
        fn totals_equal_count_detections(
            detected in prop::collection::vec(point(), 0..8),
            shift in prop::collection::vec(point(), 0..8),
            labels in prop::collection::vec(point(), 0..8),
            with_region in any::<bool>(),
        ) {
            let centroids: Vec<Point2<Laser>> = detected
                .iter()
                .zip(shift.iter().chain(std::iter::repeat(&p(0.0, 0.0))))
                .map(|(d, s)| p(d.x + s.x * 0.1, d.y + s.y * 0.1))
                .collect();
            let region = LabelledRegion::leg_tracker();
            let region = with_region.then_some(&region);
            let mut c = RangeCounts::default();
            c.score_scan(&detected, &centroids, &labels, EVAL_MATCH_RADIUS_M, region);
            let reference = count_detections(&detected, &centroids, &labels, region);
            prop_assert_eq!(c.total(), reference);
        }
    }

    fn message(stamp_ms: i64, source: LabelSource, xs: &[f64]) -> LabelMessage {
        LabelMessage {
            stamp: Stamp::from_ns(stamp_ms * 1_000_000),
            frame_id: "laser".into(),
            labels: xs.iter().map(|&x| (Some(1), p(x, 0.0))).collect(),
            source,
        }
    }

    fn stamps(ms: &[i64]) -> Vec<Stamp> {
        ms.iter().map(|&t| Stamp::from_ns(t * 1_000_000)).collect()
    }

    #[test]
    fn person_messages_join_the_scan_before_them() {
        // Scans at 100, 200, 300 ms; Person messages: one before any scan (unpaired),
        // two after scan 0, none after scan 1, one after scan 2.
        let s = stamps(&[100, 200, 300]);
        let person = |x| message(0, LabelSource::Person, &[x]);
        let labels = vec![
            (0, person(9.0)),
            (1, person(1.0)),
            (1, person(2.0)),
            (3, person(3.0)),
        ];
        for pairing in [Pairing::Auto, Pairing::Before, Pairing::After] {
            let r = pair_labels(&s, &labels, pairing);
            assert_eq!(r.unpaired, 1);
            assert_eq!(r.doubly_labelled, 0);
            assert_eq!(
                r.per_scan,
                vec![
                    Some(vec![p(1.0, 0.0), p(2.0, 0.0)]),
                    None,
                    Some(vec![p(3.0, 0.0)])
                ]
            );
        }
    }

    #[test]
    fn stamped_messages_follow_eval_tracks_rules() {
        let s = stamps(&[100, 200]);
        let pose = |t, x| message(t, LabelSource::PoseArray, &[x]);
        // Zero stamp before scan 0 (leg_tracker's extracted bags): scan 0.
        let r = pair_labels(&s, &[(0, pose(0, 1.0))], Pairing::Auto);
        assert_eq!(r.per_scan[0], Some(vec![p(1.0, 0.0)]));
        // Stamped like the scan before it: that scan; otherwise the nearer one.
        let r = pair_labels(&s, &[(1, pose(100, 1.0))], Pairing::Auto);
        assert!(r.per_scan[0].is_some() && r.per_scan[1].is_none());
        let r = pair_labels(&s, &[(1, pose(180, 1.0))], Pairing::Auto);
        assert!(r.per_scan[0].is_none() && r.per_scan[1].is_some());
        // before / after.
        let r = pair_labels(&s, &[(1, pose(100, 1.0))], Pairing::Before);
        assert!(r.per_scan[1].is_some());
        let r = pair_labels(&s, &[(2, pose(0, 1.0))], Pairing::After);
        assert!(r.per_scan[1].is_some());
        // Nothing after the last scan with before: unpaired.
        let r = pair_labels(&s, &[(2, pose(0, 1.0))], Pairing::Before);
        assert_eq!(r.unpaired, 1);
        // Two messages for one scan: the nearer in stamp stays, counted.
        let r = pair_labels(
            &s,
            &[(1, pose(100, 1.0)), (1, pose(140, 2.0))],
            Pairing::After,
        );
        assert_eq!(r.doubly_labelled, 1);
        assert_eq!(r.per_scan[0], Some(vec![p(1.0, 0.0)]));
    }
}
