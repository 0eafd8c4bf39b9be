//! Fusion and tracking for tether (design section 5, paper section IV).
//!
//! - [`gate`]: Mahalanobis gating with `S = P_l + P_v` and chi-square thresholds.
//! - [`ci`]: Covariance Intersection with the exact 2x2 closed form (determinant or
//!   trace), and independent (Kalman) fusion.
//! - [`complementary`]: the paper's per-frame complementary fusion algorithm.
//! - [`assign`]: global nearest neighbour assignment (Hungarian method).
//! - [`kalman`]: the constant-velocity Kalman filter of one person.
//! - [`tracker`]: person tracks over time, confirmation and deletion.
//! - [`clutter`]: static clutter learned over time (bushes, posts, furniture legs).
//! - [`shadow`]: what the laser could not have seen (people hidden behind things).
//! - [`target`]: the target of interest, locked through crossings and occlusions.
//!
//! Pure algorithms: no I/O and no clock; stamps come in with the data.

pub mod assign;
pub mod ci;
pub mod clutter;
pub mod complementary;
pub mod gate;
pub mod kalman;
pub mod shadow;
pub mod target;
pub mod tracker;

/// Wraps an angle into (-pi, pi].
pub(crate) fn wrap(angle_rad: f64) -> f64 {
    tether_core::wrap_angle_rad(angle_rad)
}

pub use ci::{CiCriterion, Fused, ci_weight, covariance_intersection, independent_fusion};
pub use clutter::{ClutterConfig, ClutterMap};
pub use complementary::{FusedPerson, FusionRule, complementary_fusion};
pub use gate::{CHI2_2DOF_95, CHI2_2DOF_99, CHI2_2DOF_999, Gate, mahalanobis_sq};
pub use kalman::CvFilter;
pub use shadow::Shadow;
pub use target::{
    LossReason, Refusal, SomebodyElse, TargetConfig, TargetSelector, TargetState, TargetStats,
    Transition, View,
};
pub use tracker::{
    Anchor, BatchResult, Bearing, MotionBounds, Observation, Source, Track, Tracker, TrackerConfig,
    TrackerStats, UpdateRule,
};

/// Whether a duration `elapsed_s` has reached a setting `setting_s`, within 1 us: a
/// duration summed from, or measured between, stamps a scan period apart comes out a
/// hair under or over its round value (five 0.1 s intervals make 0.49999999999999994 s,
/// three periods between stamps 0.29999999999999993 s or 0.30000000000000004 s), and
/// it counts as reached either way.
pub(crate) fn reached_s(elapsed_s: f64, setting_s: f64) -> bool {
    elapsed_s >= setting_s - 1e-6
}
