//! Shared types of tether, the person-following robot.
//!
//! Everything later in the pipeline speaks these types, so they encode the conventions
//! of the design (design section 1) in the type system where that is cheap:
//!
//! - Frames follow REP 103 (x forward, y left, z up, angles counter-clockwise, radians).
//!   Points and poses carry their frame as a type parameter ([`frame`]), so
//!   `robot_from_laser * point_in_laser` compiles and `robot_from_laser * point_in_world`
//!   does not.
//! - Time is an `i64` count of nanoseconds ([`Stamp`]); algorithms take it as an argument
//!   and never read a clock.
//! - A 2-D estimate is a mean and a symmetric positive-definite covariance
//!   ([`Gaussian2`], [`Cov2`]), checked on construction.
//! - Sensors: [`LaserScan`] keeps "no return" distinct from a distance; [`LaserModel`]
//!   holds the Hokuyo URG-04LX geometry and its range noise; [`CameraModel`] holds the
//!   pinhole intrinsics and the mounting (height, tilt, pose on the robot).
//! - Units are SI and appear in names where the type does not carry them (`range_m`,
//!   `tilt_rad`, `stamp_ns`).

// `derive(ConfigDocs)` names this crate by its path, as other crates see it.
extern crate self as tether_core;

pub mod camera;
pub mod config_docs;
pub mod frame;
pub mod gaussian;
pub mod geometry;
pub mod image;
pub mod laser;
pub mod scan;
pub mod time;

pub use camera::{
    CameraIntrinsics, CameraModel, CameraModelError, CameraMount, ExtraCamera, FIRST_CAMERA_FRAME,
    PixelBox,
};
pub use config_docs::ConfigDocs;
pub use frame::{Camera, Frame, Laser, Robot, World};
pub use gaussian::{Cov2, CovError, Gaussian2};
pub use geometry::{Point2, Point3, Pose2, Vector2, wrap_angle_rad};
pub use image::{GrayImage, ImageError};
pub use laser::{
    ExtraLaser, LaserModel, LaserModelError, LaserMount, Polynomial, RangeNoiseModel, UrgGeometry,
};
pub use scan::{LaserScan, MAX_BEAMS, NO_RETURN, ScanError};
pub use time::{NS_PER_S, Stamp};
