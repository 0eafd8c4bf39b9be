//! `tether legs`: detect legs and people in every scan of a recording (ROS 1 bag or
//! MCAP) and write them as JSON lines.
//!
//! The recording is read by [`tether_recording::samples`]: a topic that holds no scans, or whose
//! every scan fails to decode, is an error before the output is replaced; a recording
//! cut short is read up to the cut, with a warning.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use serde::Serialize;
use tether::args::{Detector, detector, detector_config, laser_model};
use tether_laser::DetectorKind;
use tether_recording::samples::{self, Sample, Topics};

/// Options of `tether legs`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The recording: a ROS 1 bag (chunks uncompressed, bz2 or lz4) or an MCAP file
    /// (ROS 2).
    pub bag: PathBuf,
    /// The `sensor_msgs/LaserScan` topic, e.g. `/scan`.
    #[arg(long)]
    pub topic: String,
    /// Which leg test to run.
    #[arg(long, value_enum, default_value_t = Detector::Learned)]
    pub detector: Detector,
    /// A leg model from `tether train-legs` (default: the built-in one).
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// A laser config (TOML, as `tether calibrate laser` writes) whose `[noise]`
    /// calibration to apply (default: the uncalibrated URG-04LX model).
    #[arg(long, value_name = "FILE")]
    pub laser: Option<PathBuf>,
    /// A detector config (`tether_laser::DetectorConfig` as JSON or TOML; every field
    /// optional, defaults as documented there).
    #[arg(long, value_name = "FILE")]
    pub detector_config: Option<PathBuf>,
    /// Where to write one JSON line per scan (`-`: standard output).
    #[arg(long, value_name = "FILE.jsonl")]
    pub out: PathBuf,
}

#[derive(Serialize)]
struct LegLine {
    x: f64,
    y: f64,
    radius_m: f64,
    score: f64,
}

#[derive(Serialize)]
struct PersonLine {
    x: f64,
    y: f64,
    cov: [f64; 4],
}

#[derive(Serialize)]
struct ScanLine {
    stamp_ns: i64,
    legs: Vec<LegLine>,
    /// Candidates the classifier nearly accepted (within `weak_margin` of its
    /// threshold): they only keep confirmed tracks alive.
    weak_legs: Vec<LegLine>,
    people: Vec<PersonLine>,
}

/// Writes one line per scan message of the topic, in bag order, including scans in
/// which nothing was found.
pub fn run(args: Args) -> anyhow::Result<()> {
    let kind = match args.detector {
        Detector::Arc => DetectorKind::Arc,
        Detector::Learned => DetectorKind::Learned,
    };
    if kind == DetectorKind::Arc && args.model.is_some() {
        anyhow::bail!("--model applies to --detector learned only");
    }
    let laser = laser_model(args.laser.as_ref())?;
    let config = detector_config(args.detector_config.as_ref())?;
    let mut detector = detector(kind, args.model.as_ref(), &laser, config)?;
    // Replaces an earlier result only if this run succeeds; `-` is stdout.
    let mut out = tether::output::Output::create(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let (mut scans, mut legs, mut people, mut malformed) = (0usize, 0usize, 0usize, 0usize);
    let topics = Topics {
        scan: args.topic.clone(),
        images: Vec::new(),
        odom: None,
    };
    let stats = samples::read(&args.bag, &topics, &mut |sample| {
        let Sample::Scan(scan) = sample else {
            return Ok(());
        };
        malformed += scan.malformed_beams();
        let detection = detector.detect(&scan);
        let leg_line = |l: &tether_laser::Leg| LegLine {
            x: l.centre_in_laser.x,
            y: l.centre_in_laser.y,
            radius_m: l.radius_m,
            score: l.score,
        };
        let line = ScanLine {
            stamp_ns: scan.stamp.ns(),
            legs: detection.legs.iter().map(leg_line).collect(),
            weak_legs: detection.weak_legs.iter().map(leg_line).collect(),
            people: detection
                .people
                .iter()
                .map(|p| PersonLine {
                    x: p.estimate.mean.x,
                    y: p.estimate.mean.y,
                    cov: p.estimate.cov.to_array(),
                })
                .collect(),
        };
        serde_json::to_writer(&mut out, &line)?;
        out.write_all(b"\n")?;
        scans += 1;
        legs += line.legs.len();
        people += line.people.len();
        Ok(())
    })?;
    out.commit()
        .with_context(|| format!("writing {}", args.out.display()))?;
    let skipped = stats.bad_messages + stats.unattributed;
    if skipped > 0 {
        tracing::warn!(
            "skipped {skipped} scan messages that did not decode (the first reasons are above)"
        );
    }
    if malformed > 0 {
        tracing::warn!("{malformed} beams were NaN or negative and were treated as no return");
    }
    tracing::info!(
        "{scans} scans, {legs} legs, {people} people ({:?} detector) written to {}",
        kind,
        args.out.display()
    );
    Ok(())
}
