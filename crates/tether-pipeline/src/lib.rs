//! The per-tick pipeline of tether: the same code runs the simulator's closed loop,
//! replays of recordings and the live robot.
//!
//! Each input is one tick: a laser scan ([`Pipeline::on_scan`]) or a camera frame's
//! people ([`Pipeline::on_camera`]), with the robot's odometry pose at its stamp. A tick
//! runs detection, fusion and tracking, updates the target of interest and produces the
//! velocity command, after the safety layer. Nothing here reads a clock or does I/O.
//!
//! Two fusion modes:
//! - `tracker` (default): laser and vision observations update person tracks as they
//!   arrive (Kalman for the laser, Covariance Intersection for vision, whose range error
//!   persists from frame to frame); the target is a locked track.
//! - `per_frame`: the paper's complementary fusion, frame by frame, with no memory: the
//!   target is the fused laser-vision pair nearest the heading.

mod camera;
pub mod config_docs;
mod drive;
pub mod follow;
mod laser;
pub mod vision;

use serde::{Deserialize, Serialize};
use tether_scanmatch::ScanMatcherConfig;
use thiserror::Error;

use tether_control::{
    MotionLimits, MotionState, SafetyConfig, SpringConfig, StopReason, Twist, VirtualSpring,
};
use tether_core::{
    CameraModel, Cov2, Gaussian2, Laser, LaserModel, Point2, Pose2, Robot, Stamp, Vector2, World,
};
pub use tether_core::{ExtraCamera, ExtraLaser};
use tether_fusion::{
    Bearing, ClutterConfig, ClutterMap, FusionRule, Gate, Observation, Refusal, SomebodyElse,
    TargetConfig, TargetSelector, TargetState, Tracker, TrackerConfig, Transition, View,
    complementary_fusion,
};
use tether_laser::{Detection, DetectorConfig, DetectorKind, LegClassifier, LegDetector};

/// How laser and camera are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FusionMode {
    /// Tracks over time; the target is a locked track.
    #[default]
    Tracker,
    /// The paper's per-frame complementary fusion, no tracking.
    PerFrame,
}

/// Fusion settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct FusionConfig {
    /// Tracker or per-frame.
    pub mode: FusionMode,
    /// How a laser and a vision estimate of the same person are fused per frame.
    pub rule: FusionRule,
    /// Gate for pairing laser and vision people per frame.
    pub gate: Gate,
    /// Use the laser's people.
    pub use_laser: bool,
    /// Use the camera's people.
    pub use_vision: bool,
    /// Let vision-only people start tracks (on when the laser is off).
    pub vision_spawns_tracks: bool,
    /// Let a lone leg (a standing person's legs often merge into one blob) start a
    /// track; confirmation still needs repeated detections.
    pub lone_legs_spawn_tracks: bool,
    /// Newest laser people older than this are not paired with a camera frame, s.
    pub pair_max_age_s: f64,
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            mode: FusionMode::Tracker,
            rule: FusionRule::CiDeterminant,
            gate: Gate::default(),
            use_laser: true,
            use_vision: true,
            vision_spawns_tracks: false,
            lone_legs_spawn_tracks: true,
            pair_max_age_s: 0.15,
        }
    }
}

/// Leg detector settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct LegsConfig {
    /// Arc test (the paper) or learned classifier.
    pub detector: DetectorKind,
    /// Segmentation, arc test and pairing parameters.
    pub config: DetectorConfig,
    /// A leg model of `tether train-legs` (JSON) for the learned detector, in place of
    /// the built-in one; a relative path is taken from the config file's folder.
    ///
    /// `None`: the built-in model. The pipeline does no I/O: the command that builds it
    /// reads the file (`tether_live::leg_model`) and passes the classifier to
    /// [`Pipeline::new`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub model: Option<std::path::PathBuf>,
}

impl Default for LegsConfig {
    fn default() -> Self {
        LegsConfig {
            detector: DetectorKind::Learned,
            config: DetectorConfig::default(),
            model: None,
        }
    }
}

/// Everything the pipeline needs to know.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct PipelineConfig {
    /// The laser (geometry, noise model, mounting); with `extra_lasers`, the one whose
    /// scans carry a frame none of them names.
    pub laser: LaserModel,
    /// More scanners on the robot (`[[extra_lasers]]`: front and rear, left and right),
    /// each taking the scans of its `frame_id` (design 5.7).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub extra_lasers: Vec<ExtraLaser>,
    /// The camera (intrinsics, mounting); with `extra_cameras`, the one whose frames
    /// carry a frame none of them names (`camera`).
    pub camera: CameraModel,
    /// More cameras on the robot (`[[extra_cameras]]`: a rear one, side ones), each
    /// taking the frames of its `frame_id` (design 5.7).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub extra_cameras: Vec<ExtraCamera>,
    /// Leg detection.
    pub legs: LegsConfig,
    /// The monocular person model of the camera.
    pub vision: vision::VisionConfig,
    /// Fusion.
    pub fusion: FusionConfig,
    /// Tracking.
    pub tracker: TrackerConfig,
    /// Target of interest.
    pub target: TargetConfig,
    /// Static clutter learned over time (leg-like places nobody walks through).
    pub clutter: ClutterConfig,
    /// The virtual spring.
    pub follower: SpringConfig,
    /// Steer along the target's trail even when the straight line to them is clear
    /// (otherwise only when the laser sees something in the way).
    pub follower_always_trail: bool,
    /// Limits of the base.
    pub limits: MotionLimits,
    /// Safety layer.
    pub safety: SafetyConfig,
    /// Ego-motion from the scans, where there is no odometry (`--ego-motion scans`, or
    /// `auto` without odometry; design 11.9): the scan matcher's settings. The pipeline
    /// does not run it (the runtime does), but a run's configuration holds it.
    pub scan_matcher: ScanMatcherConfig,
}

/// Why the pipeline cannot start.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// A part of the configuration is invalid.
    #[error("invalid {part} configuration: {message}")]
    Config {
        /// Which part.
        part: &'static str,
        /// What is wrong.
        message: String,
    },
}

/// The leg detector of a config, the one constructor every user of a config's detector
/// calls (the pipeline, `tether legs`, `eval-legs`, the replay's report): the arc test,
/// or the learned classifier with the model read from `legs.model` (`classifier`, read
/// by the caller: this crate does no I/O), else the built-in models (the coarse-scan
/// one for beams 0.45 degrees apart or more; design 4.6).
pub fn leg_detector(
    legs: &LegsConfig,
    noise: tether_core::RangeNoiseModel,
    classifier: Option<LegClassifier>,
) -> Result<LegDetector, PipelineError> {
    match legs.detector {
        DetectorKind::Arc => LegDetector::arc(legs.config, noise),
        DetectorKind::Learned => match classifier {
            Some(c) => LegDetector::learned(legs.config, noise, c),
            None => LegDetector::builtin(legs.config, noise),
        },
    }
    .map_err(|e| config_err("legs", e))
}

/// How many of `config`'s lasers take the scans of `frame_id`.
fn lasers_named(config: &PipelineConfig, frame_id: &str) -> usize {
    config
        .extra_lasers
        .iter()
        .filter(|l| l.frame_id == frame_id)
        .count()
}

fn config_err(part: &'static str, e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Config {
        part,
        message: e.to_string(),
    }
}

/// A laser person of the last scan as a camera frame needs it: where it was, how its
/// track moves (velocity and its covariance), and which track it updated.
type LaserMemory = (
    Gaussian2<World>,
    Option<(Vector2<World>, Cov2)>,
    Option<u64>,
);

/// A person found by the laser, in the laser frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserPerson {
    /// Position and covariance.
    pub estimate: Gaussian2<Laser>,
    /// Made of two legs (only those start tracks; a lone leg only updates them).
    pub two_legs: bool,
    /// A weak candidate (the classifier nearly accepted it): it only keeps a confirmed
    /// track alive.
    pub weak: bool,
    /// A lone leg the classifier accepted that the last scans did not confirm (design
    /// 4.6): it updates tracks, tentative ones too, but starts none.
    pub unconfirmed: bool,
}

/// What kind of input a tick processed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TickInput {
    /// A laser scan.
    Scan,
    /// A camera frame.
    Camera,
    /// A control timer tick with no new data.
    Timer,
}

/// A track as reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackView {
    /// Track id.
    pub id: u64,
    /// Confirmed or tentative.
    pub confirmed: bool,
    /// Position estimate (world).
    pub position: Gaussian2<World>,
    /// Velocity (world), m/s.
    pub velocity: Vector2<World>,
}

/// The target as reported.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetView {
    /// Selector state.
    pub state: TargetState,
    /// The followed track's id, if any.
    pub id: Option<u64>,
    /// Current estimate when locked (world).
    pub estimate: Option<Gaussian2<World>>,
    /// Velocity when locked (world), m/s.
    pub velocity: Option<Vector2<World>>,
}

/// The result of one tick.
#[derive(Debug, Clone)]
pub struct Tick {
    /// Stamp of the input.
    pub stamp: Stamp,
    /// Which input.
    pub input: TickInput,
    /// Laser people of this scan (world).
    pub laser_people: Vec<Gaussian2<World>>,
    /// Vision people of this frame (world).
    pub vision_people: Vec<Gaussian2<World>>,
    /// Laser-vision pairs fused in this frame (world).
    pub fused_people: Vec<Gaussian2<World>>,
    /// Tracks after the tick.
    pub tracks: Vec<TrackView>,
    /// The target.
    pub target: TargetView,
    /// The command to send.
    pub command: Twist,
    /// The command the follower asked for, before the base's limits smoothed it: the
    /// spring's, or the held command, after the obstacle stop and the reverse rule
    /// (design 6). `command` never steps past it.
    pub wanted: Twist,
    /// Why the robot is held, if it is.
    pub stop: Option<StopReason>,
    /// While the target is lost: the tracks refused as the target at this tick, and
    /// why.
    pub refusals: Vec<(u64, Refusal)>,
    /// Of those refused as somebody else, why each is somebody else.
    pub somebody_else: Vec<(u64, SomebodyElse)>,
    /// The transition the target lock made at this tick, if it made one.
    pub transition: Option<Transition>,
}

/// Counters of refused or odd input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct PipelineStats {
    /// Ticks refused because their stamp went backwards.
    pub out_of_order_ticks: u64,
    /// Beams that arrived as NaN or negative.
    pub malformed_beams: u64,
    /// Ticks with a non-finite odometry pose (treated as no data).
    pub bad_odometry: u64,
    /// Scans with more malformed beams than good ones (treated as no data).
    pub unusable_scans: u64,
    /// Laser person observations dropped because they stand in learned static clutter.
    pub clutter_observations: u64,
}

/// The pipeline.
#[derive(Debug)]
pub struct Pipeline {
    config: PipelineConfig,
    /// The scanners: the first laser, then the extra ones.
    lasers: Vec<laser::LaserSide>,
    /// Buffers kept between scans: the detection and the returns in the robot frame.
    detection: Detection,
    scan_obstacles: Vec<Point2<Robot>>,
    tracker: Tracker,
    selector: TargetSelector,
    spring: VirtualSpring,
    command: Twist,
    last_tick: Option<Stamp>,
    /// The stamp of the newest scan of any laser.
    last_scan: Option<Stamp>,
    /// A buffer for the returns that can stand between the robot and the target.
    obstacles_in_world: Vec<Point2<World>>,
    per_frame_target: Option<(Stamp, Gaussian2<World>)>,
    /// The search for the lost target under way, if any.
    search: Option<drive::Search>,
    trails: follow::Trails,
    motion: MotionState,
    heights: std::collections::BTreeMap<u64, vision::LearnedHeight>,
    /// Per camera, the first first: whether it is gone for good
    /// ([`Pipeline::camera_gone_from`]).
    cameras_gone: Vec<bool>,
    /// Static clutter in the world (scenery; each laser keeps that of its own frame,
    /// the robot's own parts, which move with it).
    clutter_world: ClutterMap<World>,
    /// Seconds between the last scan and the one before it of the same laser.
    scan_gap_s: f64,
    stats: PipelineStats,
}

impl Pipeline {
    /// Builds the pipeline. `classifier` is the learned leg detector's model (`None`:
    /// the built-in one); it is required when `config.legs.model` names a file, read
    /// from it by the caller, so that a named model is never replaced by the built-in
    /// one unseen.
    pub fn new(
        config: PipelineConfig,
        classifier: Option<LegClassifier>,
    ) -> Result<Self, PipelineError> {
        config
            .camera
            .validate()
            .map_err(|e| config_err("camera", e))?;
        camera::check_extra_cameras(&config.extra_cameras)?;
        config
            .limits
            .validate()
            .map_err(|e| config_err("limits", e))?;
        config
            .safety
            .validate()
            .map_err(|e| config_err("safety", e))?;
        config
            .scan_matcher
            .validate()
            .map_err(|e| config_err("scan_matcher", e))?;
        config
            .vision
            .validate()
            .map_err(|e| config_err("vision", e))?;
        let gate = config.fusion.gate.threshold;
        if !(gate.is_finite() && gate > 0.0) {
            return Err(config_err(
                "fusion",
                format!("gate.threshold must be > 0, got {gate}"),
            ));
        }
        if let (Some(path), None) = (&config.legs.model, &classifier) {
            return Err(config_err(
                "legs",
                format!(
                    "`model` names {} but no model read from it was given to the pipeline",
                    path.display()
                ),
            ));
        }
        let mut lasers = Vec::with_capacity(1 + config.extra_lasers.len());
        for extra in &config.extra_lasers {
            if extra.frame_id.is_empty() || lasers_named(&config, &extra.frame_id) > 1 {
                return Err(config_err(
                    "extra_lasers",
                    format!(
                        "`frame_id` {:?} must name one laser's scans, and no other's",
                        extra.frame_id
                    ),
                ));
            }
            lasers.push(laser::LaserSide::new(
                Some(extra.frame_id.clone()),
                extra.laser.clone(),
                &config.legs,
                &config.clutter,
                classifier.clone(),
            )?);
        }
        lasers.insert(
            0,
            laser::LaserSide::new(
                None,
                config.laser.clone(),
                &config.legs,
                &config.clutter,
                classifier,
            )?,
        );
        let tracker = Tracker::new(config.tracker.clone()).map_err(|e| config_err("tracker", e))?;
        let spring =
            VirtualSpring::new(config.follower.clone()).map_err(|e| config_err("follower", e))?;
        let mut target = config.target.clone();
        if !(config.fusion.use_laser && config.fusion.use_vision) {
            target.require_both_sensors = false;
        }
        target.validate().map_err(|e| config_err("target", e))?;
        let clutter_world =
            ClutterMap::new(config.clutter.clone()).map_err(|e| config_err("clutter", e))?;
        Ok(Pipeline {
            selector: TargetSelector::new(target, config.tracker.motion),
            clutter_world,
            scan_gap_s: 0.0,
            lasers,
            detection: Detection::default(),
            scan_obstacles: Vec::new(),
            tracker,
            spring,
            command: Twist::STOP,
            last_tick: None,
            last_scan: None,
            obstacles_in_world: Vec::new(),
            per_frame_target: None,
            search: None,
            trails: follow::Trails::default(),
            motion: MotionState::default(),
            heights: std::collections::BTreeMap::new(),
            cameras_gone: vec![false; 1 + config.extra_cameras.len()],
            stats: PipelineStats::default(),
            config,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &PipelineConfig {
        &self.config
    }

    /// Counters of odd input.
    pub fn stats(&self) -> PipelineStats {
        self.stats
    }

    /// The tracker (for statistics).
    pub fn tracker(&self) -> &Tracker {
        &self.tracker
    }

    /// The target selector (for statistics).
    pub fn selector(&self) -> &TargetSelector {
        &self.selector
    }

    /// The last command sent.
    pub fn command(&self) -> Twist {
        self.command
    }

    fn accept(&mut self, stamp: Stamp, world_from_robot: Pose2<World, Robot>) -> bool {
        if self.last_tick.is_some_and(|t| stamp < t) {
            self.stats.out_of_order_ticks += 1;
            return false;
        }
        if !world_from_robot.is_finite() {
            self.stats.bad_odometry += 1;
            return false;
        }
        true
    }

    /// One camera frame's people (positions in the robot frame from the monocular
    /// model), with the robot's pose at the frame's stamp.
    pub fn on_camera(
        &mut self,
        stamp: Stamp,
        people_in_robot: &[vision::VisionPerson],
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        if !self.accept(stamp, world_from_robot) {
            return self.idle_tick(stamp, TickInput::Camera);
        }
        let vision: Vec<Gaussian2<World>> = people_in_robot
            .iter()
            .map(|p| p.estimate.transformed(world_from_robot))
            .collect();
        let bearings: Vec<Bearing> = people_in_robot
            .iter()
            .map(|p| Bearing {
                origin: world_from_robot * p.camera_in_robot,
                bearing_rad: tether_core::wrap_angle_rad(world_from_robot.yaw + p.bearing_rad),
                sigma_rad: p.bearing_sigma_rad,
            })
            .collect();
        let fusion = &self.config.fusion;
        // The last scan's people carried to this frame's time: moved by their track's
        // velocity, with the velocity's uncertainty over that time added (people without
        // a track get a walking-pace allowance).
        let laser_recent: Vec<(Gaussian2<World>, Option<u64>)> = self
            .lasers
            .iter()
            .filter_map(|l| l.people.as_ref())
            .filter(|(t, _)| stamp.secs_since(*t) <= fusion.pair_max_age_s && fusion.use_laser)
            .flat_map(|(t, people)| {
                let age = stamp.secs_since(*t).max(0.0);
                people.iter().map(move |(g, motion, id)| {
                    let (velocity, spread) = match motion {
                        Some((v, c)) => (*v, c.scaled(age * age).ok()),
                        None => (Vector2::ZERO, Cov2::isotropic(1.0 * age).ok()),
                    };
                    let moved = Gaussian2 {
                        mean: g.mean + velocity * age,
                        cov: spread.map_or(g.cov, |c| g.cov.add(&c)),
                    };
                    (moved, *id)
                })
            })
            .collect();
        let fused: Vec<Gaussian2<World>> = match fusion.mode {
            FusionMode::Tracker => {
                if fusion.use_vision {
                    let observations: Vec<Observation> = vision
                        .iter()
                        .zip(&bearings)
                        .zip(people_in_robot)
                        .map(|((v, b), p)| {
                            Observation::vision(
                                *v,
                                fusion.vision_spawns_tracks || !fusion.use_laser,
                                (fusion.use_laser && !p.own_height).then_some(*b),
                            )
                        })
                        .collect();
                    let track_of = self.tracker.process(stamp, &observations).track_of;
                    // The paper's fusion of a vision and a laser estimate of the same
                    // person, paired through the tracks they updated rather than by
                    // proximity alone (two people on one viewing ray pass any gate).
                    vision
                        .iter()
                        .zip(&track_of)
                        .filter_map(|(v, id)| {
                            let id = (*id)?;
                            let (l, _) = laser_recent.iter().find(|(_, lid)| *lid == Some(id))?;
                            fusion.gate.test(v, l).map(|_| fusion.rule.fuse(v, l))
                        })
                        .collect()
                } else {
                    self.tracker.advance(stamp);
                    Vec::new()
                }
            }
            FusionMode::PerFrame => {
                self.tracker.advance(stamp);
                let laser_only: Vec<Gaussian2<World>> =
                    laser_recent.iter().map(|(g, _)| *g).collect();
                let fused = if fusion.use_vision {
                    complementary_fusion(&vision, &laser_only, &fusion.gate, fusion.rule)
                } else {
                    Vec::new()
                };
                // The fused person nearest the previous target, else nearest the heading.
                let robot_from_world = world_from_robot.inverse();
                let previous = self.per_frame_target.map(|(_, g)| g.mean);
                let pick = fused.iter().min_by(|a, b| {
                    let key = |g: &Gaussian2<World>| match previous {
                        Some(p) => g.mean.distance_m(p),
                        None => (robot_from_world * g.mean).bearing_rad().abs(),
                    };
                    key(&a.estimate).total_cmp(&key(&b.estimate))
                });
                if let Some(f) = pick {
                    self.per_frame_target = Some((stamp, f.estimate));
                }
                fused.iter().map(|f| f.estimate).collect()
            }
        };
        let mut tick = self.finish(stamp, TickInput::Camera, world_from_robot);
        tick.vision_people = vision;
        tick.fused_people = fused;
        tick
    }

    /// A control tick with no new data (run it on a timer, 10-20 Hz): predicts the
    /// tracks to `stamp`, checks the watchdogs and produces a command, so that the robot
    /// stops when every sensor falls silent.
    pub fn on_timer(&mut self, stamp: Stamp, world_from_robot: Pose2<World, Robot>) -> Tick {
        if !self.accept(stamp, world_from_robot) {
            return self.idle_tick(stamp, TickInput::Timer);
        }
        self.tracker.advance(stamp);
        self.finish(stamp, TickInput::Timer, world_from_robot)
    }

    /// The tick of an input that changed nothing: no people, the tracks, the target and
    /// the command as they are.
    fn idle_tick(&self, stamp: Stamp, input: TickInput) -> Tick {
        Tick {
            stamp,
            input,
            laser_people: Vec::new(),
            vision_people: Vec::new(),
            fused_people: Vec::new(),
            tracks: self.track_views(),
            target: self.target_view(),
            command: self.command,
            wanted: self.command,
            stop: None,
            refusals: Vec::new(),
            somebody_else: Vec::new(),
            transition: None,
        }
    }

    fn track_views(&self) -> Vec<TrackView> {
        self.tracker
            .tracks()
            .iter()
            .map(|t| TrackView {
                id: t.id,
                confirmed: t.confirmed,
                position: t.position(),
                velocity: t.velocity(),
            })
            .collect()
    }

    fn target_view(&self) -> TargetView {
        if self.config.fusion.mode == FusionMode::PerFrame {
            return TargetView {
                state: match self.per_frame_target {
                    Some(_) => TargetState::Locked { track: 0 },
                    None => TargetState::Searching,
                },
                id: self.per_frame_target.map(|_| 0),
                estimate: self.per_frame_target.map(|(_, g)| g),
                velocity: None,
            };
        }
        let state = self.selector.state();
        let track = state.locked_track().and_then(|id| self.tracker.track(id));
        TargetView {
            state,
            id: match state {
                TargetState::Locked { track } | TargetState::Lost { track, .. } => Some(track),
                TargetState::Searching => None,
            },
            estimate: track.map(|t| t.position()),
            velocity: track.map(|t| t.velocity()),
        }
    }

    /// The end of every tick, once the tracks have taken in its data: the target
    /// update, why the robot is held, the trails, the spring's command, the obstacle
    /// stop, the reverse rule and the limits, in the order of design 6 ("Safety").
    fn finish(
        &mut self,
        stamp: Stamp,
        input: TickInput,
        world_from_robot: Pose2<World, Robot>,
    ) -> Tick {
        let dt_s = self.control_period_s(stamp);
        self.forget_heights_of_dropped_tracks();
        if self.config.fusion.mode == FusionMode::Tracker {
            self.update_target(stamp, input, world_from_robot);
        }
        let target = self.target_view();
        let mut stop = self.hold_reason(stamp, &target);
        self.record_trails(stamp, world_from_robot, &target);
        let mut desired = match (stop, target.estimate) {
            (None, Some(estimate)) => {
                self.search = None;
                let pace = self.unseen_pace(stamp, &target);
                let twist = self.follow(world_from_robot, estimate.mean, target.velocity, dt_s);
                Twist {
                    v_mps: pace * twist.v_mps,
                    w_radps: pace * twist.w_radps,
                }
            }
            _ => self.held_command(stamp, world_from_robot, target.state),
        };
        let obstacle = self.obstacle_in_the_way(desired);
        if obstacle {
            desired.v_mps = desired.v_mps.min(0.0);
            stop = stop.or(Some(StopReason::Obstacle));
        }
        if desired.v_mps < 0.0 && !self.may_reverse(stamp, world_from_robot) {
            desired.v_mps = 0.0;
        }
        let emergency = obstacle
            || matches!(
                stop,
                Some(
                    StopReason::Obstacle
                        | StopReason::StaleLaser
                        | StopReason::StaleTarget
                        | StopReason::UnseenAmongOthers
                )
            );
        let command = self.apply_limits(desired, dt_s, emergency);
        Tick {
            target,
            command,
            wanted: desired,
            stop,
            refusals: self.selector.refusals().to_vec(),
            somebody_else: self.selector.refused_as_somebody_else().to_vec(),
            transition: self.selector.transition(),
            ..self.idle_tick(stamp, input)
        }
    }

    /// The time since the previous tick, s, clamped to [0, 0.2] (a long silence does
    /// not become one huge control step); this tick becomes the previous one.
    fn control_period_s(&mut self, stamp: Stamp) -> f64 {
        let dt_s = self
            .last_tick
            .map_or(0.0, |t| stamp.secs_since(t))
            .clamp(0.0, 0.2);
        self.last_tick = Some(stamp);
        dt_s
    }

    /// Forgets the head heights learned for tracks the tracker has dropped (design
    /// 3.2: a person's own height, learned while the laser measured their range).
    fn forget_heights_of_dropped_tracks(&mut self) {
        let tracker = &self.tracker;
        self.heights.retain(|id, _| tracker.track(*id).is_some());
    }

    /// Updates the target selector with the tracks and what the sensors could see at
    /// this tick (design 5.6, 11): the camera's and the laser's fields of view, the
    /// learned static clutter (design 11.2), and whether the laser fell silent for
    /// longer than a loss takes (the `sensor_gap` loss reason, design 11.6).
    fn update_target(
        &mut self,
        stamp: Stamp,
        input: TickInput,
        world_from_robot: Pose2<World, Robot>,
    ) {
        let camera_sees = self.camera_sees(world_from_robot);
        let seen_by: Vec<_> = self
            .lasers
            .iter()
            .map(|l| l.sees(world_from_robot))
            .collect();
        let laser_sees = move |p: Point2<World>| seen_by.iter().any(|sees| sees(p));
        let world_map = &self.clutter_world;
        let in_laser_clutter: Vec<_> = self
            .lasers
            .iter()
            .map(|l| l.clutter_at(world_from_robot, stamp))
            .collect();
        let in_clutter = move |p: Point2<World>| {
            world_map.is_static(p, stamp) || in_laser_clutter.iter().any(|in_it| in_it(p))
        };
        let lost_after_s = self.selector.config().lost_after_s;
        let sensor_gap = match (input, self.last_scan) {
            (_, None) => false,
            (TickInput::Scan, Some(_)) => self.scan_gap_s > lost_after_s,
            (_, Some(t)) => stamp.secs_since(t) > lost_after_s,
        };
        let view = View {
            world_from_robot,
            camera_sees: &camera_sees,
            laser_sees: &laser_sees,
            in_clutter: &in_clutter,
            laser_in_use: self.config.fusion.use_laser,
            sensor_gap,
        };
        self.selector
            .update_with_view(stamp, self.tracker.tracks(), &view);
    }
}
