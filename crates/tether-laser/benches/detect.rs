//! Detection and pairing of one 682-beam URG-04LX scan (issue 3: under 50 us median on
//! one core). The scan is synthetic (a room, two walkers, a table; 7 mm range noise)
//! so that the benchmark needs no recordings.
//!
//! `*_real` benchmarks run on the 435 scans of `/rear_scan` of leg_tracker's
//! `negative_2.bag` (768 beams, a cluttered room: 20-25 candidate clusters a scan), one
//! scan per iteration in turn, so that the median is that of a real scan; without
//! `../shared` beside the checkout they say so and measure nothing.
//!
//! Run: `cargo bench -p tether-laser --bench detect`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up: a failed unwrap is a failed run"
)]

#[path = "../tests/support/synthetic.rs"]
mod synthetic;

use std::path::Path;

use divan::{Bencher, black_box};
use tether_core::{LaserScan, RangeNoiseModel};
use tether_io::rosbag::read_scans;
use tether_laser::{Detection, DetectorConfig, LegClassifier, LegDetector};

fn main() {
    divan::main();
}

fn scan() -> LaserScan {
    let scan = synthetic::urg_scan(&synthetic::office_circles(), 0.007, 1);
    assert_eq!(scan.len(), 682);
    scan
}

fn run(bencher: Bencher, mut detector: LegDetector) {
    let scan = scan();
    let mut out = Detection::default();
    detector.detect_into(&scan, &mut out);
    bencher.bench_local(|| {
        detector.detect_into(black_box(&scan), &mut out);
        black_box(out.people.len())
    });
}

/// The learned classifier: features of every candidate, boosted trees, pairing.
#[divan::bench]
fn learned(bencher: Bencher) {
    let model = LegClassifier::default_model().unwrap();
    run(
        bencher,
        LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model).unwrap(),
    );
}

/// The paper's arc test and pairing.
#[divan::bench]
fn arc(bencher: Bencher) {
    run(
        bencher,
        LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap(),
    );
}

/// The rear scans of leg_tracker's room without people, if `../shared` is there.
fn real_scans() -> Vec<LaserScan> {
    let bag = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/laser/leg_tracker/negative_2.bag");
    match read_scans(&bag, "/rear_scan") {
        Ok(read) => read.scans.into_iter().map(|m| m.scan).collect(),
        Err(e) => {
            eprintln!("SKIPPED: {} unreadable ({e})", bag.display());
            Vec::new()
        }
    }
}

fn run_real(bencher: Bencher, mut detector: LegDetector) {
    let scans = real_scans();
    let mut out = Detection::default();
    let mut next = 0;
    bencher.bench_local(|| {
        if let Some(scan) = scans.get(next % scans.len().max(1)) {
            detector.detect_into(black_box(scan), &mut out);
        }
        next += 1;
        black_box(out.people.len())
    });
}

/// The learned classifier on real cluttered 768-beam scans.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn learned_real(bencher: Bencher) {
    let model = LegClassifier::default_model().unwrap();
    run_real(
        bencher,
        LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model).unwrap(),
    );
}

/// The arc test on real cluttered 768-beam scans.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn arc_real(bencher: Bencher) {
    run_real(
        bencher,
        LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap(),
    );
}
