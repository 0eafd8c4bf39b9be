//! The closed loop in the simulator (issue 6): tether's own estimates drive the robot.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_eval::closed_loop::{RunLog, StepKind, config_for, run};
use tether_eval::metrics::{RunMetrics, measure};
use tether_fusion::TargetState;
use tether_pipeline::PipelineConfig;
use tether_sim::Scenario;

/// The controller's bars (issue 6) are set for the ideal laser: the realistic one's
/// phantoms, weak legs and dark spells (issue 14) are judged by the target-lock
/// measures in `target_lock_realistic.rs`, where today's following error does not yet
/// hold (see docs/measured.md).
fn closed_loop(name: &str, seed: u64) -> (RunLog, RunMetrics) {
    let mut scenario = Scenario::builtin(name).unwrap();
    scenario.laser_sim.realistic = false;
    let config = config_for(&scenario, &PipelineConfig::default());
    let log = run(&scenario, seed, &config, &[], &[]).unwrap();
    let m = measure(&log);
    (log, m)
}

/// The bar for plain following, target walking at up to 1.2 m/s.
fn follows_well(name: &str) {
    for seed in [1, 2] {
        let (_, m) = closed_loop(name, seed);
        println!(
            "{name} seed {seed}: mean |d-d0| {:.3} m, min d {:.2} m, in band {:.2}, collisions {}",
            m.mean_abs_distance_error_m.unwrap_or(f64::NAN),
            m.min_distance_m,
            m.time_in_band_frac.unwrap_or(0.0),
            m.collisions
        );
        assert!(
            m.mean_abs_distance_error_m.unwrap() <= 0.15,
            "{name} seed {seed}"
        );
        assert!(m.min_distance_m >= 0.5, "{name} seed {seed}");
        assert_eq!(m.collisions, 0, "{name} seed {seed}");
        assert!(m.time_in_band_frac.unwrap() >= 0.9, "{name} seed {seed}");
    }
}

#[test]
fn follows_in_the_corridor() {
    follows_well("corridor");
}

#[test]
fn follows_through_the_office() {
    follows_well("office");
}

#[test]
fn follows_a_target_that_stops_and_goes() {
    follows_well("stop_and_go");
}

#[test]
fn follows_round_sharp_turns() {
    follows_well("turns");
    // The corners take the target out of the camera's view, never out of the tracker's.
    let (log, m) = closed_loop("turns", 1);
    assert!(m.target_lost_s < 0.5, "lost {} s", m.target_lost_s);
    let _ = log;
}

#[test]
fn never_swaps_the_target_in_the_crossing() {
    for seed in 0..20 {
        let (_, m) = closed_loop("crossing", seed);
        assert_eq!(m.target_swaps, 0, "seed {seed}");
        assert_eq!(m.collisions, 0, "seed {seed}");
    }
}

#[test]
fn waits_behind_the_pillar_and_reacquires_the_target() {
    for seed in 0..5 {
        let (log, m) = closed_loop("occlusion", seed);
        assert_eq!(m.target_swaps, 0, "seed {seed}: followed someone else");
        let scans: Vec<_> = log
            .steps
            .iter()
            .filter(|s| s.kind == StepKind::Scan)
            .collect();
        let hidden = |s: &&tether_eval::closed_loop::StepRecord| {
            s.truth.target().and_then(|t| t.laser_beams) == Some(0)
        };
        // The target disappears behind the pillar, then reappears.
        let gone = scans
            .iter()
            .position(&hidden)
            .expect("the pillar hides the target");
        let back = gone
            + scans[gone..]
                .iter()
                .position(|s| !hidden(s))
                .expect("the target comes back");
        let back_s = scans[back].truth.stamp.secs_f64();
        // Whenever it has lost the target the robot brakes to a stop within a second of
        // that loss and does not drive off after anyone (it may turn on the spot to
        // look). Checked from the disappearance until the robot is locked again after the
        // target came back.
        let is_locked = |s: &&tether_eval::closed_loop::StepRecord| {
            s.tick
                .as_ref()
                .is_some_and(|t| matches!(t.target.state, TargetState::Locked { .. }))
        };
        let mut lost_at: Option<f64> = None;
        for (k, s) in scans.iter().enumerate().skip(gone) {
            let t = s.truth.stamp.secs_f64();
            if is_locked(s) {
                if k >= back {
                    break;
                }
                lost_at = None;
                continue;
            }
            let since = *lost_at.get_or_insert(t);
            if t >= since + 1.0 {
                let v = s.truth.robot_velocity.v_mps.abs();
                assert!(
                    v < 0.05,
                    "seed {seed}: driving at {v} m/s {:.1} s after losing the target",
                    t - since
                );
            }
        }
        // Re-acquired within 2 s of reappearing: locked, on the target.
        let reacquired = scans[back..].iter().find(|s| {
            let target = s.truth.target().unwrap().position;
            s.tick.as_ref().is_some_and(|t| {
                matches!(t.target.state, TargetState::Locked { .. })
                    && t.target
                        .estimate
                        .is_some_and(|e| e.mean.distance_m(target) < 0.5)
            })
        });
        let at = reacquired
            .map(|s| s.truth.stamp.secs_f64())
            .expect("re-acquired");
        println!("occlusion seed {seed}: reappeared at {back_s:.1} s, re-acquired at {at:.1} s");
        assert!(
            at - back_s <= 2.0,
            "seed {seed}: {:.1} s to re-acquire",
            at - back_s
        );
    }
}
