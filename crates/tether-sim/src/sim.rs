//! The simulation loop: people walk, the robot drives, the laser and the camera sample
//! the world at their own rates, each sample comes out with its ground truth.
//!
//! Time advances in integer nanoseconds from one sensor event to the next, with physics
//! sub-steps of at most 10 ms in between. Scans come every laser period from t = 0,
//! camera frames every 1/rate from t = 0 (frame k at `k * 1e9 / rate` ns, rounded, so
//! the rate does not drift); when both fall on the same nanosecond the scan comes first.

use serde::Serialize;
use thiserror::Error;

use tether_core::{Camera, Laser, LaserScan, Point2, Pose2, Robot, Stamp, Vector2, World};

use crate::camera::{CameraFrame, CameraTruth, SimCamera};
use crate::geometry::Segment;
use crate::laser::{LegCircle, SimLaser, clutter_spots};
use crate::person::Person;
use crate::rng::SimRng;
use crate::robot::{Command, DiffDrive};
use crate::scenario::Scenario;
use crate::world::StaticWorld;

/// Longest physics step, ns.
const MAX_STEP_NS: i64 = 10_000_000;

/// Why a simulation cannot run.
#[derive(Debug, Error)]
pub enum SimError {
    /// The scenario failed validation.
    #[error("scenario `{name}` is invalid: field `{field}`: {message}")]
    InvalidScenario {
        /// Scenario name.
        name: String,
        /// Field path.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A scan could not be built (an inconsistent laser model).
    #[error("simulated scan is invalid: {0}")]
    Scan(#[from] tether_core::ScanError),
}

/// A leg in the ground truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LegTruth {
    /// Centre at the laser's height, world frame, m.
    pub center: Point2<World>,
    /// Radius, m.
    pub radius_m: f64,
}

/// Ground truth of one person at one instant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PersonTruth {
    /// Person id (index in the scenario).
    pub id: u32,
    /// Name from the scenario.
    pub name: String,
    /// The person the robot should follow.
    pub target: bool,
    /// Body centre, world frame, m.
    pub position: Point2<World>,
    /// Body velocity, world frame, m/s.
    pub velocity: Vector2<World>,
    /// Facing direction, rad.
    pub heading_rad: f64,
    /// Height of the head top, m.
    pub height_m: f64,
    /// Legs at the laser's height (left, right).
    pub legs: [LegTruth; 2],
    /// For scan events: how many beams of this scan hit the person's legs (0 = hidden
    /// from the laser). `None` for camera events.
    pub laser_beams: Option<u32>,
}

/// Ground truth common to every sensor event.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// Time of the event.
    pub stamp: Stamp,
    /// Robot pose.
    pub world_from_robot: Pose2<World, Robot>,
    /// Robot velocity (forward speed, turn rate).
    pub robot_velocity: Command,
    /// Laser pose.
    pub world_from_laser: Pose2<World, Laser>,
    /// Camera (ground frame) pose.
    pub world_from_camera: Pose2<World, Camera>,
    /// Every person.
    pub people: Vec<PersonTruth>,
    /// Collisions of the robot with walls or obstacles so far.
    pub collisions: u32,
}

impl Truth {
    /// The target, if the scenario has one.
    pub fn target(&self) -> Option<&PersonTruth> {
        self.people.iter().find(|p| p.target)
    }
}

/// A sensor sample.
#[derive(Debug, Clone)]
pub enum SensorData {
    /// A laser scan in the laser frame.
    Scan(LaserScan),
    /// Upper-body detections of one camera frame.
    Camera(CameraFrame),
    /// A control-loop timer tick (no data), when a control rate is set with
    /// [`Simulation::set_control_rate_hz`]: a real robot's controller runs on a timer
    /// too, so that it can stop the base when the sensors fall silent.
    Timer,
}

impl SensorData {
    /// The scan, when this is one of the first laser's (frame `laser`): what a consumer
    /// that speaks to one scanner takes (a SCIP emulator, a ROS 1 bag of leg_tracker's
    /// kind); the `extra_lasers`' scans carry their own frames.
    pub fn first_laser_scan(&self) -> Option<&LaserScan> {
        match self {
            SensorData::Scan(scan) if scan.frame_id == <Laser as tether_core::Frame>::NAME => {
                Some(scan)
            }
            _ => None,
        }
    }
}

/// One event of the simulation: a sensor sample and the truth at its instant.
#[derive(Debug, Clone)]
pub struct Event {
    /// The sample, as a real sensor would deliver it.
    pub data: SensorData,
    /// Ground truth (never to be used by the estimator under test).
    pub truth: Truth,
    /// Extra truth for camera frames.
    pub camera_truth: Option<CameraTruth>,
}

/// A scanner besides the first (`Scenario::extra_lasers`): its simulated laser, the
/// frame its scans carry, where it sits, and when its next scan is due (its own period,
/// offset between the first laser's scans).
#[derive(Debug)]
struct ExtraSimLaser {
    laser: SimLaser,
    frame_id: String,
    robot_from_laser: Pose2<Robot, Laser>,
    height_m: f64,
    period_ns: i64,
    offset_ns: i64,
    next_index: i64,
}

/// A camera besides the first (`Scenario::extra_cameras`): its simulated detector, the
/// frame its frames carry, and when its next frame is due (the first camera's rate,
/// offset between its frames).
#[derive(Debug)]
struct ExtraSimCamera {
    camera: SimCamera,
    frame_id: String,
    offset_ns: f64,
    next_index: i64,
}

/// A running simulation.
#[derive(Debug)]
pub struct Simulation {
    scenario: Scenario,
    world: StaticWorld,
    people: Vec<Person>,
    robot: DiffDrive,
    laser: Option<SimLaser>,
    extra_lasers: Vec<ExtraSimLaser>,
    camera: Option<SimCamera>,
    extra_cameras: Vec<ExtraSimCamera>,
    now: Stamp,
    end: Stamp,
    next_scan_index: i64,
    next_frame_index: i64,
    scan_period_ns: i64,
    control_period_ns: Option<i64>,
    next_timer_index: i64,
    collisions: u32,
}

/// The people's paths (closed when walked again and again) and the robot's start, as
/// segments: where the simulated clutter does not stand.
fn walkways(scenario: &Scenario) -> Vec<Segment> {
    let p = |xy: [f64; 2]| Point2::<World>::new(xy[0], xy[1]);
    let start = p([scenario.robot.start.x, scenario.robot.start.y]);
    let mut segments = vec![Segment { a: start, b: start }];
    for person in &scenario.people {
        let mut path: Vec<Point2<World>> = person.path.iter().map(|&xy| p(xy)).collect();
        if person.repeat
            && let Some(&first) = path.first()
        {
            path.push(first);
        }
        if let [only] = path[..] {
            segments.push(Segment { a: only, b: only });
        }
        segments.extend(path.windows(2).map(|w| Segment { a: w[0], b: w[1] }));
    }
    segments
}

impl Simulation {
    /// Builds the world of `scenario` for `seed`. The scenario is validated again (a
    /// hand-built [`Scenario`] may not have been).
    pub fn new(scenario: &Scenario, seed: u64) -> Result<Self, SimError> {
        if let Some(problem) = scenario.validate().into_iter().next() {
            let field = problem
                .field
                .iter()
                .map(|s| match s {
                    crate::scenario::FieldSeg::Key(k) => format!(".{k}"),
                    crate::scenario::FieldSeg::Index(i) => format!("[{i}]"),
                })
                .collect::<String>()
                .trim_start_matches('.')
                .to_owned();
            return Err(SimError::InvalidScenario {
                name: scenario.name.clone(),
                field,
                message: problem.message,
            });
        }
        let world = StaticWorld::from_scenario(scenario);
        let people = scenario
            .people
            .iter()
            .enumerate()
            .map(|(i, spec)| {
                let mut rng = SimRng::stream(seed, &format!("person/{i}"));
                Person::from_spec(i as u32, spec, &mut rng)
            })
            .collect();
        // The clutter is in the world: every scanner sees the same pieces.
        let clutter = scenario.laser_sim.enabled.then(|| {
            clutter_spots(
                &scenario.world.rooms,
                &walkways(scenario),
                &world,
                &scenario.laser_sim,
                &mut SimRng::stream(seed, "laser/clutter"),
            )
        });
        let laser = clutter.clone().map(|clutter| {
            SimLaser::new(
                scenario.laser.clone(),
                scenario.laser_sim.clone(),
                SimRng::stream(seed, "laser"),
            )
            .with_realism_rng(SimRng::stream(seed, "laser/realism"))
            .with_clutter(clutter)
        });
        let n_extra = scenario.extra_lasers.len() as i64;
        let extra_lasers = clutter
            .map(|clutter| {
                scenario
                    .extra_lasers
                    .iter()
                    .enumerate()
                    .map(|(k, extra)| {
                        let period_ns = extra.laser.scan_period_ns().max(1);
                        ExtraSimLaser {
                            laser: SimLaser::new(
                                extra.laser.clone(),
                                scenario.laser_sim.clone(),
                                SimRng::stream(seed, &format!("laser/{}", extra.frame_id)),
                            )
                            .with_realism_rng(SimRng::stream(
                                seed,
                                &format!("laser/{}/realism", extra.frame_id),
                            ))
                            .with_clutter(clutter.clone()),
                            frame_id: extra.frame_id.clone(),
                            robot_from_laser: extra.laser.robot_from_laser(),
                            height_m: extra.laser.mount.height_m,
                            period_ns,
                            offset_ns: period_ns * (k as i64 + 1) / (n_extra + 1),
                            next_index: 0,
                        }
                    })
                    .collect()
            })
            .unwrap_or_default();
        let camera = scenario.camera_sim.enabled.then(|| {
            SimCamera::new(
                scenario.camera,
                scenario.camera_sim.clone(),
                SimRng::stream(seed, "camera"),
            )
        });
        let n_cameras = scenario.extra_cameras.len();
        let extra_cameras = camera
            .as_ref()
            .map(|first| {
                scenario
                    .extra_cameras
                    .iter()
                    .enumerate()
                    .map(|(k, extra)| ExtraSimCamera {
                        camera: SimCamera::new(
                            extra.camera,
                            scenario.camera_sim.clone(),
                            SimRng::stream(seed, &format!("camera/{}", extra.frame_id)),
                        ),
                        frame_id: extra.frame_id.clone(),
                        offset_ns: first.period_ns() * (k as f64 + 1.0) / (n_cameras as f64 + 1.0),
                        next_index: 0,
                    })
                    .collect()
            })
            .unwrap_or_default();
        let end = Stamp::from_secs_f64(scenario.duration_s).unwrap_or(Stamp::ZERO);
        Ok(Simulation {
            scenario: scenario.clone(),
            world,
            people,
            robot: DiffDrive::from_spec(&scenario.robot),
            laser,
            extra_lasers,
            camera,
            extra_cameras,
            now: Stamp::ZERO,
            end,
            next_scan_index: 0,
            next_frame_index: 0,
            scan_period_ns: scenario.laser.scan_period_ns().max(1),
            control_period_ns: None,
            next_timer_index: 0,
            collisions: 0,
        })
    }

    /// The scenario being run.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The static world.
    pub fn world(&self) -> &StaticWorld {
        &self.world
    }

    /// The people.
    pub fn people(&self) -> &[Person] {
        &self.people
    }

    /// The robot.
    pub fn robot(&self) -> &DiffDrive {
        &self.robot
    }

    /// The simulated laser, if enabled.
    pub fn laser(&self) -> Option<&SimLaser> {
        self.laser.as_ref()
    }

    /// Current simulated time.
    pub fn now(&self) -> Stamp {
        self.now
    }

    /// End of the run.
    pub fn end(&self) -> Stamp {
        self.end
    }

    /// Collisions of the robot with the static world so far.
    pub fn collisions(&self) -> u32 {
        self.collisions
    }

    /// Emits a [`SensorData::Timer`] event every `1 / hz` seconds (0 turns it off).
    pub fn set_control_rate_hz(&mut self, hz: f64) {
        self.control_period_ns =
            (hz.is_finite() && hz > 0.0).then(|| (1e9 / hz).round().max(1.0) as i64);
        self.next_timer_index = (self.now.ns() + self.control_period_ns.unwrap_or(1) - 1)
            / self.control_period_ns.unwrap_or(1);
    }

    /// Sets the robot's command (kept until the next call).
    pub fn set_command(&mut self, command: Command) {
        self.robot.set_command(command);
    }

    fn next_scan_ns(&self) -> Option<i64> {
        self.laser
            .as_ref()
            .map(|_| self.next_scan_index * self.scan_period_ns)
    }

    fn next_frame_ns(&self) -> Option<i64> {
        self.camera
            .as_ref()
            .map(|c| (self.next_frame_index as f64 * c.period_ns()).round() as i64)
    }

    /// Advances to the next sensor event and returns it, or `None` at the end.
    pub fn advance(&mut self) -> Option<Event> {
        // (time, kind): 0 scan, 1 camera, 2 timer, 3 + k the k-th extra laser's scan;
        // ties in that order.
        let candidates = [
            self.next_scan_ns().map(|t| (t, 0usize)),
            self.next_frame_ns().map(|t| (t, 1)),
            self.control_period_ns
                .map(|p| (self.next_timer_index * p, 2)),
        ];
        let n_lasers = self.extra_lasers.len();
        let extras = self
            .extra_lasers
            .iter()
            .enumerate()
            .map(|(k, e)| (e.next_index * e.period_ns + e.offset_ns, 3 + k));
        let period_ns = self.camera.as_ref().map_or(1.0, SimCamera::period_ns);
        let cameras = self.extra_cameras.iter().enumerate().map(|(k, c)| {
            let at = (c.next_index as f64 * period_ns + c.offset_ns).round() as i64;
            (at, 3 + n_lasers + k)
        });
        let Some((at, kind)) = candidates
            .into_iter()
            .flatten()
            .chain(extras)
            .chain(cameras)
            .min()
        else {
            self.step_to(self.end);
            return None;
        };
        if at > self.end.ns() {
            self.step_to(self.end);
            return None;
        }
        self.step_to(Stamp::from_ns(at));
        match kind {
            2 => {
                self.next_timer_index += 1;
                Some(Event {
                    data: SensorData::Timer,
                    truth: self.truth(),
                    camera_truth: None,
                })
            }
            1 => {
                self.next_frame_index += 1;
                let truth = self.truth();
                let camera = self.camera.as_mut()?;
                let (frame, camera_truth) =
                    camera.frame(self.now, truth.world_from_robot, &self.world, &self.people);
                Some(Event {
                    data: SensorData::Camera(frame),
                    truth,
                    camera_truth: Some(camera_truth),
                })
            }
            0 => {
                self.next_scan_index += 1;
                self.scan_event(None)
            }
            k if k >= 3 + n_lasers => self.extra_camera_event(k - 3 - n_lasers),
            k => {
                self.extra_lasers.get_mut(k - 3)?.next_index += 1;
                self.scan_event(Some(k - 3))
            }
        }
    }

    /// The frame of the `k`-th extra camera now (the truth of its people's views is
    /// kept for the first camera only).
    fn extra_camera_event(&mut self, k: usize) -> Option<Event> {
        let truth = self.truth();
        let extra = self.extra_cameras.get_mut(k)?;
        extra.next_index += 1;
        let (mut frame, _) =
            extra
                .camera
                .frame(self.now, truth.world_from_robot, &self.world, &self.people);
        frame.frame_id.clone_from(&extra.frame_id);
        Some(Event {
            data: SensorData::Camera(frame),
            truth,
            camera_truth: None,
        })
    }

    /// The scan of the first laser (`None`) or of the extra laser `extra` now, with the
    /// truth as that laser saw it (its pose, the beams on each person).
    fn scan_event(&mut self, extra: Option<usize>) -> Option<Event> {
        let mut truth = self.truth();
        let (laser, height_m) = match extra {
            None => (self.laser.as_mut()?, self.scenario.laser.mount.height_m),
            Some(k) => {
                let e = self.extra_lasers.get_mut(k)?;
                truth.world_from_laser = truth.world_from_robot * e.robot_from_laser;
                (&mut e.laser, e.height_m)
            }
        };
        let legs: Vec<LegCircle> = self
            .people
            .iter()
            .flat_map(|p| {
                let [l, r] = p.legs_at(height_m);
                [
                    LegCircle {
                        circle: l,
                        person: p.id,
                        leg: 0,
                    },
                    LegCircle {
                        circle: r,
                        person: p.id,
                        leg: 1,
                    },
                ]
            })
            .collect();
        let scan = laser.scan(self.now, truth.world_from_laser, &self.world, &legs);
        for person in &mut truth.people {
            let beams = laser
                .last_hits()
                .iter()
                .filter(
                    |h| matches!(h, crate::laser::Hit::Leg { person: id, .. } if *id == person.id),
                )
                .count();
            person.laser_beams = Some(beams as u32);
        }
        match scan {
            Ok(mut scan) => {
                if let Some(k) = extra {
                    scan.frame_id.clone_from(&self.extra_lasers[k].frame_id);
                }
                Some(Event {
                    data: SensorData::Scan(scan),
                    truth,
                    camera_truth: None,
                })
            }
            Err(e) => {
                tracing::error!("dropping an invalid simulated scan: {e}");
                None
            }
        }
    }

    fn step_to(&mut self, t: Stamp) {
        while self.now < t {
            let dt_ns = t.ns_since(self.now).min(MAX_STEP_NS);
            let dt_s = dt_ns as f64 * 1e-9;
            // People give way to those listed before them (design 9).
            for i in 0..self.people.len() {
                let (before, rest) = self.people.split_at_mut(i);
                if let Some(p) = rest.first_mut() {
                    let yields = before.iter().any(|q| p.must_give_way_to(q));
                    p.set_giving_way(yields);
                }
            }
            for p in &mut self.people {
                p.step(dt_s);
            }
            let was_blocked = self.robot.blocked();
            if self.robot.step(dt_s, &self.world) && !was_blocked {
                self.collisions += 1;
            }
            self.now = self.now.saturating_add_ns(dt_ns);
        }
    }

    /// Ground truth now.
    pub fn truth(&self) -> Truth {
        let world_from_robot = self.robot.pose();
        let laser_height = self.scenario.laser.mount.height_m;
        Truth {
            stamp: self.now,
            world_from_robot,
            robot_velocity: self.robot.velocity(),
            world_from_laser: world_from_robot * self.scenario.laser.robot_from_laser(),
            world_from_camera: world_from_robot * self.scenario.camera.robot_from_camera(),
            people: self
                .people
                .iter()
                .map(|p| {
                    let legs = p.legs_at(laser_height).map(|c| LegTruth {
                        center: c.center,
                        radius_m: c.radius_m,
                    });
                    PersonTruth {
                        id: p.id,
                        name: p.name.clone(),
                        target: p.is_target,
                        position: p.position(),
                        velocity: p.velocity(),
                        heading_rad: p.heading_rad(),
                        height_m: p.body.height_m,
                        legs,
                        laser_beams: None,
                    }
                })
                .collect(),
            collisions: self.collisions,
        }
    }
}
