//! Two scanners in the closed loop (issue 33, design 5.7): the built-in `all_round`
//! robot has a 180-degree scanner at the front and one at the back, and its target walks
//! all the way round it. The scans of both go to one pipeline, told apart by their
//! `frame_id`: the target is one track from the first lock to the end, never lost, and
//! followed. With the front scanner alone the same walk loses the target behind the
//! robot in every run.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use std::collections::BTreeSet;

use tether_eval::closed_loop::{RunLog, config_for, laser_only, run};
use tether_eval::metrics::{RunMetrics, measure};
use tether_pipeline::PipelineConfig;
use tether_sim::{Scenario, SensorData};

fn closed_loop(scenario: &Scenario, seed: u64) -> (RunLog, RunMetrics) {
    let mut config = config_for(scenario, &PipelineConfig::default());
    // The laser-only version has no camera: the pipeline follows on the laser alone, as
    // `tether sim --laser-only` runs it.
    config.fusion.use_vision = scenario.camera_sim.enabled;
    let log = run(scenario, seed, &config, &[], &[]).unwrap();
    let m = measure(&log);
    (log, m)
}

/// The ids of the tracks the target was locked on, from the first lock to the end.
fn target_tracks(log: &RunLog) -> BTreeSet<u64> {
    log.steps
        .iter()
        .filter_map(|s| s.tick.as_ref()?.target.state.locked_track())
        .collect()
}

fn versions() -> Vec<Scenario> {
    let fused = Scenario::builtin("all_round").unwrap();
    let laser = laser_only(&fused);
    vec![fused, laser]
}

#[test]
fn a_target_walking_round_a_robot_with_two_scanners_is_one_track_and_is_followed() {
    for scenario in versions() {
        for seed in 1..=3 {
            let (log, m) = closed_loop(&scenario, seed);
            let what = format!("{} seed {seed}", scenario.name);
            println!(
                "{what}: mean |d-d0| {:.3} m, in band {:.2}, min d {:.2} m, lost {:.2} s",
                m.mean_abs_distance_error_m.unwrap_or(f64::NAN),
                m.time_in_band_frac.unwrap_or(0.0),
                m.min_distance_m,
                m.target_lost_s
            );
            assert_eq!(
                target_tracks(&log).len(),
                1,
                "{what}: {:?}",
                target_tracks(&log)
            );
            assert_eq!(m.target_lost_s, 0.0, "{what}");
            assert_eq!(m.target_swaps, 0, "{what}");
            assert_eq!(m.collisions, 0, "{what}");
            // A walk round the robot is not plain following: the person comes towards
            // the robot and passes beside it, 0.55 m from its centre line on the
            // scenario's path, which brings them 0.39-0.47 m from the spring's
            // attachment point 0.3 m ahead of the axle (seeds 1-3; the measure's d), and
            // the robot turns round. Mean 0.21-0.42 m measured (2026-12-07), against
            // 0.3-2.4 m with the front scanner alone.
            assert!(m.min_distance_m >= 0.3, "{what}: {}", m.min_distance_m);
            assert!(m.mean_abs_distance_error_m.unwrap() <= 0.5, "{what}");
        }
    }
}

#[test]
fn with_the_front_scanner_alone_the_target_is_lost_behind_the_robot() {
    for mut scenario in versions() {
        scenario.extra_lasers.clear();
        for seed in 1..=3 {
            let (_, m) = closed_loop(&scenario, seed);
            println!(
                "{} seed {seed}: lost {:.2} s",
                scenario.name, m.target_lost_s
            );
            assert!(
                m.target_lost_s >= 1.0,
                "{} seed {seed}: {m:?}",
                scenario.name
            );
        }
    }
}

#[test]
fn each_scanner_s_scans_carry_its_frame() {
    let scenario = Scenario::builtin("all_round").unwrap();
    let mut sim = tether_sim::Simulation::new(&scenario, 0).unwrap();
    let mut frames = std::collections::BTreeMap::<String, u32>::new();
    while let Some(event) = sim.advance() {
        if let SensorData::Scan(scan) = event.data {
            *frames.entry(scan.frame_id).or_default() += 1;
        }
    }
    // 26 s at 10 Hz each, the rear one half a period after the front one.
    assert_eq!(frames.get("laser"), Some(&261), "{frames:?}");
    assert_eq!(frames.get("rear_laser"), Some(&260), "{frames:?}");
}
