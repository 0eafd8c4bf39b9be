//! The closed loop in the simulator: simulated sensors -> laser detection -> vision
//! model -> fusion and tracking -> controller -> robot dynamics.
//!
//! The pipeline under test drives the robot. Optional passenger pipelines (laser only,
//! vision only) see exactly the same sensor data and are evaluated too, without
//! driving. Faults can be injected between the simulator and the pipelines.
//!
//! The robot's pose each pipeline is given is the simulator's true pose when the
//! scenario's robot has odometry (`[robot] odometry`, the default), and otherwise the
//! dead reckoning of the driving pipeline's own commands ([`OdometryFeed`]): a robot
//! without odometry knows only what it commanded, never where it really went.

use tether_control::Twist;
use tether_core::{LaserScan, Pose2, Robot, Stamp, World};

use tether_live::driver::{Driver, GivenPose};
use tether_live::odometry::DeadReckoning;
use tether_pipeline::{PipelineConfig, PipelineError, Tick};
use tether_sim::{Command, Event, Scenario, SensorData, SimError, Simulation, Truth};

/// Something that goes wrong on purpose between the sensors and the pipeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    /// Camera frames are lost during `[from_s, from_s + duration_s)`.
    CameraDropout {
        /// Start, s.
        from_s: f64,
        /// Length, s.
        duration_s: f64,
    },
    /// Laser scans are lost during the interval.
    LaserDropout {
        /// Start, s.
        from_s: f64,
        /// Length, s.
        duration_s: f64,
    },
    /// Every range of the scans in the interval is NaN.
    NanBurst {
        /// Start, s.
        from_s: f64,
        /// Length, s.
        duration_s: f64,
    },
    /// From `at_s` on, every stamp is `jump_s` later than the truth.
    StampJump {
        /// When, s.
        at_s: f64,
        /// Size, s.
        jump_s: f64,
    },
}

impl Fault {
    fn active(from_s: f64, duration_s: f64, t: f64) -> bool {
        t >= from_s && t < from_s + duration_s
    }
}

/// What triggered a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepKind {
    /// A laser scan.
    Scan,
    /// A camera frame.
    Camera,
    /// The control timer.
    Timer,
}

/// One tick of the run: the truth at that instant and what each pipeline made of it.
#[derive(Debug, Clone)]
pub struct StepRecord {
    /// What triggered it.
    pub kind: StepKind,
    /// Ground truth.
    pub truth: Truth,
    /// The driving pipeline's tick (`None` when a fault swallowed the input).
    pub tick: Option<Tick>,
    /// The passengers' ticks, in the order they were given.
    pub passengers: Vec<Option<Tick>>,
    /// The robot's pose the pipelines were given ([`OdometryFeed`]): the true pose
    /// with odometry, the dead reckoning without.
    pub world_from_robot_given: Pose2<World, Robot>,
}

impl StepRecord {
    /// Where the frame of the pipelines' estimates lies in the world:
    /// `world_from_robot_true * (world_from_robot_given)^-1` (the identity with
    /// odometry). Estimates mapped through it are compared with the truth *relative to
    /// the robot*, which is what following needs, whatever the odometry drifted.
    pub fn world_from_estimates(&self) -> Pose2<World, World> {
        let given_from_robot: Pose2<Robot, World> = self.world_from_robot_given.inverse();
        let w = self.truth.world_from_robot * given_from_robot;
        Pose2::new(w.x, w.y, w.yaw)
    }

    /// The truth with every position and velocity expressed in the frame of the
    /// pipelines' estimates (the truth itself with odometry).
    pub fn truth_in_estimate_frame(&self) -> Truth {
        let e: Pose2<World, World> = self.world_from_estimates().inverse();
        let mut t = self.truth.clone();
        let robot = e * t.world_from_robot;
        t.world_from_robot = Pose2::new(robot.x, robot.y, robot.yaw);
        let laser = e * t.world_from_laser;
        t.world_from_laser = Pose2::new(laser.x, laser.y, laser.yaw);
        let camera = e * t.world_from_camera;
        t.world_from_camera = Pose2::new(camera.x, camera.y, camera.yaw);
        for p in &mut t.people {
            p.position = e * p.position;
            p.velocity = e.rotate(p.velocity);
            p.heading_rad = tether_core::wrap_angle_rad(p.heading_rad + e.yaw);
            for leg in &mut p.legs {
                leg.center = e * leg.center;
            }
        }
        t
    }
}

/// A finished run.
#[derive(Debug, Clone)]
pub struct RunLog {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// Follow distance the controller aimed for, m.
    pub follow_distance_m: f64,
    /// Every tick.
    pub steps: Vec<StepRecord>,
    /// Robot collisions with walls and furniture.
    pub collisions: u32,
    /// Robot footprint radius, m.
    pub robot_radius_m: f64,
    /// Spring attachment ahead of the axle, m.
    pub attach_ahead_m: f64,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The simulator refused the scenario.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The pipeline refused its configuration.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// Recording the run failed.
    #[error(transparent)]
    Record(#[from] tether_sim::record::RecordError),
    /// Writing the run's MCAP recording failed.
    #[error("writing the MCAP recording: {0}")]
    Mcap(#[from] tether_recording::mcap::McapError),
}

/// The pipeline configuration that matches a scenario's robot: its laser (and extra
/// lasers) and camera models, follow distance and base limits, on top of `base`.
pub fn config_for(scenario: &Scenario, base: &PipelineConfig) -> PipelineConfig {
    let mut c = base.clone();
    c.laser = scenario.laser.clone();
    c.extra_lasers.clone_from(&scenario.extra_lasers);
    c.camera = scenario.camera;
    c.extra_cameras.clone_from(&scenario.extra_cameras);
    c.follower.follow_distance_m = scenario.robot.follow_distance_m;
    c.limits.track_width_m = scenario.robot.track_width_m;
    c.limits.max_wheel_speed_mps = scenario.robot.max_wheel_speed_mps;
    // The base cannot change speed faster than its wheels can.
    c.limits.max_accel_mps2 = c
        .limits
        .max_accel_mps2
        .min(scenario.robot.max_wheel_accel_mps2);
    c.limits.max_decel_mps2 = c
        .limits
        .max_decel_mps2
        .min(scenario.robot.max_wheel_accel_mps2);
    c.safety.robot_radius_m = scenario.robot.radius_m;
    c
}

/// The robot's motion as the pipelines are told it.
#[derive(Debug, Clone)]
pub enum OdometryFeed {
    /// The simulator's true pose (a base with perfect odometry).
    Truth,
    /// No odometry: the dead reckoning of the commands sent to the base, from the
    /// identity at the start.
    DeadReckoned(DeadReckoning),
}

impl OdometryFeed {
    /// The feed for `scenario`: [`OdometryFeed::Truth`] when
    /// [`Scenario::odometry_available`], dead reckoning otherwise.
    pub fn for_scenario(scenario: &Scenario) -> Self {
        if scenario.odometry_available() {
            OdometryFeed::Truth
        } else {
            OdometryFeed::DeadReckoned(DeadReckoning::new(Stamp::ZERO))
        }
    }

    /// The pose given to the pipelines at the instant of `truth`.
    pub fn pose(&self, truth: &Truth) -> Pose2<World, Robot> {
        match self {
            OdometryFeed::Truth => truth.world_from_robot,
            OdometryFeed::DeadReckoned(dr) => dr.pose_at(truth.stamp),
        }
    }

    /// The driving pipeline commanded `command` at `stamp`.
    pub fn commanded(&mut self, stamp: Stamp, command: Command) {
        if let OdometryFeed::DeadReckoned(dr) = self {
            dr.set_command(
                stamp,
                Twist {
                    v_mps: command.v_mps,
                    w_radps: command.w_radps,
                },
            );
        }
    }
}

/// Hands `event` to a pipeline's driver at the robot's pose `pose` (the simulator is the
/// clock: its timer events are the control timer's instants, ties after the data of the
/// same instant), through `faults`; `None` when a fault swallowed the input.
fn feed(
    driver: &mut Driver<'_, GivenPose>,
    event: &Event,
    pose: Pose2<World, Robot>,
    faults: &[Fault],
) -> Option<Tick> {
    let t = event.truth.stamp.secs_f64();
    let mut stamp = event.truth.stamp;
    for f in faults {
        if let Fault::StampJump { at_s, jump_s } = *f
            && t >= at_s
        {
            stamp = stamp.saturating_add_ns((jump_s * 1e9) as i64);
        }
    }
    *driver.poses_mut() = GivenPose(pose);
    match &event.data {
        SensorData::Scan(scan) => {
            if faults
                .iter()
                .any(|f| matches!(*f, Fault::LaserDropout { from_s, duration_s } if Fault::active(from_s, duration_s, t)))
            {
                return None;
            }
            let nan = faults
                .iter()
                .any(|f| matches!(*f, Fault::NanBurst { from_s, duration_s } if Fault::active(from_s, duration_s, t)));
            let ranges = if nan {
                vec![f32::NAN; scan.len()]
            } else {
                scan.ranges_m().to_vec()
            };
            let mut scan = LaserScan::new(
                stamp,
                scan.frame_id.clone(),
                scan.angle_min_rad,
                scan.angle_increment_rad,
                scan.range_min_m,
                scan.range_max_m,
                ranges,
            )
            .ok()?;
            driver.scan(&mut scan).map(|d| d.tick)
        }
        SensorData::Camera(frame) => {
            if faults
                .iter()
                .any(|f| matches!(*f, Fault::CameraDropout { from_s, duration_s } if Fault::active(from_s, duration_s, t)))
            {
                return None;
            }
            let pose = driver.camera_pose(stamp)?;
            Some(
                driver
                    .camera(stamp, &frame.frame_id, &frame.boxes, pose)
                    .tick,
            )
        }
        SensorData::Timer => driver.timer(stamp).map(|d| d.tick),
    }
}

/// The pipeline variants of a run (`tether demo`, `sim`, `eval-fusion`): the driver and
/// its laser-only and vision-only passengers.
pub fn variants(scenario: &Scenario) -> (PipelineConfig, Vec<PipelineConfig>) {
    variants_from(scenario, &PipelineConfig::default())
}

/// [`variants`] from the configuration `base` (`tether sim --config`) instead of the
/// defaults.
pub fn variants_from(
    scenario: &Scenario,
    base: &PipelineConfig,
) -> (PipelineConfig, Vec<PipelineConfig>) {
    let fused = config_for(scenario, base);
    let mut laser_only = fused.clone();
    laser_only.fusion.use_vision = false;
    let mut vision_only = fused.clone();
    vision_only.fusion.use_laser = false;
    vision_only.fusion.vision_spawns_tracks = true;
    (fused, vec![laser_only, vision_only])
}

/// The laser-only version of `scenario`: the camera off (`camera_sim.enabled = false`,
/// no frames at all), `-laser-only` appended to its name.
pub fn laser_only(scenario: &Scenario) -> Scenario {
    let mut s = scenario.clone();
    if !s.name.ends_with("-laser-only") {
        s.name = format!("{}-laser-only", scenario.name);
        s.description = format!(
            "{} Laser only: the camera is off and the laser alone finds, tracks and vouches \
             for the target.",
            scenario.description
        );
    }
    s.camera_sim.enabled = false;
    s
}

/// The pipeline of a laser-only run: the fused configuration with vision off, driving
/// alone (no passengers: there is no camera to compare with).
pub fn laser_only_variants(scenario: &Scenario) -> (PipelineConfig, Vec<PipelineConfig>) {
    laser_only_variants_from(scenario, &PipelineConfig::default())
}

/// [`laser_only_variants`] from the configuration `base`.
pub fn laser_only_variants_from(
    scenario: &Scenario,
    base: &PipelineConfig,
) -> (PipelineConfig, Vec<PipelineConfig>) {
    let (mut laser, _) = variants_from(scenario, base);
    laser.fusion.use_vision = false;
    (laser, Vec::new())
}

/// Control rate of the closed loop (timer ticks besides sensor data), Hz.
pub const CONTROL_RATE_HZ: f64 = 20.0;

/// Runs `scenario` with the pipeline `config` driving the robot and `passengers`
/// riding along.
pub fn run(
    scenario: &Scenario,
    seed: u64,
    config: &PipelineConfig,
    passengers: &[PipelineConfig],
    faults: &[Fault],
) -> Result<RunLog, RunError> {
    run_observed(scenario, seed, config, passengers, faults, &mut |_, _| {
        Ok(())
    })
}

/// Called with every event and the driving pipeline's tick.
pub type Observer<'a> = dyn FnMut(&Event, Option<&Tick>) -> Result<(), RunError> + 'a;

/// Like [`run`], calling `observe` with every event and the driving pipeline's tick
/// (to record the run, show progress...).
pub fn run_observed(
    scenario: &Scenario,
    seed: u64,
    config: &PipelineConfig,
    passengers: &[PipelineConfig],
    faults: &[Fault],
    observe: &mut Observer<'_>,
) -> Result<RunLog, RunError> {
    let mut sim = Simulation::new(scenario, seed)?;
    sim.set_control_rate_hz(CONTROL_RATE_HZ);
    let mut driving = tether_live::leg_model::pipeline(config.clone())?;
    let mut riding = passengers
        .iter()
        .map(|c| tether_live::leg_model::pipeline(c.clone()))
        .collect::<Result<Vec<_>, _>>()?;
    let mut driver = Driver::new(&mut driving, GivenPose(Pose2::IDENTITY));
    let mut riders: Vec<_> = riding
        .iter_mut()
        .map(|p| Driver::new(p, GivenPose(Pose2::IDENTITY)))
        .collect();
    let mut steps = Vec::new();
    let mut odometry = OdometryFeed::for_scenario(scenario);
    while let Some(event) = sim.advance() {
        let pose = odometry.pose(&event.truth);
        let tick = feed(&mut driver, &event, pose, faults);
        if let Some(t) = &tick {
            let command = Command {
                v_mps: t.command.v_mps,
                w_radps: t.command.w_radps,
            };
            sim.set_command(command);
            odometry.commanded(event.truth.stamp, command);
        }
        observe(&event, tick.as_ref())?;
        let passengers = riders
            .iter_mut()
            .map(|p| feed(p, &event, pose, faults))
            .collect();
        let kind = match event.data {
            SensorData::Scan(_) => StepKind::Scan,
            SensorData::Camera(_) => StepKind::Camera,
            SensorData::Timer => StepKind::Timer,
        };
        steps.push(StepRecord {
            kind,
            truth: event.truth,
            tick,
            passengers,
            world_from_robot_given: pose,
        });
    }
    Ok(RunLog {
        scenario: scenario.name.clone(),
        seed,
        follow_distance_m: config.follower.follow_distance_m,
        collisions: sim.collisions(),
        steps,
        robot_radius_m: scenario.robot.radius_m,
        attach_ahead_m: config.follower.attach_ahead_m,
    })
}

/// Seconds since the start of a run.
pub fn secs(stamp: Stamp) -> f64 {
    stamp.secs_f64()
}
