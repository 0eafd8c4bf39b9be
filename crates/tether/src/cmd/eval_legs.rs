//! `tether eval-legs`: precision and recall of the leg detectors, overall and by range
//! from the scanner (`tether_eval::leg_eval`).
//!
//! Without a recording: the arc test and the learned classifier on the test split of
//! leg_tracker's recordings (issue 3), never used for training or tuning. With one:
//! a detector on any recording whose scans have leg or person labels (issue 30).

use std::path::{Path, PathBuf};

use anyhow::Context;
use serde::Serialize;
use tether_eval::leg_eval::{
    BinReport, EVAL_MATCH_RADIUS_M, LabelChoice, RangeCounts, score_recording, test_split_counts,
};
use tether_eval::track_eval::Pairing;
use tether_laser::DetectorKind;
use tether_laser::training::{
    LabelledRegion, NEGATIVE_BAG, TEST_NEGATIVE_TOPICS, TEST_POSITIVE_BAGS,
};

use tether::args::{Detector, detector, detector_config, laser_model};
use tether_eval::leg_data::{check_data_folder, labelled_scans, negative_scans};

/// Options of `tether eval-legs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A labelled recording (ROS 1 bag or MCAP) to measure one detector on; without
    /// it, both detectors are measured on leg_tracker's test split under `--data`.
    pub recording: Option<PathBuf>,
    /// The `sensor_msgs/LaserScan` topic of the recording.
    #[arg(long, value_name = "TOPIC", requires = "recording")]
    pub scan_topic: Option<String>,
    /// The labels of the recording: `geometry_msgs/PoseArray` (legs, or people with
    /// `--labels people`), `leg_tracker/PersonArray` or `leg_tracker/Person` (people;
    /// one Person message per labelled person, every one between scan k and scan k+1
    /// belonging to scan k).
    #[arg(long, value_name = "TOPIC", requires = "recording")]
    pub labels_topic: Option<String>,
    /// What the labels are: `auto` takes PoseArray labels as legs and Person or
    /// PersonArray labels as people.
    #[arg(long, value_enum, default_value_t = LabelKind::Auto)]
    pub labels: LabelKind,
    /// Which scan a stamped label message belongs to (as `tether eval-track`).
    #[arg(long, value_enum, default_value_t = Pairing::Auto)]
    pub pairing: Pairing,
    /// Largest distance from a detection to a label for it to find the label, m
    /// (default: 0.15 for legs, as issue 3; 0.5 for people).
    #[arg(long, value_name = "M")]
    pub match_m: Option<f64>,
    /// Where the labeller labelled everything, `MIN_DEG:MAX_DEG:MAX_M` (bearing and
    /// range of the scan's frame): unmatched detections outside it are not counted.
    /// Default: everywhere. leg_tracker's extracted bags: `-15:15:5`.
    #[arg(
        long,
        value_name = "MIN_DEG:MAX_DEG:MAX_M",
        value_parser = parse_region,
        allow_hyphen_values = true
    )]
    pub region: Option<LabelledRegion>,
    /// The detector to measure on a recording.
    #[arg(long, value_enum, default_value_t = Detector::Learned)]
    pub detector: Detector,
    /// Write the figures as JSON: one object for a recording, an array of two (arc,
    /// learned) for the test split; each object's fields are documented on
    /// `cmd::eval_legs::Report`, its `bins` on `tether_eval::leg_eval::BinReport`.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Folder with leg_tracker's bags (`positive_{6,7}_extracted.bag`,
    /// `negative_2.bag`), used without a recording.
    #[arg(long, default_value = "../shared/data/laser/leg_tracker")]
    pub data: PathBuf,
    /// The learned model to measure (default: the built-in one).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// A detector config (`tether_laser::DetectorConfig` as JSON or TOML).
    #[arg(long, value_name = "FILE")]
    pub detector_config: Option<PathBuf>,
    /// A laser config (TOML) whose `[noise]` calibration to apply.
    #[arg(long, value_name = "FILE")]
    pub laser: Option<PathBuf>,
}

/// What labels stand for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LabelKind {
    /// PoseArray: legs; PersonArray and Person: people.
    Auto,
    /// Each label is a leg: matched against the detected legs.
    Legs,
    /// Each label is a person: matched against the detected people.
    People,
}

/// Default match radius for people, m: a person's position is the midpoint of their
/// legs (or one leg's centre when the other is hidden), up to about half a stride,
/// 0.3-0.4 m, from where a labeller puts them; 0.5 m is also the distance beyond which
/// the simulator's detector statistics call a detection false (docs/measured.md).
pub const PEOPLE_MATCH_M: f64 = 0.5;

fn parse_region(text: &str) -> Result<LabelledRegion, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let numbers: Result<Vec<f64>, _> = parts.iter().map(|p| p.trim().parse::<f64>()).collect();
    match numbers.as_deref() {
        Ok(&[min_deg, max_deg, max_m])
            if min_deg.is_finite() && max_deg.is_finite() && min_deg < max_deg && max_m > 0.0 =>
        {
            Ok(LabelledRegion {
                min_bearing_rad: min_deg.to_radians(),
                max_bearing_rad: max_deg.to_radians(),
                max_range_m: max_m,
            })
        }
        _ => Err(format!(
            "expected MIN_DEG:MAX_DEG:MAX_M with MIN_DEG < MAX_DEG and MAX_M > 0, e.g. \
             -15:15:5; got {text:?}"
        )),
    }
}

/// The figures of one detector, as `--json` writes them.
#[derive(Debug, Serialize)]
pub struct Report {
    /// `arc` or `learned`.
    pub detector: &'static str,
    /// The model file, `null` for the built-in one (or the arc test).
    pub model: Option<PathBuf>,
    /// The detector config file, `null` for the defaults.
    pub detector_config: Option<PathBuf>,
    /// `legs` or `people`: what was matched.
    pub labels: &'static str,
    /// The match radius, m.
    pub match_m: f64,
    /// Scans read.
    pub scans: usize,
    /// Scans with labels (scored).
    pub labelled_scans: usize,
    /// Scans without a label message (not scored).
    pub unlabelled_scans: usize,
    /// Scans known to hold no people (every detection false).
    pub empty_scans: usize,
    /// Label messages read.
    pub label_messages: usize,
    /// Label messages with no scan to go to.
    pub unpaired_label_messages: usize,
    /// Scans given more than one stamped label message (the nearest in stamp kept).
    pub doubly_labelled_scans: usize,
    /// Messages of the topics that did not decode and were skipped (scans refused as
    /// malformed included).
    pub skipped_messages: usize,
    /// Beams that were NaN or negative, read as no return.
    pub malformed_beams: usize,
    /// Detections on the scans without people (all false; included in
    /// `false_positives`).
    pub false_positives_on_empty_scans: usize,
    /// Test split only: the false detections on the labelled scans inside the
    /// labeller's window (-15 to 15 deg, under 5 m), issue 3's count; `null` otherwise.
    pub false_positives_in_labeller_window: Option<usize>,
    /// Labels found.
    pub true_positives: usize,
    /// Detections that count as false.
    pub false_positives: usize,
    /// Labels not found.
    pub false_negatives: usize,
    /// `tp / (tp + fp)`.
    pub precision: f64,
    /// `tp / (tp + fn)`.
    pub recall: f64,
    /// By range from the scanner (see `tether_eval::leg_eval`).
    pub bins: Vec<BinReport>,
}

impl Report {
    fn new(name: &'static str, args: &Args, labels: &'static str, match_m: f64) -> Self {
        Report {
            detector: name,
            model: if name == "learned" {
                args.model.clone()
            } else {
                None
            },
            detector_config: args.detector_config.clone(),
            labels,
            match_m,
            scans: 0,
            labelled_scans: 0,
            unlabelled_scans: 0,
            empty_scans: 0,
            label_messages: 0,
            unpaired_label_messages: 0,
            doubly_labelled_scans: 0,
            skipped_messages: 0,
            malformed_beams: 0,
            false_positives_on_empty_scans: 0,
            false_positives_in_labeller_window: None,
            true_positives: 0,
            false_positives: 0,
            false_negatives: 0,
            precision: 0.0,
            recall: 0.0,
            bins: Vec::new(),
        }
    }

    fn set_counts(&mut self, counts: &RangeCounts) {
        let t = counts.total();
        self.true_positives = t.true_positives;
        self.false_positives = t.false_positives;
        self.false_negatives = t.false_negatives;
        self.precision = t.precision();
        self.recall = t.recall();
        self.bins = counts.bins();
    }
}

fn write_json(path: &Path, value: &impl Serialize) -> anyhow::Result<()> {
    std::fs::write(path, serde_json::to_string_pretty(value)? + "\n")
        .with_context(|| format!("writing {}", path.display()))
}

/// Runs the measure the options ask for.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(m) = args.match_m {
        anyhow::ensure!(
            m.is_finite() && m > 0.0,
            "--match-m must be a positive distance, got {m}"
        );
    }
    if args.detector == Detector::Arc && args.model.is_some() {
        anyhow::bail!("--model applies to --detector learned only");
    }
    match &args.recording {
        Some(path) => run_recording(path, &args),
        None => run_test_split(&args),
    }
}

/// Both detectors on leg_tracker's test split, with the range-binned table.
fn run_test_split(args: &Args) -> anyhow::Result<()> {
    check_data_folder(&args.data)?;
    let laser = laser_model(args.laser.as_ref())?;
    let config = detector_config(args.detector_config.as_ref())?;
    let positives = labelled_scans(&args.data, &TEST_POSITIVE_BAGS)?;
    let negatives = negative_scans(&args.data, &TEST_NEGATIVE_TOPICS)?;
    let region = LabelledRegion::leg_tracker();
    let labels: usize = positives.iter().map(|(_, l)| l.len()).sum();
    tether::outln!(
        "test split: {} and {NEGATIVE_BAG} {}: {} labelled scans with {labels} legs, {} scans \
         without people",
        TEST_POSITIVE_BAGS.join(", "),
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
    let mut reports = Vec::new();
    let mut tables = Vec::new();
    for (name, kind) in [
        ("arc", DetectorKind::Arc),
        ("learned", DetectorKind::Learned),
    ] {
        let model = (kind == DetectorKind::Learned)
            .then_some(args.model.as_ref())
            .flatten();
        let mut d = detector(kind, model, &laser, config)?;
        let c = test_split_counts(&mut d, &positives, &negatives, &region);
        let mut windowed = c.labelled_in_window;
        windowed.add(&c.negative);
        let t = windowed.total();
        let lab_fp = c.labelled_in_window.total().false_positives;
        let neg_fp = c.negative.total().false_positives;
        tether::outln!(
            "{name:<8} {:>5} {lab_fp:>9} {neg_fp:>9} {:>5}   {:>9.3} {:>6.3}",
            t.true_positives,
            t.false_negatives,
            t.precision(),
            t.recall()
        )?;
        let mut all = c.labelled;
        all.add(&c.negative);
        let mut report = Report::new(name, args, "legs", EVAL_MATCH_RADIUS_M);
        report.scans = positives.len() + negatives.len();
        report.labelled_scans = positives.len();
        report.empty_scans = negatives.len();
        report.false_positives_on_empty_scans = neg_fp;
        report.false_positives_in_labeller_window = Some(lab_fp);
        report.set_counts(&all);
        tables.push((name, all.table()));
        reports.push(report);
    }
    for (name, table) in tables {
        tether::outln!()?;
        tether::outln!(
            "{name}, by range from the scanner (a label by its range, a false detection by \
             its own); every detection on the labelled scans that finds no leg is false \
             here, wherever it lies (issue 30's measure):"
        )?;
        tether::outln!("{}", table.trim_end())?;
    }
    if let Some(path) = &args.json {
        write_json(path, &reports)?;
    }
    Ok(())
}

/// One detector on a labelled recording ([`score_recording`]).
fn run_recording(path: &Path, args: &Args) -> anyhow::Result<()> {
    let (Some(scan_topic), Some(labels_topic)) = (&args.scan_topic, &args.labels_topic) else {
        anyhow::bail!("a recording needs --scan-topic and --labels-topic");
    };
    let laser = laser_model(args.laser.as_ref())?;
    let config = detector_config(args.detector_config.as_ref())?;
    let (kind, name) = match args.detector {
        Detector::Arc => (DetectorKind::Arc, "arc"),
        Detector::Learned => (DetectorKind::Learned, "learned"),
    };
    let mut d = detector(kind, args.model.as_ref(), &laser, config)?;
    let people = match args.labels {
        LabelKind::Legs => Some(false),
        LabelKind::People => Some(true),
        LabelKind::Auto => None,
    };
    let score = score_recording(
        path,
        scan_topic,
        labels_topic,
        &mut d,
        &LabelChoice {
            people,
            match_m: args.match_m,
            people_match_m: PEOPLE_MATCH_M,
            pairing: args.pairing,
            region: args.region,
        },
    )?;
    let labels = if score.people { "people" } else { "legs" };
    let mut report = Report::new(name, args, labels, score.match_m);
    report.scans = score.scans;
    report.labelled_scans = score.labelled_scans;
    report.unlabelled_scans = score.unlabelled_scans;
    report.label_messages = score.label_messages;
    report.unpaired_label_messages = score.unpaired_label_messages;
    report.doubly_labelled_scans = score.doubly_labelled_scans;
    report.skipped_messages = score.skipped_messages;
    report.malformed_beams = score.malformed_beams;
    report.set_counts(&score.counts);
    anyhow::ensure!(
        report.labelled_scans > 0,
        "no scan of {scan_topic} got a label from {labels_topic} ({} label messages): check \
         the topics and --pairing",
        score.label_messages
    );
    print_recording(path, scan_topic, labels_topic, args, &report, &score.counts)?;
    if let Some(json) = &args.json {
        write_json(json, &report)?;
    }
    Ok(())
}

fn print_recording(
    path: &Path,
    scan_topic: &str,
    labels_topic: &str,
    args: &Args,
    r: &Report,
    counts: &RangeCounts,
) -> anyhow::Result<()> {
    tether::outln!(
        "{}: {} scans of {scan_topic}, {} labelled by {labels_topic} ({} label messages, {} \
         unpaired, {} scans labelled more than once), {} without labels (not scored)",
        path.display(),
        r.scans,
        r.labelled_scans,
        r.label_messages,
        r.unpaired_label_messages,
        r.doubly_labelled_scans,
        r.unlabelled_scans
    )?;
    if r.skipped_messages > 0 {
        tether::outln!(
            "skipped {} messages that did not decode (the first reasons are in the log)",
            r.skipped_messages
        )?;
    }
    if r.malformed_beams > 0 {
        tether::outln!(
            "{} beams were NaN or negative and were read as no return",
            r.malformed_beams
        )?;
    }
    let region = match &args.region {
        Some(g) => format!(
            "unmatched detections count as false only between {:.1} and {:.1} deg and under {} m",
            g.min_bearing_rad.to_degrees(),
            g.max_bearing_rad.to_degrees(),
            g.max_range_m
        ),
        None => "every unmatched detection counts as false".to_string(),
    };
    tether::outln!(
        "{} detector{}, the labels are {}: a detection within {} m finds one (one to one); \
         {region}",
        r.detector,
        match &args.model {
            Some(m) if r.detector == "learned" => format!(" (model {})", m.display()),
            _ => String::new(),
        },
        r.labels,
        r.match_m
    )?;
    tether::outln!()?;
    tether::outln!("{}", counts.table().trim_end())?;
    Ok(())
}
