//! One module per subcommand: each has a clap `Args` struct and a `run` function.

pub mod base_guard;
pub mod calibrate_camera;
pub mod calibrate_laser;
#[cfg(feature = "ros2")]
pub mod cmd_vel_guard;
pub mod config;
pub mod demo;
pub mod detect;
pub mod eval_cascade;
pub mod eval_fusion;
pub mod eval_legs;
pub mod eval_target;
pub mod eval_track;
pub mod info;
pub mod legs;
pub mod replay;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod run;
pub mod scanners;
pub mod scenarios;
pub mod sim;
pub mod track;
pub mod train_cascade;
pub mod train_legs;
pub mod urg_emulator;
