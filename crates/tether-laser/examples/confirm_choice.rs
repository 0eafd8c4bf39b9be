//! How the confirmation of narrow legs (design 4.6, `tether_laser::confirm`) was chosen:
//! cross-validation on the training split, as the decision margin was.
//!
//! The folds are the built-in fine model's (`training::folds_from_scans` with
//! `TrainingViews::FINE`: a positive recording and a block of the side scanners' scans
//! each). For each fold a model is trained on the others, and the held-out recorded
//! scans are detected in their order, with their stamps, at the built-in decision
//! margin: a candidate between the margin and the margin plus `extra_margin` is a leg
//! only if a candidate at the margin stood within `radius_m` in the last `window_s`,
//! or the last scan could not see it.
//! Counted as cross-validation counts (a label found by a detection within 0.15 m, one
//! to one; false detections inside the labeller's window and on the scans without
//! people). Prints every setting of the grid by F1, the best first:
//! `ConfirmConfig::PER_SCAN` is the best.
//!
//! Run from the checkout's root, with `../shared` beside it (about a minute):
//! `cargo run --release -p tether-laser --example confirm_choice`

use std::error::Error;
use std::path::Path;

use tether_core::{Laser, LaserScan, Point2, RangeNoiseModel};
use tether_laser::confirm::{ConfirmConfig, RecentLegs};
use tether_laser::training::{
    LabelledRegion, LabelledScan, MatchCounts, NEGATIVE_BAG, POSITIVE_LABEL_TOPIC,
    POSITIVE_SCAN_TOPIC, ScanSample, TRAIN_NEGATIVE_TOPICS, TRAIN_POSITIVE_BAGS, TrainingSet,
    TrainingViews, count_detections, default_adaboost_config, folds_from_scans,
};
use tether_laser::{DetectorConfig, LegClassifier, LegDetector, Provenance, train_adaboost};
use tether_recording::rosbag::{read_labelled_scans, read_scans};

/// One held-out scan: its stamp, its candidates and their margins under the model
/// that did not see it. `stream` tells recordings and scanners apart.
struct HeldOut {
    stream: usize,
    scan: LaserScan,
    sample: ScanSample,
    margins: Vec<f64>,
}

fn main() -> Result<(), Box<dyn Error>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/laser/leg_tracker");
    if !dir.is_dir() {
        return Err(format!("{} is absent: this needs leg_tracker's bags", dir.display()).into());
    }
    let mut bags: Vec<(&str, Vec<LabelledScan>)> = Vec::new();
    for bag in TRAIN_POSITIVE_BAGS {
        let read = read_labelled_scans(dir.join(bag), POSITIVE_SCAN_TOPIC, POSITIVE_LABEL_TOPIC)?;
        let scans = read
            .scans
            .into_iter()
            .map(|s| (s.scan.scan, s.legs_in_laser));
        bags.push((bag, scans.collect()));
    }
    let mut topics: Vec<Vec<LaserScan>> = Vec::new();
    for topic in TRAIN_NEGATIVE_TOPICS {
        let read = read_scans(dir.join(NEGATIVE_BAG), topic)?;
        topics.push(read.scans.into_iter().map(|m| m.scan).collect());
    }
    let held = held_out_margins(&bags, &topics)?;
    let decision = LegClassifier::default_model()?.decision_margin;
    let mut results: Vec<(MatchCounts, ConfirmConfig)> = Vec::new();
    for extra_margin in [0.0, 0.02, 0.04, 0.06, 0.08, 0.1] {
        for radius_m in [0.3, 0.4, 0.5, 0.6, 0.8] {
            for window_s in [0.2, 0.4, 0.6, 0.8, 1.0] {
                let c = ConfirmConfig {
                    extra_margin,
                    radius_m,
                    window_s,
                };
                results.push((count(&held, decision, &c, true), c));
            }
        }
    }
    for (what, m) in [
        (
            "no confirmation",
            count(&held, decision, &ConfirmConfig::default(), false),
        ),
        (
            "PER_SCAN without the shadow clause",
            count(&held, decision, &ConfirmConfig::PER_SCAN, false),
        ),
    ] {
        println!(
            "{what}: precision {:.3} recall {:.3} F1 {:.4}",
            m.precision(),
            m.recall(),
            m.f1()
        );
    }
    // Highest F1 first; the grid's order breaks ties.
    results.sort_by(|a, b| b.0.f1().total_cmp(&a.0.f1()));
    println!("extra_margin radius_m window_s   precision recall  F1");
    for (m, c) in &results {
        let mark = if *c == ConfirmConfig::PER_SCAN {
            "  <- ConfirmConfig::PER_SCAN"
        } else {
            ""
        };
        println!(
            "{:>12} {:>8} {:>8}   {:>9.3} {:>6.3} {:.4}{mark}",
            c.extra_margin,
            c.radius_m,
            c.window_s,
            m.precision(),
            m.recall(),
            m.f1()
        );
    }
    Ok(())
}

/// The held-out recorded scans of every fold, with the margins of the model trained on
/// the other folds.
fn held_out_margins(
    bags: &[(&str, Vec<LabelledScan>)],
    topics: &[Vec<LaserScan>],
) -> Result<Vec<HeldOut>, Box<dyn Error>> {
    let mut detector = LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default())?;
    let positive: Vec<(&str, &[LabelledScan])> =
        bags.iter().map(|(n, s)| (*n, s.as_slice())).collect();
    let negative: Vec<&[LaserScan]> = topics.iter().map(|t| t.as_slice()).collect();
    let folds = folds_from_scans(&mut detector, &positive, &negative, TrainingViews::FINE);
    let k = folds.len();
    let config = default_adaboost_config();
    let mut out = Vec::new();
    for (f, (name, scans)) in bags.iter().enumerate().take(k) {
        let others = folds
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != f)
            .flat_map(|(_, fold)| fold.iter());
        let set = TrainingSet::from_scans(others);
        let model = train_adaboost(&set.samples, &set.labels, &config, Provenance::default())?;
        let mut push = |stream: usize, scan: &LaserScan, sample: ScanSample| {
            let margins = sample.features.iter().map(|x| model.margin(x)).collect();
            out.push(HeldOut {
                stream,
                scan: scan.clone(),
                sample,
                margins,
            });
        };
        for (scan, legs) in scans {
            let region = LabelledRegion::of_bag(name);
            push(
                f,
                scan,
                ScanSample::labelled(&mut detector, scan, legs, region),
            );
        }
        // The block of each side scanner that `training_folds` puts in fold `f`.
        for (t, scans) in topics.iter().enumerate() {
            let n = scans.len();
            for (i, scan) in scans.iter().enumerate() {
                if (i * k / n.max(1)).min(k - 1) == f {
                    push(k + t, scan, ScanSample::without_people(&mut detector, scan));
                }
            }
        }
    }
    Ok(out)
}

/// The held-out counts with confirmation `c` at decision margin `decision`.
fn count(held: &[HeldOut], decision: f64, c: &ConfirmConfig, shadow: bool) -> MatchCounts {
    let mut total = MatchCounts::default();
    let mut recent = RecentLegs::default();
    let mut stream = usize::MAX;
    for h in held {
        if h.stream != stream {
            recent = RecentLegs::default();
            stream = h.stream;
        }
        recent.start_scan(h.scan.stamp, c.window_s);
        recent.keep_beams(&h.scan);
        let (mut centres, mut centroids): (Vec<Point2<Laser>>, Vec<Point2<Laser>>) =
            (Vec::new(), Vec::new());
        for (k, &m) in h.margins.iter().enumerate() {
            if m < decision {
                continue;
            }
            let centre = h.sample.centres[k];
            recent.accepted(centre);
            if m >= decision + c.extra_margin
                || recent.supports(centre, c.radius_m)
                || (shadow && recent.was_hidden(centre))
            {
                centres.push(centre);
                centroids.push(h.sample.centroids[k]);
            }
        }
        recent.finish_scan();
        total.add(count_detections(
            &centres,
            &centroids,
            &h.sample.labels,
            h.sample.region.as_ref(),
        ));
    }
    total
}
