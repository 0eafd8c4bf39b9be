//! Issue 32: a stop never commands the opposite direction. Over the demo's runs (every
//! built-in scenario, fused and laser-only, the realistic laser, seeds 1-3), no command
//! crosses zero to the side the follower did not ask for (the base's smoothing never
//! steps past the wanted velocity, design 6).

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_control::StopReason;
use tether_eval::closed_loop::{config_for, run};
use tether_pipeline::PipelineConfig;
use tether_sim::{BUILTIN_NAMES, Scenario};

/// A tick: time (s), why the robot is held, the command `(v, w)` and the one the
/// follower asked for.
type Held = (f64, Option<StopReason>, (f64, f64), (f64, f64));

/// One reversal: where and what.
#[derive(Debug)]
#[allow(dead_code, reason = "read through Debug, in the failure's message")]
struct Reversal {
    run: String,
    t_s: f64,
    stop: Option<StopReason>,
    axis: &'static str,
    before: f64,
    commanded: f64,
    wanted: f64,
}

/// The commands of one run that cross zero, on either axis, to the side the follower
/// did not ask for: a stop (held, or the spring easing off to a standstill) that
/// commands the opposite direction. Crossing to a side that was asked for is not one:
/// backing away from a person come too close, the spring steering the other way.
fn reversals(run_name: &str, ticks: &[Held]) -> Vec<Reversal> {
    let mut found = Vec::new();
    for pair in ticks.windows(2) {
        let (_, _, (v0, w0), _) = pair[0];
        let (t_s, stop, (v, w), (wanted_v, wanted_w)) = pair[1];
        for (axis, before, now, wanted) in [("v", v0, v, wanted_v), ("w", w0, w, wanted_w)] {
            if now * before < 0.0 && wanted * before >= 0.0 {
                found.push(Reversal {
                    run: run_name.to_owned(),
                    t_s,
                    stop,
                    axis,
                    before,
                    commanded: now,
                    wanted,
                });
            }
        }
    }
    found
}

#[test]
fn no_stop_in_the_demo_commands_the_opposite_direction() {
    let mut found = Vec::new();
    let mut held_ticks = 0;
    let mut crossings = 0;
    for name in BUILTIN_NAMES {
        for laser_only in [false, true] {
            for seed in 1..=3 {
                let mut scenario = Scenario::builtin(name).unwrap();
                let mut config = config_for(&scenario, &PipelineConfig::default());
                if laser_only {
                    scenario.camera_sim.enabled = false;
                    config.fusion.use_vision = false;
                }
                let log = run(&scenario, seed, &config, &[], &[]).unwrap();
                let ticks: Vec<_> = log
                    .steps
                    .iter()
                    .filter_map(|s| s.tick.as_ref())
                    .map(|t| {
                        (
                            t.stamp.secs_f64(),
                            t.stop,
                            (t.command.v_mps, t.command.w_radps),
                            (t.wanted.v_mps, t.wanted.w_radps),
                        )
                    })
                    .collect();
                held_ticks += ticks.iter().filter(|t| t.1.is_some()).count();
                crossings += ticks
                    .windows(2)
                    .filter(|p| p[0].2.0 * p[1].2.0 < 0.0 || p[0].2.1 * p[1].2.1 < 0.0)
                    .count();
                let run_name = format!(
                    "{name}{} seed {seed}",
                    if laser_only { " laser-only" } else { "" }
                );
                found.extend(reversals(&run_name, &ticks));
            }
        }
    }
    println!("{held_ticks} held ticks and {crossings} commands crossing zero over the demo's runs");
    assert!(
        held_ticks > 100,
        "the runs must hold the robot now and then"
    );
    assert!(
        crossings > 100,
        "the runs must turn both ways and back up now and then"
    );
    assert!(found.is_empty(), "{} reversals: {found:#?}", found.len());
}

#[test]
fn a_reversal_is_found() {
    // The braking of issue 32's report, 1.275 m/s to a stop: 0.15, 0.025, -0.035 ...
    let stop = (0.0, 0.0);
    let ticks = [
        (0.0, None, (1.275, 0.0), (1.275, 0.0)),
        (0.1, Some(StopReason::StaleTarget), (0.15, 0.0), stop),
        (0.2, Some(StopReason::StaleTarget), (0.025, 0.0), stop),
        (0.3, Some(StopReason::StaleTarget), (-0.035, 0.0), stop),
        (0.4, Some(StopReason::TargetLost), (0.0, 0.4), (0.0, 0.5)),
        // The spring easing off a turn, past zero.
        (0.5, None, (0.2, -0.1), (0.3, 0.0)),
        // Steering the other way, and backing away from a person come too close, asked
        // for: not reversals.
        (0.6, None, (0.1, 0.2), (0.1, 0.4)),
        (0.7, Some(StopReason::Obstacle), (-0.05, 0.0), (-0.2, 0.0)),
    ];
    let found = reversals("report", &ticks);
    let seen: Vec<_> = found.iter().map(|r| (r.t_s, r.axis)).collect();
    assert_eq!(seen, [(0.3, "v"), (0.5, "w")], "{found:#?}");
}
