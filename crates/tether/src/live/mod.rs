//! The live robot (`tether run`): its configuration, the main loop, the base adapters,
//! camera frame sources and dead reckoning.

pub mod base;
pub mod camera;
pub mod clock;
pub mod config;
pub mod odometry;
pub mod run_loop;
