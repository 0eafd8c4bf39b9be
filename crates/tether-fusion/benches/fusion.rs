//! One tick of gating, fusion and tracking with 10 people and 30 leg candidates
//! (issue goal: under 20 us).
//!
//! 30 leg candidates are the 20 legs of 10 walking people and 10 furniture legs; pairing
//! turns them into 10 person observations and 5 leg-pair look-alikes. The camera sees
//! the 10 people. One tick: per-frame gating and Covariance Intersection of vision and
//! laser, association and Kalman updates of every track, and the target selector.
//!
//! `cargo bench -p tether-fusion --bench fusion`

use tether_core::{Cov2, Gaussian2, Point2, Pose2, Stamp, World};
use tether_fusion::{
    FusionRule, Gate, MotionBounds, Observation, Source, TargetConfig, TargetSelector, Tracker,
    TrackerConfig, complementary_fusion,
};

fn main() {
    divan::main();
}

/// Deterministic pseudo-random numbers for the scene.
fn lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

fn people(k: usize) -> Vec<Point2<World>> {
    (0..10)
        .map(|i| {
            let t = k as f64 * 0.1;
            let (x0, y0) = (1.0 + 0.6 * i as f64, -3.0 + 0.7 * i as f64);
            Point2::new(x0 + 0.3 * (t + i as f64).sin(), y0 + 0.8 * t.cos())
        })
        .collect()
}

fn g(p: Point2<World>, a: f64, b: f64, angle: f64) -> Gaussian2<World> {
    Gaussian2::new(p, Cov2::from_axes(a, b, angle).expect("valid")).expect("finite")
}

#[divan::bench]
fn tick_10_people_30_leg_candidates(bencher: divan::Bencher) {
    let mut rng = 7u64;
    // Pre-built frames: 10 laser people + 5 static look-alikes, 10 vision people.
    let clutter: Vec<Point2<World>> = (0..5)
        .map(|_| Point2::new(8.0 * lcg(&mut rng), -4.0 + 8.0 * lcg(&mut rng)))
        .collect();
    // (laser people, vision people) of each frame.
    type Frame = (Vec<Gaussian2<World>>, Vec<Gaussian2<World>>);
    let frames: Vec<Frame> = (0..100)
        .map(|k| {
            let ps = people(k);
            let mut laser: Vec<Gaussian2<World>> = ps
                .iter()
                .map(|p| {
                    g(
                        Point2::new(p.x + 0.03 * lcg(&mut rng), p.y),
                        0.05,
                        0.04,
                        0.3,
                    )
                })
                .collect();
            for c in &clutter {
                laser.push(g(
                    Point2::new(c.x + 0.01 * lcg(&mut rng), c.y),
                    0.05,
                    0.05,
                    0.0,
                ));
            }
            let vision = ps
                .iter()
                .map(|p| {
                    g(
                        Point2::new(p.x + 0.2 * lcg(&mut rng), p.y),
                        0.3,
                        0.04,
                        p.y.atan2(p.x),
                    )
                })
                .collect();
            (laser, vision)
        })
        .collect();
    let mut tracker = Tracker::new(TrackerConfig::default()).expect("valid");
    let mut selector = TargetSelector::new(TargetConfig::default(), MotionBounds::default());
    let mut k = 0usize;
    bencher.bench_local(|| {
        let (laser, vision) = &frames[k % frames.len()];
        let stamp = Stamp::from_ns(k as i64 * 100_000_000);
        k += 1;
        let fused =
            complementary_fusion(vision, laser, &Gate::default(), FusionRule::CiDeterminant);
        let obs: Vec<Observation> = fused
            .iter()
            .map(|f| Observation {
                source: Source::Fused,
                ..Observation::laser(f.estimate, true, true)
            })
            .chain(
                laser
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| !fused.iter().any(|f| f.laser == *i))
                    .map(|(_, l)| Observation::laser(*l, true, true)),
            )
            .collect();
        tracker.process(stamp, &obs);
        divan::black_box(selector.update(stamp, tracker.tracks(), Pose2::IDENTITY))
    });
}
