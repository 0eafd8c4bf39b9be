//! Fault runs in the closed loop (issue 6): the camera stops for 3 s, the laser stops for
//! 1 s, a burst of NaN ranges, a 0.5 s stamp jump. No panic; when the data that the
//! robot needs to drive safely go missing it stops within the data timeout, and it
//! resumes when they return.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether::closed_loop::{Fault, RunLog, StepKind, config_for, run};
use tether_fusion::TargetState;
use tether_pipeline::PipelineConfig;
use tether_sim::Scenario;

fn corridor_run(faults: &[Fault]) -> RunLog {
    let scenario = Scenario::builtin("corridor").unwrap();
    let config = config_for(&scenario, &PipelineConfig::default());
    run(&scenario, 3, &config, &[], faults).unwrap()
}

/// Commanded speed at the timer steps within [a, b) seconds.
fn commands(log: &RunLog, a: f64, b: f64) -> Vec<f64> {
    log.steps
        .iter()
        .filter(|s| s.kind == StepKind::Timer)
        .filter(|s| (a..b).contains(&s.truth.stamp.secs_f64()))
        .map(|s| s.tick.as_ref().map_or(0.0, |t| t.command.v_mps.abs()))
        .collect()
}

/// True robot speed at the timer steps within [a, b) seconds.
fn speeds(log: &RunLog, a: f64, b: f64) -> Vec<f64> {
    log.steps
        .iter()
        .filter(|s| s.kind == StepKind::Timer)
        .filter(|s| (a..b).contains(&s.truth.stamp.secs_f64()))
        .map(|s| s.truth.robot_velocity.v_mps.abs())
        .collect()
}

fn locked_at(log: &RunLog, t: f64) -> bool {
    log.steps
        .iter()
        .filter(|s| s.kind == StepKind::Timer && s.truth.stamp.secs_f64() >= t)
        .find_map(|s| s.tick.as_ref())
        .is_some_and(|tick| matches!(tick.target.state, TargetState::Locked { .. }))
}

/// The command reaches zero within the laser timeout (0.3 s) plus braking from walking
/// speed at the follower's deceleration limit (1.4 m/s at 2.5 m/s^2: 0.56 s).
const STOP_WITHIN_S: f64 = 0.3 + 0.6;

#[test]
fn laser_outage_stops_the_robot_and_it_resumes() {
    let log = corridor_run(&[Fault::LaserDropout {
        from_s: 8.0,
        duration_s: 1.0,
    }]);
    assert!(
        speeds(&log, 7.0, 8.0).iter().all(|v| *v > 0.5),
        "following before the fault"
    );
    let during = commands(&log, 8.0 + STOP_WITHIN_S, 9.0);
    assert!(
        !during.is_empty() && during.iter().all(|v| *v == 0.0),
        "stopped: {during:?}"
    );
    // The base itself, braking at its own limit, is still within half a metre per second.
    assert!(speeds(&log, 9.0, 9.05).iter().all(|v| *v < 0.5));
    let after = speeds(&log, 10.5, 12.0);
    assert!(after.iter().any(|v| *v > 0.5), "moving again: {after:?}");
    assert!(locked_at(&log, 11.0));
}

#[test]
fn nan_burst_is_treated_as_no_laser() {
    let log = corridor_run(&[Fault::NanBurst {
        from_s: 8.0,
        duration_s: 1.5,
    }]);
    let during = commands(&log, 8.0 + STOP_WITHIN_S, 9.5);
    assert!(
        !during.is_empty() && during.iter().all(|v| *v == 0.0),
        "stopped: {during:?}"
    );
    let after = speeds(&log, 11.0, 13.0);
    assert!(after.iter().any(|v| *v > 0.5), "moving again: {after:?}");
}

#[test]
fn camera_outage_leaves_the_laser_to_follow() {
    let log = corridor_run(&[Fault::CameraDropout {
        from_s: 6.0,
        duration_s: 3.0,
    }]);
    // The laser alone keeps the target: the robot follows on without stopping.
    let during = speeds(&log, 6.0, 9.0);
    assert!(
        during.iter().all(|v| *v > 0.5),
        "kept following: {during:?}"
    );
    assert!(locked_at(&log, 8.5) && locked_at(&log, 10.0));
}

#[test]
fn stamp_jump_does_not_break_the_loop() {
    let log = corridor_run(&[Fault::StampJump {
        at_s: 8.0,
        jump_s: 0.5,
    }]);
    let after = speeds(&log, 10.0, 12.0);
    assert!(after.iter().any(|v| *v > 0.5), "moving again: {after:?}");
    assert!(locked_at(&log, 11.0));
    // Nothing the robot did came close to the person.
    let m = tether::metrics::measure(&log);
    assert!(m.min_distance_m > 0.5, "{}", m.min_distance_m);
}
