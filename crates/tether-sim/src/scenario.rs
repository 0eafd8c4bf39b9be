//! Scenario files: the world, the people and their paths, the robot and its sensors,
//! described in TOML (and the built-in scenarios, which are TOML files too).
//!
//! A scenario that cannot be simulated is refused with an error naming the file, the
//! line and column, and the field: unknown keys, missing fields and wrong types are
//! caught while parsing; negative sizes, paths through walls or outside the world and
//! similar mistakes by [`Scenario::validate`], which points back into the source.

use std::path::Path;

use serde::{Deserialize, Serialize};
use tether_core::{CameraModel, ExtraCamera, ExtraLaser, LaserModel, Point2, World};
use thiserror::Error;

use crate::geometry::Segment;

/// Why a scenario cannot be used.
#[derive(Debug, Error)]
pub enum ScenarioError {
    /// The file could not be read.
    #[error("cannot read scenario file {path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The text is not TOML, or does not match the schema (unknown key, missing field,
    /// wrong type).
    #[error("{origin}:{line}:{column}: {message}\n{snippet}")]
    Parse {
        /// File name or `builtin:NAME`.
        origin: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
        /// The offending line, for context.
        snippet: String,
    },
    /// A value is well-formed but makes no sense (a negative radius, a path through a
    /// wall...).
    #[error("{origin}:{line}:{column}: field `{field}`: {message}\n{snippet}")]
    Invalid {
        /// File name or `builtin:NAME`.
        origin: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// Dotted path of the field, e.g. `people[0].path[2]`.
        field: String,
        /// What is wrong and how to fix it.
        message: String,
        /// The offending line, for context.
        snippet: String,
    },
    /// No built-in scenario has that name.
    #[error(
        "no built-in scenario named `{0}`; run `tether scenarios` to list them, or pass a .toml file"
    )]
    UnknownBuiltin(String),
}

/// A point `[x, y]` in the world frame, metres.
pub type XY = [f64; 2];

fn point(p: XY) -> Point2<World> {
    Point2::new(p[0], p[1])
}

/// A complete scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name (used in file names and reports).
    pub name: String,
    /// One line saying what the scenario tests.
    pub description: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Static world.
    #[serde(default)]
    pub world: WorldSpec,
    /// The robot and how it is driven.
    #[serde(default)]
    pub robot: RobotSpec,
    /// The laser's model (geometry, noise, mounting); every field optional.
    #[serde(default)]
    pub laser: LaserModel,
    /// More scanners on the robot (`[[extra_lasers]]`: a rear one, side ones), each
    /// with the `frame_id` its scans carry and its model; they fail as `laser_sim` says,
    /// each with random numbers of its own, and scan at their own period, spread between
    /// the first laser's scans (design 5.7, 7).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_lasers: Vec<ExtraLaser>,
    /// Simulation-only laser behaviour (dropouts).
    #[serde(default)]
    pub laser_sim: LaserSimSpec,
    /// The camera's model (intrinsics, mounting); every field optional.
    #[serde(default)]
    pub camera: CameraModel,
    /// More cameras on the robot (`[[extra_cameras]]`: a rear one, side ones), each
    /// with the `frame_id` its frames carry and its model; each detects as `camera_sim`
    /// says, with random numbers of its own, at the same rate, its frames spread between
    /// the first camera's (design 5.7, 7).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra_cameras: Vec<ExtraCamera>,
    /// Simulation-only behaviour of the upper-body detector.
    #[serde(default)]
    pub camera_sim: CameraSimSpec,
    /// The people, in order; ids are their indices.
    #[serde(default)]
    pub people: Vec<PersonSpec>,
}

/// Walls and furniture.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    /// Closed rectangular rooms: four walls each.
    #[serde(default)]
    pub rooms: Vec<RoomSpec>,
    /// Free-standing wall segments.
    #[serde(default)]
    pub walls: Vec<WallSpec>,
    /// Round pillars (full height: block the laser and the camera).
    #[serde(default)]
    pub pillars: Vec<CircleSpec>,
    /// Thin posts (coat stands, plant stems, lamp posts): block the laser only.
    #[serde(default)]
    pub posts: Vec<CircleSpec>,
    /// Litter bins: round, about 1 m tall (block the laser, not the camera).
    #[serde(default)]
    pub bins: Vec<CircleSpec>,
    /// Bushes: within the circle, stems and clumps of leaves at the laser's height
    /// (small circles drawn from the bush's index, the same in every run), whose
    /// returns come and go as the leaves move (`laser_sim.foliage_beam_loss_prob`).
    #[serde(default)]
    pub bushes: Vec<CircleSpec>,
    /// Tables: four round legs at the corners.
    #[serde(default)]
    pub tables: Vec<TableSpec>,
    /// Chairs: four thin round legs.
    #[serde(default)]
    pub chairs: Vec<ChairSpec>,
}

/// An axis-aligned rectangular room.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    /// Lower-left corner, m.
    pub min: XY,
    /// Upper-right corner, m.
    pub max: XY,
}

/// A straight wall.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// One end, m.
    pub from: XY,
    /// Other end, m.
    pub to: XY,
}

/// A circle standing on the floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleSpec {
    /// Centre, m.
    pub center: XY,
    /// Radius, m.
    pub radius_m: f64,
}

/// A table with a leg at each corner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    /// Centre, m.
    pub center: XY,
    /// Length and width of the top, m.
    #[serde(default = "default_table_size")]
    pub size_m: [f64; 2],
    /// Rotation, rad.
    #[serde(default)]
    pub yaw_rad: f64,
    /// Radius of each leg, m.
    #[serde(default = "default_table_leg_radius")]
    pub leg_radius_m: f64,
}

/// A chair with four legs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChairSpec {
    /// Centre, m.
    pub center: XY,
    /// Side of the (square) seat, m.
    #[serde(default = "default_chair_size")]
    pub size_m: f64,
    /// Rotation, rad.
    #[serde(default)]
    pub yaw_rad: f64,
    /// Radius of each leg, m.
    #[serde(default = "default_chair_leg_radius")]
    pub leg_radius_m: f64,
}

fn default_table_size() -> [f64; 2] {
    [1.2, 0.8]
}
fn default_table_leg_radius() -> f64 {
    0.025
}
fn default_chair_size() -> f64 {
    0.42
}
fn default_chair_leg_radius() -> f64 {
    0.015
}

/// How the robot is driven in the simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriverKind {
    /// Stands still.
    Still,
    /// Plays `script`: (v, w) commands from given times.
    Scripted,
    /// Follows the target using the *true* position of the target: a test driver for
    /// the simulator only, never an estimate of what tether achieves.
    #[default]
    Oracle,
}

/// A scripted command, held from `at_s` until the next one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScriptedCommand {
    /// Start time, s.
    pub at_s: f64,
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Turn rate, rad/s (counter-clockwise positive).
    pub w_radps: f64,
}

/// Where the robot starts.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseSpec {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
    /// Heading, rad.
    #[serde(default)]
    pub yaw_rad: f64,
}

/// The robot: a differential-drive base.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RobotSpec {
    /// Start pose in the world.
    pub start: PoseSpec,
    /// Radius of the round footprint, m.
    pub radius_m: f64,
    /// Distance between the wheels, m.
    pub track_width_m: f64,
    /// Top speed of each wheel, m/s.
    pub max_wheel_speed_mps: f64,
    /// Largest change of each wheel's speed, m/s^2.
    pub max_wheel_accel_mps2: f64,
    /// The base stops by itself when no command came for this long, s.
    pub command_timeout_s: f64,
    /// How the robot is driven.
    pub driver: DriverKind,
    /// Follow distance of the oracle driver, m.
    pub follow_distance_m: f64,
    /// Commands of the scripted driver.
    pub script: Vec<ScriptedCommand>,
    /// Whether the robot's odometry is given to the pipeline under test. `false`
    /// models a robot (or a recording) without odometry: the closed loop must then
    /// estimate the robot's motion itself ([`Scenario::odometry_available`]).
    pub odometry: bool,
}

impl Default for RobotSpec {
    fn default() -> Self {
        RobotSpec {
            start: PoseSpec::default(),
            radius_m: 0.2,
            track_width_m: 0.3,
            max_wheel_speed_mps: 1.6,
            max_wheel_accel_mps2: 2.5,
            command_timeout_s: 0.5,
            driver: DriverKind::default(),
            follow_distance_m: 1.0,
            script: Vec::new(),
            odometry: true,
        }
    }
}

/// Laser behaviour the model does not cover: lost returns, and (with `realistic`) the
/// ways a real URG-04LX makes a leg detector fail (issue 14), tuned so that tether's
/// detector on simulated scans shows the statistics it shows on the real training
/// recordings (`tests/realism_vs_real.rs`, docs/measured.md):
///
/// - a leg's returns are *weak* (dark or loose clothing, a grazing angle) with
///   probability `weak_leg_prob_near` at `weak_range_near_m` growing linearly to
///   `weak_leg_prob_far` at `weak_range_far_m`, independently per leg and scan;
/// - per person, a two-state Markov chain of *dark spells* (bursts of misses): a spell
///   starts with probability `spell_start_prob` per scan and lasts a geometric number
///   of scans of mean `spell_mean_scans`; during a spell each leg is weak with
///   probability `spell_weak_leg_prob`;
/// - a weak leg's beams are lost with probability `weak_beam_loss_prob` and the others
///   read `weak_range_sigma_m` of extra normal error (the cluster is still there but no
///   longer looks like a leg);
/// - *clutter*: a Poisson number of pieces (mean `clutter_per_m2` times the rooms'
///   floor area) placed at the start, each a circle of radius `ghost_radius_m`, with a
///   second one 0.2-0.45 m beside it with probability `ghost_pair_prob`, at least 0.3 m
///   clear of walls and obstacles and 1 m clear of the people's paths and the robot's
///   start; each piece shows in a scan with its own probability, uniform in
///   `clutter_shown_prob`, and not while a person's leg is within 0.5 m of it: the
///   bags, boxes, bins and chair columns of a real room, in groups, which a real
///   detector takes for legs now and then;
/// - *phantoms*: a Poisson number (mean `ghosts_per_scan`) appear per scan, shaped as
///   the clutter, 0.5-4.5 m away anywhere in the field of view, each staying in place
///   for a geometric number of scans of mean `ghost_mean_scans` or until a person's leg
///   comes within 0.5 m: mixed pixels, passing debris, reflections. A beam on a
///   person's leg keeps the leg;
/// - foliage (`world.bushes`) loses each return with `foliage_beam_loss_prob` per scan
///   (leaves move), so bushes make leg-like clusters that come and go in place.
///
/// Legs occluding each other and two legs merging into one cluster come from the
/// geometry (ray casting the two leg circles) and need no parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LaserSimSpec {
    /// Simulate the laser at all.
    pub enabled: bool,
    /// Probability that any beam returns nothing.
    pub dropout_prob: f64,
    /// Extra probability of no return at the longest range; it grows linearly from 0 at
    /// `long_range_start_m` (real URG-04LX beams flicker between valid and invalid far
    /// away, about 45 % of them).
    pub long_range_dropout_prob: f64,
    /// Range where long-range dropouts begin, m.
    pub long_range_start_m: f64,
    /// The range error the simulated scanner really makes (its "true" bias and noise):
    /// real URG-04LX beams spread by 6-7 mm, well inside the datasheet's +-10 mm / 1 %
    /// bound that the estimator's default model (`laser.noise`) assumes. Calibration
    /// (`tether calibrate laser`) estimates this from samples.
    pub noise: tether_core::RangeNoiseModel,
    /// Simulate the detector-level failures below (weak legs, dark spells, phantom
    /// returns, moving foliage); `false` gives the ideal sensor of before.
    pub realistic: bool,
    /// Probability that a leg is weak in a scan at `weak_range_near_m` and closer.
    pub weak_leg_prob_near: f64,
    /// Probability that a leg is weak in a scan at `weak_range_far_m` and farther.
    pub weak_leg_prob_far: f64,
    /// Range of `weak_leg_prob_near`, m.
    pub weak_range_near_m: f64,
    /// Range of `weak_leg_prob_far`, m.
    pub weak_range_far_m: f64,
    /// Probability per scan that a person's dark spell starts.
    pub spell_start_prob: f64,
    /// Mean length of a dark spell, scans (>= 1).
    pub spell_mean_scans: f64,
    /// Probability that a leg is weak during a spell.
    pub spell_weak_leg_prob: f64,
    /// Probability that a weak leg's beam returns nothing.
    pub weak_beam_loss_prob: f64,
    /// Extra range error of a weak leg's returns, m.
    pub weak_range_sigma_m: f64,
    /// Mean number of phantoms (leg-like returns) that appear per scan.
    pub ghosts_per_scan: f64,
    /// Mean number of scans a phantom stays (>= 1; 1 is one scan).
    pub ghost_mean_scans: f64,
    /// Probability that a phantom appears with a second one 0.2-0.45 m away.
    pub ghost_pair_prob: f64,
    /// Smallest and largest radius of a phantom, m.
    pub ghost_radius_m: [f64; 2],
    /// Leg-like clutter that stays all run, spots per m^2 of the rooms' floor (shaped
    /// as the phantoms are).
    pub clutter_per_m2: f64,
    /// Smallest and largest probability that a piece of clutter shows in a scan.
    pub clutter_shown_prob: [f64; 2],
    /// Probability that a return from foliage is lost in a scan.
    pub foliage_beam_loss_prob: f64,
    /// Probability that a beam hitting anything (wall, furniture, leg) returns nothing:
    /// the no-returns inside objects of triangulation scanners (dark or oblique
    /// surfaces), which cut a leg into pieces. 0 for the URG-04LX (not drawn at all).
    #[serde(skip_serializing_if = "is_zero")]
    pub object_beam_loss_prob: f64,
    /// A scanner of the catalogue (`tether scanners`) whose figures replace the
    /// defaults of `[laser]` and `[laser_sim]`; keys the file sets override it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scanner: Option<String>,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

impl Default for LaserSimSpec {
    fn default() -> Self {
        LaserSimSpec {
            enabled: true,
            dropout_prob: 0.002,
            long_range_dropout_prob: 0.45,
            long_range_start_m: 4.6,
            noise: tether_core::RangeNoiseModel {
                bias_m: tether_core::Polynomial(Vec::new()),
                sigma_m: tether_core::Polynomial(vec![0.006, 0.0015]),
                sigma_floor_m: 0.005,
            },
            realistic: true,
            weak_leg_prob_near: 0.04,
            weak_leg_prob_far: 0.08,
            weak_range_near_m: 1.0,
            weak_range_far_m: 5.0,
            spell_start_prob: 0.006,
            spell_mean_scans: 5.0,
            spell_weak_leg_prob: 0.9,
            weak_beam_loss_prob: 0.4,
            weak_range_sigma_m: 0.03,
            ghosts_per_scan: 0.06,
            ghost_mean_scans: 2.0,
            ghost_pair_prob: 0.6,
            ghost_radius_m: [0.04, 0.12],
            clutter_per_m2: 0.06,
            clutter_shown_prob: [0.2, 0.9],
            foliage_beam_loss_prob: 0.3,
            object_beam_loss_prob: 0.0,
            scanner: None,
        }
    }
}

impl LaserSimSpec {
    /// Probability that a leg at `range_m` is weak outside a spell.
    pub fn weak_leg_prob(&self, range_m: f64) -> f64 {
        let span = (self.weak_range_far_m - self.weak_range_near_m).max(1e-9);
        let f = ((range_m - self.weak_range_near_m) / span).clamp(0.0, 1.0);
        self.weak_leg_prob_near + f * (self.weak_leg_prob_far - self.weak_leg_prob_near)
    }

    /// The ideal sensor: `realistic` off.
    pub fn ideal() -> Self {
        LaserSimSpec {
            realistic: false,
            ..Self::default()
        }
    }
}

/// The upper-body detector as the simulator models it (design 7): true boxes plus noise,
/// misses and false positives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraSimSpec {
    /// Simulate the camera at all.
    pub enabled: bool,
    /// Frames per second.
    pub rate_hz: f64,
    /// Standard deviation of each box edge, px, plus `size_sigma_frac` of the box size.
    pub pixel_sigma_px: f64,
    /// Box-size-proportional part of the edge noise.
    pub size_sigma_frac: f64,
    /// Detection probability of a fully visible person within `reliable_range_m`.
    pub detect_prob: f64,
    /// Up to this distance the detector is at its best, m.
    pub reliable_range_m: f64,
    /// Beyond this distance nobody is detected; between, the probability falls linearly, m.
    pub max_range_m: f64,
    /// Boxes shorter than this are never found (the cascade's smallest window), px.
    pub min_box_height_px: f64,
    /// Mean number of false boxes per frame.
    pub false_positives_per_frame: f64,
}

impl Default for CameraSimSpec {
    fn default() -> Self {
        CameraSimSpec {
            enabled: true,
            rate_hz: 15.0,
            pixel_sigma_px: 2.0,
            size_sigma_frac: 0.03,
            detect_prob: 0.92,
            reliable_range_m: 3.0,
            max_range_m: 7.0,
            min_box_height_px: 22.0,
            false_positives_per_frame: 0.03,
        }
    }
}

/// A scheduled stop at a waypoint.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PauseSpec {
    /// Index of the waypoint in `path`.
    pub waypoint: usize,
    /// How long to stand, s.
    pub duration_s: f64,
}

/// A walking person.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PersonSpec {
    /// Name, for reports.
    pub name: String,
    /// The person the robot should follow (at most one).
    #[serde(default)]
    pub target: bool,
    /// Waypoints, m; the person starts at the first.
    pub path: Vec<XY>,
    /// Cruising speed, m/s (0 to 1.4 for walking).
    #[serde(default = "default_speed")]
    pub speed_mps: f64,
    /// Time at which the person starts walking, s.
    #[serde(default)]
    pub start_s: f64,
    /// Stops at waypoints.
    #[serde(default)]
    pub pauses: Vec<PauseSpec>,
    /// Walk the path again and again (back to the first waypoint after the last).
    #[serde(default)]
    pub repeat: bool,
    /// Body height, m; drawn from N(1.75 m, (0.07 m)^2) (clamped to 1.55-1.95) when absent.
    #[serde(default)]
    pub height_m: Option<f64>,
    /// Radius of each leg at the calf (0.30 m up), m; drawn from 0.058-0.072 when absent
    /// (35-38 cm girth in trousers); other heights scale it (`person::leg_girth_scale`).
    #[serde(default)]
    pub leg_radius_m: Option<f64>,
    /// Sideways distance between the leg centres, m; drawn from 0.18-0.26 when absent.
    #[serde(default)]
    pub leg_spread_m: Option<f64>,
    /// Gives way, as people do rather than walk through each other: stops while a
    /// person listed before it, within this distance in front of it, would otherwise
    /// pass closer than 0.45 m in the next 2 s (`person::Person::must_give_way_to`), m;
    /// 0 walks on regardless.
    #[serde(
        default = "default_give_way",
        skip_serializing_if = "is_default_give_way"
    )]
    pub give_way_m: f64,
}

fn default_speed() -> f64 {
    1.0
}

fn default_give_way() -> f64 {
    2.0
}

fn is_default_give_way(x: &f64) -> bool {
    *x == default_give_way()
}

/// One step of a path into the TOML document: a key or an array index.
#[derive(Debug, Clone)]
pub enum FieldSeg {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// A failed check: where and what.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Path of the field.
    pub field: Vec<FieldSeg>,
    /// What is wrong.
    pub message: String,
}

fn field_name(path: &[FieldSeg]) -> String {
    let mut s = String::new();
    for seg in path {
        match seg {
            FieldSeg::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            FieldSeg::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

macro_rules! path {
    ($($seg:expr),* $(,)?) => { vec![$(FieldSeg::from($seg)),*] };
}

impl From<&str> for FieldSeg {
    fn from(k: &str) -> Self {
        FieldSeg::Key(k.to_owned())
    }
}
impl From<usize> for FieldSeg {
    fn from(i: usize) -> Self {
        FieldSeg::Index(i)
    }
}

/// The names of the built-in scenarios, in the order `tether scenarios` lists them.
pub const BUILTIN_NAMES: &[&str] = &[
    "corridor",
    "office",
    "crossing",
    "stop_and_go",
    "turns",
    "occlusion",
    "outdoor_follow",
    "all_round",
];

fn builtin_source(name: &str) -> Option<&'static str> {
    Some(match name {
        "corridor" => include_str!("../scenarios/corridor.toml"),
        "office" => include_str!("../scenarios/office.toml"),
        "crossing" => include_str!("../scenarios/crossing.toml"),
        "stop_and_go" => include_str!("../scenarios/stop_and_go.toml"),
        "turns" => include_str!("../scenarios/turns.toml"),
        "occlusion" => include_str!("../scenarios/occlusion.toml"),
        "outdoor_follow" => include_str!("../scenarios/outdoor_follow.toml"),
        "all_round" => include_str!("../scenarios/all_round.toml"),
        _ => return None,
    })
}

/// 1-based line and column of a byte offset, and the text of that line.
fn line_col(src: &str, offset: usize) -> (usize, usize, String) {
    let offset = offset.min(src.len());
    let before = &src[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    let line_end = src[line_start..]
        .find('\n')
        .map_or(src.len(), |i| line_start + i);
    let text = src[line_start..line_end].trim_end();
    (line, column, format!("{line:>5} | {text}"))
}

/// The key of a `key = value` pair whose value starts at `offset`, if on one line.
fn key_before(src: &str, offset: usize) -> Option<&str> {
    let before = src.get(..offset)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let (key, rest) = before[line_start..].split_once('=')?;
    let key = key.trim();
    (rest.trim().is_empty() && !key.is_empty()).then_some(key)
}

/// Byte span of the value at `path` in the document, or of its closest existing parent.
fn locate(src: &str, path: &[FieldSeg]) -> usize {
    use toml::de::{DeTable, DeValue};
    let Ok(root) = DeTable::parse(src) else {
        return 0;
    };
    let root_span = root.span();
    let mut current = DeValue::Table(root.into_inner());
    let mut offset = root_span.start;
    for seg in path {
        let next = match seg {
            FieldSeg::Key(k) => current.get(k.as_str()),
            FieldSeg::Index(i) => current.get(*i),
        };
        match next {
            Some(v) => {
                offset = v.span().start;
                let inner = v.get_ref().clone();
                current = inner;
            }
            None => break,
        }
    }
    offset
}

impl Scenario {
    /// A built-in scenario by name.
    pub fn builtin(name: &str) -> Result<Scenario, ScenarioError> {
        let src =
            builtin_source(name).ok_or_else(|| ScenarioError::UnknownBuiltin(name.to_owned()))?;
        Scenario::from_toml_str(src, &format!("builtin:{name}"))
    }

    /// The TOML text of a built-in scenario (a starting point for your own).
    pub fn builtin_toml(name: &str) -> Option<&'static str> {
        builtin_source(name)
    }

    /// Reads a scenario from a file.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let src = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Scenario::from_toml_str(&src, &path.display().to_string())
    }

    /// Whether the pipeline driving the robot may be given the robot's odometry
    /// (`[robot] odometry`, default true). When false, a closed loop must not hand the
    /// pipeline the true motion: it dead-reckons its own commands or estimates the
    /// motion from the scans.
    pub fn odometry_available(&self) -> bool {
        self.robot.odometry
    }

    /// A built-in name or a path to a `.toml` file.
    pub fn resolve(name_or_path: &str) -> Result<(Scenario, String), ScenarioError> {
        if builtin_source(name_or_path).is_some() {
            let src = builtin_source(name_or_path).unwrap_or_default();
            Ok((Scenario::builtin(name_or_path)?, src.to_owned()))
        } else if name_or_path.ends_with(".toml") || Path::new(name_or_path).exists() {
            let path = Path::new(name_or_path);
            let src = std::fs::read_to_string(path).map_err(|source| ScenarioError::Io {
                path: name_or_path.to_owned(),
                source,
            })?;
            Ok((Scenario::from_toml_str(&src, name_or_path)?, src))
        } else {
            Err(ScenarioError::UnknownBuiltin(name_or_path.to_owned()))
        }
    }

    /// Parses and validates scenario text; `origin` names it in errors.
    pub fn from_toml_str(src: &str, origin: &str) -> Result<Scenario, ScenarioError> {
        let scenario: Scenario = toml::from_str(src).map_err(|e| {
            let offset = e.span().map_or(0, |s| s.start);
            let (line, column, snippet) = line_col(src, offset);
            let mut message = e.message().trim().to_owned();
            // serde names the field for unknown and missing keys; for a value of the
            // wrong type, name the key the value belongs to.
            if !message.contains('`')
                && let Some(key) = key_before(src, offset)
            {
                message = format!("field `{key}`: {message}");
            }
            ScenarioError::Parse {
                origin: origin.to_owned(),
                line,
                column,
                message,
                snippet,
            }
        })?;
        let scenario = scanner::with_named_scanner(scenario, src, origin)?;
        if let Some(problem) = scenario.validate().into_iter().next() {
            let offset = locate(src, &problem.field);
            let (line, column, snippet) = line_col(src, offset);
            return Err(ScenarioError::Invalid {
                origin: origin.to_owned(),
                line,
                column,
                field: field_name(&problem.field),
                message: problem.message,
                snippet,
            });
        }
        Ok(scenario)
    }

    /// The wall segments of the world (rooms expanded into four walls).
    pub fn wall_segments(&self) -> Vec<(Segment, Vec<FieldSeg>)> {
        let mut out = Vec::new();
        for (i, room) in self.world.rooms.iter().enumerate() {
            let [x0, y0] = room.min;
            let [x1, y1] = room.max;
            let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
            for k in 0..4 {
                let seg = Segment::new(point(corners[k]), point(corners[(k + 1) % 4]));
                out.push((seg, path!["world", "rooms", i]));
            }
        }
        for (i, wall) in self.world.walls.iter().enumerate() {
            out.push((
                Segment::new(point(wall.from), point(wall.to)),
                path!["world", "walls", i],
            ));
        }
        out
    }

    /// The axis-aligned box around every wall: `(min, max)`, or `None` without walls.
    pub fn bounds(&self) -> Option<(XY, XY)> {
        let walls = self.wall_segments();
        if walls.is_empty() {
            return None;
        }
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (s, _) in &walls {
            for p in [s.a, s.b] {
                lo = [lo[0].min(p.x), lo[1].min(p.y)];
                hi = [hi[0].max(p.x), hi[1].max(p.y)];
            }
        }
        Some((lo, hi))
    }
}

/// How far from the origin anything in a scenario may be, m: beyond it a world is a
/// typo (a room of 1e15 m once took 60 s and 6.9 GB drawing its picture).
pub const MAX_WORLD_EXTENT_M: f64 = 10_000.0;

mod scanner;
mod validate;

#[cfg(test)]
mod tests;
