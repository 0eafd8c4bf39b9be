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
    inputs_with(None)
}

/// [`inputs`] from the office seen by the named scanner of the simulator's catalogue
/// (`None`: the scenario's own URG-04LX).
fn inputs_with(scanner: Option<&str>) -> Inputs {
    let mut scenario = Scenario::builtin("office").expect("built-in");
    if let Some(name) = scanner {
        scenario = scenario.with_scanner(name).expect("a catalogued scanner");
    }
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
    camera_ticks(bencher, &inputs());
}

/// The same tick on a 720-beam 360-degree scan (YDLIDAR X4 from the simulator's
/// catalogue: 0.5-degree steps, a quarter of the beams inside objects lost; issue 30's
/// goal: under 100 us).
#[divan::bench]
fn scan_and_camera_tick_720_beams(bencher: divan::Bencher) {
    camera_ticks(bencher, &inputs_with(Some("ydlidar_x4")));
}

/// Leg detection alone (the built-in learned detector, as the pipeline builds it) on
/// the office's 720-beam 360-degree scans (YDLIDAR X4; issue 30's goal: under 100 us).
#[divan::bench]
fn leg_detection_720_beams(bencher: divan::Bencher) {
    let data = inputs_with(Some("ydlidar_x4"));
    assert_eq!(data.scans[0].0.len(), 720);
    let mut detector = tether_laser::LegDetector::learned(
        data.config.legs.config,
        data.config.laser.noise.clone(),
        tether_laser::LegClassifier::default_model().expect("the built-in model"),
    )
    .expect("the default configuration is valid");
    let mut out = tether_laser::Detection::default();
    let mut k = 0usize;
    bencher.bench_local(|| {
        detector.detect_into(&data.scans[k % data.scans.len()].0, &mut out);
        k += 1;
        divan::black_box(out.legs.len())
    });
}

fn camera_ticks(bencher: divan::Bencher, data: &Inputs) {
    let order = pairs(data);
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

/// A laser-only tick as a robot without odometry runs it (issue 14 goal: under 100 us):
/// the scan matched against the static scene (the people tracked left out) for the
/// robot's pose, then detection, tracking with the physical gate and the clutter map,
/// and the target's reachable region.
#[divan::bench]
fn scan_tick_with_scan_matching(bencher: divan::Bencher) {
    use tether_scanmatch::{
        ExclusionZone, MotionPrior, ScanMatcher, ScanMatcherConfig, ScanPoints,
    };
    let data = inputs();
    let mut config = data.config.clone();
    config.fusion.use_vision = false;
    let mount = config.laser.robot_from_laser();
    let fresh = || {
        (
            Pipeline::new(config.clone(), None).expect("valid config"),
            ScanMatcher::new(ScanMatcherConfig::default()),
        )
    };
    let (mut pipeline, mut matcher) = fresh();
    let mut points = ScanPoints::default();
    let mut zones: Vec<ExclusionZone> = Vec::new();
    let mut pose = tether_core::Pose2::IDENTITY;
    let mut step = |pipeline: &mut Pipeline, matcher: &mut ScanMatcher, k: usize| {
        let (scan, _) = &data.scans[k];
        let robot_from_world = pose.inverse();
        zones.clear();
        zones.extend(pipeline.tracker().tracks().iter().map(|t| ExclusionZone {
            center: robot_from_world * t.position().mean,
            radius_m: 0.6,
        }));
        points
            .fill_from_scan(scan, mount)
            .expect("a simulated scan reads");
        pose = matcher
            .update(scan.stamp, &points, MotionPrior::ConstantVelocity, &zones)
            .world_from_robot;
        pipeline.on_scan(scan, pose).command
    };
    let mut k = 0usize;
    while k < 40 {
        step(&mut pipeline, &mut matcher, k);
        k += 1;
    }
    bencher.bench_local(|| {
        if k >= data.scans.len() {
            (pipeline, matcher) = fresh();
            k = 0;
        }
        let out = step(&mut pipeline, &mut matcher, k);
        k += 1;
        divan::black_box(out)
    });
}
