//! tether's reports (docs/design.md, *Reports*): self-contained HTML pages with inline
//! SVG, no scripts and no network, the same bytes for the same run.
//!
//! - [`sim_report`]: `report.html` of `tether demo` and `tether sim`, one section per
//!   simulated run (map, distance and bearing, commands, measures);
//! - [`replay_report`]: the pictures and track table of `tether replay`'s report of a
//!   recording (top view, snapshots of chosen instants, one row per track);
//! - [`plot`]: line plots over time, shared by both.
//!
//! The small SVG helpers (escaping, scale bars, label places) are `tether-svg`'s; only
//! the report of a simulated run uses the simulator, to draw its world.

pub mod plot;
pub mod replay_report;
pub mod sim_report;
