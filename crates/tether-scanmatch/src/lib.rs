//! Ego-motion from laser scans, for robots and recordings without odometry (SPEC 11;
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

pub mod icp;
pub mod linalg;
pub mod matcher;
pub mod points;
pub mod reference;
pub mod synthetic;

pub use icp::{IcpConfig, IcpScratch, MatchFailure, MatchResult, match_scan};
pub use linalg::Mat3;
pub use matcher::{
    Estimate, ExclusionZone, Failure, MatcherCounts, MotionPrior, Quality, ScanMatcher,
    ScanMatcherConfig, arc,
};
pub use points::{ScanPoints, ScanPointsError};
pub use reference::{Line, LineFit, Nearest, NeighbourSearch, Reference};
