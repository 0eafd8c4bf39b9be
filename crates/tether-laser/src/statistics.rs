//! The statistics of a leg detector that matter for tracking (issue 14, design 11), measured
//! the same way on real recordings and on simulated runs, so that the simulator can be
//! made to fail like the real sensor.
//!
//! - **Per-leg detection probability against range** (bins of [`RANGE_BIN_M`]): a
//!   labelled leg cluster counts as detected when the detector puts a leg within
//!   [`LEG_MATCH_RADIUS_M`] of it.
//! - **Runs of missed scans of the person**: a labelled scan misses the person when
//!   none of its labelled legs is detected. Runs are cut where the stamps jump by more
//!   than [`STRETCH_GAP_S`] (the recordings have gaps; each starts a new stretch). The
//!   persistence of misses is the Markov estimate
//!   `P(miss | miss) = #(miss then miss) / #(miss then any)` over consecutive scans of a
//!   stretch.
//! - **Merged legs**: the share of labelled clusters wider than [`MERGED_WIDTH_M`]: a
//!   leg at the URG-04LX's height gives a 9-16 cm cluster (design 4), two legs seen as one
//!   cluster give a wider one.
//! - **False positives** on scans of people-free scenes (or detections away from every
//!   person in a simulation): leg detections per scan, and how long a false positive
//!   stays in one place: a detection continues the run of the previous scan's detection
//!   nearest to it when that lies within [`PERSIST_RADIUS_M`] (each run continued at
//!   most once, nearest pairs first), in one fixed frame (the scanner's, for a static
//!   scanner).
//!
//! Pure computation on positions already extracted from scans; reading recordings is
//! the caller's I/O.

use std::fmt::Write as _;

use tether_core::{Laser, LaserScan, Point2};

use crate::detector::LegDetector;
use crate::training::LabelledRegion;

/// Width of a range bin, m.
pub const RANGE_BIN_M: f64 = 0.5;
/// Number of range bins (0 to 5 m: the labelled region of leg_tracker's bags).
pub const N_RANGE_BINS: usize = 10;
/// Largest distance from a labelled leg to a detected leg for the leg to count as
/// detected, m (issue 14).
pub const LEG_MATCH_RADIUS_M: f64 = 0.25;
/// Largest distance a false positive may move between scans and still be the same one
/// "persisting in place", m (issue 14).
pub const PERSIST_RADIUS_M: f64 = 0.3;
/// A jump of the stamps longer than this starts a new stretch, s (issue 14).
pub const STRETCH_GAP_S: f64 = 0.5;
/// A labelled cluster wider than this is two legs merged into one, m. Single legs give
/// 9-16 cm clusters at the URG-04LX's height (design 4); two legs side by side (each
/// 10-13 cm wide, 15-30 cm apart) give 22 cm and more.
pub const MERGED_WIDTH_M: f64 = 0.2;
/// Upper bounds (inclusive) of the miss-run histogram bins, scans; the last bin is open.
pub const MISS_RUN_BINS: [usize; 6] = [1, 2, 3, 5, 10, 20];
/// Upper bounds (inclusive) of the persistence histogram bins, scans; the last bin is
/// open.
pub const PERSIST_RUN_BINS: [usize; 6] = [1, 2, 5, 10, 50, 200];

/// A labelled leg cluster: where it is and how wide its cluster is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabelledLeg {
    /// The label (the cluster's centroid), laser frame, m.
    pub position_in_laser: Point2<Laser>,
    /// Width of the cluster (first to last return), m; `NaN` if no cluster was found.
    pub width_m: f64,
}

/// Labels with their clusters' widths: each label takes the width of the candidate
/// cluster whose centroid is nearest to it (the labels of leg_tracker's bags are those
/// centroids).
pub fn labelled_legs(
    detector: &mut LegDetector,
    scan: &LaserScan,
    labels_in_laser: &[Point2<Laser>],
) -> Vec<LabelledLeg> {
    let candidates = detector.candidates(scan);
    labels_in_laser
        .iter()
        .map(|&label| {
            let width_m = candidates
                .iter()
                .map(|c| (c.centroid_in_laser.distance_m(label), c.features[WIDTH]))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .filter(|&(d, _)| d < 0.05)
                .map_or(f64::NAN, |(_, w)| w);
            LabelledLeg {
                position_in_laser: label,
                width_m,
            }
        })
        .collect()
}

/// Index of the width among the candidate features.
const WIDTH: usize = 5;

/// Leg clusters of `scan` that belong to people, found from where the people's legs
/// truly are (a simulator's ground truth): every candidate cluster whose centroid lies
/// within `reach_m` of a true leg centre and inside `region`, as leg_tracker's labeller
/// labelled every cluster in its window.
pub fn clusters_near(
    detector: &mut LegDetector,
    scan: &LaserScan,
    true_legs_in_laser: &[Point2<Laser>],
    reach_m: f64,
    region: &LabelledRegion,
) -> Vec<LabelledLeg> {
    detector
        .candidates(scan)
        .iter()
        .filter(|c| region.contains(c.centroid_in_laser))
        .filter(|c| {
            true_legs_in_laser
                .iter()
                .any(|l| l.distance_m(c.centroid_in_laser) <= reach_m)
        })
        .map(|c| LabelledLeg {
            position_in_laser: c.centroid_in_laser,
            width_m: c.features[WIDTH],
        })
        .collect()
}

/// The centres of the legs the detector accepts in `scan` (strong legs only).
pub fn detected_legs(detector: &mut LegDetector, scan: &LaserScan) -> Vec<Point2<Laser>> {
    detector
        .detect(scan)
        .legs
        .iter()
        .map(|l| l.centre_in_laser)
        .collect()
}

/// One open run of a false positive staying in place.
#[derive(Debug, Clone, Copy)]
struct OpenRun {
    x_m: f64,
    y_m: f64,
    scans: usize,
}

/// Accumulates the statistics over labelled scans (one person) and over scans of
/// false positives. Feed the scans of one recording (or one simulated person) in time
/// order; call [`DetectorStatistics::end_sequence`] between recordings.
#[derive(Debug, Clone, Default)]
pub struct DetectorStatistics {
    labelled_per_bin: [usize; N_RANGE_BINS],
    detected_per_bin: [usize; N_RANGE_BINS],
    labelled_legs: usize,
    merged_legs: usize,
    measured_widths: usize,
    person_scans: usize,
    person_missed_scans: usize,
    miss_then_any: usize,
    miss_then_miss: usize,
    miss_runs: Vec<usize>,
    current_miss_run: usize,
    last_person: Option<(f64, bool)>,
    fp_scans: usize,
    fp_detections: usize,
    fp_runs: Vec<usize>,
    open_runs: Vec<OpenRun>,
    last_fp_stamp_s: Option<f64>,
}

impl DetectorStatistics {
    /// Empty statistics.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds everything `other` counted (its open runs closed first), as if its scans
    /// had been a separate recording fed to `self`.
    pub fn merge(&mut self, other: &DetectorStatistics) {
        let mut o = other.clone();
        o.end_sequence();
        for k in 0..N_RANGE_BINS {
            self.labelled_per_bin[k] += o.labelled_per_bin[k];
            self.detected_per_bin[k] += o.detected_per_bin[k];
        }
        self.labelled_legs += o.labelled_legs;
        self.merged_legs += o.merged_legs;
        self.measured_widths += o.measured_widths;
        self.person_scans += o.person_scans;
        self.person_missed_scans += o.person_missed_scans;
        self.miss_then_any += o.miss_then_any;
        self.miss_then_miss += o.miss_then_miss;
        self.miss_runs.extend(o.miss_runs);
        self.fp_scans += o.fp_scans;
        self.fp_detections += o.fp_detections;
        self.fp_runs.extend(o.fp_runs);
    }

    /// Ends the current recording: open runs are closed.
    pub fn end_sequence(&mut self) {
        self.close_miss_run();
        self.last_person = None;
        self.close_fp_runs();
        self.last_fp_stamp_s = None;
    }

    fn close_miss_run(&mut self) {
        if self.current_miss_run > 0 {
            self.miss_runs.push(self.current_miss_run);
            self.current_miss_run = 0;
        }
    }

    fn close_fp_runs(&mut self) {
        self.fp_runs
            .extend(self.open_runs.drain(..).map(|r| r.scans));
    }

    /// A scan with one person's labelled legs and the detector's legs, at `stamp_s`.
    /// A scan without labels is ignored (the person is not there to be missed).
    pub fn add_labelled_scan(
        &mut self,
        stamp_s: f64,
        labels: &[LabelledLeg],
        detections_in_laser: &[Point2<Laser>],
    ) {
        if labels.is_empty() {
            return;
        }
        let mut any = false;
        for label in labels {
            let detected = detections_in_laser
                .iter()
                .any(|d| d.distance_m(label.position_in_laser) <= LEG_MATCH_RADIUS_M);
            any |= detected;
            let bin = (label.position_in_laser.range_m() / RANGE_BIN_M) as usize;
            if bin < N_RANGE_BINS {
                self.labelled_per_bin[bin] += 1;
                self.detected_per_bin[bin] += usize::from(detected);
            }
            self.labelled_legs += 1;
            if label.width_m.is_finite() {
                self.measured_widths += 1;
                self.merged_legs += usize::from(label.width_m > MERGED_WIDTH_M);
            }
        }
        let missed = !any;
        let continues = self
            .last_person
            .is_some_and(|(t, _)| stamp_s - t <= STRETCH_GAP_S && stamp_s >= t);
        if !continues {
            self.close_miss_run();
        } else if let Some((_, true)) = self.last_person {
            self.miss_then_any += 1;
            self.miss_then_miss += usize::from(missed);
        }
        self.person_scans += 1;
        if missed {
            self.person_missed_scans += 1;
            self.current_miss_run += 1;
        } else {
            self.close_miss_run();
        }
        self.last_person = Some((stamp_s, missed));
    }

    /// A scan's false positives at `stamp_s`, positions `(x, y)` in one fixed frame
    /// for the whole sequence, m.
    pub fn add_false_positives(&mut self, stamp_s: f64, positions_m: &[(f64, f64)]) {
        let continues = self
            .last_fp_stamp_s
            .is_some_and(|t| stamp_s - t <= STRETCH_GAP_S && stamp_s >= t);
        if !continues {
            self.close_fp_runs();
        }
        self.last_fp_stamp_s = Some(stamp_s);
        self.fp_scans += 1;
        self.fp_detections += positions_m.len();
        // Nearest pairs first, each open run and each detection used once.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (i, &(x, y)) in positions_m.iter().enumerate() {
            for (j, r) in self.open_runs.iter().enumerate() {
                let d = (x - r.x_m).hypot(y - r.y_m);
                if d <= PERSIST_RADIUS_M {
                    pairs.push((d, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut run_of = vec![None; positions_m.len()];
        let mut taken = vec![false; self.open_runs.len()];
        for (_, i, j) in pairs {
            if run_of[i].is_none() && !taken[j] {
                run_of[i] = Some(j);
                taken[j] = true;
            }
        }
        let mut next = Vec::with_capacity(positions_m.len());
        for (i, &(x, y)) in positions_m.iter().enumerate() {
            let scans = run_of[i].map_or(0, |j| self.open_runs[j].scans);
            next.push(OpenRun {
                x_m: x,
                y_m: y,
                scans: scans + 1,
            });
        }
        for (j, r) in self.open_runs.iter().enumerate() {
            if !taken[j] {
                self.fp_runs.push(r.scans);
            }
        }
        self.open_runs = next;
    }

    /// The figures so far (open runs counted as if they ended now).
    pub fn summary(&self) -> StatisticsSummary {
        let mut s = self.clone();
        s.end_sequence();
        let ratio = |a: usize, b: usize| {
            if b == 0 {
                f64::NAN
            } else {
                a as f64 / b as f64
            }
        };
        let detection_by_range = (0..N_RANGE_BINS)
            .map(|k| RangeBin {
                from_m: k as f64 * RANGE_BIN_M,
                to_m: (k + 1) as f64 * RANGE_BIN_M,
                labelled: s.labelled_per_bin[k],
                detected: s.detected_per_bin[k],
            })
            .collect();
        let detected: usize = s.detected_per_bin.iter().sum();
        let binned: usize = s.labelled_per_bin.iter().sum();
        let fp_in_long = s.fp_runs.iter().filter(|&&n| n >= 10).sum::<usize>();
        StatisticsSummary {
            detection_by_range,
            leg_detection_prob: ratio(detected, binned),
            labelled_legs: s.labelled_legs,
            person_scans: s.person_scans,
            person_miss_rate: ratio(s.person_missed_scans, s.person_scans),
            miss_run_histogram: histogram(&s.miss_runs, &MISS_RUN_BINS),
            miss_run_mean_scans: ratio(s.miss_runs.iter().sum(), s.miss_runs.len()),
            miss_run_max_scans: s.miss_runs.iter().copied().max().unwrap_or(0),
            p_miss_given_miss: ratio(s.miss_then_miss, s.miss_then_any),
            merged_share: ratio(s.merged_legs, s.measured_widths),
            fp_scans: s.fp_scans,
            fp_per_scan: ratio(s.fp_detections, s.fp_scans),
            fp_run_histogram: histogram(&s.fp_runs, &PERSIST_RUN_BINS),
            fp_run_mean_scans: ratio(s.fp_runs.iter().sum(), s.fp_runs.len()),
            fp_share_persisting_1s: ratio(fp_in_long, s.fp_detections),
        }
    }
}

/// Counts of `values` in bins with inclusive upper bounds `bounds` and an open last bin.
fn histogram(values: &[usize], bounds: &[usize]) -> Vec<usize> {
    let mut out = vec![0; bounds.len() + 1];
    for &v in values {
        let k = bounds.iter().position(|&b| v <= b).unwrap_or(bounds.len());
        out[k] += 1;
    }
    out
}

/// Detection counts in one range bin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RangeBin {
    /// Lower bound, m.
    pub from_m: f64,
    /// Upper bound, m.
    pub to_m: f64,
    /// Labelled legs in the bin.
    pub labelled: usize,
    /// Of those, detected.
    pub detected: usize,
}

impl RangeBin {
    /// Detection probability (`NaN` for an empty bin).
    pub fn probability(&self) -> f64 {
        if self.labelled == 0 {
            f64::NAN
        } else {
            self.detected as f64 / self.labelled as f64
        }
    }
}

/// The measured figures. Ratios with nothing to count are `NaN`.
#[derive(Debug, Clone, PartialEq)]
pub struct StatisticsSummary {
    /// Per-leg detection probability by range.
    pub detection_by_range: Vec<RangeBin>,
    /// Per-leg detection probability over all ranges below 5 m.
    pub leg_detection_prob: f64,
    /// Labelled legs.
    pub labelled_legs: usize,
    /// Labelled scans (scans with the person).
    pub person_scans: usize,
    /// Share of labelled scans with none of the person's legs detected.
    pub person_miss_rate: f64,
    /// Runs of consecutive missed scans, counted in the bins of [`MISS_RUN_BINS`].
    pub miss_run_histogram: Vec<usize>,
    /// Mean length of a run of missed scans, scans.
    pub miss_run_mean_scans: f64,
    /// Longest run of missed scans, scans.
    pub miss_run_max_scans: usize,
    /// P(miss at k+1 | miss at k).
    pub p_miss_given_miss: f64,
    /// Share of labelled clusters wider than [`MERGED_WIDTH_M`].
    pub merged_share: f64,
    /// Scans of false positives.
    pub fp_scans: usize,
    /// False positive legs per scan.
    pub fp_per_scan: f64,
    /// Runs of a false positive staying in place, in the bins of [`PERSIST_RUN_BINS`].
    pub fp_run_histogram: Vec<usize>,
    /// Mean length of such a run, scans.
    pub fp_run_mean_scans: f64,
    /// Share of false positive detections in runs of 10 scans (1 s) or longer.
    pub fp_share_persisting_1s: f64,
}

/// Labels of the rows of [`side_by_side`], in order.
pub fn row_names() -> Vec<String> {
    let mut rows: Vec<String> = (0..N_RANGE_BINS)
        .map(|k| {
            format!(
                "P(leg detected), {:.1}-{:.1} m",
                k as f64 * RANGE_BIN_M,
                (k + 1) as f64 * RANGE_BIN_M
            )
        })
        .collect();
    rows.extend(
        [
            "P(leg detected), 0-5 m",
            "labelled legs",
            "person missed, share of scans",
            "miss run mean, scans",
            "miss run max, scans",
            "P(miss | miss)",
        ]
        .map(String::from),
    );
    let mut lo = 1;
    for &b in &MISS_RUN_BINS {
        rows.push(if lo == b {
            format!("miss runs of {b} scan(s)")
        } else {
            format!("miss runs of {lo}-{b} scans")
        });
        lo = b + 1;
    }
    rows.push(format!("miss runs of {lo}+ scans"));
    rows.extend(
        [
            "merged legs, share of clusters",
            "false-positive scans",
            "false positives per scan",
            "FP run mean, scans",
            "FP share in runs >= 1 s",
        ]
        .map(String::from),
    );
    rows
}

impl StatisticsSummary {
    /// The values of the rows of [`row_names`], formatted.
    pub fn row_values(&self) -> Vec<String> {
        let p = |x: f64| {
            if x.is_nan() {
                "-".to_string()
            } else {
                format!("{x:.3}")
            }
        };
        let mut out: Vec<String> = self
            .detection_by_range
            .iter()
            .map(|b| {
                if b.labelled == 0 {
                    "-".to_string()
                } else {
                    format!("{} ({})", p(b.probability()), b.labelled)
                }
            })
            .collect();
        out.push(p(self.leg_detection_prob));
        out.push(self.labelled_legs.to_string());
        out.push(p(self.person_miss_rate));
        out.push(if self.miss_run_mean_scans.is_nan() {
            "-".into()
        } else {
            format!("{:.2}", self.miss_run_mean_scans)
        });
        out.push(self.miss_run_max_scans.to_string());
        out.push(p(self.p_miss_given_miss));
        out.extend(self.miss_run_histogram.iter().map(usize::to_string));
        out.push(p(self.merged_share));
        out.push(self.fp_scans.to_string());
        out.push(p(self.fp_per_scan));
        out.push(if self.fp_run_mean_scans.is_nan() {
            "-".into()
        } else {
            format!("{:.2}", self.fp_run_mean_scans)
        });
        out.push(p(self.fp_share_persisting_1s));
        out
    }
}

/// A Markdown table with one column per named summary.
pub fn side_by_side(columns: &[(&str, &StatisticsSummary)]) -> String {
    let mut out = String::new();
    let _ = write!(out, "| statistic |");
    for (name, _) in columns {
        let _ = write!(out, " {name} |");
    }
    out.push('\n');
    out.push_str("|---|");
    for _ in columns {
        out.push_str("---:|");
    }
    out.push('\n');
    let values: Vec<Vec<String>> = columns.iter().map(|(_, s)| s.row_values()).collect();
    for (k, row) in row_names().iter().enumerate() {
        let _ = write!(out, "| {row} |");
        for v in &values {
            let _ = write!(out, " {} |", v[k]);
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leg(x: f64, y: f64, w: f64) -> LabelledLeg {
        LabelledLeg {
            position_in_laser: Point2::new(x, y),
            width_m: w,
        }
    }

    #[test]
    fn miss_runs_and_their_persistence() {
        let mut s = DetectorStatistics::new();
        let l = [leg(1.2, 0.0, 0.1)];
        let hit = [Point2::new(1.3, 0.0)];
        // hit, miss, miss, hit, miss, (gap) miss, hit
        let seq: [(f64, bool); 7] = [
            (0.0, true),
            (0.1, false),
            (0.2, false),
            (0.3, true),
            (0.4, false),
            (2.0, false),
            (2.1, true),
        ];
        for (t, h) in seq {
            s.add_labelled_scan(t, &l, if h { &hit } else { &[] });
        }
        let m = s.summary();
        assert_eq!(m.person_scans, 7);
        assert!((m.person_miss_rate - 4.0 / 7.0).abs() < 1e-12);
        // Runs: 2, 1 (cut by the gap), 1.
        assert_eq!(m.miss_run_histogram, vec![2, 1, 0, 0, 0, 0, 0]);
        assert!((m.miss_run_mean_scans - 4.0 / 3.0).abs() < 1e-12);
        // Miss followed (within a stretch) by: miss, hit, hit -> the one after the
        // gap is not counted.
        assert!((m.p_miss_given_miss - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.detection_by_range[2].labelled, 7);
        assert_eq!(m.detection_by_range[2].detected, 3);
    }

    #[test]
    fn a_detection_too_far_is_a_miss_and_wide_clusters_are_merged() {
        let mut s = DetectorStatistics::new();
        s.add_labelled_scan(
            0.0,
            &[leg(2.0, 0.0, 0.12), leg(2.0, 0.6, 0.26)],
            // 0.3 m from either: beyond the 0.25 m match radius.
            &[Point2::new(2.0, 0.3)],
        );
        let m = s.summary();
        assert_eq!(m.labelled_legs, 2);
        assert_eq!(m.detection_by_range[4].detected, 0);
        assert!((m.merged_share - 0.5).abs() < 1e-12);
        assert!((m.person_miss_rate - 1.0).abs() < 1e-12);
    }

    #[test]
    fn false_positives_persist_while_they_stay_within_the_radius() {
        let mut s = DetectorStatistics::new();
        // A pole at (1, 0) seen for 12 scans with jitter, a flicker at (3, 3) once.
        for k in 0..12 {
            let j = 0.01 * (k % 3) as f64;
            let mut p = vec![(1.0 + j, j)];
            if k == 5 {
                p.push((3.0, 3.0));
            }
            s.add_false_positives(0.1 * k as f64, &p);
        }
        // It moves 0.5 m: a new run.
        s.add_false_positives(1.2, &[(1.5, 0.0)]);
        let m = s.summary();
        assert_eq!(m.fp_scans, 13);
        assert!((m.fp_per_scan - 14.0 / 13.0).abs() < 1e-12);
        // Runs: 12, 1, 1.
        assert_eq!(m.fp_run_histogram, vec![2, 0, 0, 0, 1, 0, 0]);
        assert!((m.fp_share_persisting_1s - 12.0 / 14.0).abs() < 1e-12);
        let mut twice = s.clone();
        twice.merge(&s);
        let t = twice.summary();
        assert_eq!(t.fp_scans, 26);
        assert_eq!(t.fp_run_histogram, vec![4, 0, 0, 0, 2, 0, 0]);
        let table = side_by_side(&[("a", &m), ("b", &m)]);
        assert_eq!(table.lines().count(), 2 + row_names().len());
    }
}
