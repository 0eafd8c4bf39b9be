//! `tether eval-legs`: precision and recall of the arc test and of the learned
//! classifier on the test split of leg_tracker's recordings (issue 3), never used for
//! training or tuning.

use std::path::PathBuf;

use tether_laser::DetectorKind;
use tether_laser::training::{
    EVAL_MATCH_RADIUS_M, Evaluation, LabelledRegion, TEST_NEGATIVE_TOPICS, TEST_POSITIVE_BAGS,
    evaluate,
};

use super::legs::{detector, laser_model};
use super::train_legs::{labelled_scans, negative_scans};

/// Options of `tether eval-legs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder with leg_tracker's bags (`positive_{6,7}_extracted.bag`,
    /// `negative_2.bag`).
    #[arg(long, default_value = "../shared/data/laser/leg_tracker")]
    pub data: PathBuf,
    /// The learned model to measure (default: the built-in one).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// A laser config (TOML) whose `[noise]` calibration to apply.
    #[arg(long, value_name = "FILE")]
    pub laser: Option<PathBuf>,
}

fn row(name: &str, e: &Evaluation) -> anyhow::Result<()> {
    let t = e.total();
    tether::outln!(
        "{name:<8} {:>5} {:>9} {:>9} {:>5}   {:>9.3} {:>6.3}",
        t.true_positives,
        e.labelled.false_positives,
        e.negative_false_positives,
        t.false_negatives,
        t.precision(),
        t.recall()
    )
}

/// Measures both detectors and prints a table.
pub fn run(args: Args) -> anyhow::Result<()> {
    super::train_legs::check_data_folder(&args.data)?;
    let laser = laser_model(args.laser.as_ref())?;
    let positives = labelled_scans(&args.data, &TEST_POSITIVE_BAGS)?;
    let negatives = negative_scans(&args.data, &TEST_NEGATIVE_TOPICS)?;
    let region = LabelledRegion::leg_tracker();
    let labels: usize = positives.iter().map(|(_, l)| l.len()).sum();
    tether::outln!(
        "test split: {} and {} {}: {} labelled scans with {labels} legs, {} scans without \
         people",
        TEST_POSITIVE_BAGS.join(", "),
        tether_laser::training::NEGATIVE_BAG,
        TEST_NEGATIVE_TOPICS.join(", "),
        positives.len(),
        negatives.len()
    )?;
    tether::outln!(
        "a detection within {EVAL_MATCH_RADIUS_M} m of a labelled leg centre finds it (one to \
         one); on labelled scans, a detection that finds none is false only if its returns' \
         centroid lies where the labeller labelled every cluster ({:.0} to {:.0} deg, under {} \
         m); on the scans without people every detection is false",
        region.min_bearing_rad.to_degrees(),
        region.max_bearing_rad.to_degrees(),
        region.max_range_m
    )?;
    tether::outln!()?;
    tether::outln!("detector    TP  FP(lab.)  FP(neg.)    FN   precision recall")?;
    for (name, kind) in [
        ("arc", DetectorKind::Arc),
        ("learned", DetectorKind::Learned),
    ] {
        let model = if kind == DetectorKind::Learned {
            args.model.as_ref()
        } else {
            None
        };
        let mut d = detector(kind, model, &laser)?;
        let e = evaluate(
            &mut d,
            positives.iter().map(|(s, l)| (s, l.as_slice())),
            negatives.iter(),
            &region,
        );
        row(name, &e)?;
    }
    Ok(())
}
