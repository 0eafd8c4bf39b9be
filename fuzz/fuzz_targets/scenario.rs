//! Scenario TOML (`tether sim --scenario FILE`) on arbitrary text: parsing and
//! validation must never panic; a scenario that passes must build its simulated world,
//! draw its SVG map (bounded by the input, whatever its coordinates: a room of 1e15 m
//! once drew a grid for 60 s and 6.9 GB) and simulate its first sensor events without a
//! panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_core::{Point2, World};
use tether_sim::scenario::Scenario;
use tether_sim::sim::Simulation;
use tether_sim::svg::MapSvg;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(scenario) = Scenario::from_toml_str(&text, "fuzz.toml") else {
        return;
    };
    assert!(scenario.validate().is_empty(), "from_toml_str validates");
    let Ok(mut sim) = Simulation::new(&scenario, 1) else {
        return;
    };
    let extent: Vec<Point2<World>> = scenario
        .people
        .iter()
        .flat_map(|p| p.path.iter().map(|&[x, y]| Point2::new(x, y)))
        .collect();
    let svg = MapSvg::new(&scenario, sim.world(), extent, 60.0).finish();
    let bound = 1_000_000 + 2_000 * text.len();
    assert!(
        svg.len() <= bound,
        "an SVG of {} bytes from {} bytes",
        svg.len(),
        text.len()
    );
    for _ in 0..3 {
        if sim.advance().is_none() {
            break;
        }
    }
});
