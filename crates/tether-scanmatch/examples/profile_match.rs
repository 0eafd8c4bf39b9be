//! Times one synthetic 682-beam match many times and prints its iterations, for
//! profiling: `cargo run --release -p tether-scanmatch --example profile_match`.

#![allow(clippy::unwrap_used, reason = "a profiling tool: fail loudly")]

use std::time::Instant;

use tether_core::Stamp;
use tether_core::{LaserModel, Pose2, Robot, World};
use tether_scanmatch::synthetic::Scene;
use tether_scanmatch::{
    IcpConfig, IcpScratch, MotionPrior, NeighbourSearch, Reference, ScanMatcher, ScanMatcherConfig,
    match_scan,
};

/// CPU time this thread has run, s (Linux `schedstat`), so that other processes on a
/// shared machine do not count; wall time where it is not available.
fn cpu_s(wall: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or_else(|| wall.elapsed().as_secs_f64(), |ns| ns * 1e-9)
}

fn main() {
    let wall = Instant::now();
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let a = Pose2::<World, Robot>::new(0.0, 0.0, 0.3);
    let b = a * Pose2::<Robot, Robot>::new(0.08, 0.01, 3f64.to_radians());
    let first = scene.urg_points(&model, a, 0.01, 1);
    let second = scene.urg_points(&model, b, 0.01, 2);
    let mut config = IcpConfig::default();
    let mut mconfig = ScanMatcherConfig::default();
    for kv in std::env::args().skip(1) {
        let (k, v) = kv.split_once('=').unwrap();
        let x: f64 = v.parse().unwrap();
        match k {
            "tol" => {
                config.translation_tolerance_m = x;
                config.rotation_tolerance_rad = x;
            }
            "reuse" => {
                config.reuse_correspondences_below_m = x;
                config.reuse_correspondences_below_rad = x;
            }
            "spacing" => mconfig.min_point_spacing_m = x,
            "iters" => config.max_iterations = x as u32,
            _ => panic!("unknown key {k}"),
        }
    }
    mconfig.icp = config.clone();
    let reference = Reference::build(&first, &config.lines, |_| true);
    let prior = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]];
    let mut scratch = IcpScratch::default();
    let guess = Pose2::new(0.07, 0.0, 2.5f64.to_radians());
    // `DRIVE_ONLY=1` skips the single-match timing (for a profiler).
    let n = if std::env::var("DRIVE_ONLY").is_ok() {
        1
    } else {
        2000
    };
    let t = cpu_s(wall);
    let mut r = None;
    for _ in 0..n {
        r = Some(
            match_scan(
                &reference,
                second.points(),
                guess,
                &prior,
                &config,
                NeighbourSearch::AngularWindow,
                &mut scratch,
            )
            .unwrap(),
        );
    }
    let per = (cpu_s(wall) - t) / n as f64;
    let r = r.unwrap();
    println!(
        "{:.1} us (CPU) per match, {} iterations, {} points, {} matched, {} rows used",
        per * 1e6,
        r.iterations,
        second.len(),
        r.matched,
        r.used
    );
    let t = cpu_s(wall);
    let mut rebuilt = Reference::default();
    for _ in 0..n {
        rebuilt.rebuild(&first, &config.lines, |_| true);
    }
    println!(
        "{:.1} us (CPU) per keyframe build ({} returns)",
        (cpu_s(wall) - t) / n as f64 * 1e6,
        rebuilt.len()
    );
    // `ScanMatcher::update` (which spaces the points and renews keyframes) over a drive
    // of 40 scans at 1 m/s turning at 0.2 rad/s, repeated.
    let step = Pose2::<Robot, Robot>::new(0.1, 0.0, 0.02);
    let mut pose = Pose2::<World, Robot>::new(-1.5, -0.8, 0.2);
    let scans: Vec<_> = (0..40)
        .map(|i| {
            let s = scene.urg_points(&model, pose, 0.01, 10 + i);
            pose = pose * step;
            s
        })
        .collect();
    let mut matcher = ScanMatcher::new(mconfig);
    let t = cpu_s(wall);
    let mut iterations = 0u64;
    let mut keyframes = 0u64;
    let mut matched_sum = 0u64;
    let rounds = if n == 1 { 200 } else { 50 };
    for round in 0..rounds {
        matcher.reset();
        for (i, scan) in scans.iter().enumerate() {
            let stamp = Stamp::from_ns((round * 100 + i as i64) * 100_000_000);
            let e = matcher.update(stamp, scan, MotionPrior::ConstantVelocity, &[]);
            iterations += u64::from(e.iterations);
            keyframes += u64::from(e.new_keyframe);
            matched_sum += e.matched_points as u64;
        }
    }
    let updates = (rounds as usize * scans.len()) as f64;
    println!(
        "{:.1} us (CPU) per update while driving ({:.2} iterations, {:.2} keyframes, {:.0} points matched per scan)",
        (cpu_s(wall) - t) / updates * 1e6,
        iterations as f64 / updates,
        keyframes as f64 / updates,
        matched_sum as f64 / updates
    );
}
