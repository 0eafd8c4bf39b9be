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

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use tether_core::{Gaussian2, Point2, Pose2, Robot, Stamp, Vector2, World};

use crate::tracker::{Anchor, MotionBounds, Track};
use memory::{Lock, Locked, Lost, Notes};

mod acquire;
mod config;
mod eligible;
mod locked;
mod memory;
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
    /// Seen as a pair of legs fewer times than the laser needs to vouch for it
    /// (`min_leg_pairs`, or `min_leg_pairs_standing` for a person standing).
    NoLegPair,
    /// Seen as a pair of legs in too small a share of its updates (`min_pair_share`):
    /// a bush or a phantom shows a pair now and then, a person often.
    FewLegPairs,
    /// Mostly faint legs (more than `max_weak_share` of its updates were legs the
    /// classifier barely accepted).
    WeakLegs,
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
            Refusal::FewLegPairs => "few_leg_pairs",
            Refusal::WeakLegs => "weak_legs",
            Refusal::NotWalking => "not_walking",
            Refusal::StaticClutter => "static_clutter",
            Refusal::Ambiguous => "ambiguous",
        }
    }

    /// Every refusal, in output order.
    pub const ALL: [Refusal; 11] = [
        Refusal::OutOfReach,
        Refusal::SomebodyElse,
        Refusal::CameraDoesNotVouch,
        Refusal::NotSeenByLaser,
        Refusal::NoNewEvidence,
        Refusal::NoLegPair,
        Refusal::FewLegPairs,
        Refusal::WeakLegs,
        Refusal::NotWalking,
        Refusal::StaticClutter,
        Refusal::Ambiguous,
    ];
}

/// Why a track is somebody else (design 11.4): what a `somebody_else` refusal rests on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SomebodyElse {
    /// Seen as a whole person at the same instants as the target, apart from it, for
    /// `beside_s`.
    SeenBeside,
    /// Already there, away from the target, when the target was last observed, and
    /// neither born at the target nor ever the target.
    ThereBefore,
    /// Born apart from the target while the target was observed, and still away from it
    /// at the loss.
    BornApart,
    /// Born, while the target was unseen, where the target could not have been.
    BornElsewhere,
    /// The target's track was led off onto this track, or this is the target's own track
    /// that was led off onto somebody else.
    LedOff,
}

impl SomebodyElse {
    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            SomebodyElse::SeenBeside => "seen_beside",
            SomebodyElse::ThereBefore => "there_before",
            SomebodyElse::BornApart => "born_apart",
            SomebodyElse::BornElsewhere => "born_elsewhere",
            SomebodyElse::LedOff => "led_off",
        }
    }
}

/// What moved the lock at an update: every transition there is (design 5.6, the table
/// of transitions; [`TargetSelector::transition`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Transition {
    /// Searching -> Locked: a track chosen at the start.
    Chosen,
    /// Locked -> Locked on another track: while the target's track coasted, another
    /// track took up its person.
    CoastingHandover,
    /// Locked -> Locked on another track: in a close encounter, another track carried
    /// on the target's walk clearly better than its own track.
    EncounterHandover,
    /// Locked -> Lost (`led_off`): the target's track ran onto somebody else's.
    LedOff,
    /// Locked -> Lost: the target's track went silent or was dropped (`unseen`,
    /// `left_view`, `sensor_gap`, `track_dropped`).
    Lost,
    /// Locked -> Searching: a track the selector never saw (a user's id) is gone, and
    /// there is nothing to search from.
    GaveUp,
    /// Lost -> Locked: the lost track itself is back.
    Back,
    /// Lost -> Locked on another track: the one candidate.
    Reacquired,
    /// Lost -> Locked: lost for `restart_after_s`, the one track standing in front of
    /// the robot for `restart_dwell_s`, taken up as at the start.
    Restarted,
}

impl Transition {
    /// Every transition, in the order of the design's table.
    pub const ALL: [Transition; 9] = [
        Transition::Chosen,
        Transition::CoastingHandover,
        Transition::EncounterHandover,
        Transition::LedOff,
        Transition::Lost,
        Transition::GaveUp,
        Transition::Back,
        Transition::Reacquired,
        Transition::Restarted,
    ];

    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Transition::Chosen => "chosen",
            Transition::CoastingHandover => "coasting_handover",
            Transition::EncounterHandover => "encounter_handover",
            Transition::LedOff => "led_off",
            Transition::Lost => "lost",
            Transition::GaveUp => "gave_up",
            Transition::Back => "back",
            Transition::Reacquired => "reacquired",
            Transition::Restarted => "restarted",
        }
    }

    /// The states it goes from and to ([`TargetState::name`]).
    pub fn from_to(self) -> (&'static str, &'static str) {
        match self {
            Transition::Chosen => ("searching", "locked"),
            Transition::CoastingHandover | Transition::EncounterHandover => ("locked", "locked"),
            Transition::LedOff | Transition::Lost => ("locked", "lost"),
            Transition::GaveUp => ("locked", "searching"),
            Transition::Back | Transition::Reacquired | Transition::Restarted => ("lost", "locked"),
        }
    }
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
    /// ... too few pairs of legs.
    pub refused_no_leg_pair: u64,
    /// ... pairs of legs in too small a share of its updates.
    pub refused_few_leg_pairs: u64,
    /// ... mostly faint legs.
    pub refused_weak_legs: u64,
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
            Refusal::FewLegPairs => &mut self.refused_few_leg_pairs,
            Refusal::WeakLegs => &mut self.refused_weak_legs,
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
    /// The state and its memory.
    lock: Lock,
    stats: TargetStats,
    /// What is known about each track the tracker has (its verdicts).
    notes: BTreeMap<u64, Notes>,
    /// The previous update's stamp.
    last_now: Option<Stamp>,
    /// This update's refusals.
    refusals_now: Vec<(u64, Refusal)>,
    /// Why each track refused as somebody else at this update is somebody else.
    somebody_else_now: Vec<(u64, SomebodyElse)>,
    /// This update's transition.
    transition_now: Option<Transition>,
    /// Every track's last good estimate at the previous update: what a track the
    /// tracker has since merged into another one was doing.
    last_anchors: BTreeMap<u64, Anchor>,
}

/// What `Locked` does at an update.
enum LockedStep {
    /// Keeps its track.
    Stay,
    /// Hands the target over to another track (`CoastingHandover` or
    /// `EncounterHandover`).
    HandOver(u64, Transition),
    /// Loses the target, for this reason, searching from this estimate (`None`: a
    /// track never seen, nothing to search from).
    Lose(LossReason, Option<Anchor>),
}

/// What `Lost` does at an update.
enum LostStep {
    /// Keeps searching.
    Stay,
    /// Takes up this track as the target.
    Reacquire(u64),
    /// Takes up this track as at the start.
    Restart(u64),
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
            lock: Lock::Searching,
            stats: TargetStats::default(),
            notes: BTreeMap::new(),
            last_now: None,
            refusals_now: Vec::new(),
            somebody_else_now: Vec::new(),
            transition_now: None,
            last_anchors: BTreeMap::new(),
        }
    }

    /// Current state.
    pub fn state(&self) -> TargetState {
        self.lock.state()
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

    /// Why each track refused as `somebody_else` at the last update is somebody else.
    pub fn refused_as_somebody_else(&self) -> &[(u64, SomebodyElse)] {
        &self.somebody_else_now
    }

    /// The transition the last update made, if it made one.
    pub fn transition(&self) -> Option<Transition> {
        self.transition_now
    }

    /// Where the lost target is most likely at `now`: its last good estimate moved by
    /// its velocity for at most a second (a walker keeps going for a moment; longer
    /// than that, direction is anybody's guess), with the reachable distance as
    /// standard deviation. `None` unless lost.
    pub fn lost_prediction(&self, now: Stamp) -> Option<Gaussian2<World>> {
        let Lock::Lost(Lost { from, .. }) = &self.lock else {
            return None;
        };
        let (last, dt) = (from.position, now.secs_since(from.stamp).max(0.0));
        let mean = last.mean + from.velocity * dt.min(1.0);
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
        match &self.lock {
            Lock::Lost(l) => self.reachable_from(&l.from, p, p_sigma_m, now),
            _ => false,
        }
    }

    /// Whether a person last seen at `from` could be at `p` (standard deviation
    /// `p_sigma_m`) at `now`.
    fn reachable_from(&self, from: &Anchor, p: Point2<World>, p_sigma_m: f64, now: Stamp) -> bool {
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
        self.somebody_else_now.clear();
        self.transition_now = None;
        let mut lock = std::mem::take(&mut self.lock);
        // Before the other track is forgotten below.
        let merged_somebody_else = self.merged_somebody_else(&lock, tracks);
        self.last_anchors = tracks.iter().map(|t| (t.id, t.anchor)).collect();
        // Time since the previous update, capped so that a gap in the input does not
        // count as time seen together.
        let dt = self
            .last_now
            .map_or(0.0, |l| now.secs_since(l).clamp(0.0, 0.2));
        self.last_now = Some(now);
        self.forget_gone(&mut lock, tracks);
        self.judge_new_tracks(&mut lock, now, tracks);
        let tick = Tick {
            now,
            tracks,
            view,
            dt,
        };
        self.lock = self.step(lock, &tick, merged_somebody_else);
        self.lock.state()
    }

    /// One transition of the lock: every transition there is, and the memory each
    /// starts its state with (design 5.6, the table of transitions).
    fn step(&mut self, lock: Lock, tick: &Tick, merged_somebody_else: Option<Anchor>) -> Lock {
        let (next, transition) = match lock {
            Lock::Searching => match self.choose(tick.now, tick.tracks, tick.view) {
                None => return Lock::Searching,
                Some(id) => {
                    self.stats.locks += 1;
                    (self.lock_onto(id, None, tick.tracks), Transition::Chosen)
                }
            },
            Lock::Locked(mut l) => match self.step_locked(&mut l, tick, merged_somebody_else) {
                LockedStep::Stay => return Lock::Locked(l),
                LockedStep::HandOver(to, how) => {
                    self.stats.handovers += 1;
                    // The same person on another track: its walk when it was last
                    // alone still carries it; the company of the old track is asked
                    // about again.
                    let mut next = self.lock_onto(to, None, tick.tracks);
                    if let Lock::Locked(n) = &mut next {
                        n.alone = l.alone;
                    }
                    (next, how)
                }
                LockedStep::Lose(reason, from) => {
                    self.stats.count_loss(reason);
                    match from {
                        Some(from) => (
                            Lock::Lost(self.lost(l, reason, from, tick.tracks)),
                            if reason == LossReason::LedOff {
                                Transition::LedOff
                            } else {
                                Transition::Lost
                            },
                        ),
                        // Locked without ever having seen the track (a user's id that
                        // vanished): nothing to bound the search by.
                        None => (Lock::Searching, Transition::GaveUp),
                    }
                }
            },
            Lock::Lost(mut l) => match self.step_lost(&mut l, tick) {
                LostStep::Stay => return Lock::Lost(l),
                LostStep::Reacquire(id) => {
                    self.stats.reacquisitions += 1;
                    let how = if id == l.track {
                        self.stats.reacquired_same_track += 1;
                        Transition::Back
                    } else {
                        Transition::Reacquired
                    };
                    (self.lock_onto(id, Some(l), tick.tracks), how)
                }
                LostStep::Restart(id) => {
                    self.stats.restarts += 1;
                    self.stats.locks += 1;
                    (
                        self.lock_onto(id, Some(l), tick.tracks),
                        Transition::Restarted,
                    )
                }
            },
        };
        self.transition_now = Some(transition);
        next
    }

    /// The lock on track `id` (`lost`: the loss it ends). The lost track itself comes
    /// back with the company it kept; a new track starts afresh, and the tracks already
    /// near it are noted as born at it (they may be the same person, its legs tracked
    /// apart).
    fn lock_onto(&mut self, id: u64, lost: Option<Lost>, tracks: &[Track]) -> Lock {
        let found = tracks.iter().find(|t| t.id == id);
        let mut locked = Locked::new(id, found.map(|t| t.anchor));
        self.notes.entry(id).or_default().former = true;
        match lost {
            Some(lost) if lost.track == id => locked.company = lost.company,
            _ => {
                if let Some(here) = found.map(|t| t.position().mean) {
                    for t in tracks {
                        if t.id != id
                            && t.position().mean.distance_m(here)
                                <= self.config.encounter_distance_m
                        {
                            self.notes.entry(t.id).or_default().at_target = true;
                        }
                    }
                }
            }
        }
        Lock::Locked(locked)
    }

    /// Track `t`'s last good estimate: its estimate after its last update, unless the
    /// single-leg updates since its last update by a whole person (a pair of legs, the
    /// camera; at most `encounter_max_s` before) have left that walk, when it is the
    /// estimate after that whole-person update. A coasting target's track may
    /// take a phantom return, the edge of a pillar or a bystander's leg that its wide
    /// reach covers, and run off after them; where the person can be is bounded from
    /// where they were last seen whole, never from that runaway (design 5; issue 14).
    fn good_anchor(&self, t: &Track) -> Anchor {
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
    fn off_prediction_sigma(&self, a: &Anchor, t: &Track, at: Stamp) -> f64 {
        self.off_walk_sigma(a, &t.position(), at)
    }

    /// How many standard deviations the estimate `g` (at `at`) is from where the walk
    /// of `a` leads: the formula of [`Self::off_prediction_sigma`].
    fn off_walk_sigma(&self, a: &Anchor, g: &Gaussian2<World>, at: Stamp) -> f64 {
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
    fn off_motion_sq(&self, a: &Anchor, t: &Track, at: Stamp) -> f64 {
        let dt = at.secs_since(a.stamp).max(0.0);
        let dv = t.velocity() - a.velocity;
        let sigma_vt = t.anchor.velocity_sigma_mps;
        let var_v = a.velocity_sigma_mps.powi(2)
            + sigma_vt * sigma_vt
            + (self.config.encounter_accel_mps2 * dt).powi(2);
        self.off_prediction_sigma(a, t, at).powi(2) + dv.norm().powi(2) / var_v.max(1e-6)
    }

    /// Whether track `id` has been seen beside the target (locked or lost) for
    /// `beside_s`.
    #[cfg(test)]
    fn seen_beside(&mut self, id: u64) -> bool {
        let beside_s = self.config.beside_s;
        self.lock
            .company_mut()
            .is_some_and(|c| c.seen_beside_for(id, beside_s))
    }

    /// The notes on track `id` (all false for a track not noted).
    fn notes_of(&self, id: u64) -> Notes {
        self.notes.get(&id).copied().unwrap_or_default()
    }
}

/// One update's input.
struct Tick<'a, 'v> {
    now: Stamp,
    tracks: &'a [Track],
    view: &'a View<'v>,
    /// Time since the previous update (capped), s.
    dt: f64,
}

#[cfg(test)]
mod tests;
