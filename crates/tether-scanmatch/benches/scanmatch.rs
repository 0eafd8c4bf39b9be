//! One 682-beam URG-04LX scan matched against a keyframe (issue 14: at most 30 us per
//! scan). The scans are ray-cast in the synthetic room with 1 cm range noise, so the
//! benchmark needs no recordings.
//!
//! - `match_against_keyframe`: PL-ICP of one scan moved 8 cm and 3 deg against a
//!   prepared keyframe (the per-scan cost between keyframes).
//! - `build_keyframe`: preparing a scan as a keyframe (line fits, direction table),
//!   paid once every 0.3 m / 0.2 rad.
//! - `update_while_driving`: `ScanMatcher::update` over a drive of 40 scans at
//!   1 m/s, keyframes included: the cost a pipeline tick pays on average.
//! - `match_brute_force`: the same match with brute-force neighbours, for scale.
//!
//! Run: `cargo bench -p tether-scanmatch --bench scanmatch`.

#![allow(
    clippy::unwrap_used,
    reason = "benchmark set-up: a failed unwrap is a failed run"
)]

use divan::{Bencher, black_box};
use tether_core::{LaserModel, Pose2, Robot, Stamp, World};
use tether_scanmatch::synthetic::Scene;
use tether_scanmatch::{
    IcpConfig, IcpScratch, MotionPrior, NeighbourSearch, Reference, ScanMatcher, ScanMatcherConfig,
    ScanPoints, match_scan,
};

fn main() {
    divan::main();
}

fn pair() -> (ScanPoints, ScanPoints) {
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let a = Pose2::<World, Robot>::new(0.0, 0.0, 0.3);
    let b = a * Pose2::<Robot, Robot>::new(0.08, 0.01, 3f64.to_radians());
    (
        scene.urg_points(&model, a, 0.01, 1),
        scene.urg_points(&model, b, 0.01, 2),
    )
}

fn run_match(bencher: Bencher, search: NeighbourSearch) {
    let (first, second) = pair();
    assert!(second.len() > 600, "{} returns", second.len());
    let config = IcpConfig::default();
    let reference = Reference::build(&first, &config.lines, |_| true);
    let prior = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]];
    let mut scratch = IcpScratch::default();
    // A constant-velocity guess: the previous step, 1 cm and 0.5 deg off.
    let guess = Pose2::new(0.07, 0.0, 2.5f64.to_radians());
    bencher.bench_local(|| {
        match_scan(
            black_box(&reference),
            black_box(second.points()),
            guess,
            &prior,
            &config,
            search,
            &mut scratch,
        )
        .unwrap()
    });
}

#[divan::bench]
fn match_against_keyframe(bencher: Bencher) {
    run_match(bencher, NeighbourSearch::AngularWindow);
}

#[divan::bench(sample_count = 20)]
fn match_brute_force(bencher: Bencher) {
    run_match(bencher, NeighbourSearch::BruteForce);
}

#[divan::bench]
fn build_keyframe(bencher: Bencher) {
    let (first, _) = pair();
    let config = IcpConfig::default();
    let mut reference = Reference::default();
    bencher.bench_local(|| {
        reference.rebuild(black_box(&first), &config.lines, |_| true);
        reference.len()
    });
}

#[divan::bench]
fn update_while_driving(bencher: Bencher) {
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let step = Pose2::<Robot, Robot>::new(0.1, 0.0, 0.02);
    let mut pose = Pose2::<World, Robot>::new(-1.5, -0.8, 0.2);
    let scans: Vec<ScanPoints> = (0..40)
        .map(|i| {
            let s = scene.urg_points(&model, pose, 0.01, 10 + i);
            pose = pose * step;
            s
        })
        .collect();
    let mut matcher = ScanMatcher::new(ScanMatcherConfig::default());
    let mut i = 0usize;
    bencher.bench_local(|| {
        if i.is_multiple_of(scans.len()) {
            matcher.reset();
        }
        let e = matcher.update(
            Stamp::from_ns(i as i64 * 100_000_000),
            black_box(&scans[i % scans.len()]),
            MotionPrior::ConstantVelocity,
            &[],
        );
        i += 1;
        e.matched_points
    });
}
