//! The track table: one row per confirmed track.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use tether_core::{Point2, Stamp, World};
use tether_fusion::tracker::Track;

use super::{MAX_TRACK_ROWS, WALK_STEP_M, track_color};

/// What the track table needs of a track at a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSeen {
    /// Id.
    pub id: u64,
    /// Confirmed.
    pub confirmed: bool,
    /// When it was born.
    pub born: Stamp,
    /// Its last update by any observation.
    pub last_update: Stamp,
    /// Its last update by the laser.
    pub last_laser: Option<Stamp>,
    /// Its position estimate.
    pub position: Point2<World>,
}

impl TrackSeen {
    /// Of a tracker's track.
    pub fn of(t: &Track) -> Self {
        TrackSeen {
            id: t.id,
            confirmed: t.confirmed,
            born: t.born,
            last_update: t.last_update,
            last_laser: t.last_laser,
            position: t.position().mean,
        }
    }
}

#[derive(Debug, Clone)]
struct TrackRecord {
    born: Stamp,
    last_update: Stamp,
    confirmed: bool,
    target: bool,
    walked_m: f64,
    walk_anchor: Point2<World>,
    scans_updated: u32,
}

/// One row of the track table.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackRow {
    /// Track id.
    pub id: u64,
    /// Born, s from the replay's first tick.
    pub first_s: f64,
    /// Last updated by an observation, s from the first tick.
    pub last_s: f64,
    /// `last_s - first_s`.
    pub duration_s: f64,
    /// Walked, m (in steps of at least [`WALK_STEP_M`]).
    pub walked_m: f64,
    /// `walked_m / duration_s`, when it lasted.
    pub mean_speed_mps: Option<f64>,
    /// Scans whose laser observations updated it.
    pub scans_updated: u32,
    /// Ever followed as the target.
    pub target: bool,
}

/// Per-track figures over a replay, for the tracks that were ever confirmed.
#[derive(Debug, Clone, Default)]
pub struct TrackTable {
    records: BTreeMap<u64, TrackRecord>,
    forgotten: usize,
}

impl TrackTable {
    /// Empty.
    pub fn new() -> Self {
        Self::default()
    }

    /// The tracker's tracks after a tick at `stamp` (a scan's when `scan`), and the
    /// track followed as the target then.
    pub fn update(&mut self, stamp: Stamp, scan: bool, tracks: &[TrackSeen], target: Option<u64>) {
        for t in tracks {
            let r = self.records.entry(t.id).or_insert_with(|| TrackRecord {
                born: t.born,
                last_update: t.last_update,
                confirmed: false,
                target: false,
                walked_m: 0.0,
                walk_anchor: t.position,
                scans_updated: 0,
            });
            r.confirmed |= t.confirmed;
            r.target |= target == Some(t.id);
            if t.last_update == stamp {
                r.last_update = stamp;
                let d = t.position.distance_m(r.walk_anchor);
                if d >= WALK_STEP_M && d.is_finite() {
                    r.walked_m += d;
                    r.walk_anchor = t.position;
                }
                if scan && t.last_laser == Some(stamp) {
                    r.scans_updated += 1;
                }
            }
        }
        // A tentative track that is gone was nobody: forget it.
        let before = self.records.len();
        self.records
            .retain(|id, r| r.confirmed || tracks.iter().any(|t| t.id == *id));
        self.forgotten += before - self.records.len();
    }

    /// The rows, at most [`MAX_TRACK_ROWS`] (every target's track, then the longest),
    /// sorted by first seen; and how many confirmed tracks were left out.
    pub fn rows(&self, start: Stamp) -> (Vec<TrackRow>, usize) {
        let mut rows: Vec<TrackRow> = self
            .records
            .iter()
            .filter(|(_, r)| r.confirmed)
            .map(|(&id, r)| {
                let first_s = r.born.secs_since(start);
                let last_s = r.last_update.secs_since(start);
                let duration_s = (last_s - first_s).max(0.0);
                TrackRow {
                    id,
                    first_s,
                    last_s,
                    duration_s,
                    walked_m: r.walked_m,
                    mean_speed_mps: (duration_s > 0.0).then(|| r.walked_m / duration_s),
                    scans_updated: r.scans_updated,
                    target: r.target,
                }
            })
            .collect();
        rows.sort_by(|a, b| {
            b.target
                .cmp(&a.target)
                .then(b.duration_s.total_cmp(&a.duration_s))
                .then(a.id.cmp(&b.id))
        });
        let left_out = rows.len().saturating_sub(MAX_TRACK_ROWS);
        rows.truncate(MAX_TRACK_ROWS);
        rows.sort_by(|a, b| a.first_s.total_cmp(&b.first_s).then(a.id.cmp(&b.id)));
        (rows, left_out)
    }

    /// The table, with a line saying what the columns are and what was left out.
    pub fn html(&self, start: Stamp) -> String {
        let (rows, left_out) = self.rows(start);
        if rows.is_empty() {
            return String::from("<p>No track was confirmed.</p>");
        }
        let mut s = format!(
            "<p>{} confirmed tracks{}. First seen: the track's birth; last seen: its last \
             update by an observation (s from the start of the replay); walked: along its \
             updated estimates, in steps of at least {WALK_STEP_M} m (a standing person's \
             jitter is no walk); scans: the scans whose laser observations updated it; \
             target: followed as the target at some tick.{}</p>",
            rows.len() + left_out,
            if self.forgotten > 0 {
                format!(
                    " ({} tentative tracks that were never confirmed are not listed)",
                    self.forgotten
                )
            } else {
                String::new()
            },
            if left_out > 0 {
                format!(
                    " The {MAX_TRACK_ROWS} listed are the target's and the longest; {left_out} \
                     shorter ones are left out."
                )
            } else {
                String::new()
            }
        );
        s.push_str(
            "<table class=\"tracks\"><tr><th>track</th><th>first seen (s)</th><th>last \
             seen (s)</th><th>duration (s)</th><th>walked (m)</th><th>mean speed (m/s)</th>\
             <th>scans updated</th><th>target</th></tr>",
        );
        for r in &rows {
            let _ = write!(
                s,
                "<tr><td><span style=\"color:{}\">●</span> {}</td><td>{:.1}</td><td>{:.1}</td>\
                 <td>{:.1}</td><td>{:.1}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                track_color(r.id, r.target),
                r.id,
                r.first_s,
                r.last_s,
                r.duration_s,
                r.walked_m,
                r.mean_speed_mps
                    .map_or("–".to_owned(), |v| format!("{v:.2}")),
                r.scans_updated,
                if r.target { "yes" } else { "" }
            );
        }
        s.push_str("</table>");
        s
    }
}
