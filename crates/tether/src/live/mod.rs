//! The live robot (`tether run`, `tether ros2`): its configuration, the main loop, the base adapters,
//! camera frame sources and dead reckoning.

pub mod base;
pub mod camera;
pub mod clock;
pub mod config;
pub mod guard;
pub mod monitor;
pub mod odometry;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod run_loop;
