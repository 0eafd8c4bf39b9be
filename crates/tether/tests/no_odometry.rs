//! A scenario without odometry (`[robot] odometry = false`, issue 14): the closed loop
//! never hands the pipelines the robot's true motion, only the dead reckoning of their
//! own commands, and the measures still compare estimates with the truth relative to
//! the robot.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_eval::closed_loop::{StepKind, config_for, run};
use tether_eval::metrics::measure;
use tether_pipeline::PipelineConfig;
use tether_sim::Scenario;

#[test]
fn outdoor_follow_gives_the_pipeline_dead_reckoning_not_the_truth() {
    let mut scenario = Scenario::builtin("outdoor_follow").unwrap();
    assert!(!scenario.odometry_available());
    scenario.duration_s = 120.0;
    let config = config_for(&scenario, &PipelineConfig::default());
    let log = run(&scenario, 3, &config, &[], &[]).unwrap();
    let scans: Vec<_> = log
        .steps
        .iter()
        .filter(|s| s.kind == StepKind::Scan)
        .collect();
    // The given pose starts at the origin, not at the robot's start (9, 8) in the park.
    let first = scans[0].world_from_robot_given;
    assert!(first.x.abs() < 1e-9 && first.y.abs() < 1e-9, "{first:?}");
    // Driven distance and the gap between the given and the true motion since the start.
    let start_true = scans[0].truth.world_from_robot;
    let mut driven_m = 0.0;
    let mut worst_gap_m: f64 = 0.0;
    for w in scans.windows(2) {
        driven_m += w[0]
            .truth
            .world_from_robot
            .translation()
            .distance_m(w[1].truth.world_from_robot.translation());
        // Where the true robot is relative to its start, against where the given pose
        // says it is relative to the origin.
        let true_rel = start_true.inverse() * w[1].truth.world_from_robot;
        let given = w[1].world_from_robot_given;
        worst_gap_m = worst_gap_m.max((true_rel.x - given.x).hypot(true_rel.y - given.y));
    }
    let last = scans.last().unwrap();
    let true_rel = start_true.inverse() * last.truth.world_from_robot;
    let given = last.world_from_robot_given;
    let end_gap_m = (true_rel.x - given.x).hypot(true_rel.y - given.y);
    println!(
        "outdoor_follow 120 s, seed 3: driven {driven_m:.1} m, dead reckoning off by \
         {end_gap_m:.2} m at the end ({:.1} % of the distance), {worst_gap_m:.2} m at worst",
        100.0 * end_gap_m / driven_m
    );
    assert!(driven_m > 30.0, "the robot follows: {driven_m} m");
    // The base's acceleration limits make the commands differ from the motion, so the
    // dead reckoning cannot be the truth in disguise.
    assert!(worst_gap_m > 0.01, "the given pose is the true one");
    // The measures see through the frame: the target's estimate is compared relative
    // to the robot, so its error is that of tracking, not of the drift.
    for s in &scans {
        let seen = s.truth_in_estimate_frame();
        let (a, b) = (seen.world_from_robot, s.world_from_robot_given);
        assert!((a.x - b.x).abs() < 1e-9 && (a.y - b.y).abs() < 1e-9);
        let target = s.truth.target().unwrap();
        let robot_from_target = s.truth.world_from_robot.inverse() * target.position;
        let in_frame = seen.target().unwrap().position;
        let q = b.inverse() * in_frame;
        assert!((q.x - robot_from_target.x).abs() < 1e-9);
        assert!((q.y - robot_from_target.y).abs() < 1e-9);
    }
    let m = measure(&log);
    println!(
        "fused RMSE {:?} m, mean |d - d0| {:?} m, collisions {}",
        m.rmse_fused_m, m.mean_abs_distance_error_m, m.collisions
    );
    assert_eq!(m.collisions, 0);
}
