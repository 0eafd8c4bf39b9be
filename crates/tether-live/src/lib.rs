//! tether's live runtime, shared by `tether run` (the robot's own laser, camera and
//! base) and `tether ros2` (a node on a ROS 2 graph): one loop and one safety path for
//! both.
//!
//! Sources run on threads of their own and send [`Input`]s over one channel:
//!
//! - [`sources::scip`]: a SCIP 2.0 Hokuyo on a serial port or TCP;
//! - [`sources::camera`]: camera frames (a folder of images or V4L2, [`sources::frames`])
//!   through the upper-body cascade;
//! - `ros2::inputs` (feature `ros2`): scans, odometry, `/tf`, `/clock`, images and
//!   detections from topics.
//!
//! The loop ([`run_loop::run`]) runs the pipeline on every scan and frame and on a 20 Hz
//! timer, so that the pipeline's watchdog stops the robot when every sensor falls
//! silent; it stops the robot when the odometry goes stale or the clock stands still,
//! and sends every output a final stop whatever ends the run (its duration, Ctrl-C, a
//! failed sensor or output, a panic). Every output is a [`CommandSink`]:
//!
//! - [`base`]: JSON lines, an iRobot Create's Open Interface, wheel-speed lines (with
//!   [`guard`], the process that stops the base when tether is killed);
//! - `ros2::outputs` (feature `ros2`): `/cmd_vel` and the results on `/tether/...`;
//! - [`recorder`]: the MCAP recording of a run (scans, frames, odometry, ticks).
//!
//! [`recording_run`] drives the same pipeline over a recording's samples in log order
//! (`tether track`, `eval-track`, `replay`), with the loop's rules of time
//! ([`control_timer`]) and, for a recording of `tether run`, the loop's poses
//! ([`robot_pose`]): a replay's commands are then the live run's.
//!
//! [`leg_model`] reads the leg model a config names for every pipeline built.
//!
//! [`robot`] wires them for `tether run`, `ros2::node` for `tether ros2`; the command
//! line parses the arguments, calls one of them and prints what it returns.
//!
//! What a tick becomes outside the pipeline is here too, because the loop's outputs are
//! its first users and the offline commands (`replay`, `track`, `sim --record`) share
//! them: [`results`] and [`markers`] (the `/tether/...` messages), [`target_log`] (the
//! target's locks and losses), and [`ego`] (odometry from the scans).

pub mod base;
pub mod clock;
pub mod config;
pub mod config_docs;
pub mod control_timer;
pub mod driver;
pub mod ego;
pub mod guard;
pub mod leg_model;
pub mod markers;
pub mod monitor;
pub mod node_params;
pub mod odometry;
pub mod pipeline_file;
pub mod recorder;
pub mod recording_run;
pub mod results;
pub mod robot;
pub mod robot_pose;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod run_loop;
pub mod sources;
pub mod stop_log;
pub mod target_log;

pub use base::{CommandLine, CommandSink};
pub use run_loop::{Ending, LoopConfig, OutputError, RunSummary};
pub use sources::Input;
