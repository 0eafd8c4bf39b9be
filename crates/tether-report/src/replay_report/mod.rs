//! The pictures and the track table of `tether replay`'s report (issue 17): a top view
//! with metre axes and a scale bar, snapshots of chosen instants drawn the way
//! leg_tracker users look at rviz (the scan's returns, the detected legs, the laser's
//! person observations, the tracks with their ids, velocities and covariances, the
//! target, the robot), and one row per confirmed track.
//!
//! Everything is drawn in the replay's output frame (`odom`, `scan_odom` or
//! `base_link`), one metre the same length across and up, and comes out the same bytes
//! for the same replay (no hashing, no clock).
//!
//! # Which instants
//!
//! At most [`MAX_SNAPSHOTS`] (8), in time order:
//!
//! - **Target losses**: each loss of the target is a candidate when it happens (with
//!   the scan of that tick, or the last scan before it when a camera frame lost it); at
//!   most [`MAX_LOSS_SNAPSHOTS`] (4) are drawn, spread evenly over the losses by their
//!   order (all of them when there are no more).
//! - **Evenly spaced**: the rest (4 to 8) are the scans nearest the middles of as many
//!   equal parts of the recording's scans, by scan index.
//!
//! A recording's number of scans is known only at its end (a recording cut short has
//! no index to count them beforehand), and a 12-minute log has 7,200 scans, too many to
//! hold. So candidates are thinned as they come ([`Thinned`]): scan `i` is kept when
//! `i` is a multiple of a stride that doubles (dropping every other candidate) whenever
//! more than 32 are held. At most 32 scans are ever held, spaced at most a
//! sixteenth of the recording apart, so each evenly spaced snapshot is within a
//! sixteenth of the recording of its ideal place (and exactly there for recordings of
//! up to 32 scans). Losses are thinned the same way by loss number, at most 8 held.
//! The legs are found again, with the pipeline's own detector and configuration, only
//! for the scans drawn.

mod frame;
mod marks;
mod overview;
mod picker;
mod snapshot;
mod summary;
mod tracks;

pub use frame::{Bounds, MapFrame, scale_bar_m};
pub use overview::overview_svg;
pub use picker::{SnapshotPicker, Thinned};
pub use snapshot::{Chosen, Snapshot, snapshots_html};
pub use summary::ReplaySummary;
pub use tracks::{TrackRow, TrackSeen, TrackTable};

/// Most snapshots in a report.
pub const MAX_SNAPSHOTS: usize = 8;
/// Most of them at target losses.
pub const MAX_LOSS_SNAPSHOTS: usize = 4;
/// Scans held as candidates for the evenly spaced snapshots.
const EVEN_CANDIDATES: usize = 32;
/// Losses held as candidates.
const LOSS_CANDIDATES: usize = 8;
/// A track's walk is counted in steps of at least this, m: a standing person's
/// estimate jitters by centimetres (and by a leg's width when one leg updates it), which
/// is no walking.
pub const WALK_STEP_M: f64 = 0.25;
/// Most rows of the track table.
pub const MAX_TRACK_ROWS: usize = 50;

/// The target's colour everywhere in the report.
const TARGET: &str = "#d62728";
const SCAN: &str = "#3a3a3a";
const LEG: &str = "#2ca02c";
const PERSON: &str = "#1f77b4";
const TENTATIVE: &str = "#999999";
const ROBOT: &str = "#222222";

/// A track's colour: red for the target, else by id, the same in every picture. Dark
/// enough for an id written in it on white, and apart from the legs' green and the laser
/// people's blue.
pub fn track_color(id: u64, target: bool) -> &'static str {
    if target {
        TARGET
    } else {
        TRACK_COLORS[(id % TRACK_COLORS.len() as u64) as usize]
    }
}

/// The colours of the tracks other than the target's, by id.
pub const TRACK_COLORS: [&str; 6] = [
    "#9467bd", "#d95f02", "#8c564b", "#c51b8a", "#0e8a9a", "#6b6b00",
];

/// What a legend entry stands for: `class:colour` for each colour (see
/// [`marks::Entry`]).
fn stands_for(class: &str, colors: &[&str]) -> String {
    colors
        .iter()
        .map(|c| format!("{class}:{c}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `n` and the noun, singular or plural.
fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests;
