//! The target lock in the closed loop with the realistic laser (issue 14): phantoms,
//! weak legs with range, dark-clothing spells, merged legs. Per scenario and sensor
//! mode, over seeds 0-2: the share of the time the target is visible to the laser that
//! the locked track is on them, and the scans locked on somebody else. The bars are
//! what holds today (`tether eval-target --seeds 20` gives the full figures); the
//! issue's own bar (99 %, never a wrong person) is not met everywhere yet, see
//! docs/measured.md.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_eval::closed_loop::{config_for, run};
use tether_eval::target_metrics::{TargetLockMetrics, measure_target_lock};
use tether_pipeline::PipelineConfig;
use tether_sim::Scenario;

fn pooled(name: &str, laser_only: bool, seeds: std::ops::Range<u64>) -> TargetLockMetrics {
    let scenario = Scenario::builtin(name).unwrap();
    assert!(
        scenario.laser_sim.realistic,
        "{name} runs the realistic laser"
    );
    let mut config = config_for(&scenario, &PipelineConfig::default());
    if laser_only {
        config.fusion.use_vision = false;
    }
    let mut all = TargetLockMetrics::default();
    for seed in seeds {
        let m = measure_target_lock(&run(&scenario, seed, &config, &[], &[]).unwrap());
        all.visible_scans += m.visible_scans;
        all.on_target_scans += m.on_target_scans;
        all.wrong_scans += m.wrong_scans;
        all.reappearances += m.reappearances;
        all.reacquired_within_1s += m.reacquired_within_1s;
    }
    all.on_target_frac = Some(all.on_target_scans as f64 / all.visible_scans.max(1) as f64);
    println!(
        "{name} {}: on target {:.4} of {} visible scans, {} wrong",
        if laser_only { "laser" } else { "fused" },
        all.on_target_frac.unwrap(),
        all.visible_scans,
        all.wrong_scans
    );
    all
}

#[test]
fn fused_the_target_holds_and_is_never_a_bystander() {
    for name in ["corridor", "office", "crossing", "stop_and_go", "turns"] {
        let m = pooled(name, false, 0..3);
        assert!(m.visible_scans > 300, "{name}: {m:?}");
        assert!(m.on_target_frac.unwrap() >= 0.97, "{name}: {m:?}");
        assert_eq!(m.wrong_scans, 0, "{name}: {m:?}");
    }
}

#[test]
fn laser_only_the_target_holds() {
    for name in ["corridor", "crossing", "stop_and_go", "turns"] {
        let m = pooled(name, true, 0..3);
        assert!(m.visible_scans > 300, "{name}: {m:?}");
        assert!(m.on_target_frac.unwrap() >= 0.95, "{name}: {m:?}");
        // At most a moment on the bystander as they cross right beside the target.
        assert!(
            m.wrong_scans as f64 <= 0.01 * m.visible_scans as f64,
            "{name}: {m:?}"
        );
    }
}

#[test]
fn outdoor_follow_without_odometry_holds_the_target_with_the_laser_alone() {
    let m = pooled("outdoor_follow", true, 0..1);
    assert!(m.visible_scans > 3000, "{m:?}");
    assert!(m.on_target_frac.unwrap() >= 0.98, "{m:?}");
    assert!(
        m.wrong_scans as f64 <= 0.005 * m.visible_scans as f64,
        "{m:?}"
    );
}

#[test]
fn outdoor_follow_fused_keeps_the_person_when_another_track_comes_onto_them() {
    // Seed 3: at 382 s a track swept along by the robot's turn comes onto the target
    // and rides on it while the target's own track walks on; taking that for the
    // target being led off lost it for 57 s and then locked a bystander (68 scans).
    let m = pooled("outdoor_follow", false, 3..4);
    assert!(m.visible_scans > 5000, "{m:?}");
    assert!(m.on_target_frac.unwrap() >= 0.99, "{m:?}");
    assert!(m.wrong_scans <= 5, "{m:?}");
}

#[test]
fn occlusion_the_target_comes_back_after_the_pillar_and_never_on_the_bystander() {
    // Behind the pillar the coasting track must not run off onto false positives, nor
    // a false camera box bring it back where the person is not.
    for laser_only in [false, true] {
        let m = pooled("occlusion", laser_only, 0..6);
        assert!(m.visible_scans > 500, "{m:?}");
        // 99.7 % fused and 99.0 % laser only on 2026-12-06 (the person taken up by
        // their hidden track on the first leg out of the pillar's shadow, design 5.5);
        // 93 % was the bar before.
        assert!(m.on_target_frac.unwrap() >= 0.98, "{m:?}");
        assert_eq!(m.wrong_scans, 0, "{m:?}");
        assert!(m.reappearances >= 5, "{m:?}");
        // Every one taken up within 1 s after coming out.
        assert_eq!(m.reacquired_within_1s, m.reappearances, "{m:?}");
    }
}
