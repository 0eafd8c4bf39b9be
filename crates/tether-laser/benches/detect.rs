//! Detection and pairing of one 682-beam URG-04LX scan (issue 3: under 50 us median on
//! one core). The scan is synthetic (a room, two walkers, a table; 7 mm range noise)
//! so that the benchmark needs no recordings.
//!
//! `*_real` benchmarks run on the 435 scans of `/rear_scan` of leg_tracker's
//! `negative_2.bag` (a UHG-08LX in a cluttered room), one scan per iteration in turn,
//! so that the median is that of a real scan: `*_real_768` as recorded (768 beams over
//! 270 deg, 20-25 candidate clusters a scan), `*_real_urg` as the paper's URG-04LX
//! would see the same room: both scanners step 360/1024 deg, so the URG-04LX's 683
//! beams over 240 deg are the middle 683 of the 768, and its 5.6 m range limit turns
//! farther returns into "no return" (about 12 candidates a scan). Without `../shared`
//! beside the checkout they say so and measure nothing.
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
use tether_laser::{Detection, DetectorConfig, LegClassifier, LegDetector};
use tether_recording::rosbag::read_scans;

fn main() {
    divan::main();
}

fn scan() -> LaserScan {
    let scan = synthetic::urg_scan(&synthetic::office_circles(), 0.007, 1);
    assert_eq!(scan.len(), 682);
    scan
}

/// Detects in `scans` in turn, one scan per iteration (none if `scans` is empty), after
/// one scan to size the detector's buffers.
fn run(bencher: Bencher, mut detector: LegDetector, scans: &[LaserScan]) {
    let mut out = Detection::default();
    if let Some(first) = scans.first() {
        detector.detect_into(first, &mut out);
    }
    let mut next = 0;
    bencher.bench_local(|| {
        if let Some(scan) = scans.get(next % scans.len().max(1)) {
            detector.detect_into(black_box(scan), &mut out);
        }
        next += 1;
        black_box(out.people.len())
    });
}

/// The learned classifier: features of every candidate, boosted trees, pairing.
#[divan::bench]
fn learned(bencher: Bencher) {
    run(bencher, learned_detector(), &[scan()]);
}

/// The paper's arc test and pairing.
#[divan::bench]
fn arc(bencher: Bencher) {
    run(bencher, arc_detector(), &[scan()]);
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

/// URG-04LX: 683 beams, range limit 5.6 m.
const URG_BEAMS: usize = 683;
const URG_RANGE_MAX_M: f32 = 5.6;

/// `scan` as a URG-04LX at the same place would see it: the middle [`URG_BEAMS`]
/// beams, returns beyond [`URG_RANGE_MAX_M`] dropped.
fn as_urg(scan: &LaserScan) -> LaserScan {
    let skip = scan.len().saturating_sub(URG_BEAMS) / 2;
    let ranges = scan.ranges_m()[skip..]
        .iter()
        .take(URG_BEAMS)
        .map(|&r| {
            if r <= URG_RANGE_MAX_M {
                r
            } else {
                f32::INFINITY
            }
        })
        .collect();
    LaserScan::new(
        scan.stamp,
        scan.frame_id.clone(),
        scan.angle_rad(skip),
        scan.angle_increment_rad,
        0.02,
        f64::from(URG_RANGE_MAX_M),
        ranges,
    )
    .unwrap()
}

fn learned_detector() -> LegDetector {
    let model = LegClassifier::default_model().unwrap();
    LegDetector::learned(DetectorConfig::default(), RangeNoiseModel::default(), model).unwrap()
}

fn arc_detector() -> LegDetector {
    LegDetector::arc(DetectorConfig::default(), RangeNoiseModel::default()).unwrap()
}

/// The learned classifier on the real cluttered scans as recorded, 768 beams.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn learned_real_768(bencher: Bencher) {
    run(bencher, learned_detector(), &real_scans());
}

/// The arc test on the real cluttered scans as recorded, 768 beams.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn arc_real_768(bencher: Bencher) {
    run(bencher, arc_detector(), &real_scans());
}

/// The learned classifier on the real cluttered scans as a URG-04LX sees them.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn learned_real_urg(bencher: Bencher) {
    let scans: Vec<LaserScan> = real_scans().iter().map(as_urg).collect();
    run(bencher, learned_detector(), &scans);
}

/// The arc test on the real cluttered scans as a URG-04LX sees them.
#[divan::bench(sample_size = 1, sample_count = 4350)]
fn arc_real_urg(bencher: Bencher) {
    let scans: Vec<LaserScan> = real_scans().iter().map(as_urg).collect();
    run(bencher, arc_detector(), &scans);
}

/// A scan at the beam cap ([`tether_core::MAX_BEAMS`], 16,384 over 270 deg) whose ranges
/// alternate between 0.03 m and 0.25 m: every beam is its own run, and the near half
/// are all within reach of each other (the window of a return nearer than the
/// clustering distance is unbounded). The worst case of the clustering, which the
/// cap keeps to a fraction of a second.
fn adversarial(ranges: impl Fn(usize) -> f32) -> LaserScan {
    let n = tether_core::MAX_BEAMS;
    let inc = 1.5 * std::f64::consts::PI / n as f64;
    let ranges = (0..n).map(ranges).collect();
    LaserScan::new(
        tether_core::Stamp::ZERO,
        "laser",
        -2.36,
        inc,
        0.02,
        30.0,
        ranges,
    )
    .unwrap()
}

#[divan::bench(sample_count = 10)]
fn arc_cap_alternating_near(bencher: Bencher) {
    let scan = adversarial(|i| if i % 2 == 0 { 0.03 } else { 0.25 });
    run(bencher, arc_detector(), &[scan]);
}

/// The cap's beams with pseudo-random ranges of 0.5-5 m (clutter everywhere).
#[divan::bench(sample_count = 10)]
fn arc_cap_random(bencher: Bencher) {
    let scan = adversarial(|i| {
        0.5 + 4.5 * ((i as u64).wrapping_mul(2_654_435_761) % 1000) as f32 / 1000.0
    });
    run(bencher, arc_detector(), &[scan]);
}
