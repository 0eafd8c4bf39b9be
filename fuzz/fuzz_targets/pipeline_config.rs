//! The pipeline TOML of `tether track --config` (and `replay`, `eval-track`) on
//! arbitrary text: a file without `[robot]` is a `PipelineConfig` read by serde, one
//! with `[robot]` a robot's config whose pipeline is derived from it. Neither may panic;
//! a config that reads and makes a pipeline (which validates it) then runs it on a few
//! scans of a person walking and on its timer: no panic, and every command is finite
//! and within the configured speed limits.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use tether::live::config::RobotConfig;
use tether_core::{LaserScan, Pose2, Stamp};
use tether_laser::LegClassifier;
use tether_pipeline::{Pipeline, PipelineConfig, Tick};

/// The default leg model, read once (`Pipeline::new` would read it for every input).
fn default_model() -> LegClassifier {
    static MODEL: std::sync::OnceLock<LegClassifier> = std::sync::OnceLock::new();
    MODEL
        .get_or_init(|| LegClassifier::default_model().expect("the default model reads"))
        .clone()
}

/// A 360-beam scan (1 degree apart, facing forward) of a wall at 4 m and two legs at
/// about 1.5 m, moved by `k` beams.
fn scan(k: usize, stamp: Stamp) -> LaserScan {
    let ranges = (0..360usize)
        .map(|i| {
            let j = i.wrapping_sub(k);
            match j {
                175..=177 | 181..=183 => 1.5,
                _ => 4.0,
            }
        })
        .collect();
    let step = std::f64::consts::PI / 180.0;
    LaserScan::new(
        stamp,
        "laser",
        -std::f64::consts::PI,
        step,
        0.02,
        5.6,
        ranges,
    )
    .expect("a valid scan")
}

fn check(tick: &Tick, config: &PipelineConfig) {
    let c = tick.command;
    let l = &config.limits;
    assert!(c.v_mps.is_finite() && c.w_radps.is_finite(), "{c:?}");
    assert!(
        c.v_mps <= l.max_speed_mps + 1e-9 && c.v_mps >= -l.max_reverse_mps - 1e-9,
        "{c:?} beyond {l:?}"
    );
    assert!(
        c.w_radps.abs() <= l.max_turn_radps + 1e-9,
        "{c:?} beyond {l:?}"
    );
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // As `tether track`'s `load_config`: a robot's config when it has `[robot]`.
    let is_robot = toml::from_str::<toml::Table>(text).is_ok_and(|t| t.contains_key("robot"));
    let config = if is_robot {
        let Ok(robot) = RobotConfig::parse(text, Path::new("fuzz.toml")) else {
            return;
        };
        robot
            .pipeline_config()
            .expect("a robot config that parsed gives its pipeline")
    } else {
        let Ok(config) = toml::from_str::<PipelineConfig>(text) else {
            return;
        };
        config
    };
    let Ok(mut pipeline) = Pipeline::new(config.clone(), Some(default_model())) else {
        return;
    };
    for k in 0..8u8 {
        let stamp = Stamp::from_ns(1_000_000_000 + i64::from(k) * 100_000_000);
        let tick = pipeline.on_scan(&scan(usize::from(k), stamp), Pose2::IDENTITY);
        check(&tick, &config);
        let tick = pipeline.on_timer(Stamp::from_ns(stamp.ns() + 50_000_000), Pose2::IDENTITY);
        check(&tick, &config);
    }
});
