//! The `tether` application: the closed loop in the simulator, its measures and the
//! report, shared by the command line, the tests and the benchmarks. The live runtime
//! (`run`, `ros2`) is the `tether-live` crate, re-exported here as [`live`].

pub mod closed_loop;
pub mod config_docs;
pub mod ego_motion;
pub mod leg_eval;
pub mod logs;
pub mod metrics;
pub mod output;
pub mod plot;
pub mod recording;
pub mod replay_report;
pub mod report;
pub mod target_metrics;
pub mod track_eval;
pub mod tracking;

/// The live runtime (`tether::live::config`, `tether::live::run_loop`, ...), where these
/// paths lived before it became a crate of its own.
pub use tether_live as live;
/// Modules that moved to `tether-live` with the runtime, at their old paths.
pub use tether_live::{ego, markers, results, target_log};
