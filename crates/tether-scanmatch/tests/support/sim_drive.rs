//! A built-in scenario driven by the simulator's (ground-truth) follower, with
//! scan-matching odometry estimated beside it from the scans alone: what
//! `tests/sim_drift.rs` measures and `examples/sim_drift.rs` tunes.

use tether_core::{LaserScan, Pose2, Robot};
use tether_scanmatch::{
    Estimate, ExclusionZone, MotionPrior, ScanMatcher, ScanMatcherConfig, ScanPoints,
};
use tether_sim::{Event, Scenario, SensorData, Simulation};

/// One scan of the drive, after the matcher's update.
pub struct Step<'a> {
    pub event: &'a Event,
    pub scan: &'a LaserScan,
    /// Scans so far, this one included.
    pub scans: usize,
    pub points: &'a ScanPoints,
    pub matcher: &'a ScanMatcher,
    pub estimate: &'a Estimate,
    /// The true pose relative to the first scan's, what the estimate should be.
    pub truth: Pose2<Robot, Robot>,
    /// The distance the robot has driven so far, m.
    pub distance_m: f64,
}

impl Step<'_> {
    /// The estimate's position error, m, and yaw error, rad.
    pub fn error(&self) -> (f64, f64) {
        let (est, t) = (self.estimate.world_from_robot, self.truth);
        (
            (est.x - t.x).hypot(est.y - t.y),
            tether_core::wrap_angle_rad(est.yaw - t.yaw),
        )
    }
}

/// Drives the built-in scenario `name` with `seed`; `on_scan` sees every scan. People
/// are excluded (when `exclude_people`) as a tracker would give them: a zone around
/// each true leg seen by the laser. The prior is the commanded velocity (when
/// `commanded`) or constant velocity. Returns the matcher at the end.
pub fn drive(
    name: &str,
    seed: u64,
    config: ScanMatcherConfig,
    exclude_people: bool,
    commanded: bool,
    mut on_scan: impl FnMut(&Step),
) -> ScanMatcher {
    let scenario = Scenario::builtin(name).expect("a built-in scenario");
    let mut sim = Simulation::new(&scenario, seed).expect("the scenario runs");
    let mut driver = tether_sim::driver::driver_for(&scenario);
    let robot_from_laser = scenario.laser.robot_from_laser();
    let mut matcher = ScanMatcher::new(config);
    let mut points = ScanPoints::default();
    let mut start: Option<Pose2<tether_core::World, Robot>> = None;
    let mut last: Option<Pose2<tether_core::World, Robot>> = None;
    let mut distance_m = 0.0;
    let mut scans = 0;
    let mut command = tether_sim::Command::STOP;
    while let Some(event) = sim.advance() {
        if let Some(c) = driver.on_event(&event) {
            sim.set_command(c);
            command = c;
        }
        let SensorData::Scan(scan) = &event.data else {
            continue;
        };
        scans += 1;
        let truth = event.truth.world_from_robot;
        let first = *start.get_or_insert(truth);
        if let Some(l) = last {
            distance_m += (truth.x - l.x).hypot(truth.y - l.y);
        }
        last = Some(truth);
        let robot_from_world = truth.inverse();
        let zones: Vec<ExclusionZone> = if exclude_people {
            event
                .truth
                .people
                .iter()
                .flat_map(|p| p.legs)
                .map(|leg| ExclusionZone {
                    center: robot_from_world * leg.center,
                    radius_m: leg.radius_m + 0.15,
                })
                .collect()
        } else {
            Vec::new()
        };
        points
            .fill_from_scan(scan, robot_from_laser)
            .expect("a simulated scan fills");
        let prior = if commanded {
            MotionPrior::Velocity {
                v_mps: command.v_mps,
                w_radps: command.w_radps,
            }
        } else {
            MotionPrior::ConstantVelocity
        };
        let estimate = matcher.update(scan.stamp, &points, prior, &zones);
        on_scan(&Step {
            event: &event,
            scan,
            scans,
            points: &points,
            matcher: &matcher,
            estimate: &estimate,
            truth: first.inverse() * truth,
            distance_m,
        });
    }
    matcher
}
