//! How much faster than real time the simulator runs (issue: at least 1000x for the
//! `office` scenario with the laser and the camera on, on one core).
//!
//! `cargo bench -p tether-sim --bench sim` prints the time to simulate 10 s of each
//! scenario (no files written); real-time factor = 10 s / that time.

use tether_sim::driver::driver_for;
use tether_sim::{Scenario, Simulation};

fn main() {
    divan::main();
}

/// Simulated seconds per run.
const SIM_SECONDS: f64 = 10.0;

#[divan::bench(args = ["office", "corridor", "crossing"], sample_count = 20)]
fn ten_simulated_seconds(bencher: divan::Bencher, name: &str) {
    let mut scenario = Scenario::builtin(name).expect("built-in scenario");
    scenario.duration_s = SIM_SECONDS;
    bencher.bench_local(|| {
        let mut sim = Simulation::new(&scenario, 7).expect("valid scenario");
        let mut driver = driver_for(&scenario);
        let mut events = 0u32;
        while let Some(event) = sim.advance() {
            if let Some(command) = driver.on_event(&event) {
                sim.set_command(command);
            }
            events += 1;
        }
        divan::black_box(events)
    });
}

/// One laser scan of the office from the middle of the room.
#[divan::bench]
fn one_office_scan(bencher: divan::Bencher) {
    let scenario = Scenario::builtin("office").expect("built-in scenario");
    let mut sim = Simulation::new(&scenario, 7).expect("valid scenario");
    // Walk into the scenario so that people and furniture are in view.
    for _ in 0..30 {
        sim.advance();
    }
    let world = sim.world().clone();
    let mut laser = sim.laser().expect("laser on").clone();
    let pose = sim.truth().world_from_laser;
    bencher.bench_local(|| {
        laser
            .scan(tether_core::Stamp::ZERO, pose, &world, &[])
            .map(|s| s.returns())
    });
}
