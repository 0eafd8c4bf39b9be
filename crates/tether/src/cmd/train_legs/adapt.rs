//! `tether train-legs --from-recording REC`: adapt the learned leg classifier to a new
//! scanner without hand labels (design 4.7). The clusters of a recording of one person
//! walking in front of the still robot are labelled by how they move
//! (`tether_laser::self_label`), the last part of the recording is held back, and a
//! model is trained on the rest (`tether_laser::adapt`) and measured beside the
//! built-in one on the held-back part.

use std::path::Path;

use anyhow::Context;
use tether_core::{Laser, LaserScan, Point2, RangeNoiseModel};
use tether_eval::leg_eval::pair_labels;
use tether_eval::track_eval::Pairing;
use tether_laser::adapt::{
    measure_on_candidates, split_held_back, time_folds, train_on_candidates,
};
use tether_laser::self_label::{EVERYWHERE, SelfLabelConfig, empty_scene, self_label};
use tether_laser::training::{MatchCounts, evaluate};
use tether_laser::{AdaBoostConfig, DetectorConfig, LegClassifier, LegDetector};
use tether_recording::samples::{self, LabelMessage, Sample, Topics};

use super::Args;

/// Cross-validation folds (blocks of consecutive scans) of the part trained on.
const FOLDS: usize = 4;

/// Label messages, each with the number of scans read before it.
type LabelMessages = Vec<(usize, LabelMessage)>;

/// The scans of `topic`, with the label messages of `labels_topic` if given (each with
/// the number of scans read before it).
fn read_scans(
    path: &Path,
    topic: &str,
    labels_topic: Option<&str>,
) -> anyhow::Result<(Vec<LaserScan>, LabelMessages)> {
    let topics = Topics {
        scan: topic.to_string(),
        images: Vec::new(),
        odom: None,
    };
    let scans = std::cell::RefCell::new(Vec::new());
    let mut labels = Vec::new();
    let mut on_sample = |sample| {
        if let Sample::Scan(scan) = sample {
            scans.borrow_mut().push(scan);
        }
        Ok(())
    };
    let stats = match labels_topic {
        Some(t) => samples::read_with_labels(path, &topics, t, &mut on_sample, &mut |m| {
            labels.push((scans.borrow().len(), m));
            Ok(())
        }),
        None => samples::read(path, &topics, &mut on_sample),
    }
    .with_context(|| format!("reading {}", path.display()))?;
    let scans = scans.into_inner();
    if stats.bad_messages + stats.unattributed > 0 {
        tracing::warn!(
            "{}: skipped {} messages that did not decode",
            path.display(),
            stats.bad_messages + stats.unattributed
        );
    }
    anyhow::ensure!(
        !scans.is_empty(),
        "{} has no scan on {topic} (pass --scan-topic)",
        path.display()
    );
    Ok((scans, labels))
}

fn row(name: &str, c: &MatchCounts) -> String {
    format!(
        "{name:<10} {:>6} {:>6} {:>6}   {:>9.3} {:>6.3} {:>6.3}",
        c.true_positives,
        c.false_positives,
        c.false_negatives,
        c.precision(),
        c.recall(),
        c.f1()
    )
}

/// Labels, trains, measures and writes the model.
pub fn run(path: &Path, args: &Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.held_back.is_finite() && (0.05..=0.5).contains(&args.held_back),
        "--held-back must be between 0.05 and 0.5, got {}",
        args.held_back
    );
    let noise = RangeNoiseModel::default();
    let mut detector = LegDetector::arc(DetectorConfig::default(), noise.clone())?;
    let (scans, label_messages) = read_scans(path, &args.scan_topic, args.truth_topic.as_deref())?;
    let (labelled, report) = self_label(&mut detector, &scans, &SelfLabelConfig::default());
    tether::outln!(
        "{}: {} scans of {}, {} clusters: {} static, {} moving tracks of which {} walk \
         (in {} scans); labels: {} legs, {} non-legs, {} left out",
        path.display(),
        report.scans,
        args.scan_topic,
        report.candidates,
        report.static_candidates,
        report.tracks,
        report.walkers,
        report.scans_with_walker,
        report.legs,
        report.non_legs,
        report.left_out
    )?;
    anyhow::ensure!(
        report.walkers > 0 && report.legs > 0,
        "no one walking was found in {}: record a person walking around in front of the \
         still robot, 0.5-4 m away, for about a minute",
        path.display()
    );
    let (train, held) = split_held_back(labelled, args.held_back);
    let mut folds = time_folds(train, FOLDS);
    let mut held_empty = Vec::new();
    if let Some(empty) = &args.empty {
        let (empty_scans, _) = read_scans(empty, &args.scan_topic, None)?;
        let all = empty_scene(&mut detector, &empty_scans);
        tether::outln!(
            "{}: {} scans of the empty scene, {} clusters (non-legs)",
            empty.display(),
            all.len(),
            all.iter().map(|s| s.labels.len()).sum::<usize>()
        )?;
        let (train, h) = split_held_back(all, args.held_back);
        for (fold, part) in folds.iter_mut().zip(time_folds(train, FOLDS)) {
            fold.extend(part);
        }
        held_empty = h;
    }
    let config = AdaBoostConfig {
        rounds: args.rounds,
        max_depth: args.depth,
        // Labels from motion: the recording as it is, no views.
        views: tether_laser::training::TrainingViews::default(),
        ..tether_laser::training::default_adaboost_config()
    };
    let mut sources = vec![format!(
        "{} {} (self-labelled, the first {:.0} %)",
        file_name(path),
        args.scan_topic,
        100.0 * (1.0 - args.held_back)
    )];
    if let Some(empty) = &args.empty {
        sources.push(format!(
            "{} {} (empty scene: non-legs)",
            file_name(empty),
            args.scan_topic
        ));
    }
    let started = std::time::Instant::now();
    let (model, set, cv) = train_on_candidates(
        &folds,
        &config,
        "tether train-legs --from-recording".to_string(),
        sources,
    )?;
    tether::outln!(
        "trained {} trees on {} legs and {} non-legs in {:.1} s; decision margin {} by \
         {FOLDS}-fold cross-validation (F1 {:.3})",
        model.trees.len(),
        set.positives(),
        set.negatives(),
        started.elapsed().as_secs_f64(),
        cv.margin(),
        cv.best_counts().f1()
    )?;
    // The built-in model a detector would use on these scans.
    let coarse = scans
        .first()
        .is_some_and(|s| s.angle_increment_rad.abs() >= tether_laser::COARSE_BEAM_STEP_RAD);
    let built_in = if coarse {
        LegClassifier::default_coarse_model()?
    } else {
        LegClassifier::default_model()?
    };
    let mut held_all = held;
    let held_labelled_scans = held_all.len();
    held_all.extend(held_empty);
    tether::outln!()?;
    tether::outln!(
        "held back: the last {:.0} % ({held_labelled_scans} scans{}), against the self-labels, \
         per cluster:",
        100.0 * args.held_back,
        if args.empty.is_some() {
            " and the last part of the empty scene"
        } else {
            ""
        }
    )?;
    tether::outln!("model          TP     FP     FN   precision recall     F1")?;
    tether::outln!(
        "{}",
        row("built-in", &measure_on_candidates(&built_in, &held_all))
    )?;
    tether::outln!(
        "{}",
        row("adapted", &measure_on_candidates(&model, &held_all))
    )?;
    if let Some(topic) = &args.truth_topic {
        print_truth(
            &scans,
            &label_messages,
            held_labelled_scans,
            topic,
            &noise,
            &built_in,
            &model,
        )?;
    }
    std::fs::write(&args.out, model.to_json())
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    tether::outln!()?;
    tether::outln!(
        "wrote {0}: name it in the robot's config (`[pipeline.legs] model = \"{0}\"`, \
         relative to the config) or give `--leg-model {0}` (run, ros2, track, replay, ...; \
         `--model` for legs and eval-legs)",
        args.out.display()
    )?;
    Ok(())
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// The held-back scans measured against the true leg labels of `topic`.
fn print_truth(
    scans: &[LaserScan],
    label_messages: &[(usize, LabelMessage)],
    held_scans: usize,
    topic: &str,
    noise: &RangeNoiseModel,
    built_in: &LegClassifier,
    adapted: &LegClassifier,
) -> anyhow::Result<()> {
    let stamps: Vec<_> = scans.iter().map(|s| s.stamp).collect();
    let paired = pair_labels(&stamps, label_messages, Pairing::Auto);
    let first = scans.len() - held_scans;
    let truth: Vec<(&LaserScan, &[Point2<Laser>])> = scans[first..]
        .iter()
        .zip(&paired.per_scan[first..])
        .filter_map(|(s, l)| l.as_deref().map(|l| (s, l)))
        .collect();
    tether::outln!()?;
    if truth.is_empty() {
        tether::outln!(
            "no held-back scan has a label of {topic}: nothing to measure against the truth"
        )?;
        return Ok(());
    }
    tether::outln!(
        "held back, against the true legs of {topic} ({} labelled scans): a detection within \
         0.15 m finds a leg, every other detection is false:",
        truth.len()
    )?;
    tether::outln!("model          TP     FP     FN   precision recall     F1")?;
    for (name, model) in [("built-in", built_in), ("adapted", adapted)] {
        let mut d = LegDetector::learned(DetectorConfig::default(), noise.clone(), model.clone())?;
        let c = evaluate(
            &mut d,
            truth.iter().copied(),
            std::iter::empty(),
            &EVERYWHERE,
        )
        .total();
        tether::outln!("{}", row(name, &c))?;
    }
    Ok(())
}
