//! The target of interest: the one person the robot follows (SPEC 5, 11).
//!
//! States: `Searching` (no target yet), `Locked` (following a track), `Lost` (the
//! target's track went silent or was dropped; re-acquisition is possible). The lock is
//! on a track identity, so crossings and short occlusions are handled by the tracker's
//! association: a track that coasts for a moment (a few missed scans) stays locked.
//!
//! While lost, the person can only be where a walker can get to from the target's last
//! good estimate (its track's state right after its last update, never an
//! extrapolation of a coasting filter): the region of [`MotionBounds::reachable`],
//! growing with the time lost at a bounded speed and acceleration. A track there is a
//! candidate only if the sensors vouch that it is a person:
//! - where the camera sees, both sensors must have seen it recently (a coasting track
//!   may latch onto a pillar or a table leg the camera would never call a person);
//! - elsewhere the laser alone must vouch: it has been seen as a pair of legs, it has
//!   walked (gone places, as a post does not), and it does not stand in learned static
//!   clutter;
//! - and it was not somebody else: a track confirmed before the loss that was not the
//!   target is another person.
//!
//! Exactly one candidate re-acquires; several mean "stop and wait": the robot never
//! follows a bystander. The state and the counters always say why the target is lost
//! and why a candidate was refused.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};
use tether_core::{Gaussian2, Point2, Pose2, Robot, Stamp, Vector2, World, wrap_angle_rad};

use crate::tracker::{MotionBounds, Track};

/// Target selection settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TargetConfig {
    /// Follow this track id instead of choosing (when it exists).
    pub track_id: Option<u64>,
    /// Follow the person nearest this point, `[x, y]` in the robot frame at the time of
    /// the choice, m (within `near_point_radius_m`), instead of the one nearest the
    /// heading.
    pub near_point_m: Option<[f64; 2]>,
    /// How close to `near_point_m` the chosen person must be, m.
    pub near_point_radius_m: f64,
    /// Only people seen by both sensors within this window can be chosen at start, s.
    pub both_sensors_window_s: f64,
    /// Only a person seen by both sensors can be chosen at start, and, where the camera
    /// sees, re-acquired (turned off when one sensor is absent).
    pub require_both_sensors: bool,
    /// Farthest person that can be chosen at start, m.
    pub max_select_range_m: f64,
    /// Largest bearing off the robot's heading for the choice at start, rad.
    pub max_select_bearing_rad: f64,
    /// The target counts as lost when its track has not been updated for this long, s
    /// (until then it coasts, still locked).
    pub lost_after_s: f64,
    /// Leg-pair observations a walking track needs before the laser alone vouches for
    /// it when re-acquiring (walking already sets it apart from static clutter; one
    /// pair says it walks on legs).
    pub min_leg_pairs: u32,
    /// Leg-pair observations a track that has not walked needs before the laser alone
    /// vouches for it at the start (a person standing in front of the robot; nothing
    /// but the legs sets them apart from a pair of table legs until the clutter map
    /// has learned the room).
    pub min_leg_pairs_standing: u32,
    /// Distance a track must have walked before the laser alone vouches for it when
    /// re-acquiring, m.
    pub min_walked_m: f64,
    /// Margin added to the region where a lost target can be, beyond three standard
    /// deviations of its last estimate and of the candidate's, m.
    pub region_margin_m: f64,
}

impl Default for TargetConfig {
    fn default() -> Self {
        TargetConfig {
            track_id: None,
            near_point_m: None,
            near_point_radius_m: 1.0,
            both_sensors_window_s: 1.0,
            require_both_sensors: true,
            max_select_range_m: 4.0,
            max_select_bearing_rad: 0.6,
            lost_after_s: 1.0,
            min_leg_pairs: 1,
            min_leg_pairs_standing: 2,
            min_walked_m: 0.5,
            region_margin_m: 0.3,
        }
    }
}

impl TargetConfig {
    /// Checks every field; says what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("near_point_radius_m", self.near_point_radius_m),
            ("both_sensors_window_s", self.both_sensors_window_s),
            ("max_select_range_m", self.max_select_range_m),
            ("max_select_bearing_rad", self.max_select_bearing_rad),
            ("lost_after_s", self.lost_after_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("target {name} must be > 0, got {v}"));
            }
        }
        for (name, v) in [
            ("min_walked_m", self.min_walked_m),
            ("region_margin_m", self.region_margin_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("target {name} must be >= 0, got {v}"));
            }
        }
        if let Some([x, y]) = self.near_point_m
            && !(x.is_finite() && y.is_finite())
        {
            return Err(format!(
                "target near_point_m must be finite, got [{x}, {y}]"
            ));
        }
        Ok(())
    }
}

/// Why the target is lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LossReason {
    /// Its track had no observation for `lost_after_s` while the sensors kept working
    /// and the person should still have been in view: the detectors missed them
    /// (occlusion, merged legs, a hard pose).
    Unseen,
    /// Its track had no observation for `lost_after_s` and the person was last heading
    /// out of the laser's field of view or range.
    LeftView,
    /// No scans for longer than `lost_after_s`: the laser stopped or the recording has
    /// a gap.
    SensorGap,
    /// The tracker dropped its track (too uncertain or silent too long) before the
    /// selector saw it go silent.
    TrackDropped,
}

impl LossReason {
    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            LossReason::Unseen => "unseen",
            LossReason::LeftView => "left_view",
            LossReason::SensorGap => "sensor_gap",
            LossReason::TrackDropped => "track_dropped",
        }
    }
}

/// Why a track was not taken for the lost target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Refusal {
    /// Farther from the last good estimate than a person could have walked.
    OutOfReach,
    /// Confirmed as somebody else before the target was lost.
    SomebodyElse,
    /// In the camera's view but not seen by both sensors.
    CameraDoesNotVouch,
    /// Never seen as a pair of legs.
    NoLegPair,
    /// Has not walked: it could be a post or a bush.
    NotWalking,
    /// Stands in learned static clutter.
    StaticClutter,
    /// One of several candidates: the robot waits rather than follow a bystander.
    Ambiguous,
}

impl Refusal {
    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Refusal::OutOfReach => "out_of_reach",
            Refusal::SomebodyElse => "somebody_else",
            Refusal::CameraDoesNotVouch => "camera_does_not_vouch",
            Refusal::NoLegPair => "no_leg_pair",
            Refusal::NotWalking => "not_walking",
            Refusal::StaticClutter => "static_clutter",
            Refusal::Ambiguous => "ambiguous",
        }
    }

    /// Every refusal, in output order.
    pub const ALL: [Refusal; 7] = [
        Refusal::OutOfReach,
        Refusal::SomebodyElse,
        Refusal::CameraDoesNotVouch,
        Refusal::NoLegPair,
        Refusal::NotWalking,
        Refusal::StaticClutter,
        Refusal::Ambiguous,
    ];
}

/// Where the target stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TargetState {
    /// No target chosen yet.
    Searching,
    /// Following this track.
    Locked {
        /// Track id.
        track: u64,
    },
    /// The target's track went silent at `since`; `last` is its last good estimate.
    Lost {
        /// The track that was followed.
        track: u64,
        /// Why.
        reason: LossReason,
        /// When its track was last updated.
        since: Stamp,
        /// Its last good estimate (right after that update).
        last: Gaussian2<World>,
        /// Its velocity then.
        velocity: Vector2<World>,
        /// The standard deviation of that velocity, m/s.
        velocity_sigma_mps: f64,
    },
}

impl TargetState {
    /// The followed track, if locked.
    pub fn locked_track(&self) -> Option<u64> {
        match self {
            TargetState::Locked { track } => Some(*track),
            _ => None,
        }
    }

    /// Name used in outputs: `searching`, `locked` or `lost`.
    pub fn name(&self) -> &'static str {
        match self {
            TargetState::Searching => "searching",
            TargetState::Locked { .. } => "locked",
            TargetState::Lost { .. } => "lost",
        }
    }

    /// Why the target is lost, if it is.
    pub fn loss_reason(&self) -> Option<LossReason> {
        match self {
            TargetState::Lost { reason, .. } => Some(*reason),
            _ => None,
        }
    }
}

/// Counts of what the selector did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct TargetStats {
    /// Times a target was chosen from `Searching`.
    pub locks: u64,
    /// Times the target was lost.
    pub losses: u64,
    /// Losses by reason: unseen.
    pub lost_unseen: u64,
    /// Losses by reason: left the field of view.
    pub lost_left_view: u64,
    /// Losses by reason: no scans.
    pub lost_sensor_gap: u64,
    /// Losses by reason: track dropped.
    pub lost_track_dropped: u64,
    /// Times it was re-acquired (same or another track id).
    pub reacquisitions: u64,
    /// Of those, onto the same track id.
    pub reacquired_same_track: u64,
    /// Times re-acquisition was refused because several tracks could be the target
    /// (once per loss and candidate set).
    pub ambiguous: u64,
    /// Candidates refused while lost (each track counted once per loss and reason):
    /// out of reach.
    pub refused_out_of_reach: u64,
    /// ... somebody else.
    pub refused_somebody_else: u64,
    /// ... the camera does not vouch.
    pub refused_camera_does_not_vouch: u64,
    /// ... never a pair of legs.
    pub refused_no_leg_pair: u64,
    /// ... has not walked.
    pub refused_not_walking: u64,
    /// ... in static clutter.
    pub refused_static_clutter: u64,
}

impl TargetStats {
    /// Counts one loss for `reason`.
    pub fn count_loss(&mut self, reason: LossReason) {
        self.losses += 1;
        *match reason {
            LossReason::Unseen => &mut self.lost_unseen,
            LossReason::LeftView => &mut self.lost_left_view,
            LossReason::SensorGap => &mut self.lost_sensor_gap,
            LossReason::TrackDropped => &mut self.lost_track_dropped,
        } += 1;
    }

    /// Counts one refusal (an ambiguity counts in `ambiguous`).
    pub fn count_refusal(&mut self, refusal: Refusal) {
        *match refusal {
            Refusal::OutOfReach => &mut self.refused_out_of_reach,
            Refusal::SomebodyElse => &mut self.refused_somebody_else,
            Refusal::CameraDoesNotVouch => &mut self.refused_camera_does_not_vouch,
            Refusal::NoLegPair => &mut self.refused_no_leg_pair,
            Refusal::NotWalking => &mut self.refused_not_walking,
            Refusal::StaticClutter => &mut self.refused_static_clutter,
            Refusal::Ambiguous => &mut self.ambiguous,
        } += 1;
    }
}

/// What the selector needs to know about the sensors at a tick.
pub struct View<'a> {
    /// The robot's pose.
    pub world_from_robot: Pose2<World, Robot>,
    /// Whether the camera is in use and sees a point.
    pub camera_sees: &'a dyn Fn(Point2<World>) -> bool,
    /// Whether the laser sees a point (field of view and range).
    pub laser_sees: &'a dyn Fn(Point2<World>) -> bool,
    /// Whether a point is in learned static clutter.
    pub in_clutter: &'a dyn Fn(Point2<World>) -> bool,
    /// Whether the laser is in use (when it is not, the camera alone vouches).
    pub laser_in_use: bool,
    /// No scan arrived for longer than `lost_after_s` before this tick.
    pub sensor_gap: bool,
}

impl View<'_> {
    /// A view in which both sensors see everywhere and nothing is clutter.
    pub fn everywhere(world_from_robot: Pose2<World, Robot>) -> View<'static> {
        View {
            world_from_robot,
            camera_sees: &|_| true,
            laser_sees: &|_| true,
            in_clutter: &|_| false,
            laser_in_use: true,
            sensor_gap: false,
        }
    }
}

/// Chooses and keeps the target.
#[derive(Debug, Clone)]
pub struct TargetSelector {
    config: TargetConfig,
    motion: MotionBounds,
    state: TargetState,
    stats: TargetStats,
    /// The locked track's last good estimate, kept in case the tracker drops the track
    /// between two calls.
    last_good: Option<crate::tracker::Anchor>,
    /// Confirmed tracks other than the target when it was lost: other people.
    others_at_loss: BTreeSet<u64>,
    /// Refusals already counted in this loss (track, reason).
    refused: BTreeSet<(u64, Refusal)>,
    /// The candidate sets already counted as ambiguous in this loss.
    ambiguous_sets: BTreeSet<Vec<u64>>,
    /// This tick's refusals.
    refusals_now: Vec<(u64, Refusal)>,
}

impl TargetSelector {
    /// A selector in the `Searching` state; `motion` bounds where a lost person can be.
    pub fn new(config: TargetConfig, motion: MotionBounds) -> Self {
        TargetSelector {
            config,
            motion,
            state: TargetState::Searching,
            stats: TargetStats::default(),
            last_good: None,
            others_at_loss: BTreeSet::new(),
            refused: BTreeSet::new(),
            ambiguous_sets: BTreeSet::new(),
            refusals_now: Vec::new(),
        }
    }

    /// Current state.
    pub fn state(&self) -> TargetState {
        self.state
    }

    /// Counters.
    pub fn stats(&self) -> TargetStats {
        self.stats
    }

    /// Settings.
    pub fn config(&self) -> &TargetConfig {
        &self.config
    }

    /// The candidates refused at the last update while lost, with the reasons.
    pub fn refusals(&self) -> &[(u64, Refusal)] {
        &self.refusals_now
    }

    /// Where the lost target is most likely at `now`: its last good estimate moved by
    /// its velocity for at most a second (a walker keeps going for a moment; longer
    /// than that, direction is anybody's guess), with the reachable distance as
    /// standard deviation. `None` unless lost.
    pub fn lost_prediction(&self, now: Stamp) -> Option<Gaussian2<World>> {
        let TargetState::Lost {
            since,
            last,
            velocity,
            ..
        } = self.state
        else {
            return None;
        };
        let dt = now.secs_since(since).max(0.0);
        let mean = last.mean + velocity * dt.min(1.0);
        let reach = (self.motion.max_speed_mps * dt).max(0.1);
        let cov = tether_core::Cov2::new(
            last.cov.xx() + reach * reach,
            last.cov.xy(),
            last.cov.yy() + reach * reach,
        )
        .unwrap_or(last.cov);
        Some(Gaussian2 { mean, cov })
    }

    /// Whether the lost target could be at `p` (standard deviation `p_sigma_m`) at `now`.
    pub fn within_reach(&self, p: Point2<World>, p_sigma_m: f64, now: Stamp) -> bool {
        let TargetState::Lost {
            since,
            last,
            velocity,
            velocity_sigma_mps,
            ..
        } = self.state
        else {
            return false;
        };
        let sd = last.cov.principal_axes().0.max(0.0).sqrt();
        let margin = 3.0 * (sd + p_sigma_m) + self.config.region_margin_m;
        // A lost person is no longer bound by the coasting cap: the region grows with
        // the time lost, but never faster than a walker.
        let bounds = MotionBounds {
            max_coast_growth_m: f64::INFINITY,
            ..self.motion
        };
        bounds.reachable(
            last.mean,
            velocity,
            velocity_sigma_mps,
            now.secs_since(since),
            margin,
            p,
        )
    }

    /// Updates the state from the current tracks, with both sensors seeing everywhere.
    pub fn update(
        &mut self,
        now: Stamp,
        tracks: &[Track],
        world_from_robot: Pose2<World, Robot>,
    ) -> TargetState {
        self.update_with_view(now, tracks, &View::everywhere(world_from_robot))
    }

    /// Updates the state from the current tracks, knowing what the sensors see.
    pub fn update_with_view(&mut self, now: Stamp, tracks: &[Track], view: &View) -> TargetState {
        self.refusals_now.clear();
        let fresh = |t: &Track| now.secs_since(t.last_update) <= self.config.lost_after_s;
        self.state = match self.state {
            TargetState::Searching => self.choose(now, tracks, view),
            TargetState::Locked { track } => match tracks.iter().find(|t| t.id == track) {
                Some(t) if fresh(t) => {
                    self.last_good = Some(t.anchor);
                    TargetState::Locked { track }
                }
                found => self.lose(track, found, tracks, view),
            },
            TargetState::Lost { track, .. } => self.reacquire(now, track, tracks, view),
        };
        if let TargetState::Locked { .. } = self.state {
            self.refused.clear();
            self.ambiguous_sets.clear();
        }
        self.state
    }

    fn lose(
        &mut self,
        track: u64,
        found: Option<&Track>,
        tracks: &[Track],
        view: &View,
    ) -> TargetState {
        let anchor = found.map(|t| t.anchor).or(self.last_good);
        let reason = if view.sensor_gap {
            LossReason::SensorGap
        } else if found.is_none() {
            LossReason::TrackDropped
        } else if anchor.is_some_and(|a| {
            // Heading out of view: where it would be a few tenths of a second on.
            !(view.laser_sees)(a.position.mean + a.velocity * 0.5)
        }) {
            LossReason::LeftView
        } else {
            LossReason::Unseen
        };
        self.stats.count_loss(reason);
        // Somebody else: a track seen beside the target, before the target's last
        // observation. A track born after it may be the target itself, taken up again
        // by a new track while the old one coasted.
        let seen_until = anchor.map(|a| a.stamp);
        self.others_at_loss = tracks
            .iter()
            .filter(|t| t.confirmed && t.id != track)
            .filter(|t| seen_until.is_some_and(|s| t.born <= s))
            .map(|t| t.id)
            .collect();
        self.refused.clear();
        self.ambiguous_sets.clear();
        match anchor {
            Some(a) => TargetState::Lost {
                track,
                reason,
                since: a.stamp,
                last: a.position,
                velocity: a.velocity,
                velocity_sigma_mps: a.velocity_sigma_mps,
            },
            // Locked without ever having seen the track (a user's id that vanished):
            // nothing to bound the search by.
            None => TargetState::Searching,
        }
    }

    /// Why `t` cannot be the lost target, if it cannot (`None`: a candidate).
    fn refusal(&self, t: &Track, now: Stamp, view: &View) -> Option<Refusal> {
        let p = t.position();
        let sd = p.cov.principal_axes().0.max(0.0).sqrt();
        if !self.within_reach(p.mean, sd, now) {
            return Some(Refusal::OutOfReach);
        }
        if self.others_at_loss.contains(&t.id) {
            return Some(Refusal::SomebodyElse);
        }
        if (view.camera_sees)(p.mean) && self.config.require_both_sensors {
            // Where the camera sees, both sensors vouch (as at the start).
            return (!t.seen_by_both(now, self.config.both_sensors_window_s))
                .then_some(Refusal::CameraDoesNotVouch);
        }
        if !view.laser_in_use {
            return None;
        }
        self.laser_refusal(t, view, true)
    }

    /// Why the laser alone does not vouch that `t` is a person (`walking`: it must also
    /// have walked).
    fn laser_refusal(&self, t: &Track, view: &View, walking: bool) -> Option<Refusal> {
        if (view.in_clutter)(t.position().mean) {
            Some(Refusal::StaticClutter)
        } else if t.pair_hits
            < if walking {
                self.config.min_leg_pairs
            } else {
                self.config.min_leg_pairs_standing
            }
        {
            Some(Refusal::NoLegPair)
        } else if walking && t.walked_m < self.config.min_walked_m {
            Some(Refusal::NotWalking)
        } else {
            None
        }
    }

    fn refuse(&mut self, track: u64, refusal: Refusal) {
        self.refusals_now.push((track, refusal));
        if self.refused.insert((track, refusal)) {
            self.stats.count_refusal(refusal);
        }
    }

    fn reacquire(&mut self, now: Stamp, track: u64, tracks: &[Track], view: &View) -> TargetState {
        let lost_after_s = self.config.lost_after_s;
        let fresh = |t: &Track| now.secs_since(t.last_update) <= lost_after_s;
        let mut candidates = Vec::new();
        for t in tracks.iter().filter(|t| t.confirmed && fresh(t)) {
            if t.id == track {
                // The tracker kept its identity: back, if it is still where the target
                // could be (a track that ran off after something else is not).
                let p = t.position();
                let sd = p.cov.principal_axes().0.max(0.0).sqrt();
                if self.within_reach(p.mean, sd, now) {
                    self.stats.reacquisitions += 1;
                    self.stats.reacquired_same_track += 1;
                    self.last_good = Some(t.anchor);
                    return TargetState::Locked { track };
                }
                self.refuse(t.id, Refusal::OutOfReach);
                continue;
            }
            match self.refusal(t, now, view) {
                Some(r) => self.refuse(t.id, r),
                None => candidates.push(t),
            }
        }
        match candidates.as_slice() {
            [one] => {
                self.stats.reacquisitions += 1;
                self.last_good = Some(one.anchor);
                TargetState::Locked { track: one.id }
            }
            [] => self.state,
            several => {
                let ids: Vec<u64> = several.iter().map(|t| t.id).collect();
                for &id in &ids {
                    self.refusals_now.push((id, Refusal::Ambiguous));
                }
                if self.ambiguous_sets.insert(ids) {
                    self.stats.ambiguous += 1;
                }
                self.state
            }
        }
    }

    fn choose(&mut self, now: Stamp, tracks: &[Track], view: &View) -> TargetState {
        let c = &self.config;
        let chosen = if let Some(id) = c.track_id {
            tracks.iter().find(|t| t.id == id)
        } else {
            let robot_from_world = view.world_from_robot.inverse();
            let eligible = tracks
                .iter()
                .filter(|t| t.confirmed && now.secs_since(t.last_update) <= c.lost_after_s)
                .filter(|t| {
                    if c.require_both_sensors {
                        t.seen_by_both(now, c.both_sensors_window_s)
                    } else if view.laser_in_use {
                        // The user stands in front of the robot to start: a pair of
                        // legs outside static clutter, walking or not.
                        self.laser_refusal(t, view, false).is_none()
                    } else {
                        true
                    }
                })
                .map(|t| (robot_from_world * t.position().mean, t));
            match c.near_point_m {
                Some([x, y]) => {
                    let point = Point2::<Robot>::new(x, y);
                    eligible
                        .map(|(p, t)| (p.distance_m(point), t))
                        .filter(|(d, _)| *d <= c.near_point_radius_m)
                        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id)))
                        .map(|(_, t)| t)
                }
                None => eligible
                    .filter_map(|(p, t)| {
                        let bearing = wrap_angle_rad(p.bearing_rad()).abs();
                        (p.range_m() <= c.max_select_range_m && bearing <= c.max_select_bearing_rad)
                            .then_some((bearing, t))
                    })
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id)))
                    .map(|(_, t)| t),
            }
        };
        match chosen {
            Some(t) => {
                self.stats.locks += 1;
                self.last_good = Some(t.anchor);
                TargetState::Locked { track: t.id }
            }
            None => TargetState::Searching,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::CvFilter;
    use crate::tracker::Anchor;
    use tether_core::Cov2;

    fn track(id: u64, x: f64, y: f64, last_ms: i64, both: bool) -> Track {
        let g = Gaussian2::<World>::new(Point2::new(x, y), Cov2::isotropic(0.05).unwrap()).unwrap();
        let t = Stamp::from_ns(last_ms * 1_000_000);
        Track {
            id,
            filter: CvFilter::new(&g, 0.3),
            confirmed: true,
            hits: 10,
            born: Stamp::ZERO,
            last_update: t,
            last_laser: Some(t),
            last_vision: both.then_some(t),
            anchor: Anchor {
                stamp: t,
                position: g,
                velocity: Vector2::ZERO,
                velocity_sigma_mps: 0.1,
            },
            birth_position: Point2::new(x - 1.0, y),
            walked_m: 1.0,
            pair_hits: 5,
            duplicate_since: None,
        }
    }

    fn at(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    fn selector() -> TargetSelector {
        TargetSelector::new(TargetConfig::default(), MotionBounds::default())
    }

    #[test]
    fn chooses_the_person_seen_by_both_sensors_nearest_the_heading() {
        let mut s = selector();
        let tracks = [
            track(1, 2.0, 0.8, 0, true),
            track(2, 2.0, 0.1, 0, false),
            track(3, 3.0, -0.2, 0, true),
        ];
        let state = s.update(at(0), &tracks, Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(3));
        assert_eq!(s.stats().locks, 1);
    }

    #[test]
    fn chooses_the_person_nearest_a_given_point() {
        let config = TargetConfig {
            near_point_m: Some([2.0, 0.9]),
            ..TargetConfig::default()
        };
        let mut s = TargetSelector::new(config, MotionBounds::default());
        let tracks = [track(1, 2.0, 0.8, 0, true), track(3, 3.0, -0.2, 0, true)];
        assert_eq!(
            s.update(at(0), &tracks, Pose2::IDENTITY).locked_track(),
            Some(1)
        );
        let config = TargetConfig {
            near_point_m: Some([-3.0, 0.0]),
            ..TargetConfig::default()
        };
        let mut s = TargetSelector::new(config, MotionBounds::default());
        assert_eq!(
            s.update(at(0), &tracks, Pose2::IDENTITY),
            TargetState::Searching,
            "nobody near the point"
        );
    }

    #[test]
    fn a_coasting_target_stays_locked_until_lost_after_s() {
        let mut s = selector();
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        let state = s.update(at(900), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(1));
        let state = s.update(at(1100), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        assert_eq!(state.loss_reason(), Some(LossReason::Unseen));
        assert_eq!(s.stats().lost_unseen, 1);
    }

    #[test]
    fn lost_target_is_reacquired_only_when_unambiguous() {
        let mut s = selector();
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        // The track goes silent: lost.
        let state = s.update(at(1100), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        // Two new tracks near the last estimate: ambiguous, stay lost.
        let a = track(7, 2.1, 0.0, 1200, true);
        let b = track(8, 1.9, 0.1, 1200, true);
        let state = s.update(at(1200), &[a.clone(), b.clone()], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { .. }));
        assert_eq!(s.stats().ambiguous, 1);
        assert_eq!(s.refusals().len(), 2);
        // The same pair again is the same ambiguity, not a new one.
        s.update(at(1250), &[a.clone(), b], Pose2::IDENTITY);
        assert_eq!(s.stats().ambiguous, 1);
        // One new track near the prediction: re-acquired.
        let state = s.update(at(1300), &[a], Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(7));
        assert_eq!(s.stats().reacquisitions, 1);
    }

    #[test]
    fn the_region_grows_at_walking_speed_from_the_last_good_estimate() {
        let mut s = selector();
        let mut t = track(1, 2.0, 0.0, 0, true);
        s.update(at(0), std::slice::from_ref(&t), Pose2::IDENTITY);
        // A runaway filter: the coasting track's own estimate is far away; the region
        // must stay centred on the anchor.
        t.filter.x = [6.0, 3.0, 1.7, 1.0];
        s.update(at(1100), &[t], Pose2::IDENTITY);
        // 1.1 s after the last update, 2.6 m away: too far for a walker (2 m/s,
        // 2 m/s^2 from standing: 1.2 m, plus 0.3 m of velocity and 0.6 m of margins).
        let far = track(9, 4.6, 0.0, 1100, true);
        assert!(
            s.update(at(1100), std::slice::from_ref(&far), Pose2::IDENTITY)
                .locked_track()
                .is_none()
        );
        assert_eq!(s.refusals(), &[(9, Refusal::OutOfReach)]);
        // 3 s later the same place is within reach.
        let later = track(9, 4.6, 0.0, 3000, true);
        assert_eq!(
            s.update(at(3000), &[later], Pose2::IDENTITY).locked_track(),
            Some(9)
        );
        // Nowhere near the runaway extrapolation.
        let mut s2 = selector();
        let mut t = track(1, 2.0, 0.0, 0, true);
        s2.update(at(0), std::slice::from_ref(&t), Pose2::IDENTITY);
        t.filter.x = [6.0, 3.0, 1.7, 1.0];
        s2.update(at(1100), &[t], Pose2::IDENTITY);
        let runaway = track(9, 6.0, 3.0, 1100, true);
        assert!(
            s2.update(at(1100), &[runaway], Pose2::IDENTITY)
                .locked_track()
                .is_none()
        );
    }

    #[test]
    fn the_laser_alone_vouches_only_for_walking_leg_pairs_outside_clutter() {
        let laser_only = TargetConfig {
            require_both_sensors: false,
            ..TargetConfig::default()
        };
        let lose_then_offer = |candidate: Track, clutter: bool| {
            let mut s = TargetSelector::new(laser_only.clone(), MotionBounds::default());
            // Clutter (when there is any) where the candidate stands, not the target.
            let in_clutter = move |p: Point2<World>| clutter && p.x > 2.1;
            let view = View {
                in_clutter: &in_clutter,
                ..View::everywhere(Pose2::IDENTITY)
            };
            s.update_with_view(at(0), &[track(1, 2.0, 0.0, 0, false)], &view);
            s.update_with_view(at(1100), &[], &view);
            let state = s.update_with_view(at(1200), &[candidate], &view);
            (state.locked_track(), s.refusals().to_vec())
        };
        let walker = track(5, 2.3, 0.2, 1200, false);
        assert_eq!(lose_then_offer(walker.clone(), false).0, Some(5));
        let mut post = walker.clone();
        post.walked_m = 0.1;
        assert_eq!(
            lose_then_offer(post, false),
            (None, vec![(5, Refusal::NotWalking)])
        );
        let mut lone = walker.clone();
        lone.pair_hits = 0;
        assert_eq!(
            lose_then_offer(lone, false),
            (None, vec![(5, Refusal::NoLegPair)])
        );
        assert_eq!(
            lose_then_offer(walker, true),
            (None, vec![(5, Refusal::StaticClutter)])
        );
    }

    #[test]
    fn a_far_bystander_is_never_taken_for_the_target() {
        let mut s = selector();
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        let bystander = track(2, 6.0, 3.0, 1100, true);
        s.update(at(1100), std::slice::from_ref(&bystander), Pose2::IDENTITY);
        let state = s.update(at(1500), &[bystander], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        assert_eq!(s.stats().refused_out_of_reach, 1, "counted once per loss");
    }

    #[test]
    fn an_old_bystander_near_the_target_does_not_inherit_the_lock() {
        // A person who was already tracked before the loss is someone else.
        let mut s = selector();
        let other = track(2, 2.5, 0.3, 0, true);
        s.update(
            at(0),
            &[track(1, 2.0, 0.0, 0, true), other.clone()],
            Pose2::IDENTITY,
        );
        let mut other_now = other;
        other_now.last_update = at(1100);
        let state = s.update(
            at(1100),
            &[track(1, 2.0, 0.0, 0, true), other_now.clone()],
            Pose2::IDENTITY,
        );
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        let state = s.update(at(1200), &[other_now], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        assert_eq!(s.refusals(), &[(2, Refusal::SomebodyElse)]);
    }

    #[test]
    fn a_new_track_taking_up_the_target_while_it_coasted_is_not_somebody_else() {
        // The target's last observation is at 0; a new track is born on the same person
        // at 300 ms and confirmed before the old one counts as lost at 1100 ms.
        let mut s = selector();
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        let mut new = track(2, 2.4, 0.1, 1100, true);
        new.born = at(300);
        let state = s.update(
            at(1100),
            &[track(1, 2.0, 0.0, 0, true), new.clone()],
            Pose2::IDENTITY,
        );
        assert!(
            matches!(state, TargetState::Lost { track: 1, .. }) || state.locked_track() == Some(2),
            "{state:?}"
        );
        let state = s.update(at(1200), &[new], Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(2));
    }

    #[test]
    fn loss_reasons_say_what_happened() {
        let lose = |view: &View, tracks: &[Track]| {
            let mut s = selector();
            s.update_with_view(at(0), &[track(1, 2.0, 0.0, 0, true)], view);
            s.update_with_view(at(1100), tracks, view).loss_reason()
        };
        let everywhere = View::everywhere(Pose2::IDENTITY);
        assert_eq!(lose(&everywhere, &[]), Some(LossReason::TrackDropped));
        let silent = [track(1, 2.0, 0.0, 0, true)];
        assert_eq!(lose(&everywhere, &silent), Some(LossReason::Unseen));
        let gap = View {
            sensor_gap: true,
            ..View::everywhere(Pose2::IDENTITY)
        };
        assert_eq!(lose(&gap, &silent), Some(LossReason::SensorGap));
        let blind = View {
            laser_sees: &|_| false,
            ..View::everywhere(Pose2::IDENTITY)
        };
        assert_eq!(lose(&blind, &silent), Some(LossReason::LeftView));
    }

    #[test]
    fn settings_are_checked() {
        assert!(TargetConfig::default().validate().is_ok());
        let bad = TargetConfig {
            lost_after_s: 0.0,
            ..TargetConfig::default()
        };
        assert!(bad.validate().is_err());
        let bad = TargetConfig {
            near_point_m: Some([f64::NAN, 0.0]),
            ..TargetConfig::default()
        };
        assert!(bad.validate().is_err());
    }
}
