//! Ego-motion from laser scans, for robots and recordings without odometry (design 11;
//! issue 14).
//!
//! - [`ScanPoints`]: the returns of one scan in the robot frame, with their beam
//!   directions (from a [`tether_core::LaserScan`] and the mount `robot_from_laser`, or
//!   from angles and ranges).
//! - [`Reference`]: a keyframe searchable by beam direction. The returns of a scan are
//!   ordered by angle, so the nearest return to a point is found by walking beams
//!   outwards from the point's direction until no farther beam can be closer: exact,
//!   and no k-d tree.
//! - [`match_scan`]: point-to-line ICP (Censi, ICRA 2008) solved by Gauss-Newton in
//!   SE(2), with trimming, Huber weights, a covariance from the Hessian, and degeneracy
//!   detection (a corridor: the smallest eigenvalue of the Hessian) that keeps the
//!   prior along the unconstrained direction.
//! - [`ScanMatcher`]: `update(stamp, scan, prior, exclusion) -> Estimate`; matches
//!   against a keyframe renewed after 0.3 m, 0.2 rad or a loss of overlap, with a motion
//!   prior as the initial guess and exclusion zones around tracked people, and
//!   accumulates `world_from_robot`.
//! - [`synthetic`]: ray-cast scenes with known motion for tests and benchmarks.
//!
//! ```
//! use tether_core::{LaserModel, Pose2, Robot, Stamp, World};
//! use tether_scanmatch::synthetic::Scene;
//! use tether_scanmatch::{MotionPrior, Quality, ScanMatcher, ScanMatcherConfig};
//!
//! let model = LaserModel::urg_04lx();
//! let room = Scene::room();
//! let start = Pose2::<World, Robot>::new(0.0, 0.0, 0.0);
//! let moved = start * Pose2::<Robot, Robot>::new(0.1, 0.0, 0.05);
//! let mut matcher = ScanMatcher::new(ScanMatcherConfig::default());
//! let first = room.urg_points(&model, start, 0.01, 1);
//! let second = room.urg_points(&model, moved, 0.01, 2);
//! matcher.update(Stamp::from_ns(0), &first, MotionPrior::Stationary, &[]);
//! let e = matcher.update(Stamp::from_ns(100_000_000), &second, MotionPrior::Stationary, &[]);
//! assert_eq!(e.quality, Quality::Good);
//! assert!((e.world_from_robot.x - 0.1).abs() < 0.01);
//! assert!((e.world_from_robot.yaw - 0.05).abs() < 0.01);
//! ```

pub mod icp;
pub mod linalg;
pub mod matcher;
pub mod points;
pub mod reference;
pub mod synthetic;

pub use icp::{IcpConfig, IcpScratch, MatchFailure, MatchResult, match_scan};
pub use linalg::Mat3;
pub use matcher::{
    ConfigError, Estimate, ExclusionZone, Failure, MatcherCounts, MotionPrior, Quality,
    RobotBounds, ScanMatcher, ScanMatcherConfig, arc,
};
pub use points::{ScanPoints, ScanPointsError};
pub use reference::{Line, LineFit, Nearest, NeighbourSearch, Reference};
