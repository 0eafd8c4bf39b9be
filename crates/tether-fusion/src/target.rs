//! The target of interest: the one person the robot follows (design 5, 11).
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
use tether_core::{Gaussian2, Point2, Pose2, Robot, Stamp, Vector2, World};

use crate::tracker::{MotionBounds, Track};

mod acquire;
mod config;
mod update;

/// Uncertainty of where a track was born (one observation of a person), m.
const BIRTH_SIGMA_M: f64 = 0.15;

/// A target whose track was updated by a whole person (a pair of legs, the camera) this
/// recently, and is updated now, is being seen, s: about three scans of a slow laser.
const SEEN_WHOLE_S: f64 = 0.5;

/// A target's track updated now and, before that, at most this long ago is observed
/// steadily, s (two to three scans of a 7.5-10 Hz laser).
const STEADY_GAP_S: f64 = 0.3;

pub use config::TargetConfig;

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
    /// Its track ran into another person's track and stayed on it: the target was
    /// occluded by, or crossed, that person and its track took that person's legs.
    LedOff,
}

impl LossReason {
    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            LossReason::Unseen => "unseen",
            LossReason::LeftView => "left_view",
            LossReason::SensorGap => "sensor_gap",
            LossReason::TrackDropped => "track_dropped",
            LossReason::LedOff => "led_off",
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
    /// Where the laser must vouch for it, the laser has not seen it: only the camera has
    /// ever seen the track, or (the lost target's own track) the laser, in use and
    /// seeing the place, has not seen it since the loss.
    NotSeenByLaser,
    /// The lost target's own track is back with no more than it had when lost (no new
    /// pair of legs, fewer than two updates since): a coasting track's wide reach takes
    /// a stray return as readily as the person.
    NoNewEvidence,
    /// Not seen as a pair of legs often enough (too few pairs, pairs in too small a
    /// share of its updates, or mostly faint legs): what the laser sees of it is not
    /// a person's steady pair of legs.
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
            Refusal::NotSeenByLaser => "not_seen_by_laser",
            Refusal::NoNewEvidence => "no_new_evidence",
            Refusal::NoLegPair => "no_leg_pair",
            Refusal::NotWalking => "not_walking",
            Refusal::StaticClutter => "static_clutter",
            Refusal::Ambiguous => "ambiguous",
        }
    }

    /// Every refusal, in output order.
    pub const ALL: [Refusal; 9] = [
        Refusal::OutOfReach,
        Refusal::SomebodyElse,
        Refusal::CameraDoesNotVouch,
        Refusal::NotSeenByLaser,
        Refusal::NoNewEvidence,
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
    /// Losses by reason: led off onto another person's track.
    pub lost_led_off: u64,
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
    /// ... only the camera has seen it, where the laser must vouch.
    pub refused_not_seen_by_laser: u64,
    /// ... the lost target's own track, back with nothing new since the loss.
    pub refused_no_new_evidence: u64,
    /// ... never a pair of legs.
    pub refused_no_leg_pair: u64,
    /// ... has not walked.
    pub refused_not_walking: u64,
    /// ... in static clutter.
    pub refused_static_clutter: u64,
    /// Times the target was handed over from its track to another during a close
    /// encounter (the tracker had swapped them, or the target's track was led off).
    pub handovers: u64,
    /// Times a target lost for `restart_after_s` was taken up again as at the start.
    pub restarts: u64,
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
            LossReason::LedOff => &mut self.lost_led_off,
        } += 1;
    }

    /// Counts one refusal (an ambiguity counts in `ambiguous`).
    pub fn count_refusal(&mut self, refusal: Refusal) {
        *match refusal {
            Refusal::OutOfReach => &mut self.refused_out_of_reach,
            Refusal::SomebodyElse => &mut self.refused_somebody_else,
            Refusal::CameraDoesNotVouch => &mut self.refused_camera_does_not_vouch,
            Refusal::NotSeenByLaser => &mut self.refused_not_seen_by_laser,
            Refusal::NoNewEvidence => &mut self.refused_no_new_evidence,
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
    /// For each other track, how long it has been updated together with the locked
    /// target and apart from it, s.
    beside: std::collections::BTreeMap<u64, f64>,
    /// The previous update's stamp.
    last_now: Option<Stamp>,
    /// The locked track `beside` is about.
    beside_of: Option<u64>,
    /// The target's state the last time it was alone (no other track within
    /// `encounter_distance_m`): what carries it through a close encounter.
    alone: Option<crate::tracker::Anchor>,
    /// For each track that is somebody else, how long the target's track has stayed on
    /// it, s.
    on_other: std::collections::BTreeMap<u64, f64>,
    /// Tracks the selector has seen (to notice births).
    seen: BTreeSet<u64>,
    /// Tracks born, while the target was unseen, where it could not have been.
    born_elsewhere: BTreeSet<u64>,
    /// Tracks born apart from the target while it was observed (seen whole a moment
    /// before, or steadily): somebody else if still away from it when it is lost (the
    /// target's track, not the new one, may have been on the wrong thing).
    born_apart: BTreeSet<u64>,
    /// Tracks that have been the target: the same person, whatever the tracker has
    /// done since, until shown otherwise.
    former: BTreeSet<u64>,
    /// Tracks born within `encounter_distance_m` of the locked target, or that were
    /// that near it when it was locked: perhaps the target itself (taken up by a new
    /// track, or its legs tracked apart).
    born_at_target: BTreeSet<u64>,
    /// Refusals already counted in this loss (track, reason).
    refused: BTreeSet<(u64, Refusal)>,
    /// The candidate sets already counted as ambiguous in this loss.
    ambiguous_sets: BTreeSet<Vec<u64>>,
    /// This tick's refusals.
    refusals_now: Vec<(u64, Refusal)>,
    /// While lost for `restart_after_s`: the one track standing in front of the robot,
    /// and since when.
    presented: Option<(u64, Stamp)>,
    /// The lost target's track as it was when lost: its (not weak) updates and its last
    /// evidence of a whole person. Coming back, it must show more than that.
    evidence_at_loss: Option<(u64, u32, Option<Stamp>)>,
    /// The locked track, its last update and the update before that.
    target_updates: Option<(u64, Stamp, Option<Stamp>)>,
    /// Every track's last good estimate at the previous update: what a track the
    /// tracker has since merged into another one was doing.
    last_anchors: std::collections::BTreeMap<u64, crate::tracker::Anchor>,
}

impl TargetSelector {
    /// The camera is gone for good (a live camera that failed): from now on the
    /// laser alone vouches for the target, as in a laser-only configuration.
    pub fn camera_gone(&mut self) {
        self.config.require_both_sensors = false;
    }

    /// A selector in the `Searching` state; `motion` bounds where a lost person can be.
    pub fn new(config: TargetConfig, motion: MotionBounds) -> Self {
        TargetSelector {
            config,
            motion,
            state: TargetState::Searching,
            stats: TargetStats::default(),
            last_good: None,
            others_at_loss: BTreeSet::new(),
            beside: std::collections::BTreeMap::new(),
            last_now: None,
            beside_of: None,
            alone: None,
            on_other: std::collections::BTreeMap::new(),
            seen: BTreeSet::new(),
            former: BTreeSet::new(),
            born_elsewhere: BTreeSet::new(),
            born_apart: BTreeSet::new(),
            born_at_target: BTreeSet::new(),
            refused: BTreeSet::new(),
            ambiguous_sets: BTreeSet::new(),
            refusals_now: Vec::new(),
            presented: None,
            evidence_at_loss: None,
            target_updates: None,
            last_anchors: std::collections::BTreeMap::new(),
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
        let from = crate::tracker::Anchor {
            stamp: since,
            position: last,
            velocity,
            velocity_sigma_mps,
        };
        self.reachable_from(&from, p, p_sigma_m, now)
    }

    /// Whether a person last seen at `from` could be at `p` (standard deviation
    /// `p_sigma_m`) at `now`.
    fn reachable_from(
        &self,
        from: &crate::tracker::Anchor,
        p: Point2<World>,
        p_sigma_m: f64,
        now: Stamp,
    ) -> bool {
        let sd = from.position.cov.principal_axes().0.max(0.0).sqrt();
        let margin = 3.0 * (sd + p_sigma_m) + self.config.region_margin_m;
        // A lost person is no longer bound by the coasting cap: the region grows with
        // the time lost, but never faster than a walker.
        let bounds = MotionBounds {
            max_coast_growth_m: f64::INFINITY,
            ..self.motion
        };
        bounds.reachable(
            from.position.mean,
            from.velocity,
            from.velocity_sigma_mps,
            now.secs_since(from.stamp),
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

    /// Updates the state from the current tracks, knowing what the sensors see: the
    /// memory of who is who brought up to date, verdicts on the tracks seen for the
    /// first time, then one transition of the state (design 5.6).
    pub fn update_with_view(&mut self, now: Stamp, tracks: &[Track], view: &View) -> TargetState {
        self.refusals_now.clear();
        // Before the other track is forgotten below.
        let merged_somebody_else = self.merged_somebody_else(tracks);
        self.last_anchors = tracks.iter().map(|t| (t.id, t.anchor)).collect();
        // Time since the previous update, capped so that a gap in the input does not
        // count as time seen together.
        let dt = self
            .last_now
            .map_or(0.0, |l| now.secs_since(l).clamp(0.0, 0.2));
        self.last_now = Some(now);
        self.forget_gone(tracks);
        self.judge_new_tracks(now, tracks);
        self.state = match self.state {
            TargetState::Searching => self.choose(now, tracks, view),
            TargetState::Locked { track } => {
                self.step_locked(now, track, tracks, view, dt, merged_somebody_else)
            }
            TargetState::Lost { track, since, .. } => {
                self.reacquire(now, track, since, tracks, view)
            }
        };
        self.after_transition(tracks);
        self.state
    }

    /// Track `t`'s last good estimate: its estimate after its last update, unless the
    /// single-leg updates since its last update by a whole person (a pair of legs, the
    /// camera; at most `encounter_max_s` before) have left that walk, when it is the
    /// estimate after that whole-person update. A coasting target's track may
    /// take a phantom return, the edge of a pillar or a bystander's leg that its wide
    /// reach covers, and run off after them; where the person can be is bounded from
    /// where they were last seen whole, never from that runaway (design 5; issue 14).
    fn good_anchor(&self, t: &Track) -> crate::tracker::Anchor {
        let last = t.anchor;
        let Some(p) = t.pair_anchor else {
            return last;
        };
        let dt = last.stamp.secs_since(p.stamp);
        if dt <= 0.0 || dt > self.config.encounter_max_s {
            return last;
        }
        // Single-leg updates that carry on the walk seen whole are the person's own: the
        // last update is good when it lies within `handover_within_sigma` of where that
        // walk leads.
        if self.off_walk_sigma(&p, &last.position, last.stamp) <= self.config.handover_within_sigma
        {
            last
        } else {
            p
        }
    }

    /// How many standard deviations track `t` is (at `at`) from where the target, alone
    /// at `a`, would be: `|p_t - (p_a + v_a dt)| / sqrt(sigma_a^2 + sigma_t^2 + (sigma_v
    /// dt)^2 + (A dt^2 / 2)^2)`, `A` = `encounter_accel_mps2`.
    fn off_prediction_sigma(&self, a: &crate::tracker::Anchor, t: &Track, at: Stamp) -> f64 {
        self.off_walk_sigma(a, &t.position(), at)
    }

    /// How many standard deviations the estimate `g` (at `at`) is from where the walk
    /// of `a` leads: the formula of [`Self::off_prediction_sigma`].
    fn off_walk_sigma(&self, a: &crate::tracker::Anchor, g: &Gaussian2<World>, at: Stamp) -> f64 {
        let dt = at.secs_since(a.stamp).max(0.0);
        let predicted = a.position.mean + a.velocity * dt;
        let sd2 = |c: &tether_core::Cov2| c.principal_axes().0.max(0.0);
        let spread = 0.5 * self.config.encounter_accel_mps2 * dt * dt;
        let var = sd2(&a.position.cov)
            + sd2(&g.cov)
            + (a.velocity_sigma_mps * dt).powi(2)
            + spread * spread;
        g.mean.distance_m(predicted) / var.max(1e-6).sqrt()
    }

    /// The squared normalised distance of track `t` (at `at`) from the target's motion
    /// when it was alone at `a`: the position term of [`Self::off_prediction_sigma`]
    /// squared plus `|v_t - v_a|^2 / (sigma_va^2 + sigma_vt^2 + (A dt)^2)`.
    fn off_motion_sq(&self, a: &crate::tracker::Anchor, t: &Track, at: Stamp) -> f64 {
        let dt = at.secs_since(a.stamp).max(0.0);
        let dv = t.velocity() - a.velocity;
        let sigma_vt = t.anchor.velocity_sigma_mps;
        let var_v = a.velocity_sigma_mps.powi(2)
            + sigma_vt * sigma_vt
            + (self.config.encounter_accel_mps2 * dt).powi(2);
        self.off_prediction_sigma(a, t, at).powi(2) + dv.norm().powi(2) / var_v.max(1e-6)
    }

    /// The locked target `t`, carried through close encounters: while another track is
    /// within `encounter_distance_m`, the target's motion from when it was last alone
    /// is the reference; a target track that leaves it far behind while exactly one
    /// other track (a person the laser vouches for, not somebody else) follows it hands
    /// the target over to that track.
    fn through_encounter(
        &mut self,
        now: Stamp,
        t: &Track,
        tracks: &[Track],
        view: &View,
    ) -> TargetState {
        let c = &self.config;
        let here = t.position().mean;
        let fresh = |u: &Track| now.secs_since(u.last_update) <= c.lost_after_s;
        let company = tracks.iter().any(|u| {
            u.id != t.id && fresh(u) && u.position().mean.distance_m(here) < c.encounter_distance_m
        });
        if !company {
            if t.last_update == now {
                self.alone = Some(self.good_anchor(t));
            }
            return TargetState::Locked { track: t.id };
        }
        let Some(a) = self
            .alone
            .filter(|a| now.secs_since(a.stamp) <= c.encounter_max_s && now > a.stamp)
        else {
            return TargetState::Locked { track: t.id };
        };
        let d_target = self.off_motion_sq(&a, t, now);
        // The candidates are the company: a swap of identities happens between tracks
        // that meet, and a track away from the target that only fits the reference's
        // extrapolation is not one (the target may have turned where it was hidden).
        let mut others: Vec<(f64, &Track)> = tracks
            .iter()
            .filter(|u| {
                u.id != t.id
                    && u.confirmed
                    && u.last_update == now
                    && u.position().mean.distance_m(here) < c.encounter_distance_m
            })
            .map(|u| (self.off_motion_sq(&a, u, now), u))
            .collect();
        others.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.id.cmp(&y.1.id)));
        let margin = c.handover_margin;
        match others.as_slice() {
            [(d, u), rest @ ..]
                if *d <= c.handover_within_sigma.powi(2)
                    && d_target - d >= margin
                    && rest.first().is_none_or(|(d2, _)| d2 - d >= margin)
                    && !self.is_somebody_else(u)
                    && (!view.laser_in_use || self.laser_refusal(u, view, false).is_none()) =>
            {
                self.stats.handovers += 1;
                self.last_good = Some(u.anchor);
                TargetState::Locked { track: u.id }
            }
            _ => TargetState::Locked { track: t.id },
        }
    }

    /// Adds `dt_s` to every other confirmed track seen now as a whole person, apart from
    /// the target
    /// (called when the target itself was seen now as a whole person: a pair of legs,
    /// or by the camera, so that a target led off by clutter does not make the person
    /// it left somebody else).
    fn count_beside(&mut self, target: &Track, tracks: &[Track], now: Stamp, dt_s: f64) {
        let here = target.position().mean;
        for u in tracks {
            if u.id != target.id
                && u.confirmed
                && u.last_pair == Some(now)
                && u.position().mean.distance_m(here) > self.config.beside_distance_m
            {
                *self.beside.entry(u.id).or_insert(0.0) += dt_s;
            }
        }
    }

    /// Whether `u` was somebody else already when the target was last seen at `a`: a
    /// track older than that observation, not born at the target nor ever the target,
    /// and not where the target was last seen.
    fn there_before(&self, u: &Track, a: &crate::tracker::Anchor) -> bool {
        u.born <= a.stamp
            && !self.born_at_target.contains(&u.id)
            && !self.former.contains(&u.id)
            && u.position().mean.distance_m(a.position.mean) > self.config.encounter_distance_m
    }

    /// Whether another track `u` is surely somebody else: both were seen as whole
    /// people, apart, at the same instants for `beside_s`.
    fn is_somebody_else(&self, u: &Track) -> bool {
        self.seen_beside_long_enough(u.id)
    }

    /// Whether track `id` has been seen beside the target for `beside_s` (the time is a
    /// sum of scan intervals: five 0.1 s intervals make 0.49999999999999994 s, which
    /// counts as 0.5 s).
    fn seen_beside_long_enough(&self, id: u64) -> bool {
        self.beside
            .get(&id)
            .is_some_and(|&s| s >= self.config.beside_s - 1e-6)
    }

    /// Adds `dt_s` to the time the target's track `t` has spent on each track of
    /// somebody else (within `led_off_distance_m`); true once one reaches
    /// `led_off_after_s`. While the target's track carries on its motion from when it
    /// was last alone (within `handover_within_sigma`, [`Self::off_motion_sq`]), it is
    /// the other track that came onto the target's person (a phantom swept along by
    /// the robot's turn, a track that lost its own person), not the target that was
    /// led off: nothing accrues.
    ///
    /// When the tracker has just merged somebody else's track into the target's (the
    /// two stayed on one spot for its `duplicate_after_s`; `merged`: the other track's
    /// last good estimate), the target's track now follows one of the two people: it
    /// is led off when it carries on the other person's motion better than the
    /// target's from when it was last alone (`encounter_max_s` ago at most). Two
    /// tracks that have walked together for longer than that are one person's legs
    /// tracked apart, or two people walking as one, and the merge changes nothing.
    fn led_off(
        &mut self,
        t: &Track,
        tracks: &[Track],
        now: Stamp,
        dt_s: f64,
        merged: Option<crate::tracker::Anchor>,
    ) -> bool {
        let alone = self
            .alone
            .filter(|a| now.secs_since(a.stamp) <= self.config.encounter_max_s && now > a.stamp);
        if let Some(other) = merged {
            let d_other = self.off_motion_sq(&other, t, now);
            if alone.is_some_and(|a| d_other < self.off_motion_sq(&a, t, now)) {
                return true;
            }
        }
        let on_course = alone.is_some_and(|a| {
            self.off_motion_sq(&a, t, now) <= self.config.handover_within_sigma.powi(2)
        });
        if on_course {
            self.on_other.clear();
            return false;
        }
        let here = t.position().mean;
        let fresh = |u: &Track| now.secs_since(u.last_update) <= self.config.lost_after_s;
        let on: Vec<u64> = tracks
            .iter()
            .filter(|u| u.id != t.id && u.confirmed && fresh(u))
            .filter(|u| u.position().mean.distance_m(here) < self.config.led_off_distance_m)
            .filter(|u| self.is_somebody_else(u))
            .map(|u| u.id)
            .collect();
        self.on_other.retain(|id, _| on.contains(id));
        let mut led = false;
        for id in on {
            let s = self.on_other.entry(id).or_insert(0.0);
            *s += dt_s;
            led |= *s >= self.config.led_off_after_s - 1e-6;
        }
        led
    }

    /// The target's track `track` was led off onto somebody else: lost, and neither
    /// that track nor the one it merged with can take the target up again.
    fn lose_led_off(&mut self, track: u64, tracks: &[Track]) -> TargetState {
        let others: Vec<u64> = self.on_other.keys().copied().collect();
        let last = self.last_good;
        self.stats.count_loss(LossReason::LedOff);
        let state = self.lose_with(track, LossReason::LedOff, last, tracks);
        self.others_at_loss.insert(track);
        self.others_at_loss.extend(others);
        self.on_other.clear();
        state
    }

    /// Lost `track` (`found`: its track, if the tracker still has it), searched for
    /// from `anchor`.
    fn lose(
        &mut self,
        track: u64,
        found: Option<&Track>,
        anchor: Option<crate::tracker::Anchor>,
        tracks: &[Track],
        view: &View,
    ) -> TargetState {
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
        self.lose_with(track, reason, anchor, tracks)
    }

    /// The lost state for `track`, lost for `reason` with `anchor` as its last good
    /// estimate; notes who is somebody else.
    fn lose_with(
        &mut self,
        track: u64,
        reason: LossReason,
        anchor: Option<crate::tracker::Anchor>,
        tracks: &[Track],
    ) -> TargetState {
        // Somebody else: a track seen beside the target, apart from it, for long enough
        // (`beside_s`), or one already there before the target's last observation, not
        // born at the target, and away from where the target was last seen. A track
        // born at the target, or standing where it was lost, may be the target itself,
        // taken up by a new track while the old one coasted or was led off.
        self.others_at_loss = tracks
            .iter()
            .filter(|t| t.confirmed && t.id != track)
            .filter(|t| {
                self.seen_beside_long_enough(t.id)
                    || anchor.is_some_and(|a| self.there_before(t, &a))
                    || (self.born_apart.contains(&t.id)
                        && anchor.is_some_and(|a| {
                            t.position().mean.distance_m(a.position.mean)
                                > self.config.encounter_distance_m
                        }))
            })
            .map(|t| t.id)
            .collect();
        self.refused.clear();
        self.ambiguous_sets.clear();
        self.evidence_at_loss = tracks
            .iter()
            .find(|t| t.id == track)
            .map(|t| (track, t.hits, t.last_pair));
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
        if self.others_at_loss.contains(&t.id) || self.born_elsewhere.contains(&t.id) {
            return Some(Refusal::SomebodyElse);
        }
        self.vouching_refusal(t, now, view)
    }

    /// Why the sensors do not vouch for `t` as the target taken up again.
    fn vouching_refusal(&self, t: &Track, now: Stamp, view: &View) -> Option<Refusal> {
        if (view.camera_sees)(t.position().mean) && self.config.require_both_sensors {
            // Where the camera sees, both sensors vouch (as at the start).
            return (!t.seen_by_both(now, self.config.both_sensors_window_s))
                .then_some(Refusal::CameraDoesNotVouch);
        }
        if !view.laser_in_use {
            return None;
        }
        self.laser_refusal(t, view, true)
    }

    /// While the target's track `t` coasts (no observation for `handover_coast_s`),
    /// the other track that takes up the target, if one clearly does. Candidates are
    /// tracks updated now, within `encounter_distance_m` of the target's track's last
    /// observation or of where its walk from when it was last alone leads, where the
    /// target could have gone since, not somebody else, seen by both sensors or
    /// vouched for by the laser as a person standing would be at the start. The
    /// tracker has given the person's observations to another track (the target's
    /// track went astray, or its person was split in two); waiting for the loss would
    /// leave the target with a track that runs off.
    ///
    /// Alone, the one candidate takes the target. In company (another track came
    /// within `encounter_distance_m`, `encounter_max_s` ago at most), the target's last
    /// observation may already be dragged towards the person it met, so the region
    /// is bounded from its state when it was last alone, and of several candidates the
    /// one whose motion carries on that state ([`Self::off_motion_sq`]) takes it only
    /// if it fits better than the next by `handover_margin`: somebody crossing behind
    /// the target walks another way.
    fn coasting_handover(
        &self,
        now: Stamp,
        t: &Track,
        tracks: &[Track],
        view: &View,
    ) -> Option<u64> {
        if now.secs_since(t.last_update) <= self.config.handover_coast_s {
            return None;
        }
        // In company, the target's own last observation may already be dragged off by
        // the person it met: the reference is its motion when it was last alone, and
        // the candidates are every track that continues it.
        let alone = self
            .alone
            .filter(|al| now.secs_since(al.stamp) <= self.config.encounter_max_s && now > al.stamp);
        // Where the target was last seen whole: a track that coasts on single legs may
        // be running off after somebody else's.
        let good = self.good_anchor(t);
        let a = alone.unwrap_or(good);
        // Near where the target was last seen, or where its motion from when it was
        // alone would have taken it.
        let r = self.config.encounter_distance_m;
        let near = |p: Point2<World>| {
            p.distance_m(t.anchor.position.mean) <= r
                || p.distance_m(good.position.mean) <= r
                || alone.is_some_and(|al| {
                    p.distance_m(al.position.mean + al.velocity * now.secs_since(al.stamp)) <= r
                })
        };
        let candidates = tracks.iter().filter(|u| {
            u.id != t.id
                && u.confirmed
                && u.last_update == now
                && near(u.position().mean)
                && self.reachable_from(
                    &a,
                    u.position().mean,
                    u.position().cov.principal_axes().0.max(0.0).sqrt(),
                    now,
                )
                && !self.is_somebody_else(u)
                && !self.born_elsewhere.contains(&u.id)
                && !self.there_before(u, &t.anchor)
                && (u.seen_by_both(now, self.config.both_sensors_window_s)
                    || (view.laser_in_use && self.laser_refusal(u, view, false).is_none())
                    || (!view.laser_in_use && self.vouching_refusal(u, now, view).is_none()))
        });
        let candidates: Vec<&Track> = candidates.collect();
        let (Some(al), [_, _, ..]) = (alone, candidates.as_slice()) else {
            return match candidates.as_slice() {
                [u] => Some(u.id),
                _ => None,
            };
        };
        // Several tracks where the target could be: the one that carries on its motion
        // from when it was alone, clearly better than the next.
        let mut ranked: Vec<(f64, u64)> = candidates
            .iter()
            .map(|u| (self.off_motion_sq(&al, u, now), u.id))
            .collect();
        ranked.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        match ranked.as_slice() {
            [(d, u), (d2, _), ..] if d2 - d >= self.config.handover_margin => Some(*u),
            _ => None,
        }
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
            || (walking
                && (f64::from(t.pair_hits) < self.config.min_pair_share * f64::from(t.hits)
                    || f64::from(t.weak_hits)
                        > self.config.max_weak_share * f64::from(t.hits + t.weak_hits)))
        {
            // No pair of legs because no leg at all: a track of the camera alone.
            Some(if t.last_laser.is_none() {
                Refusal::NotSeenByLaser
            } else {
                Refusal::NoLegPair
            })
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
}

#[cfg(test)]
mod tests;
