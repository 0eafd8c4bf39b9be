//! tether's simulated world: the test bed and the demo of the person follower.
//!
//! It simulates the paper's setting (design section 7): rooms with walls, pillars, tables
//! and chairs whose legs look like human legs to a laser; people walking along waypoint
//! paths with a human gait (the stance leg fixed while the other swings); a
//! differential-drive robot carrying a Hokuyo URG-04LX and a camera whose upper-body
//! detector is modelled at the level of its boxes. Every sensor sample comes with the
//! ground truth of its instant.
//!
//! - [`Scenario`]: TOML scenario files and the built-in scenarios.
//! - [`Simulation`]: the event loop (`advance` to the next scan or frame,
//!   `set_command` for the robot).
//! - [`Driver`]: what drives the robot; [`driver::OracleFollower`] is a ground-truth
//!   follower for testing the simulator only.
//! - [`record`]: the files a run writes (`scans.jsonl`, `camera.jsonl`, `truth.jsonl`,
//!   `camera_truth.jsonl`, `scene.svg`...).
//!
//! The laser fails the way tether's leg detector sees a real URG-04LX fail (issue 14;
//! `[laser_sim] realistic`, the default): weak leg returns more likely with range,
//! per-person dark spells (misses in bursts), one-scan phantom leg-like returns, and
//! bushes whose returns flicker; `tests/realism_vs_real.rs` compares the detector's
//! statistics on simulated runs with those on real recordings.
//!
//! Runs are deterministic: every random draw comes from a named stream of the run's
//! seed ([`rng::SimRng`]), and the same scenario and seed give byte-identical files.

pub mod camera;
pub mod driver;
pub mod geometry;
pub mod laser;
pub mod person;
pub mod record;
pub mod rng;
pub mod robot;
pub mod scanners;
pub mod scenario;
pub mod sim;
pub mod svg;
pub mod world;

pub use camera::{CameraFrame, CameraTruth, SimCamera};
pub use driver::Driver;
pub use laser::{Hit, SimLaser};
pub use person::Person;
pub use record::{RunSummary, run_to_dir};
pub use robot::{Command, DiffDrive};
pub use scanners::{SCANNER_NAMES, Scanner, UnknownScanner};
pub use scenario::{BUILTIN_NAMES, Scenario, ScenarioError};
pub use sim::{Event, SensorData, SimError, Simulation, Truth};
pub use world::StaticWorld;
