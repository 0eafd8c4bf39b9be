//! Labels for the leg classifier made from the recording itself (design 4.7): one person
//! walks around in front of a still robot for a minute, and every cluster is labelled
//! by how it moves over time, so that a new scanner needs no hand labels.
//!
//! The rule, on the detector's own candidates ([`LegDetector::candidates`]), all in the
//! frame of the still scanner (which is then a fixed frame):
//!
//! 1. **Static places.** A candidate is *static* when, in at least
//!    [`SelfLabelConfig::static_min_share`] of the scans, some return of the scan lies
//!    in the grid cell ([`SelfLabelConfig::static_cell_m`]) of its centroid or one of
//!    the eight around it: walls, furniture and posts return the beams of the whole
//!    recording (however differently their returns are cut into clusters from scan to
//!    scan); a walking person is at one place for a moment.
//! 2. **Walkers.** The other candidates of a scan are grouped (single linkage within
//!    [`SelfLabelConfig::group_link_m`], the farthest two legs of one person are apart)
//!    and the groups are tracked from scan to scan (nearest first, within a gate that
//!    grows with the time since the track's last group). A track is a *walker* when it
//!    - lasts at least [`SelfLabelConfig::min_track_s`],
//!    - spans at least [`SelfLabelConfig::min_extent_m`] (two of its positions apart),
//!    - moves at walking speed: the median of its displacements over about one second,
//!      per second, lies in [`SelfLabelConfig::walking_speed_mps`],
//!    - is one or two clusters: at most [`SelfLabelConfig::max_crowded_share`] of its
//!      groups hold more,
//!    - and its legs alternate: where the group holds two clusters, the difference of
//!      their positions along the walking direction (the left leg's less the right
//!      leg's, left and right by the side of the walking direction they lie on) changes
//!      sign at least [`SelfLabelConfig::min_steps_per_s`] times a second of the track
//!      (a step is such a change; people walk at about two steps a second).
//! 3. **Labels.** A candidate of a walker's group is a leg when the group holds at most
//!    two candidates and it lies at least [`SelfLabelConfig::static_clearance_m`] from
//!    every static candidate of the scan (a leg brushing a chair may have merged with
//!    it). A static candidate is a non-leg when no walker's group lies within
//!    [`SelfLabelConfig::walker_clearance_m`] of it in that scan, and its place was
//!    not mostly occupied while a walker stood there (a person who stood still long
//!    enough to look static). Everything else (groups of more than two, tracks that are
//!    not walkers, passing phantoms) is left out: a wrong label costs more than a
//!    missing one.
//!
//! A recording of the empty scene ([`empty_scene`]) adds scans whose every candidate is
//! a non-leg. The robot must stand still during the recording: the rule reads
//! positions in the scanner's frame as positions in the world.

use std::collections::HashMap;

use tether_core::{Laser, LaserScan, Point2, Vector2};

use crate::detector::LegDetector;
use crate::training::{LabelledRegion, ScanSample};

/// The parameters of the self-labelling rule (see the module's doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfLabelConfig {
    /// Cell of the grid of returns, m: a candidate's place is its centroid's cell and
    /// the eight around it.
    pub static_cell_m: f64,
    /// Share of the scans in which a place must hold a return for the candidates
    /// there to be static.
    pub static_min_share: f64,
    /// Candidates of one scan within this distance of each other belong to one group,
    /// m (leg_tracker pairs legs within 0.6 m).
    pub group_link_m: f64,
    /// A track takes a group within `gate_base_m + gate_speed_mps * dt` of its
    /// predicted position, `dt` the time since its last group, m.
    pub gate_base_m: f64,
    /// See `gate_base_m`, m/s (a brisk walk is under 2 m/s).
    pub gate_speed_mps: f64,
    /// A track without a group for longer than this ends, s.
    pub max_gap_s: f64,
    /// Shortest walker track, s.
    pub min_track_s: f64,
    /// Smallest span of a walker track (largest distance between two of its
    /// positions), m.
    pub min_extent_m: f64,
    /// The range of the median walking speed, m/s.
    pub walking_speed_mps: (f64, f64),
    /// Fewest leg alternations (steps) per second of track.
    pub min_steps_per_s: f64,
    /// Largest share of a walker's groups that hold more than two candidates (a person
    /// is one or two clusters).
    pub max_crowded_share: f64,
    /// A leg's along-track lead smaller than this is no evidence of which leg leads, m.
    pub min_lead_m: f64,
    /// A leg label needs this distance from every static candidate of its scan, m.
    pub static_clearance_m: f64,
    /// A non-leg label needs this distance from every walker group of its scan, m.
    pub walker_clearance_m: f64,
    /// A static place is not a non-leg when a walker stood within this distance of it
    /// for at least half of the scans it was occupied in, m.
    pub stood_radius_m: f64,
}

impl Default for SelfLabelConfig {
    fn default() -> Self {
        SelfLabelConfig {
            static_cell_m: 0.1,
            static_min_share: 0.5,
            group_link_m: 0.6,
            gate_base_m: 0.4,
            gate_speed_mps: 2.0,
            max_gap_s: 0.5,
            min_track_s: 3.0,
            min_extent_m: 1.0,
            walking_speed_mps: (0.25, 2.0),
            min_steps_per_s: 0.5,
            max_crowded_share: 0.2,
            min_lead_m: 0.05,
            static_clearance_m: 0.3,
            walker_clearance_m: 0.7,
            stood_radius_m: 0.3,
        }
    }
}

/// One scan's candidates with their labels: `Some(true)` a leg, `Some(false)` a
/// non-leg, `None` left out.
#[derive(Debug, Clone, Default)]
pub struct LabelledCandidates {
    /// The candidates (features, centres, centroids; its `positive` and `labels` are
    /// not used).
    pub sample: ScanSample,
    /// The label of each candidate.
    pub labels: Vec<Option<bool>>,
}

impl LabelledCandidates {
    /// Number of candidates labelled `label`.
    pub fn count(&self, label: Option<bool>) -> usize {
        self.labels.iter().filter(|&&l| l == label).count()
    }

    /// Candidates labelled by the truth: the candidate with the nearest centroid within
    /// [`crate::training::TRAIN_MATCH_RADIUS_M`] of each true leg (each candidate at most
    /// once, as [`ScanSample::labelled`]) is a leg, every other candidate a non-leg.
    pub fn from_truth(
        detector: &mut LegDetector,
        scan: &LaserScan,
        legs_in_laser: &[Point2<Laser>],
    ) -> Self {
        let sample = ScanSample::labelled(detector, scan, legs_in_laser, EVERYWHERE);
        let labels = sample.positive.iter().map(|&p| Some(p)).collect();
        LabelledCandidates { sample, labels }
    }
}

/// A region that holds every point: with it, every detection that finds no label is
/// false.
pub const EVERYWHERE: LabelledRegion = LabelledRegion {
    min_bearing_rad: -4.0,
    max_bearing_rad: 4.0,
    max_range_m: f64::INFINITY,
};

/// What the self-labelling found.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SelfLabelReport {
    /// Scans labelled.
    pub scans: usize,
    /// Candidates in them.
    pub candidates: usize,
    /// Candidates at static places.
    pub static_candidates: usize,
    /// Tracks of moving groups.
    pub tracks: usize,
    /// Of those, walkers.
    pub walkers: usize,
    /// Scans with a walker's group.
    pub scans_with_walker: usize,
    /// Legs labelled.
    pub legs: usize,
    /// Non-legs labelled.
    pub non_legs: usize,
    /// Candidates left out.
    pub left_out: usize,
    /// Walker groups left out for holding more than two candidates.
    pub crowded_groups: usize,
}

/// Every candidate of scans of the empty scene: all non-legs.
pub fn empty_scene(detector: &mut LegDetector, scans: &[LaserScan]) -> Vec<LabelledCandidates> {
    scans
        .iter()
        .map(|scan| {
            let sample = ScanSample::without_people(detector, scan);
            let labels = vec![Some(false); sample.features.len()];
            LabelledCandidates { sample, labels }
        })
        .collect()
}

/// One group of a track: a scan's moving candidates that lie together.
#[derive(Debug, Clone)]
struct Entry {
    scan: usize,
    time_s: f64,
    members: Vec<usize>,
    position: Point2<Laser>,
    /// The centroids of the two members of a group of two.
    legs: Option<(Point2<Laser>, Point2<Laser>)>,
}

/// Labels the candidates of `scans` (one recording of a still scanner, in time order)
/// by the rule of the module's doc.
pub fn self_label(
    detector: &mut LegDetector,
    scans: &[LaserScan],
    config: &SelfLabelConfig,
) -> (Vec<LabelledCandidates>, SelfLabelReport) {
    let samples: Vec<ScanSample> = scans
        .iter()
        .map(|s| ScanSample::without_people(detector, s))
        .collect();
    let times_s: Vec<f64> = scans.iter().map(|s| s.stamp.secs_f64()).collect();
    let places = StaticPlaces::new(scans, config.static_cell_m);
    let is_static: Vec<Vec<bool>> = samples
        .iter()
        .map(|s| {
            s.centroids
                .iter()
                .map(|&c| places.share(c) >= config.static_min_share)
                .collect()
        })
        .collect();
    let tracks = track_groups(&samples, &is_static, &times_s, config);
    let mut report = SelfLabelReport {
        scans: scans.len(),
        candidates: samples.iter().map(|s| s.centroids.len()).sum(),
        static_candidates: is_static.iter().flatten().filter(|&&s| s).count(),
        tracks: tracks.len(),
        ..SelfLabelReport::default()
    };
    let walkers: Vec<&Vec<Entry>> = tracks.iter().filter(|t| is_walker(t, config)).collect();
    report.walkers = walkers.len();
    // The walker groups of each scan.
    let mut groups: Vec<Vec<&Entry>> = vec![Vec::new(); scans.len()];
    for track in &walkers {
        for e in track.iter() {
            groups[e.scan].push(e);
        }
    }
    report.scans_with_walker = groups.iter().filter(|g| !g.is_empty()).count();
    let stood = places.stood_share(&groups, config);
    let mut out = Vec::with_capacity(scans.len());
    for (k, sample) in samples.into_iter().enumerate() {
        let mut labels = vec![None; sample.centroids.len()];
        let statics: Vec<Point2<Laser>> = sample
            .centroids
            .iter()
            .zip(&is_static[k])
            .filter(|(_, s)| **s)
            .map(|(c, _)| *c)
            .collect();
        for (j, &c) in sample.centroids.iter().enumerate() {
            if is_static[k][j]
                && groups[k]
                    .iter()
                    .all(|g| g.position.distance_m(c) >= config.walker_clearance_m)
                && stood(c) < 0.5
            {
                labels[j] = Some(false);
            }
        }
        for g in &groups[k] {
            if g.members.len() > 2 {
                report.crowded_groups += 1;
                continue;
            }
            for &m in &g.members {
                let c = sample.centroids[m];
                if statics
                    .iter()
                    .all(|s| s.distance_m(c) >= config.static_clearance_m)
                {
                    labels[m] = Some(true);
                }
            }
        }
        report.legs += labels.iter().filter(|l| **l == Some(true)).count();
        report.non_legs += labels.iter().filter(|l| **l == Some(false)).count();
        report.left_out += labels.iter().filter(|l| l.is_none()).count();
        out.push(LabelledCandidates { sample, labels });
    }
    (out, report)
}

/// Where a recording's returns lie: for each cell of a grid, the scans with a return
/// in it.
struct StaticPlaces {
    cell_m: f64,
    scans: usize,
    grid: HashMap<(i64, i64), Vec<u32>>,
}

impl StaticPlaces {
    fn new(scans: &[LaserScan], cell_m: f64) -> Self {
        let mut grid: HashMap<(i64, i64), Vec<u32>> = HashMap::new();
        for (k, scan) in scans.iter().enumerate() {
            for (_, p) in scan.points() {
                if p.is_finite() {
                    let v = grid.entry(Self::cell(p, cell_m)).or_default();
                    if v.last() != Some(&(k as u32)) {
                        v.push(k as u32);
                    }
                }
            }
        }
        StaticPlaces {
            cell_m,
            scans: scans.len(),
            grid,
        }
    }

    fn cell(p: Point2<Laser>, cell_m: f64) -> (i64, i64) {
        ((p.x / cell_m).floor() as i64, (p.y / cell_m).floor() as i64)
    }

    /// The scans with a return in the cell of `p` or one of its eight neighbours
    /// (within `cell_m` to `2.9 cell_m` of `p`), sorted, each once.
    fn scans_near(&self, p: Point2<Laser>) -> Vec<u32> {
        if !p.is_finite() {
            return Vec::new();
        }
        let (cx, cy) = Self::cell(p, self.cell_m);
        let mut seen = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.grid.get(&(cx + dx, cy + dy)) {
                    seen.extend_from_slice(v);
                }
            }
        }
        seen.sort_unstable();
        seen.dedup();
        seen
    }

    /// Share of the scans with a return near `p`.
    fn share(&self, p: Point2<Laser>) -> f64 {
        self.scans_near(p).len() as f64 / self.scans.max(1) as f64
    }

    /// For a place: the share of the scans with a return near it during which a
    /// walker's group lay within `stood_radius_m` of it.
    fn stood_share<'a>(
        &'a self,
        groups: &'a [Vec<&Entry>],
        config: &'a SelfLabelConfig,
    ) -> impl Fn(Point2<Laser>) -> f64 + 'a {
        move |p| {
            let near = self.scans_near(p);
            let stood = near
                .iter()
                .filter(|&&k| {
                    groups[k as usize]
                        .iter()
                        .any(|g| g.position.distance_m(p) <= config.stood_radius_m)
                })
                .count();
            stood as f64 / near.len().max(1) as f64
        }
    }
}

/// Groups the moving candidates of each scan and tracks the groups over the scans.
fn track_groups(
    samples: &[ScanSample],
    is_static: &[Vec<bool>],
    times_s: &[f64],
    config: &SelfLabelConfig,
) -> Vec<Vec<Entry>> {
    /// A track being built: its groups and smoothed velocity.
    struct Live {
        entries: Vec<Entry>,
        velocity: Vector2<Laser>,
    }
    let mut live: Vec<Live> = Vec::new();
    let mut done: Vec<Vec<Entry>> = Vec::new();
    for (k, sample) in samples.iter().enumerate() {
        let t = times_s[k];
        let moving: Vec<usize> = (0..sample.centroids.len())
            .filter(|&j| !is_static[k][j] && sample.centroids[j].is_finite())
            .collect();
        let groups = single_linkage(&moving, &sample.centroids, config.group_link_m);
        // End the tracks that waited too long.
        let (ended, kept): (Vec<Live>, Vec<Live>) = live.into_iter().partition(|l| {
            l.entries
                .last()
                .is_none_or(|e| t - e.time_s > config.max_gap_s)
        });
        done.extend(ended.into_iter().map(|l| l.entries));
        live = kept;
        // Nearest pairs of (track, group) within the gate, closest first.
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (i, l) in live.iter().enumerate() {
            let Some(last) = l.entries.last() else {
                continue;
            };
            let dt = (t - last.time_s).max(0.0);
            let predicted = last.position + l.velocity * dt;
            let gate = config.gate_base_m + config.gate_speed_mps * dt;
            for (j, (_, position)) in groups.iter().enumerate() {
                let d = predicted.distance_m(*position);
                if d <= gate {
                    pairs.push((d, i, j));
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
        let mut track_used = vec![false; live.len()];
        let mut group_used = vec![false; groups.len()];
        for (_, i, j) in pairs {
            if track_used[i] || group_used[j] {
                continue;
            }
            track_used[i] = true;
            group_used[j] = true;
            let l = &mut live[i];
            let (members, position) = groups[j].clone();
            let legs = two_legs(&members, &sample.centroids);
            if let Some(last) = l.entries.last() {
                let dt = t - last.time_s;
                if dt > 1e-6 {
                    let v = (position - last.position) * (1.0 / dt);
                    l.velocity = l.velocity * 0.7 + v * 0.3;
                }
            }
            l.entries.push(Entry {
                scan: k,
                time_s: t,
                members,
                position,
                legs,
            });
        }
        for (j, (members, position)) in groups.into_iter().enumerate() {
            if !group_used[j] {
                let legs = two_legs(&members, &sample.centroids);
                live.push(Live {
                    entries: vec![Entry {
                        scan: k,
                        time_s: t,
                        members,
                        position,
                        legs,
                    }],
                    velocity: Vector2::new(0.0, 0.0),
                });
            }
        }
    }
    done.extend(live.into_iter().map(|l| l.entries));
    done.sort_by_key(|t| t.first().map(|e| (e.scan, e.members.first().copied())));
    done
}

/// The centroids of a group of exactly two.
fn two_legs(
    members: &[usize],
    centroids: &[Point2<Laser>],
) -> Option<(Point2<Laser>, Point2<Laser>)> {
    match members {
        [a, b] => Some((centroids[*a], centroids[*b])),
        _ => None,
    }
}

/// Groups `indices` of `points` by single linkage within `link_m`; each group with the
/// mean of its points, groups in order of their first index.
fn single_linkage(
    indices: &[usize],
    points: &[Point2<Laser>],
    link_m: f64,
) -> Vec<(Vec<usize>, Point2<Laser>)> {
    let n = indices.len();
    let mut group = vec![usize::MAX; n];
    let mut out = Vec::new();
    for start in 0..n {
        if group[start] != usize::MAX {
            continue;
        }
        let id = out.len();
        group[start] = id;
        let mut members = vec![start];
        let mut next = 0;
        while next < members.len() {
            let a = points[indices[members[next]]];
            for b in 0..n {
                if group[b] == usize::MAX && a.distance_m(points[indices[b]]) <= link_m {
                    group[b] = id;
                    members.push(b);
                }
            }
            next += 1;
        }
        members.sort_unstable();
        let members: Vec<usize> = members.into_iter().map(|m| indices[m]).collect();
        let (sx, sy) = members
            .iter()
            .fold((0.0, 0.0), |(x, y), &m| (x + points[m].x, y + points[m].y));
        let n_m = members.len() as f64;
        out.push((members, Point2::new(sx / n_m, sy / n_m)));
    }
    out
}

/// Whether a track is a walker (see the module's doc).
fn is_walker(track: &[Entry], config: &SelfLabelConfig) -> bool {
    let (Some(first), Some(last)) = (track.first(), track.last()) else {
        return false;
    };
    let duration_s = last.time_s - first.time_s;
    if duration_s < config.min_track_s {
        return false;
    }
    let extent_m = track
        .iter()
        .flat_map(|a| track.iter().map(move |b| a.position.distance_m(b.position)))
        .fold(0.0, f64::max);
    if extent_m < config.min_extent_m {
        return false;
    }
    let Some(speed) = median_speed_mps(track) else {
        return false;
    };
    let (slow, fast) = config.walking_speed_mps;
    if !(slow..=fast).contains(&speed) {
        return false;
    }
    let crowded = track.iter().filter(|e| e.members.len() > 2).count();
    if crowded as f64 > config.max_crowded_share * track.len() as f64 {
        return false;
    }
    steps(track, config.min_lead_m) as f64 >= config.min_steps_per_s * duration_s
}

/// The median of the track's displacements over about one second (the first group at
/// least 1 s later, if within 1.5 s), per second.
fn median_speed_mps(track: &[Entry]) -> Option<f64> {
    let mut speeds = Vec::new();
    let mut j = 0;
    for (i, a) in track.iter().enumerate() {
        j = j.max(i);
        while j < track.len() && track[j].time_s - a.time_s < 1.0 {
            j += 1;
        }
        if let Some(b) = track.get(j) {
            let dt = b.time_s - a.time_s;
            if dt <= 1.5 {
                speeds.push(a.position.distance_m(b.position) / dt);
            }
        }
    }
    if speeds.is_empty() {
        return None;
    }
    speeds.sort_by(f64::total_cmp);
    Some(speeds[speeds.len() / 2])
}

/// Leg alternations of a track: over its groups of two (in time order), how often the
/// sign of the left leg's lead over the right leg along the walking direction changes.
/// The walking direction at a group is that of the displacement from the group 0.5 s
/// before to the one 0.5 s after (at least 0.1 m, else the group is skipped).
fn steps(track: &[Entry], min_lead_m: f64) -> usize {
    let mut last_sign = 0i8;
    let mut changes = 0;
    for i in 0..track.len() {
        let Some(lead) = left_lead_m(track, i) else {
            continue;
        };
        if lead.abs() < min_lead_m {
            continue;
        }
        let sign = if lead > 0.0 { 1 } else { -1 };
        if last_sign != 0 && sign != last_sign {
            changes += 1;
        }
        last_sign = sign;
    }
    changes
}

/// The left leg's lead over the right leg along the walking direction at group `i` of
/// the track, m; `None` when the group does not hold two clusters or the walking
/// direction is unknown.
fn left_lead_m(track: &[Entry], i: usize) -> Option<f64> {
    let e = &track[i];
    let legs = e.legs.as_ref()?;
    let before = track[..i]
        .iter()
        .rev()
        .find(|b| e.time_s - b.time_s >= 0.5)?;
    let after = track[i..].iter().find(|a| a.time_s - e.time_s >= 0.5)?;
    let d = after.position - before.position;
    if d.norm() < 0.1 {
        return None;
    }
    let heading = d * (1.0 / d.norm());
    let (a, b) = (legs.0 - e.position, legs.1 - e.position);
    let (left, right) = if heading.cross(a) >= heading.cross(b) {
        (a, b)
    } else {
        (b, a)
    };
    Some(heading.dot(left - right))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(x: f64, y: f64) -> Point2<Laser> {
        Point2::new(x, y)
    }

    #[test]
    fn single_linkage_chains_within_the_link_only() {
        let pts = [p(0.0, 0.0), p(0.5, 0.0), p(1.0, 0.0), p(3.0, 0.0)];
        let g = single_linkage(&[0, 1, 2, 3], &pts, 0.6);
        assert_eq!(g.len(), 2);
        assert_eq!(g[0].0, vec![0, 1, 2]);
        assert!(g[0].1.distance_m(p(0.5, 0.0)) < 1e-12);
        assert_eq!(g[1].0, vec![3]);
    }

    /// A track walking along +x at 1 m/s, 10 scans a second; with `alternate`, its two
    /// legs swap the lead every 0.5 s, else the left one always leads.
    fn walk(alternate: bool) -> Vec<Entry> {
        (0..60)
            .map(|k| {
                let t = f64::from(k) / 10.0;
                let lead = if alternate && (k / 5) % 2 == 1 {
                    -0.2
                } else {
                    0.2
                };
                let (left, right) = (p(t + lead / 2.0, 0.1), p(t - lead / 2.0, -0.1));
                Entry {
                    scan: k as usize,
                    time_s: t,
                    members: vec![0, 1],
                    position: p(t, 0.0),
                    legs: Some((left, right)),
                }
            })
            .collect()
    }

    #[test]
    fn a_walker_needs_alternating_legs() {
        let config = SelfLabelConfig::default();
        assert!(is_walker(&walk(true), &config));
        assert_eq!(steps(&walk(false), config.min_lead_m), 0);
        assert!(!is_walker(&walk(false), &config));
    }

    #[test]
    fn too_short_or_too_slow_is_no_walker() {
        let config = SelfLabelConfig::default();
        assert!(!is_walker(&walk(true)[..20], &config));
        let mut slow = walk(true);
        for e in &mut slow {
            e.position = p(e.time_s * 0.1, 0.0);
        }
        assert!(!is_walker(&slow, &config));
    }
}
