//! Drift of scan-matching odometry in the simulator: every built-in scenario driven by
//! the simulator's (ground-truth) follower, the estimate accumulated from the scans
//! alone (constant-velocity prior, no odometry), and compared with the true robot path.
//! Drift = final position error / distance driven; issue 14 asks for under 2 % in the
//! office scenario and in any long outdoor scenario.
//!
//! People are excluded as a tracker would give them: a zone around each true leg seen
//! by the laser (design 11: the match is on the static part of the scene).

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

#[path = "support/sim_drive.rs"]
#[allow(
    dead_code,
    reason = "shared by the drift test and the tuning example, which use different parts"
)]
mod sim_drive;

use tether_scanmatch::{Quality, ScanMatcherConfig};
use tether_sim::BUILTIN_NAMES;

#[derive(Debug)]
struct Drift {
    distance_m: f64,
    final_error_m: f64,
    final_yaw_error_rad: f64,
    max_error_m: f64,
    scans: usize,
    failed: u64,
    /// Of the failures, matches refused as a motion the robot cannot make.
    implausible: u64,
    degenerate: u64,
    keyframes: u64,
}

impl Drift {
    fn ratio(&self) -> f64 {
        self.final_error_m / self.distance_m.max(1e-9)
    }
}

fn drive(name: &str, seed: u64, exclude_people: bool, commanded: bool) -> Drift {
    let mut distance_m = 0.0;
    let mut max_error_m: f64 = 0.0;
    let mut final_error = (0.0, 0.0);
    let mut scans = 0;
    let matcher = sim_drive::drive(
        name,
        seed,
        ScanMatcherConfig::default(),
        exclude_people,
        commanded,
        |step| {
            scans = step.scans;
            distance_m = step.distance_m;
            let error = step.error();
            max_error_m = max_error_m.max(error.0);
            final_error = error;
            if matches!(step.estimate.quality, Quality::PriorOnly(_)) && step.scans > 1 {
                println!(
                    "{name}: scan {}: {} points ({} returns), keyframe {}: {:?}",
                    step.scans,
                    step.points.len(),
                    step.scan.returns(),
                    step.matcher.keyframe().len(),
                    step.estimate.quality
                );
            }
        },
    );
    let c = matcher.counts();
    Drift {
        distance_m,
        final_error_m: final_error.0,
        final_yaw_error_rad: final_error.1,
        max_error_m,
        scans,
        failed: c.failed,
        implausible: c.implausible,
        degenerate: c.degenerate,
        keyframes: c.keyframes,
    }
}

/// Every scenario, with the constant-velocity prior (no odometry at all) and with the
/// commanded velocities as the prior (what `tether run` has). Where the scene does not
/// constrain the motion (corridors) and the prior is "the last velocity", the robot's
/// speed along the corridor cannot be known from scans: those scans must be flagged
/// degenerate, so that the drift is never silent.
#[test]
fn drift_in_every_scenario_and_under_two_percent_in_office_and_outdoors() {
    let mut names: Vec<&str> = BUILTIN_NAMES.to_vec();
    names.sort_unstable();
    println!(
        "| scenario | prior | driven (m) | final error (m) | drift | final yaw error (deg) | max error (m) | scans | degenerate | failed | keyframes |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in names {
        for commanded in [false, true] {
            let d = drive(name, 1, true, commanded);
            println!(
                "| {name} | {} | {:.1} | {:.3} | {:.2} % | {:.2} | {:.3} | {} | {} | {} | {} |",
                if commanded {
                    "commanded"
                } else {
                    "constant velocity"
                },
                d.distance_m,
                d.final_error_m,
                100.0 * d.ratio(),
                d.final_yaw_error_rad.to_degrees(),
                d.max_error_m,
                d.scans,
                d.degenerate,
                d.failed,
                d.keyframes
            );
            // The office constrains the motion everywhere. In the open park of
            // `outdoor_follow` many scans hold too few returns (bushes and posts far
            // apart): there the commands' prior carries the match, as in the closed loop
            // and `tether run`; with the last velocity alone the drift is large but
            // flagged (see below).
            if name == "office" || (name.contains("outdoor") && commanded) {
                assert!(d.distance_m > 5.0, "{name} should drive: {d:?}");
                assert!(
                    d.ratio() < 0.02,
                    "{name}: drift {:.2} %: {d:?}",
                    100.0 * d.ratio()
                );
            }
            if name == "office" {
                // Every scan has enough structure to match (a false minimum refused
                // for a motion the base cannot make is not a lack of structure).
                assert_eq!(d.failed - d.implausible, 0, "{name}: {d:?}");
            }
            if !commanded && d.ratio() > 0.05 {
                assert!(
                    (d.degenerate + d.failed) as f64 > 0.05 * d.scans as f64,
                    "{name}: large drift without degeneracy flags: {d:?}"
                );
            }
        }
    }
}

#[test]
fn office_drift_holds_over_seeds() {
    for seed in 2..8 {
        let d = drive("office", seed, true, false);
        println!(
            "office seed {seed}: drift {:.2} % over {:.1} m",
            100.0 * d.ratio(),
            d.distance_m
        );
        assert!(d.ratio() < 0.02, "seed {seed}: {d:?}");
    }
}
