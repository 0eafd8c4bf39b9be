//! `tether train-legs`: train the learned leg classifier on leg_tracker's labelled
//! recordings (the training split of issue 3 only), choosing its decision margin by
//! cross-validation on that split.

mod adapt;

use std::path::PathBuf;

use anyhow::Context;
use tether_core::RangeNoiseModel;
use tether_eval::leg_data::{check_data_folder, labelled_scans, negative_scans};
use tether_laser::training::{
    TRAIN_NEGATIVE_TOPICS, TRAIN_POSITIVE_BAGS, TrainingViews, default_adaboost_config,
    folds_from_scans, train_with_cross_validation,
};
use tether_laser::{AdaBoostConfig, DetectorConfig, LegClassifier, LegDetector};

/// Options of `tether train-legs`. The defaults reproduce the built-in model.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder with leg_tracker's bags (`positive_*_extracted.bag`, `negative_2.bag`).
    #[arg(long, default_value = "../shared/data/laser/leg_tracker")]
    pub data: PathBuf,
    /// Where to write the model (JSON). The built-in model is
    /// `crates/tether-laser/models/legs_default.json`.
    #[arg(long, default_value = "legs.json", value_name = "FILE")]
    pub out: PathBuf,
    /// Boosting rounds.
    #[arg(long, default_value_t = default_adaboost_config().rounds)]
    pub rounds: usize,
    /// Depth of each boosted tree (1: stumps).
    #[arg(long, default_value_t = default_adaboost_config().max_depth)]
    pub depth: usize,
    /// Also train on each scan seen that many times from nearer (a leg or an object
    /// brought to 0.3-1.5 m, where a follower keeps its person: design 4.6). Default 1,
    /// or 2 with `--coarse`.
    #[arg(long, value_name = "N")]
    pub nearer_views: Option<usize>,
    /// Also train on each scan (and each view from nearer) seen that many times as a
    /// coarser, noisier scanner would see it (0.5-1 degree steps, range noise up to
    /// 2.5 % of the distance, up to one beam in four lost: design 4.6). Default 0, or 1
    /// with `--coarse`.
    #[arg(long, value_name = "N")]
    pub coarser_views: Option<usize>,
    /// Also train on each labelled scan (and each view from nearer) seen that many
    /// times with a backdrop 0.8-4 m behind its people, where the recording saw
    /// nothing or saw farther (people in a room rather than an open hall: design 4.6).
    /// Default 0: on the test split it costs recall (docs/measured.md).
    #[arg(long, value_name = "N")]
    pub backdrop_views: Option<usize>,
    /// Train a model for coarse scanners (beams 0.45 degrees apart or more), on the
    /// coarser views only: the built-in one is
    /// `crates/tether-laser/models/legs_coarse.json`.
    #[arg(long)]
    pub coarse: bool,
    /// Adapt to a new scanner instead (design 4.7): a recording (ROS 1 bag or MCAP) of
    /// one person walking around in front of the still robot for about a minute; its
    /// clusters are labelled by how they move, the last `--held-back` of it is kept for
    /// measuring, and the model is trained on the rest. `--data` is not read.
    #[arg(long, value_name = "REC")]
    pub from_recording: Option<PathBuf>,
    /// The `sensor_msgs/LaserScan` topic of `--from-recording` and `--empty`.
    #[arg(long, value_name = "TOPIC", default_value = "/scan")]
    pub scan_topic: String,
    /// A recording of the empty scene (nobody in view) with the same scanner: every
    /// cluster a non-leg.
    #[arg(long, value_name = "REC", requires = "from_recording")]
    pub empty: Option<PathBuf>,
    /// Share of each recording (its last scans) held back for measuring.
    #[arg(
        long,
        value_name = "SHARE",
        default_value_t = 0.25,
        requires = "from_recording"
    )]
    pub held_back: f64,
    /// True leg labels of `--from-recording` (`geometry_msgs/PoseArray` of leg centres
    /// in the scan's frame, paired with scans as `tether eval-legs` does): the held-back
    /// part is then also measured against them. Never used for training.
    #[arg(long, value_name = "TOPIC", requires = "from_recording")]
    pub truth_topic: Option<String>,
}

/// Trains on the training split and writes the model.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(recording) = &args.from_recording {
        return adapt::run(recording, &args);
    }
    check_data_folder(&args.data)?;
    let config = AdaBoostConfig {
        rounds: args.rounds,
        max_depth: args.depth,
        views: {
            let base = if args.coarse {
                TrainingViews::COARSE
            } else {
                TrainingViews::FINE
            };
            TrainingViews {
                nearer: args.nearer_views.unwrap_or(base.nearer),
                coarser: args.coarser_views.unwrap_or(base.coarser),
                backdrop: args.backdrop_views.unwrap_or(base.backdrop),
                coarse_only: args.coarse,
            }
        },
        ..default_adaboost_config()
    };
    let mut detector = LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default())?;
    let mut bags = Vec::new();
    for bag in TRAIN_POSITIVE_BAGS {
        bags.push((bag, labelled_scans(&args.data, &[bag])?));
    }
    let mut topics = Vec::new();
    for topic in TRAIN_NEGATIVE_TOPICS {
        topics.push(negative_scans(&args.data, &[topic])?);
    }
    let folds = folds_from_scans(
        &mut detector,
        &bags
            .iter()
            .map(|(name, scans)| (*name, scans.as_slice()))
            .collect::<Vec<_>>(),
        &topics.iter().map(Vec::as_slice).collect::<Vec<_>>(),
        config.views,
    );
    let started = std::time::Instant::now();
    let (model, set, cv) = train_with_cross_validation(&folds, &config)?;
    tether::outln!(
        "cross-validation ({} folds: one positive bag and a block of the negative scans \
         each), detections within 0.15 m of a label:",
        folds.len()
    )?;
    tether::outln!("fold     TP     FP     FN   precision recall")?;
    for (k, c) in cv.fold_counts.iter().enumerate() {
        tether::outln!(
            "{:<5} {:>5} {:>6} {:>6}   {:>9.3} {:>6.3}",
            k + 1,
            c.true_positives,
            c.false_positives,
            c.false_negatives,
            c.precision(),
            c.recall()
        )?;
    }
    let c = cv.best_counts();
    tether::outln!(
        "all   {:>5} {:>6} {:>6}   {:>9.3} {:>6.3}   (decision margin {}: the highest F1, {:.3})",
        c.true_positives,
        c.false_positives,
        c.false_negatives,
        c.precision(),
        c.recall(),
        cv.margin(),
        c.f1()
    )?;
    tether::outln!(
        "trained {} trees of depth {} on {} legs and {} non-legs in {:.1} s, cross-validation \
         included ({} labelled legs matched no cluster)",
        model.trees.len(),
        config.max_depth,
        set.positives(),
        set.negatives(),
        started.elapsed().as_secs_f64(),
        set.unmatched_labels
    )?;
    let json = model.to_json();
    std::fs::write(&args.out, &json)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let (built_in, which) = if args.coarse {
        (
            LegClassifier::default_coarse_model(),
            "built-in coarse-scan model",
        )
    } else {
        (LegClassifier::default_model(), "built-in model")
    };
    let same = built_in.is_ok_and(|m| m.to_json() == json);
    tether::outln!(
        "wrote {} ({} the {which})",
        args.out.display(),
        if same { "identical to" } else { "differs from" }
    )?;
    Ok(())
}
