//! tether's measures and test beds (docs/design.md, *Measures*): what the tests, the benchmarks and
//! the `demo`, `eval-target`, `eval-track` and `eval-legs` commands score runs with.
//!
//! - [`closed_loop`]: a scenario of the simulator run through the pipeline in closed
//!   loop (sensors, pipeline, base, world), with its log of steps;
//! - [`metrics`]: the following measures of such a run (distance kept, comfort band,
//!   collisions, tracking);
//! - [`target_metrics`]: the target measures (on target, wrong scans, reappearances);
//! - [`mot`]: CLEAR MOT, as py-motmetrics computes it;
//! - [`track_eval`]: tracking and the target scored against a labelled recording;
//! - [`leg_eval`]: leg detections scored against labelled legs, by range;
//! - [`leg_data`]: leg_tracker's labelled recordings, the training and test splits;
//! - [`scip_sim`]: the simulator served as a Hokuyo (`tether urg-emulator`), and
//!   `ros2_sim` (feature `ros2`): the simulated robot on a ROS 2 graph (`tether sim
//!   --ros2`): the test beds that drive the simulator from outside.
//!
//! Nothing here prints or draws: the command line prints, `tether-report` draws.

pub mod closed_loop;
pub mod leg_data;
pub mod leg_eval;
pub mod metrics;
pub mod mot;
#[cfg(feature = "ros2")]
pub mod ros2_sim;
pub mod scip_sim;
pub mod target_metrics;
pub mod track_eval;

pub use mot::{ClearMot, MotSummary};
