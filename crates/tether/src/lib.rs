//! The `tether` application: the closed loop in the simulator, its measures and the
//! report, shared by the command line, the tests and the benchmarks.

pub mod closed_loop;
pub mod config_docs;
pub mod ego;
pub mod live;
pub mod logs;
pub mod markers;
pub mod metrics;
pub mod output;
pub mod plot;
pub mod recording;
pub mod replay_report;
pub mod report;
pub mod results;
pub mod target_log;
pub mod target_metrics;
pub mod track_eval;
pub mod tracking;
