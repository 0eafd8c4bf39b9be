//! Following control for tether (design section 6, paper section V corrected).
//!
//! - [`spring`]: the virtual spring follower, its gains from the linearised loops, and
//!   the paper's printed equations as a variant for comparison.
//! - [`limits`]: speed, turn-rate, wheel-speed and acceleration limits that keep the
//!   curvature.
//! - [`safety`]: watchdogs and the obstacle stop.
//!
//! Pure algorithms: no I/O and no clock.

pub mod limits;
pub mod safety;
pub mod spring;

pub use limits::{LimitsError, MotionLimits, MotionState, Twist};
pub use safety::{SEARCH_RATE_RADPS, SafetyConfig, SafetyConfigError, StopReason};
pub use spring::{
    PersonInRobot, SpringConfig, SpringConfigError, SpringGains, SpringVariant, VirtualSpring,
};
