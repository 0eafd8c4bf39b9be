//! What the built-in leg detector misses up close on the test split (design 4.6).
//!
//! For every labelled leg of `positive_{6,7}_extracted.bag` within 1.5 m of the scanner
//! that no detected leg finds (within 0.15 m, one to one, nearest first), the candidate
//! cluster whose centroid lies nearest the label: none within 0.25 m, or one the
//! classifier refused, with its width, its number of returns and its margin against the
//! model's decision margin. A refused cluster wider than 0.2 m is the person's two legs
//! merged into one blob when the labeller labelled it as one leg (no other label within
//! 0.35 m).
//!
//! Run from the checkout's root, with `../shared` beside it:
//! `cargo run --release -p tether-laser --example close_misses`

use std::error::Error;
use std::path::Path;

use tether_core::{Laser, Point2, RangeNoiseModel};
use tether_laser::training::{POSITIVE_LABEL_TOPIC, POSITIVE_SCAN_TOPIC, TEST_POSITIVE_BAGS};
use tether_laser::{Candidate, Detection, DetectorConfig, LegClassifier, LegDetector};
use tether_recording::rosbag::read_labelled_scans;

/// A detected leg this close to a label finds it, m (as `tether eval-legs`).
const MATCH_M: f64 = 0.15;
/// A candidate this close to a missed label is the label's cluster, m.
const CLUSTER_M: f64 = 0.25;
/// Another label this close means both legs were labelled, m.
const OTHER_LABEL_M: f64 = 0.35;
/// A cluster wider than this is two legs merged, m (as `statistics`).
const MERGED_WIDTH_M: f64 = 0.2;
/// Index of `n_points` and `width_m` in the feature vector.
const N_POINTS: usize = 0;
const WIDTH: usize = 5;

/// Counts by range bin: 0-0.5, 0.5-1.0, 1.0-1.5 m.
type Bins = [usize; 3];

#[derive(Default)]
struct Tally {
    labels: Bins,
    found: Bins,
    no_candidate: Bins,
    refused: Bins,
    refused_merged_one_label: Bins,
    margins: Vec<f64>,
    widths: Vec<f64>,
}

fn bin(range_m: f64) -> usize {
    ((range_m / 0.5) as usize).min(2)
}

/// Labels found by `legs`, one to one, nearest pairs first.
fn found(labels: &[Point2<Laser>], legs: &[Point2<Laser>]) -> Vec<bool> {
    let mut pairs: Vec<(f64, usize, usize)> = labels
        .iter()
        .enumerate()
        .flat_map(|(i, l)| {
            legs.iter()
                .enumerate()
                .map(move |(j, g)| (l.distance_m(*g), i, j))
        })
        .filter(|(d, _, _)| *d <= MATCH_M)
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut label_found, mut leg_used) = (vec![false; labels.len()], vec![false; legs.len()]);
    for (_, i, j) in pairs {
        if !label_found[i] && !leg_used[j] {
            label_found[i] = true;
            leg_used[j] = true;
        }
    }
    label_found
}

fn main() -> Result<(), Box<dyn Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/laser/leg_tracker");
    if !dir.is_dir() {
        return Err(format!("{} is absent: this needs leg_tracker's bags", dir.display()).into());
    }
    let model = LegClassifier::default_model()?;
    let (config, noise) = (DetectorConfig::default(), RangeNoiseModel::default());
    let mut detector = LegDetector::builtin(config, noise)?;
    let mut detection = Detection::default();
    let mut t = Tally::default();
    for bag in TEST_POSITIVE_BAGS {
        let read = read_labelled_scans(dir.join(bag), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)?;
        for s in &read.scans {
            let scan = &s.scan.scan;
            detector.detect_into(scan, &mut detection);
            let legs: Vec<Point2<Laser>> =
                detection.legs.iter().map(|l| l.centre_in_laser).collect();
            let candidates = detector.candidates(scan);
            let labels = &s.legs_in_laser;
            for (i, (label, ok)) in labels.iter().zip(found(labels, &legs)).enumerate() {
                let range_m = label.range_m();
                if range_m > 1.5 {
                    continue;
                }
                let b = bin(range_m);
                t.labels[b] += 1;
                if ok {
                    t.found[b] += 1;
                    continue;
                }
                let nearest: Option<&Candidate> = candidates
                    .iter()
                    .filter(|c| c.centroid_in_laser.distance_m(*label) <= CLUSTER_M)
                    .min_by(|a, c| {
                        let d = |x: &Candidate| x.centroid_in_laser.distance_m(*label);
                        d(a).total_cmp(&d(c))
                    });
                let Some(c) = nearest else {
                    t.no_candidate[b] += 1;
                    continue;
                };
                t.refused[b] += 1;
                t.margins.push(model.margin(&c.features));
                t.widths.push(c.features[WIDTH]);
                let one_label = labels
                    .iter()
                    .enumerate()
                    .all(|(j, o)| j == i || o.distance_m(*label) > OTHER_LABEL_M);
                if one_label && c.features[WIDTH] > MERGED_WIDTH_M {
                    t.refused_merged_one_label[b] += 1;
                }
                if std::env::var_os("VERBOSE").is_some() {
                    println!(
                        "{bag} scan {}: label at {range_m:.2} m, cluster {:.2} m wide, {} returns, \
                         margin {:.3}",
                        s.scan.seq,
                        c.features[WIDTH],
                        c.features[N_POINTS],
                        model.margin(&c.features)
                    );
                }
            }
        }
    }
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        format!("{lo:.3} to {hi:.3}")
    };
    println!("labelled legs within 1.5 m, by range 0-0.5 / 0.5-1.0 / 1.0-1.5 m:");
    println!("  labelled                         {:?}", t.labels);
    println!("  found                            {:?}", t.found);
    println!("  missed, no candidate near        {:?}", t.no_candidate);
    println!("  missed, candidate refused        {:?}", t.refused);
    println!(
        "    of those, wider than {MERGED_WIDTH_M} m, one label {:?}",
        t.refused_merged_one_label
    );
    if !t.margins.is_empty() {
        println!(
            "refused candidates: margins {} (decision margin {}), widths {} m",
            range(&t.margins),
            model.decision_margin,
            range(&t.widths)
        );
    }
    Ok(())
}
