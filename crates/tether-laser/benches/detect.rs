//! Detection and pairing of one 682-beam URG-04LX scan (issue 3: under 50 us median on
//! one core). The scan is synthetic (a room, two walkers, a table; 7 mm range noise)
//! so that the benchmark needs no recordings.
//!
//! Run: `cargo bench -p tether-laser --bench detect`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up: a failed unwrap is a failed run"
)]

#[path = "../tests/support/synthetic.rs"]
mod synthetic;

use divan::{Bencher, black_box};
use tether_core::{LaserScan, RangeNoiseModel};
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
