//! One full pipeline tick (issues 6 and 30: under 100 us): a 682-beam URG-04LX scan of the
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
    assert_eq!(
        data.config.legs.detector,
        tether_laser::DetectorKind::Learned
    );
    // What `Pipeline::new` builds: the built-in models, the coarse one for these
    // 0.5-degree beams.
    let mut detector = tether_laser::LegDetector::builtin(
        data.config.legs.config,
        data.config.laser.noise.clone(),
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
    let step = |pipeline: &mut Pipeline, k: usize| {
        let (si, fi) = order[k];
        let (scan, pose) = &data.scans[si];
        let a = pipeline.on_scan(scan, *pose);
        let (stamp, boxes, pose) = &data.frames[fi];
        let b = pipeline.on_camera_boxes(*stamp, boxes, *pose);
        (a.command, b.command)
    };
    // A fresh pipeline, warmed up: locked on the target over the first seconds.
    let fresh = || {
        let mut pipeline = Pipeline::new(data.config.clone(), None).expect("valid config");
        for k in 0..WARM_UP_TICKS {
            step(&mut pipeline, k);
        }
        (pipeline, WARM_UP_TICKS)
    };
    let state = std::cell::RefCell::new(fresh());
    bencher
        .with_inputs(|| {
            // Start over with a fresh pipeline when the recording runs out, outside the
            // timed tick: building one (reading the leg models) is no tick.
            let mut state = state.borrow_mut();
            if state.1 >= order.len() {
                *state = fresh();
            }
        })
        .bench_local_values(|()| {
            let mut state = state.borrow_mut();
            if state.1 >= order.len() {
                // Only when a sample runs more ticks than the recording has left.
                *state = fresh();
            }
            let (pipeline, k) = &mut *state;
            let out = step(pipeline, *k);
            *k += 1;
            divan::black_box(out)
        });
}

/// Ticks run before the measured ones, and again after each fresh start: the first
/// seconds of the recording, in which the pipeline locks on the target.
const WARM_UP_TICKS: usize = 40;

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
    // The pipeline and matcher with their buffers and the last pose, and the next scan.
    struct State {
        pipeline: Pipeline,
        matcher: ScanMatcher,
        points: ScanPoints,
        zones: Vec<ExclusionZone>,
        pose: tether_core::Pose2<tether_core::World, tether_core::Robot>,
        k: usize,
    }
    let step = |s: &mut State| {
        let (scan, _) = &data.scans[s.k];
        s.k += 1;
        let robot_from_world = s.pose.inverse();
        s.zones.clear();
        s.zones
            .extend(s.pipeline.tracker().tracks().iter().map(|t| ExclusionZone {
                center: robot_from_world * t.position().mean,
                radius_m: 0.6,
            }));
        s.points
            .fill_from_scan(scan, mount)
            .expect("a simulated scan reads");
        s.pose = s
            .matcher
            .update(
                scan.stamp,
                &s.points,
                MotionPrior::ConstantVelocity,
                &s.zones,
            )
            .world_from_robot;
        s.pipeline.on_scan(scan, s.pose).command
    };
    let fresh = || {
        let mut s = State {
            pipeline: Pipeline::new(config.clone(), None).expect("valid config"),
            matcher: ScanMatcher::new(ScanMatcherConfig::default()),
            points: ScanPoints::default(),
            zones: Vec::new(),
            pose: tether_core::Pose2::IDENTITY,
            k: 0,
        };
        while s.k < WARM_UP_TICKS {
            step(&mut s);
        }
        s
    };
    let state = std::cell::RefCell::new(fresh());
    bencher
        .with_inputs(|| {
            // A fresh start when the recording runs out, outside the timed tick.
            let mut state = state.borrow_mut();
            if state.k >= data.scans.len() {
                *state = fresh();
            }
        })
        .bench_local_values(|()| {
            let mut state = state.borrow_mut();
            if state.k >= data.scans.len() {
                *state = fresh();
            }
            divan::black_box(step(&mut state))
        });
}
