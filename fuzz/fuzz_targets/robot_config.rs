//! The live robot's TOML config (`tether run --config`) on arbitrary text: parsing and
//! checking must never panic, and a config that passes must give its laser link, its
//! frame input and its pipeline configuration without a panic.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use tether::live::config::RobotConfig;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(config) = RobotConfig::parse(&text, Path::new("robot.toml")) else {
        return;
    };
    let _ = config.laser_link();
    let _ = config.frame_input();
    let _ = config.pipeline_config();
});
