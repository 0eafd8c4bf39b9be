//! The `tether` application: what its commands share that is the command line's own
//! (the `--ego-motion` choice, the log and terminal output, files written whole). The
//! annotated settings are `tether-live`'s (`config_docs`). The closed loop and the measures are `tether-eval`'s, the
//! reports `tether-report`'s; the live runtime (`run`, `ros2`) is the `tether-live`
//! crate, re-exported here as [`live`].

pub mod args;
pub mod ego_motion;
pub mod logs;
pub mod output;

/// The live runtime (`tether::live::config`, `tether::live::run_loop`, ...), where these
/// paths lived before it became a crate of its own.
pub use tether_live as live;
/// Modules that moved to `tether-live` with the runtime, at their old paths.
pub use tether_live::{ego, markers, results, target_log};
