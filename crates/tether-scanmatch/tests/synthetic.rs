//! Matching on ray-cast scenes with a known motion: the room is recovered to a centimetre
//! and half a degree, the corridor is flagged degenerate, people in exclusion zones do
//! not pull, and the fast neighbour search gives the brute-force result.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use proptest::prelude::*;
use tether_core::{LaserModel, Point2, Pose2, Robot, Stamp, World};
use tether_scanmatch::synthetic::Scene;
use tether_scanmatch::{
    ExclusionZone, IcpConfig, IcpScratch, MotionPrior, NeighbourSearch, Quality, Reference,
    ScanMatcher, ScanMatcherConfig, match_scan,
};

const SIGMA_M: f64 = 0.01;

fn stamp(i: i64) -> Stamp {
    Stamp::from_ns(i * 100_000_000)
}

/// Matches a scan at `b` against one at `a` (both world_from_robot), from a guess of no
/// motion, and returns the estimated and true `a_from_b`.
fn match_pair(
    scene: &Scene,
    a: Pose2<World, Robot>,
    b: Pose2<World, Robot>,
    search: NeighbourSearch,
) -> (tether_scanmatch::MatchResult, Pose2<Robot, Robot>) {
    match_pair_seeded(scene, a, b, search, (1, 2))
}

/// [`match_pair`] with the scans' noise drawn from `seeds`.
fn match_pair_seeded(
    scene: &Scene,
    a: Pose2<World, Robot>,
    b: Pose2<World, Robot>,
    search: NeighbourSearch,
    seeds: (u64, u64),
) -> (tether_scanmatch::MatchResult, Pose2<Robot, Robot>) {
    let model = LaserModel::urg_04lx();
    let first = scene.urg_points(&model, a, SIGMA_M, seeds.0);
    let second = scene.urg_points(&model, b, SIGMA_M, seeds.1);
    let config = IcpConfig::default();
    let reference = Reference::build(&first, &config.lines, |_| true);
    let prior = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]];
    let r = match_scan(
        &reference,
        second.points(),
        Pose2::IDENTITY,
        &prior,
        &config,
        search,
        &mut IcpScratch::default(),
    )
    .unwrap();
    (r, a.inverse() * b)
}

#[test]
fn room_motion_is_recovered_within_a_centimetre_and_half_a_degree() {
    let scene = Scene::room();
    let a = Pose2::new(0.0, 0.0, 0.3);
    for (dx, dy, dyaw) in [
        (0.10, 0.0, 0.0),
        (0.15, -0.05, 0.08),
        (-0.05, 0.12, -0.15),
        (0.0, 0.0, 0.2),
        (0.2, 0.1, 0.1),
    ] {
        let b = a * Pose2::<Robot, Robot>::new(dx, dy, dyaw);
        let (r, truth) = match_pair(&scene, a, b, NeighbourSearch::AngularWindow);
        let e = truth.inverse() * r.keyframe_from_robot;
        println!(
            "room, motion ({dx}, {dy}, {dyaw}): error {:.2} mm, {:.3} deg, {} iterations",
            1e3 * e.x.hypot(e.y),
            e.yaw.to_degrees(),
            r.iterations
        );
        assert!(
            e.x.hypot(e.y) < 0.01 && e.yaw.abs() < 0.5f64.to_radians(),
            "motion ({dx}, {dy}, {dyaw}): error {e:?}, {r:?}"
        );
        assert_eq!(r.degenerate_directions, 0, "{r:?}");
        assert!(r.converged);
        // The covariance is positive and small.
        assert!(r.covariance[0][0] > 0.0 && r.covariance[0][0].sqrt() < 0.01);
        assert!(r.covariance[2][2] > 0.0 && r.covariance[2][2].sqrt() < 0.01);
    }
}

#[test]
fn corridor_is_flagged_degenerate_and_keeps_the_prior_along_it() {
    let scene = Scene::corridor();
    let a = Pose2::new(0.0, 0.0, 0.0);
    let b = a * Pose2::<Robot, Robot>::new(0.2, 0.05, 0.03);
    let (r, truth) = match_pair(&scene, a, b, NeighbourSearch::AngularWindow);
    assert_eq!(r.degenerate_directions, 1, "{r:?}");
    // The unconstrained direction is the corridor's axis (x).
    assert!(r.eigenvectors[0][0].abs() > 0.95, "{:?}", r.eigenvectors);
    // Across the corridor and in yaw the scan decides; along it the guess (0) stays.
    assert!((r.keyframe_from_robot.y - truth.y).abs() < 0.01, "{r:?}");
    assert!((r.keyframe_from_robot.yaw - truth.yaw).abs() < 0.5f64.to_radians());
    assert!(r.keyframe_from_robot.x.abs() < 0.02, "{r:?}");
    // Its variance along the corridor is the prior's, not the scan's.
    assert!(
        (r.covariance[0][0] - 0.01).abs() < 0.002,
        "{:?}",
        r.covariance
    );
    assert!(r.covariance[1][1] < 1e-4);

    // The room is not degenerate from the same motion.
    let (room, _) = match_pair(&Scene::room(), a, b, NeighbourSearch::AngularWindow);
    assert_eq!(room.degenerate_directions, 0);
    assert!(room.eigenvalues[0] > 5.0 * IcpConfig::default().degeneracy_min_eigenvalue);
}

/// A room with a crowd that walks along with the robot: without exclusion the crowd
/// drags the estimate; with zones around them the estimate is right.
#[test]
fn points_in_exclusion_zones_are_ignored() {
    let model = LaserModel::urg_04lx();
    let base = Scene::room();
    let world_from_a = Pose2::<World, Robot>::new(0.0, 0.0, 0.0);
    let truth = Pose2::<Robot, Robot>::new(0.12, 0.0, 0.0);
    let world_from_b = world_from_a * truth;
    // Four people ahead walking with the robot: to the matcher they say "no motion".
    let people_a: Vec<Point2<World>> = [(1.2, -0.9), (1.5, -0.3), (1.3, 0.4), (1.6, 1.0)]
        .iter()
        .map(|&(x, y)| Point2::new(x, y))
        .collect();
    let people_b: Vec<Point2<World>> = people_a
        .iter()
        .map(|p| Point2::new(p.x + 0.12, p.y))
        .collect();
    let with_people = |people: &[Point2<World>]| {
        let mut s = base.clone();
        for &p in people {
            // A short wall segment facing the robot: a body-sized flat target.
            s.walls
                .push((Point2::new(p.x, p.y - 0.15), Point2::new(p.x, p.y + 0.15)));
        }
        s
    };
    let scan_a = with_people(&people_a).urg_points(&model, world_from_a, SIGMA_M, 3);
    let scan_b = with_people(&people_b).urg_points(&model, world_from_b, SIGMA_M, 4);
    let zones = |people: &[Point2<World>], world_from_robot: Pose2<World, Robot>| {
        people
            .iter()
            .map(|&p| ExclusionZone {
                center: world_from_robot.inverse() * p,
                radius_m: 0.35,
            })
            .collect::<Vec<_>>()
    };
    let run = |exclude: bool| {
        let mut m = ScanMatcher::new(ScanMatcherConfig::default());
        let za = if exclude {
            zones(&people_a, world_from_a)
        } else {
            vec![]
        };
        let zb = if exclude {
            zones(&people_b, world_from_b)
        } else {
            vec![]
        };
        m.update(stamp(0), &scan_a, MotionPrior::Stationary, &za);
        m.update(stamp(1), &scan_b, MotionPrior::Stationary, &zb)
    };
    let excluded = run(true);
    assert!(excluded.excluded_points > 50, "{excluded:?}");
    let e = truth.inverse() * excluded.robot_from_robot;
    assert!(e.x.hypot(e.y) < 0.01, "with exclusion: {excluded:?}");
    let dragged = run(false);
    let e_dragged = truth.inverse() * dragged.robot_from_robot;
    println!(
        "four walkers ahead: error {:.1} mm with exclusion, {:.1} mm without",
        1e3 * e.x.hypot(e.y),
        1e3 * e_dragged.x.hypot(e_dragged.y)
    );
    assert!(
        e_dragged.x.hypot(e_dragged.y) > 2.0 * e.x.hypot(e.y),
        "the crowd should have pulled without exclusion: {dragged:?} vs {excluded:?}"
    );
}

#[test]
fn a_drive_through_the_room_accumulates_little_drift() {
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let mut m = ScanMatcher::new(ScanMatcherConfig::default());
    // A circle of 1 m radius inside the room, 4 m long.
    let start = Pose2::<World, Robot>::new(0.5, -0.5, 0.0);
    let step = Pose2::<Robot, Robot>::new(0.04, 0.0, 0.04);
    let mut truth = start;
    let mut distance_m = 0.0;
    let mut last = None;
    for i in 0..100 {
        let scan = scene.urg_points(&model, truth, SIGMA_M, 100 + i as u64);
        let e = m.update(stamp(i), &scan, MotionPrior::ConstantVelocity, &[]);
        assert!(!matches!(e.quality, Quality::PriorOnly(_)), "{i}: {e:?}");
        last = Some(e);
        truth = truth * step;
        distance_m += 0.04;
    }
    let e = last.unwrap();
    let true_last = start.inverse() * (truth * step.inverse());
    let est = Pose2::<Robot, Robot>::new(
        e.world_from_robot.x,
        e.world_from_robot.y,
        e.world_from_robot.yaw,
    );
    let err = true_last.inverse() * est;
    let drift = err.x.hypot(err.y) / (distance_m - 0.04);
    assert!(drift < 0.01, "drift {drift}: {err:?}");
    assert!(m.counts().keyframes >= 10, "{:?}", m.counts());
}

#[test]
fn bad_input_is_reported_not_panicked_on() {
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let scan = scene.urg_points(&model, Pose2::IDENTITY, SIGMA_M, 1);
    let mut m = ScanMatcher::new(ScanMatcherConfig::default());
    assert_eq!(
        m.update(stamp(5), &scan, MotionPrior::ConstantVelocity, &[])
            .quality,
        Quality::First
    );
    let e = m.update(stamp(5), &scan, MotionPrior::ConstantVelocity, &[]);
    assert_eq!(
        e.quality,
        Quality::PriorOnly(tether_scanmatch::Failure::StampNotIncreasing)
    );
    // An empty scan: the prior carries the pose, and the next good scan matches again.
    let empty = tether_scanmatch::ScanPoints::default();
    let e = m.update(
        stamp(6),
        &empty,
        MotionPrior::Velocity {
            v_mps: 1.0,
            w_radps: 0.0,
        },
        &[],
    );
    assert_eq!(
        e.quality,
        Quality::PriorOnly(tether_scanmatch::Failure::TooFewPoints)
    );
    assert!((e.world_from_robot.x - 0.1).abs() < 1e-9);
    // Everything excluded.
    let all = [ExclusionZone {
        center: Point2::new(0.0, 0.0),
        radius_m: 100.0,
    }];
    let e = m.update(stamp(7), &scan, MotionPrior::Stationary, &all);
    assert!(matches!(e.quality, Quality::PriorOnly(_)));
    // A gap of 10 s resets the constant-velocity prior.
    let e = m.update(stamp(107), &scan, MotionPrior::ConstantVelocity, &[]);
    assert!(e.prior_reset);
    assert_eq!(m.counts().stamps_not_increasing, 1);
    // After the failures the matcher recovers: the keyframe was renewed.
    let e = m.update(stamp(108), &scan, MotionPrior::ConstantVelocity, &[]);
    assert_eq!(e.quality, Quality::Good, "{e:?}");
    assert!(e.robot_from_robot.x.abs() < 1e-3, "{e:?}");
    // A bad mount or bad beams are refused when the points are made, not in update.
    assert!(
        tether_scanmatch::ScanPoints::from_polar(&[0.0, 7.0], &[1.0, 1.0], Pose2::IDENTITY)
            .is_err()
    );
}

/// The same scans give bit-identical estimates.
#[test]
fn estimates_are_deterministic() {
    let model = LaserModel::urg_04lx();
    let scene = Scene::room();
    let run = || {
        let mut m = ScanMatcher::new(ScanMatcherConfig::default());
        let mut pose = Pose2::<World, Robot>::new(0.5, -0.5, 0.0);
        let mut out = Vec::new();
        for i in 0..20 {
            let scan = scene.urg_points(&model, pose, SIGMA_M, 50 + i as u64);
            let e = m.update(stamp(i), &scan, MotionPrior::ConstantVelocity, &[]);
            out.push(format!(
                "{:?}",
                (e.world_from_robot, e.world_covariance, e.quality)
            ));
            pose = pose * Pose2::<Robot, Robot>::new(0.06, 0.0, 0.03);
        }
        out
    };
    assert_eq!(run(), run());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    /// The whole match with the direction search equals the match with brute-force
    /// nearest neighbours, for random motions in the room.
    #[test]
    fn fast_search_matches_brute_force(
        dx in -0.2f64..0.2, dy in -0.2f64..0.2, dyaw in -0.2f64..0.2,
        x in -1.0f64..1.0, y in -1.0f64..1.0, yaw in -3.1f64..3.1,
    ) {
        let scene = Scene::room();
        let a = Pose2::new(x, y, yaw);
        let b = a * Pose2::<Robot, Robot>::new(dx, dy, dyaw);
        let (fast, _) = match_pair(&scene, a, b, NeighbourSearch::AngularWindow);
        let (slow, _) = match_pair(&scene, a, b, NeighbourSearch::BruteForce);
        prop_assert_eq!(fast.matched, slow.matched);
        prop_assert_eq!(fast.iterations, slow.iterations);
        let (f, s) = (fast.keyframe_from_robot, slow.keyframe_from_robot);
        prop_assert!((f.x - s.x).abs() < 1e-9 && (f.y - s.y).abs() < 1e-9 && (f.yaw - s.yaw).abs() < 1e-9,
            "{:?} vs {:?}", f, s);
    }
}

/// How honest the covariance is: the normalised estimation error squared
/// `e^T Sigma^-1 e` over 200 noisy room matches, whose mean is 3 for a consistent 3-DOF
/// estimate. The Hessian estimate ignores the error of the keyframe's own lines, so it
/// is optimistic; the test bounds by how much, so that a regression shows.
#[test]
fn covariance_is_within_a_known_factor_of_the_errors() {
    let scene = Scene::room();
    let mut nees_sum = 0.0;
    let runs = 200;
    for seed in 0..runs {
        let a = Pose2::<World, Robot>::new(0.0, 0.0, 0.01 * seed as f64);
        let b = a * Pose2::<Robot, Robot>::new(0.1, 0.02, 0.03);
        let (r, truth) = match_pair_seeded(
            &scene,
            a,
            b,
            NeighbourSearch::AngularWindow,
            (1000 + 2 * seed, 1001 + 2 * seed),
        );
        let e = truth.inverse() * r.keyframe_from_robot;
        let e = [e.x, e.y, e.yaw];
        // Sigma^-1 e by Cramer's rule (3x3).
        let m = r.covariance;
        let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        assert!(det > 0.0, "{m:?}");
        let inv = [
            [
                m[1][1] * m[2][2] - m[1][2] * m[2][1],
                m[0][2] * m[2][1] - m[0][1] * m[2][2],
                m[0][1] * m[1][2] - m[0][2] * m[1][1],
            ],
            [
                m[1][2] * m[2][0] - m[1][0] * m[2][2],
                m[0][0] * m[2][2] - m[0][2] * m[2][0],
                m[0][2] * m[1][0] - m[0][0] * m[1][2],
            ],
            [
                m[1][0] * m[2][1] - m[1][1] * m[2][0],
                m[0][1] * m[2][0] - m[0][0] * m[2][1],
                m[0][0] * m[1][1] - m[0][1] * m[1][0],
            ],
        ];
        let nees: f64 = (0..3)
            .map(|i| (0..3).map(|j| e[i] * inv[i][j] * e[j]).sum::<f64>())
            .sum::<f64>()
            / det;
        nees_sum += nees;
    }
    let mean = nees_sum / runs as f64;
    println!("room matches: mean NEES {mean:.2} (3 for a consistent covariance)");
    assert!(mean > 2.0 && mean < 16.0, "mean NEES {mean}");
}

#[test]
fn settings_read_from_toml_and_nonsense_is_refused() {
    let config: ScanMatcherConfig = toml::from_str(
        "keyframe_translation_m = 0.5\n[icp]\nhuber_m = 0.02\n[icp.lines]\nhalf_span_m = 0.08\n",
    )
    .unwrap();
    assert_eq!(config.keyframe_translation_m, 0.5);
    assert_eq!(config.icp.huber_m, 0.02);
    assert_eq!(config.icp.lines.half_span_m, 0.08);
    assert_eq!(
        config.icp.max_iterations,
        IcpConfig::default().max_iterations
    );
    assert!(config.validate().is_ok());
    assert!(ScanMatcherConfig::default().validate().is_ok());
    assert!(toml::from_str::<ScanMatcherConfig>("keyframe_translaton_m = 0.5").is_err());
    let mut bad = ScanMatcherConfig::default();
    bad.icp.max_correspondence_m = f64::NAN;
    let e = bad.validate().unwrap_err();
    assert_eq!(e.field, "icp.max_correspondence_m");
    assert!(e.to_string().contains("positive finite"), "{e}");
    let mut bad = ScanMatcherConfig::default();
    bad.icp.trim_fraction = 1.0;
    assert_eq!(bad.validate().unwrap_err().field, "icp.trim_fraction");
    let mut bad = ScanMatcherConfig::default();
    bad.icp.min_matches = 2;
    assert_eq!(bad.validate().unwrap_err().field, "icp.min_matches");
}

/// Outdoors, as far as a scan can tell: no walls, only posts, trunks and bushes (circles
/// of 3-40 cm) scattered about every 2.5 m. Every match is point-to-point on a few
/// objects; a 20 m drive at 1 m/s, turning gently, must still drift under 2 %.
#[test]
fn sparse_outdoor_scene_drifts_under_two_percent() {
    use tether_scanmatch::synthetic::Gauss;
    let model = LaserModel::urg_04lx();
    let mut scene = Scene::default();
    let mut rng = Gauss::new(77);
    for i in 0..16 {
        for j in 0..16 {
            let x = -10.0 + 2.5 * i as f64 + 1.5 * (rng.uniform() - 0.5);
            let y = -10.0 + 2.5 * j as f64 + 1.5 * (rng.uniform() - 0.5);
            let r = 0.03 + 0.37 * rng.uniform() * rng.uniform();
            scene.posts.push((Point2::new(x, y), r));
        }
    }
    let mut m = ScanMatcher::new(ScanMatcherConfig::default());
    let start = Pose2::<World, Robot>::new(-0.3, -0.4, 0.3);
    let step = Pose2::<Robot, Robot>::new(0.1, 0.0, 0.01);
    let mut truth = start;
    let mut last = None;
    let mut degenerate = 0;
    for i in 0..200 {
        let scan = scene.urg_points(&model, truth, SIGMA_M, 500 + i as u64);
        let e = m.update(stamp(i), &scan, MotionPrior::ConstantVelocity, &[]);
        assert!(!matches!(e.quality, Quality::PriorOnly(_)), "{i}: {e:?}");
        degenerate += usize::from(matches!(e.quality, Quality::Degenerate { .. }));
        last = Some((e, truth));
        truth = truth * step;
    }
    let (e, true_last) = last.unwrap();
    let true_rel = start.inverse() * true_last;
    let err_m = (e.world_from_robot.x - true_rel.x).hypot(e.world_from_robot.y - true_rel.y);
    let drift = err_m / (199.0 * 0.1);
    println!(
        "sparse outdoor scene: drift {:.2} % over 19.9 m, {degenerate} degenerate, {:?}",
        100.0 * drift,
        m.counts()
    );
    assert!(drift < 0.02, "drift {drift}");
}

/// A base that cannot slide sideways: in the room, a true sideways step of 0.2 m in one
/// scan interval (2 m/s) is matched exactly, and refused as a motion the robot cannot
/// make, so the estimate falls back to the prior; the same step forward is taken; and
/// a sudden reversal after a trusted forward velocity is refused too.
#[test]
fn matches_the_robot_cannot_make_are_refused() {
    let scene = Scene::room();
    let model = LaserModel::urg_04lx();
    let a = Pose2::<World, Robot>::new(0.0, 0.0, 0.0);
    let run = |step: Pose2<Robot, Robot>| {
        let mut m = ScanMatcher::new(ScanMatcherConfig::default());
        m.update(
            stamp(0),
            &scene.urg_points(&model, a, SIGMA_M, 1),
            MotionPrior::Stationary,
            &[],
        );
        let e = m.update(
            stamp(1),
            &scene.urg_points(&model, a * step, SIGMA_M, 2),
            MotionPrior::Stationary,
            &[],
        );
        (e, m.counts())
    };
    let (sideways, counts) = run(Pose2::new(0.0, 0.2, 0.0));
    assert_eq!(
        sideways.quality,
        Quality::PriorOnly(tether_scanmatch::Failure::Implausible),
        "{sideways:?}"
    );
    assert_eq!(counts.implausible, 1);
    assert_eq!(
        sideways.robot_from_robot,
        Pose2::IDENTITY,
        "the prior (stationary)"
    );
    let (forward, counts) = run(Pose2::new(0.2, 0.0, 0.0));
    assert_eq!(forward.quality, Quality::Good, "{forward:?}");
    assert!((forward.robot_from_robot.x - 0.2).abs() < 0.01);
    assert_eq!(counts.implausible, 0);

    // Driving forward at 1 m/s, then a match 1 m/s backwards one scan later: a
    // reversal at 20 m/s^2.
    let mut m = ScanMatcher::new(ScanMatcherConfig::default());
    let mut pose = a;
    for i in 0..4 {
        m.update(
            stamp(i),
            &scene.urg_points(&model, pose, SIGMA_M, 10 + i as u64),
            MotionPrior::ConstantVelocity,
            &[],
        );
        pose = pose * Pose2::<Robot, Robot>::new(0.1, 0.0, 0.0);
    }
    let back = pose * Pose2::<Robot, Robot>::new(-0.2, 0.0, 0.0);
    let e = m.update(
        stamp(4),
        &scene.urg_points(&model, back, SIGMA_M, 20),
        MotionPrior::ConstantVelocity,
        &[],
    );
    assert_eq!(
        e.quality,
        Quality::PriorOnly(tether_scanmatch::Failure::Implausible),
        "{e:?}"
    );
}
