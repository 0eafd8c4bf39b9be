//! The simulated laser fails the way the real one does (issue 14): the statistics of
//! tether's leg detector that matter for tracking (detection against range, runs of
//! misses of the person, merged legs, false positives and how long they stay in place;
//! `tether_laser::statistics`) computed on simulated runs of the built-in scenarios and
//! on the real training split, each within a stated tolerance, with a side-by-side table
//! (real training / simulated / real test) for docs/measured.md.
//!
//! The simulated labels are made as leg_tracker's labeller made the real ones: every
//! cluster of the default clustering whose centroid lies near a true leg of the person
//! (within [`LABEL_REACH_M`]) inside its window (+-15 deg, 5 m); false positives are the
//! detected legs farther than [`FP_CLEARANCE_M`] from every person's legs, their
//! persistence measured in the world frame (the real scanners were static, so their
//! frame was a world frame).
//!
//! Without `../shared` the test prints why and passes, unless `TETHER_REQUIRE_SHARED=1`.

#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "test code: a failed unwrap is a failed test"
)]

#[path = "../../tether-laser/tests/support/real_statistics.rs"]
#[allow(
    dead_code,
    reason = "shared with tether-laser's test, which uses the rest"
)]
mod real_statistics;
#[path = "support/still_laser.rs"]
mod still_laser;

use tether_core::{Laser, Point2};
use tether_laser::statistics::{
    DetectorStatistics, StatisticsSummary, clusters_near, detected_legs, side_by_side,
};
use tether_laser::training::LabelledRegion;
use tether_sim::driver::driver_for;
use tether_sim::{BUILTIN_NAMES, Scenario, SensorData, Simulation};

/// A cluster whose centroid lies this close to a true leg centre is the person's, m
/// (a leg's returns lie about one radius in front of its centre; two merged legs
/// 0.1-0.15 m to either side of the cluster's centroid).
const LABEL_REACH_M: f64 = 0.2;
/// A detected leg this far from every person's legs is a false positive, m.
const FP_CLEARANCE_M: f64 = 0.5;
/// Seeds per scenario.
const SEEDS: u64 = 3;

/// The statistics of simulated runs of `scenario` for `seeds`.
fn simulated(scenario: &Scenario, seeds: std::ops::Range<u64>) -> DetectorStatistics {
    let mut all = DetectorStatistics::new();
    let region = LabelledRegion::leg_tracker();
    for seed in seeds {
        let mut sim = Simulation::new(scenario, seed).unwrap();
        let mut driver = driver_for(scenario);
        let mut detector = real_statistics::default_detector();
        let n_people = scenario.people.len();
        let mut per_person: Vec<DetectorStatistics> =
            (0..n_people).map(|_| DetectorStatistics::new()).collect();
        let mut fps = DetectorStatistics::new();
        while let Some(event) = sim.advance() {
            if let Some(c) = driver.on_event(&event) {
                sim.set_command(c);
            }
            let SensorData::Scan(scan) = &event.data else {
                continue;
            };
            let t = event.truth.stamp.secs_f64();
            let laser_from_world = event.truth.world_from_laser.inverse();
            let found = detected_legs(&mut detector, scan);
            let mut all_legs: Vec<Point2<Laser>> = Vec::new();
            for (k, person) in event.truth.people.iter().enumerate() {
                let legs: Vec<Point2<Laser>> = person
                    .legs
                    .iter()
                    .map(|l| laser_from_world * l.center)
                    .collect();
                all_legs.extend(&legs);
                let labels = clusters_near(&mut detector, scan, &legs, LABEL_REACH_M, &region);
                per_person[k].add_labelled_scan(t, &labels, &found);
            }
            let world_from_laser = event.truth.world_from_laser;
            let false_positives: Vec<(f64, f64)> = found
                .iter()
                .filter(|d| all_legs.iter().all(|l| l.distance_m(**d) > FP_CLEARANCE_M))
                .map(|d| {
                    let w = world_from_laser * *d;
                    (w.x, w.y)
                })
                .collect();
            fps.add_false_positives(t, &false_positives);
        }
        for p in &per_person {
            all.merge(p);
        }
        all.merge(&fps);
    }
    all
}

/// People walking 0.5-5 m in front of a still laser, as in the recordings of
/// leg_tracker's `positive_*` bags (a still scanner, one or more people walking in
/// front of it, towards it, away and across).
fn walkers() -> String {
    still_laser::still_laser_scene(
        "walkers",
        "people walking 0.5-5 m in front of a still laser, like the real recordings",
        [-2.0, -5.0],
        [7.0, 5.0],
        r#"
[[people]]
name = "towards_and_away"
path = [[0.8, 0.2], [4.8, -0.3]]
speed_mps = 1.0
repeat = true

[[people]]
name = "across"
path = [[2.2, -1.2], [2.6, 1.2], [3.6, 0.9], [3.4, -1.0]]
speed_mps = 1.1
repeat = true
"#,
    )
}

/// Longest simulated time of a scenario in the comparison, s (`outdoor_follow` lasts
/// ten minutes; its first two stand for it, so that it does not outweigh the others).
const MAX_DURATION_S: f64 = 120.0;

fn builtins() -> Vec<Scenario> {
    BUILTIN_NAMES
        .iter()
        .map(|n| {
            let mut s = Scenario::builtin(n).unwrap();
            s.duration_s = s.duration_s.min(MAX_DURATION_S);
            s
        })
        .collect()
}

#[test]
fn simulated_detector_statistics_match_the_real_training_split() {
    let Some(dir) = real_statistics::shared_data_dir() else {
        return;
    };
    let (train, test) = real_statistics::real_splits_held_out(&dir);
    let mut sim = DetectorStatistics::new();
    let mut ideal = DetectorStatistics::new();
    let mut columns: Vec<(String, StatisticsSummary)> = Vec::new();
    let mut scenarios = builtins();
    scenarios.push(Scenario::from_toml_str(&walkers(), "walkers").unwrap());
    for scenario in scenarios {
        let s = simulated(&scenario, 0..SEEDS);
        columns.push((scenario.name.clone(), s.summary()));
        sim.merge(&s);
        let mut perfect = scenario.clone();
        perfect.laser_sim.realistic = false;
        ideal.merge(&simulated(&perfect, 0..SEEDS));
    }
    let (train, sim, test, ideal) = (
        train.summary(),
        sim.summary(),
        test.summary(),
        ideal.summary(),
    );
    let mut table: Vec<(&str, &StatisticsSummary)> = vec![
        ("real training", &train),
        ("simulated", &sim),
        ("real test", &test),
        ("ideal sensor", &ideal),
    ];
    for (n, s) in &columns {
        table.push((n.as_str(), s));
    }
    println!("{}", side_by_side(&table));

    // Each figure within its tolerance of the real training split's. The tolerances
    // are about the difference between the two real splits (training and test differ
    // by 0.03 in leg detection, 0.10 in missed scans, 0.6 scans in the mean run of
    // misses, 0.11 in P(miss | miss)).
    let checks: [(&str, f64, f64, f64, f64); 8] = [
        (
            "P(leg detected), 0-5 m",
            train.leg_detection_prob,
            sim.leg_detection_prob,
            ideal.leg_detection_prob,
            0.08,
        ),
        (
            "person missed, share of scans",
            train.person_miss_rate,
            sim.person_miss_rate,
            ideal.person_miss_rate,
            0.10,
        ),
        (
            "miss run mean, scans",
            train.miss_run_mean_scans,
            sim.miss_run_mean_scans,
            ideal.miss_run_mean_scans,
            0.6,
        ),
        (
            "P(miss | miss)",
            train.p_miss_given_miss,
            sim.p_miss_given_miss,
            ideal.p_miss_given_miss,
            0.12,
        ),
        (
            "merged legs",
            train.merged_share,
            sim.merged_share,
            ideal.merged_share,
            0.10,
        ),
        (
            "false positives per scan",
            train.fp_per_scan,
            sim.fp_per_scan,
            ideal.fp_per_scan,
            0.10,
        ),
        (
            "FP run mean, scans",
            train.fp_run_mean_scans,
            sim.fp_run_mean_scans,
            ideal.fp_run_mean_scans,
            0.5,
        ),
        (
            "FP share in runs >= 1 s",
            train.fp_share_persisting_1s,
            sim.fp_share_persisting_1s,
            ideal.fp_share_persisting_1s,
            0.05,
        ),
    ];
    let mut failed = Vec::new();
    for (name, real, simulated, perfect, tolerance) in checks {
        println!(
            "{name}: real {real:.3}, simulated {simulated:.3} (ideal sensor {perfect:.3}), tolerance {tolerance}"
        );
        if !((simulated - real).abs() <= tolerance) {
            failed.push(name);
        }
    }
    assert!(failed.is_empty(), "outside the tolerance: {failed:?}");
    // Misses come in bursts, as in the real recordings: a miss makes the next one
    // more likely than a miss at random.
    assert!(
        sim.p_miss_given_miss > 1.5 * sim.person_miss_rate,
        "{sim:?}"
    );
    // The ideal sensor is not what the real one is: without the failures the false
    // positives are too few (with the model of before they were also too persistent,
    // 0.37 against 0.04 in runs of a second; the built-in model now flickers on the
    // furniture too, 0.025 against 0.066), so it falls outside at least one tolerance.
    assert!(
        (ideal.fp_per_scan - train.fp_per_scan).abs() > 0.1,
        "{ideal:?}"
    );
    let ideal_outside = checks
        .iter()
        .filter(|(_, real, _, perfect, tolerance)| (perfect - real).abs() > *tolerance)
        .count();
    assert!(ideal_outside > 0, "{ideal:?}");
}
