//! One full pipeline tick (issue 6 goal: under 100 us): a 682-beam URG-04LX scan of the
//! office with the target and a colleague in view, then a camera frame's upper-body
//! boxes — leg detection, vision model, fusion, tracking, target, spring, safety.
//!
//! `cargo bench -p tether-pipeline --bench tick`

use tether_pipeline::{Pipeline, PipelineConfig};
use tether_sim::{Scenario, SensorData, Simulation};

fn main() {
    divan::main();
}

/// Recorded inputs: (scan, pose) and (stamp, boxes, pose) from 12 s of the office.
struct Inputs {
    scans: Vec<(
        tether_core::LaserScan,
        tether_core::Pose2<tether_core::World, tether_core::Robot>,
    )>,
    frames: Vec<(
        tether_core::Stamp,
        Vec<tether_core::PixelBox>,
        tether_core::Pose2<tether_core::World, tether_core::Robot>,
    )>,
    config: PipelineConfig,
}

fn inputs() -> Inputs {
    let mut scenario = Scenario::builtin("office").expect("built-in");
    scenario.duration_s = 12.0;
    scenario.robot.driver = tether_sim::scenario::DriverKind::Oracle;
    let mut sim = Simulation::new(&scenario, 5).expect("valid");
    let mut driver = tether_sim::driver::driver_for(&scenario);
    let mut scans = Vec::new();
    let mut frames = Vec::new();
    while let Some(event) = sim.advance() {
        if let Some(c) = driver.on_event(&event) {
            sim.set_command(c);
        }
        let pose = event.truth.world_from_robot;
        match event.data {
            SensorData::Scan(scan) => scans.push((scan, pose)),
            SensorData::Camera(frame) => frames.push((frame.stamp, frame.boxes, pose)),
            SensorData::Timer => {}
        }
    }
    let config = PipelineConfig {
        laser: scenario.laser.clone(),
        camera: scenario.camera,
        ..PipelineConfig::default()
    };
    Inputs {
        scans,
        frames,
        config,
    }
}

/// Each scan with the first camera frame at or after it: ticks in time order.
fn pairs(data: &Inputs) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut fi = 0;
    for (si, (scan, _)) in data.scans.iter().enumerate() {
        while fi < data.frames.len() && data.frames[fi].0 < scan.stamp {
            fi += 1;
        }
        if fi < data.frames.len() {
            out.push((si, fi));
        }
    }
    out
}

#[divan::bench]
fn scan_and_camera_tick(bencher: divan::Bencher) {
    let data = inputs();
    let order = pairs(&data);
    let mut pipeline = Pipeline::new(data.config.clone(), None).expect("valid config");
    // Warm up: lock on the target over the first seconds.
    let mut k = 0usize;
    let step = |pipeline: &mut Pipeline, k: usize| {
        let (si, fi) = order[k];
        let (scan, pose) = &data.scans[si];
        let a = pipeline.on_scan(scan, *pose);
        let (stamp, boxes, pose) = &data.frames[fi];
        let b = pipeline.on_camera_boxes(*stamp, boxes, *pose);
        (a.command, b.command)
    };
    while k < 40 {
        step(&mut pipeline, k);
        k += 1;
    }
    bencher.bench_local(|| {
        if k >= order.len() {
            // Start over with a fresh pipeline when the recording runs out.
            pipeline = Pipeline::new(data.config.clone(), None).expect("valid config");
            k = 0;
        }
        let out = step(&mut pipeline, k);
        k += 1;
        divan::black_box(out)
    });
}
