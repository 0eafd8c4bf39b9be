//! Multi-person tracking: one constant-velocity Kalman filter per person in the world
//! (odometry) frame, global nearest neighbour association with the Hungarian method on
//! the negative log likelihood of each pairing,
//! confirmation after a few consistent detections, deletion after missed updates or
//! when the uncertainty grows too large.
//!
//! Observations are processed as each sensor delivers them (a laser scan's people, a
//! camera frame's people, or laser-vision pairs fused per frame), in time order. Input
//! that cannot be used is rejected and counted, never allowed to corrupt a track:
//! batches older than the tracker's clock, non-finite or absurd observations.
//!
//! Motion is bounded by what people do (design 11, [`MotionBounds`]): an observation that
//! a track could only explain by an impossible jump does not update it, and the region
//! a coasting track may take observations from stops growing. A track's estimated
//! speed never exceeds the bound. Weak observations (leg candidates the classifier
//! nearly accepted) only keep confirmed tracks alive: they never start or confirm one.

use serde::{Deserialize, Serialize};
use tether_core::{Gaussian2, Point2, Stamp, Vector2, World};
use thiserror::Error;

use crate::gate::Gate;
use crate::kalman::CvFilter;

mod process;

/// Lower bound on `ln det S` in the assignment cost: innovations tighter than a few
/// centimetres all count the same, so sub-centimetre covariances do not dominate.
const LN_DET_FLOOR: f64 = -12.0;

/// Which sensor an observation comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// A laser person (a leg pair, or a lone leg).
    Laser,
    /// A camera person (upper-body box through the pinhole model).
    Vision,
    /// A laser person and a camera person fused in the same frame.
    Fused,
}

/// The bearing part of a camera observation: the direction from the camera to the
/// person, which the camera measures well (its range, through an assumed person
/// height, it measures poorly and with an error that persists from frame to frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bearing {
    /// The camera's position.
    pub origin: Point2<World>,
    /// Direction to the person, rad (world frame).
    pub bearing_rad: f64,
    /// Standard deviation, rad.
    pub sigma_rad: f64,
}

/// One person observation in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// Where it comes from.
    pub source: Source,
    /// Position estimate.
    pub estimate: Gaussian2<World>,
    /// Whether it may start a new track (a lone leg, say, should not).
    pub may_spawn: bool,
    /// For camera observations: the bearing alone, used instead of the full position
    /// when the track has recent laser support (the complementary use of the two
    /// sensors: range from the laser, bearing from both).
    pub bearing: Option<Bearing>,
    /// For laser observations: made of a pair of legs (the laser's own evidence that
    /// this is a person rather than a lone post).
    pub leg_pair: bool,
    /// A weak observation (a cluster the leg classifier nearly accepted): it may keep a
    /// confirmed track alive, but never starts or confirms one.
    pub weak: bool,
    /// For laser observations: where the scan before could not see ([`crate::Shadow`]):
    /// somebody coming out from behind something, who may be a hidden track's person
    /// however far their track coasted ([`TrackerConfig::coast_lone_leg_after_s`]).
    pub from_shadow: bool,
}

impl Observation {
    /// A laser person: a leg pair, or a lone leg that may start a track if
    /// `lone_leg_spawns`.
    pub fn laser(estimate: Gaussian2<World>, leg_pair: bool, lone_leg_spawns: bool) -> Self {
        Observation {
            source: Source::Laser,
            estimate,
            may_spawn: leg_pair || lone_leg_spawns,
            bearing: None,
            leg_pair,
            weak: false,
            from_shadow: false,
        }
    }

    /// A weak laser observation (see [`Observation::weak`]).
    pub fn weak_laser(estimate: Gaussian2<World>) -> Self {
        Observation {
            weak: true,
            ..Observation::laser(estimate, false, false)
        }
    }

    /// A camera person, with its bearing for tracks the laser supports.
    pub fn vision(estimate: Gaussian2<World>, may_spawn: bool, bearing: Option<Bearing>) -> Self {
        Observation {
            source: Source::Vision,
            estimate,
            may_spawn,
            bearing,
            leg_pair: false,
            weak: false,
            from_shadow: false,
        }
    }
}

/// What people can do (design 11): walking up to about 2 m/s, accelerations of a few
/// m/s^2. Used to refuse observations a track could only reach by an impossible jump
/// and to bound where a lost person can be.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct MotionBounds {
    /// Highest speed of a person, m/s.
    #[config(range = "> 0")]
    pub max_speed_mps: f64,
    /// Highest sustained acceleration of a person, m/s^2.
    #[config(range = "> 0")]
    pub max_accel_mps2: f64,
    /// The region a coasting track takes observations from grows by at most this
    /// beyond its estimate's own uncertainty, m: a track silent for long is more
    /// likely lost than far away.
    #[config(range = "> 0")]
    pub max_coast_growth_m: f64,
}

impl Default for MotionBounds {
    fn default() -> Self {
        MotionBounds {
            max_speed_mps: 2.0,
            max_accel_mps2: 2.0,
            max_coast_growth_m: 1.0,
        }
    }
}

impl MotionBounds {
    /// Whether a person last known at `last` (position and velocity, the velocity's
    /// standard deviation `sigma_v_mps`) can be at `p` after `dt_s`, within `margin_m`
    /// of uncertainty. The reachable set of a body whose speed is at most `V` and whose
    /// acceleration is at most `A` lies in both discs
    ///
    /// `|p - (p0 + v0 dt)| <= A dt^2 / 2 + 3 sigma_v dt`  and  `|p - p0| <= V dt`,
    ///
    /// each widened by `margin_m`; `max_coast_growth_m` caps the first disc's growth.
    pub fn reachable(
        &self,
        last: Point2<World>,
        velocity: Vector2<World>,
        sigma_v_mps: f64,
        dt_s: f64,
        margin_m: f64,
        p: Point2<World>,
    ) -> bool {
        let dt = dt_s.max(0.0);
        let drift = (0.5 * self.max_accel_mps2 * dt * dt + 3.0 * sigma_v_mps * dt)
            .min(self.max_coast_growth_m);
        let predicted = last + velocity * dt;
        p.distance_m(predicted) <= margin_m + drift
            && p.distance_m(last) <= margin_m + self.max_speed_mps * dt
    }

    fn validate(&self) -> Result<(), TrackerConfigError> {
        for (field, value) in [
            ("motion.max_speed_mps", self.max_speed_mps),
            ("motion.max_accel_mps2", self.max_accel_mps2),
            ("motion.max_coast_growth_m", self.max_coast_growth_m),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(TrackerConfigError {
                    field,
                    value,
                    why: "must be a positive number",
                });
            }
        }
        Ok(())
    }
}

/// How an observation updates a track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateRule {
    /// Kalman update: the observation's error is independent of the track's.
    Kalman,
    /// Covariance Intersection: consistent whatever the correlation (for errors that
    /// persist from frame to frame, like the vision range of a person whose height
    /// differs from the assumed one).
    CovarianceIntersection,
}

/// Tracker settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerConfig {
    /// Association gate on the innovation's squared Mahalanobis distance.
    pub gate: Gate,
    /// Spectral density of the white-noise acceleration, m^2/s^3 (how briskly people
    /// change velocity).
    #[config(range = "> 0")]
    pub accel_noise: f64,
    /// Velocity uncertainty of a new track, m/s.
    #[config(range = "> 0")]
    pub initial_speed_sigma_mps: f64,
    /// Updates that confirm a tentative track.
    #[config(range = ">= 1")]
    pub confirm_hits: u32,
    /// A tentative track not updated for this long is dropped, s.
    #[config(range = "> 0")]
    pub tentative_timeout_s: f64,
    /// A confirmed track not updated for this long is dropped, s.
    #[config(range = "> 0")]
    pub max_coast_s: f64,
    /// A return hides what lies more than this behind it ([`crate::Shadow`]), m.
    #[config(range = "> 0")]
    pub shadow_margin_m: f64,
    /// A person found within this distance beside the last scan's shadow came out of it,
    /// m: about how far a walker moves between two scans (1 m/s at 10 Hz). The
    /// detector finds a leg only once a few beams hit it, by when it is already past
    /// the shadow's edge ([`Observation::from_shadow`]).
    #[config(range = ">= 0")]
    pub shadow_edge_m: f64,
    /// A track whose position standard deviation exceeds this is dropped, m.
    #[config(range = "> 0")]
    pub max_position_sigma_m: f64,
    /// Observations with a position standard deviation above this are ignored, m.
    #[config(range = "> 0")]
    pub max_observation_sigma_m: f64,
    /// How laser (and fused) observations update tracks.
    pub laser_update: UpdateRule,
    /// How vision observations update tracks that lack recent laser support.
    pub vision_update: UpdateRule,
    /// A track updated by the laser within this long takes only the bearing of a
    /// vision observation, s (0: always the full position).
    #[config(range = ">= 0")]
    pub laser_support_s: f64,
    /// A camera observation updates no track that another confirmed track is closer to
    /// than this, m (0: no such rule). Two people closer than about a body width (0.5 m)
    /// overlap in the image: the box, and the range the monocular model reads from it,
    /// may be either one's or both merged, and giving it to the wrong track at a crossing
    /// drags that track onto the other person; the laser, which resolves their legs,
    /// updates them alone until they part.
    #[config(range = ">= 0")]
    pub vision_min_separation_m: f64,
    /// What people can do: the physical gate of every track.
    pub motion: MotionBounds,
    /// No new track starts closer than this to a confirmed track, m: two people's
    /// centres are never closer than about a body width, so what is found there is the
    /// tracked person's other leg, or a false positive at their feet (0: no rule).
    #[config(range = ">= 0")]
    pub spawn_separation_m: f64,
    /// Two confirmed tracks closer than this for `duplicate_after_s` are one person
    /// tracked twice (its legs seen apart): the younger is dropped, m (0: no rule).
    #[config(range = ">= 0")]
    pub duplicate_distance_m: f64,
    /// How long two tracks must stay within `duplicate_distance_m` to be one person, s
    /// (two people passing close by stay that close for a moment only).
    #[config(range = ">= 0")]
    pub duplicate_after_s: f64,
    /// A weak observation (a leg the classifier barely accepts) updates only a
    /// confirmed track updated within `weak_keepalive_s`, or whose prediction is within
    /// `weak_max_offset_m` of it: it keeps a track going through a dark spell, but a
    /// track that has been coasting does not jump to it, since a coasting track's reach
    /// covers a leg-like bush or a bystander's leg as readily as its person's, s.
    #[config(range = ">= 0")]
    pub weak_keepalive_s: f64,
    /// See `weak_keepalive_s`, m.
    #[config(range = ">= 0")]
    pub weak_max_offset_m: f64,
    /// A lone leg, or a camera observation alone for a track the laser has tracked,
    /// updates a track that has not been updated for this long only within
    /// `coast_lone_leg_offset_m` of its prediction, s. A coasting track's reach grows
    /// with the time it has been unseen, and at a realistic scanner's rate of false
    /// positives (a few tenths per scan) one of them falls inside it within a second as
    /// readily as the person's leg; a camera's false box, with its poor range, gates as
    /// easily. Taking it would move the track a metre onto clutter, and the next false
    /// positives carry it off. A leg pair, or the laser and camera together, still take
    /// the track up anywhere in its reach; anything else farther off waits (a person
    /// who reappears away from where their track coasted to starts a new track, which
    /// the target selector vouches for as usual). Camera-only tracking (no laser ever
    /// on the track) is left as it was.
    #[config(range = ">= 0")]
    pub coast_lone_leg_after_s: f64,
    /// See `coast_lone_leg_after_s`, m (0: no such rule).
    #[config(range = ">= 0")]
    pub coast_lone_leg_offset_m: f64,
    /// A track given a lone leg also takes a second lone leg within this distance of
    /// the first that no track was given and no other track explains better, and is
    /// updated with their midpoint (design 5.5, "legs paired by the tracks"), m (0: no
    /// such rule). The detector's own pairing distance (0.6 m): a stride.
    #[config(range = ">= 0")]
    pub pair_lone_legs_within_m: f64,
    /// A lone leg that a confirmed track explains with a cost (`d^2 + ln det S`)
    /// lower by more than this is not given to any other track (design 5.5, "legs
    /// paired by the tracks"; 0: no such rule).
    #[config(range = ">= 0")]
    pub leg_owner_cost_gap: f64,
    /// Match in a cascade: confirmed tracks choose their observations first, and
    /// tentative tracks share what is left (`false`: one assignment of all tracks).
    /// Chosen on the measures (design 5.5): fewer scans on somebody else in the
    /// simulator, the same on the real recordings.
    pub confirmed_first: bool,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            gate: Gate::default(),
            accel_noise: 0.5,
            initial_speed_sigma_mps: 1.0,
            confirm_hits: 3,
            tentative_timeout_s: 0.35,
            max_coast_s: 2.0,
            shadow_margin_m: 0.3,
            shadow_edge_m: 0.1,
            max_position_sigma_m: 1.5,
            max_observation_sigma_m: 3.0,
            laser_update: UpdateRule::Kalman,
            vision_update: UpdateRule::CovarianceIntersection,
            laser_support_s: 0.5,
            vision_min_separation_m: 0.5,
            motion: MotionBounds::default(),
            spawn_separation_m: 0.45,
            duplicate_distance_m: 0.45,
            duplicate_after_s: 0.8,
            weak_keepalive_s: 0.3,
            weak_max_offset_m: 0.5,
            coast_lone_leg_after_s: 0.3,
            coast_lone_leg_offset_m: 0.5,
            pair_lone_legs_within_m: 0.6,
            leg_owner_cost_gap: 6.0,
            confirmed_first: true,
        }
    }
}

/// Why tracker settings are unusable.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("tracker setting `{field}` = {value} is invalid: {why}")]
pub struct TrackerConfigError {
    /// Field name.
    pub field: &'static str,
    /// Offending value.
    pub value: f64,
    /// What it must be.
    pub why: &'static str,
}

impl TrackerConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), TrackerConfigError> {
        let positive = [
            ("gate.threshold", self.gate.threshold),
            ("accel_noise", self.accel_noise),
            ("initial_speed_sigma_mps", self.initial_speed_sigma_mps),
            ("tentative_timeout_s", self.tentative_timeout_s),
            ("max_coast_s", self.max_coast_s),
            ("shadow_margin_m", self.shadow_margin_m),
            ("max_position_sigma_m", self.max_position_sigma_m),
            ("max_observation_sigma_m", self.max_observation_sigma_m),
        ];
        for (field, value) in [
            ("laser_support_s", self.laser_support_s),
            ("shadow_edge_m", self.shadow_edge_m),
            ("vision_min_separation_m", self.vision_min_separation_m),
            ("spawn_separation_m", self.spawn_separation_m),
            ("duplicate_distance_m", self.duplicate_distance_m),
            ("duplicate_after_s", self.duplicate_after_s),
            ("weak_keepalive_s", self.weak_keepalive_s),
            ("weak_max_offset_m", self.weak_max_offset_m),
            ("coast_lone_leg_after_s", self.coast_lone_leg_after_s),
            ("coast_lone_leg_offset_m", self.coast_lone_leg_offset_m),
            ("pair_lone_legs_within_m", self.pair_lone_legs_within_m),
            ("leg_owner_cost_gap", self.leg_owner_cost_gap),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(TrackerConfigError {
                    field,
                    value,
                    why: "must be >= 0",
                });
            }
        }
        for (field, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(TrackerConfigError {
                    field,
                    value,
                    why: "must be a positive number",
                });
            }
        }
        self.motion.validate()?;
        if self.confirm_hits == 0 {
            return Err(TrackerConfigError {
                field: "confirm_hits",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        Ok(())
    }
}

/// A tracked person.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// Identity, unique over the tracker's life.
    pub id: u64,
    /// State estimate.
    pub filter: CvFilter,
    /// Confirmed (seen consistently), as opposed to tentative.
    pub confirmed: bool,
    /// Updates received.
    pub hits: u32,
    /// Creation time.
    pub born: Stamp,
    /// Last update by any observation.
    pub last_update: Stamp,
    /// Last scan in which the track, not updated, was hidden from the laser
    /// ([`Tracker::note_shadow`]).
    pub last_hidden: Option<Stamp>,
    /// Last update by a person coming out of the last scan's shadow while the track
    /// was hidden ([`Observation::from_shadow`], [`Track::hidden_since_update`]): the
    /// person seen again where they went out of sight.
    pub came_out: Option<Stamp>,
    /// Last update by a laser (or fused) observation.
    pub last_laser: Option<Stamp>,
    /// Last update by a vision (or fused) observation.
    pub last_vision: Option<Stamp>,
    /// The track's estimate right after its last update: its last good estimate, from
    /// which a coasting or lost person's whereabouts are bounded.
    pub anchor: Anchor,
    /// Where the track started.
    pub birth_position: Point2<World>,
    /// Farthest the track's updated estimate has been from where it started, m: a
    /// walking person goes places, a post does not.
    pub walked_m: f64,
    /// Updates by a pair of legs.
    pub pair_hits: u32,
    /// Updates by weak observations (legs the classifier barely accepts; not in
    /// `hits`).
    pub weak_hits: u32,
    /// Last update by evidence of a whole person: a pair of legs, or the camera.
    pub last_pair: Option<Stamp>,
    /// The track's estimate right after its last update by evidence of a whole person
    /// (see `last_pair`): a single leg may be a phantom, a bush or somebody else's leg
    /// that a coasting track took, a pair of legs or the camera hardly.
    pub pair_anchor: Option<Anchor>,
    /// Since when this track has stayed within `duplicate_distance_m` of an older
    /// confirmed track.
    pub duplicate_since: Option<Stamp>,
    /// The last track dropped as a second track on this one's person (its id, and
    /// when): the two stayed within `duplicate_distance_m`. Usually this track's own
    /// person's other leg; but when the dropped track was somebody else, this track
    /// may have come onto them, and whoever follows it must check.
    pub merged: Option<(u64, Stamp)>,
}

/// A track's state right after an update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// When.
    pub stamp: Stamp,
    /// Position estimate.
    pub position: Gaussian2<World>,
    /// Velocity, m/s.
    pub velocity: Vector2<World>,
    /// Largest standard deviation of the velocity, m/s.
    pub velocity_sigma_mps: f64,
}

impl Anchor {
    fn of(filter: &CvFilter, stamp: Stamp) -> Self {
        Anchor {
            stamp,
            position: filter.position(),
            velocity: filter.velocity(),
            velocity_sigma_mps: filter
                .velocity_cov()
                .map_or(0.0, |c| c.principal_axes().0.max(0.0).sqrt()),
        }
    }
}

impl Track {
    /// Position estimate.
    pub fn position(&self) -> Gaussian2<World> {
        self.filter.position()
    }

    /// Velocity estimate, m/s.
    pub fn velocity(&self) -> Vector2<World> {
        self.filter.velocity()
    }

    /// Whether the track went behind something since its last update: a scan since
    /// then could not have seen where it is ([`Tracker::note_shadow`]).
    pub fn hidden_since_update(&self) -> bool {
        self.last_hidden.is_some_and(|h| h > self.last_update)
    }

    /// True when both sensors updated the track within `window_s` before `now`.
    pub fn seen_by_both(&self, now: Stamp, window_s: f64) -> bool {
        let recent = |t: Option<Stamp>| t.is_some_and(|t| now.secs_since(t) <= window_s);
        recent(self.last_laser) && recent(self.last_vision)
    }

    /// Whether this track can explain an observation at `z` taken at `now` without an
    /// impossible jump from its last good estimate ([`MotionBounds::reachable`], with
    /// three standard deviations of the anchor's and the observation's positions as the
    /// margin).
    pub fn can_reach(&self, z: &Gaussian2<World>, now: Stamp, bounds: &MotionBounds) -> bool {
        let sd = |c: &tether_core::Cov2| c.principal_axes().0.max(0.0).sqrt();
        let a = &self.anchor;
        bounds.reachable(
            a.position.mean,
            a.velocity,
            a.velocity_sigma_mps,
            now.secs_since(a.stamp),
            3.0 * (sd(&a.position.cov) + sd(&z.cov)),
            z.mean,
        )
    }
}

/// Counters of input the tracker refused.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct TrackerStats {
    /// Batches older than the tracker's clock (out-of-order stamps).
    pub out_of_order_batches: u64,
    /// Observations ignored as non-finite or too uncertain.
    pub rejected_observations: u64,
    /// Observations that updated a track.
    pub associated: u64,
    /// Camera observations left out because several tracks could explain them.
    pub ambiguous_observations: u64,
    /// Tracks started.
    pub tracks_started: u64,
    /// Tracks dropped.
    pub tracks_dropped: u64,
    /// Of those, tracks dropped as a second track on an already tracked person.
    pub duplicates_dropped: u64,
    /// Observations inside a track's statistical gate that it could only reach by an
    /// impossible jump (speed or acceleration beyond [`MotionBounds`]).
    pub implausible_jumps: u64,
    /// Updates that would have left a track faster than the speed bound (its velocity
    /// was clamped).
    pub speed_clamps: u64,
    /// Weak observations that kept a confirmed track alive.
    pub weak_updates: u64,
    /// Second lone legs a track took with its first (design 5.5, "legs paired by the
    /// tracks").
    pub legs_paired_by_tracks: u64,
}

/// The multi-person tracker.
#[derive(Debug, Clone)]
pub struct Tracker {
    config: TrackerConfig,
    tracks: Vec<Track>,
    next_id: u64,
    now: Option<Stamp>,
    stats: TrackerStats,
}

/// What one batch did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchResult {
    /// For each observation, the id of the track it updated or started.
    pub track_of: Vec<Option<u64>>,
    /// False when the whole batch was refused (out of order).
    pub accepted: bool,
}

impl Tracker {
    /// A tracker with checked settings.
    pub fn new(config: TrackerConfig) -> Result<Self, TrackerConfigError> {
        config.validate()?;
        Ok(Tracker {
            config,
            tracks: Vec::new(),
            next_id: 1,
            now: None,
            stats: TrackerStats::default(),
        })
    }

    /// Settings.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// Current tracks (tentative and confirmed), in creation order.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// A track by id.
    pub fn track(&self, id: u64) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Refusal counters.
    pub fn stats(&self) -> TrackerStats {
        self.stats
    }

    /// The tracker's clock: the stamp of the last accepted batch.
    pub fn now(&self) -> Option<Stamp> {
        self.now
    }

    /// Predicts every track to `stamp` (if it is not older than the clock) and drops
    /// stale tracks, without observations.
    pub fn advance(&mut self, stamp: Stamp) -> bool {
        if let Some(now) = self.now
            && stamp < now
        {
            self.stats.out_of_order_batches += 1;
            return false;
        }
        let dt = self.now.map_or(0.0, |now| stamp.secs_since(now));
        for t in &mut self.tracks {
            t.filter.predict(dt, self.config.accel_noise);
        }
        self.now = Some(stamp);
        self.prune(stamp);
        true
    }

    /// Marks each track not updated at `stamp` that `hidden` says the laser could not
    /// see (a [`crate::Shadow`] of the scan taken at `stamp`): its person went behind
    /// something, and may come out of its shadow away from where the track coasted to
    /// ([`Track::hidden_since_update`], [`Observation::from_shadow`]).
    pub fn note_shadow(&mut self, stamp: Stamp, hidden: impl Fn(Point2<World>) -> bool) {
        if self.now != Some(stamp) {
            return;
        }
        for t in &mut self.tracks {
            if t.last_update != stamp && hidden(t.position().mean) {
                t.last_hidden = Some(stamp);
            }
        }
    }

    /// A tentative track that has come within `spawn_separation_m` of a confirmed one
    /// goes, as one would not have started there: it is the person's other leg or
    /// clutter at their feet, and would take the person's returns (design 5.5).
    fn drop_tentative_on_confirmed(&mut self) {
        let sep = self.config.spawn_separation_m;
        if sep <= 0.0 {
            return;
        }
        let confirmed: Vec<Point2<World>> = self
            .tracks
            .iter()
            .filter(|t| t.confirmed)
            .map(|t| t.position().mean)
            .collect();
        let before = self.tracks.len();
        self.tracks.retain(|t| {
            t.confirmed
                || confirmed
                    .iter()
                    .all(|p| p.distance_m(t.position().mean) >= sep)
        });
        self.stats.tracks_dropped += (before - self.tracks.len()) as u64;
    }

    /// Drops the tracks silent too long (tentative ones sooner), non-finite or too
    /// uncertain, then tentative tracks sitting on confirmed ones, then the younger of a
    /// person tracked twice.
    fn prune(&mut self, now: Stamp) {
        self.drop_silent(now);
        self.drop_tentative_on_confirmed();
        self.merge_duplicates(now);
    }

    /// Drops the tracks silent too long, non-finite or too uncertain.
    fn drop_silent(&mut self, now: Stamp) {
        let c = &self.config;
        let max_var = c.max_position_sigma_m * c.max_position_sigma_m;
        let before = self.tracks.len();
        self.tracks.retain(|t| {
            let silent_s = now.secs_since(t.last_update);
            let timeout = if t.confirmed {
                c.max_coast_s
            } else {
                c.tentative_timeout_s
            };
            silent_s <= timeout
                && t.filter.is_finite()
                && t.position().cov.principal_axes().0 <= max_var
        });
        self.stats.tracks_dropped += (before - self.tracks.len()) as u64;
    }

    /// One person tracked twice: the younger of two confirmed tracks that stay closer
    /// than `duplicate_distance_m` for `duplicate_after_s` goes, and the older remembers
    /// the merge.
    fn merge_duplicates(&mut self, now: Stamp) {
        let c = &self.config;
        // Tracks are in creation order, so an older one comes first.
        if c.duplicate_distance_m > 0.0 {
            let positions: Vec<(bool, Point2<World>)> = self
                .tracks
                .iter()
                .map(|t| (t.confirmed, t.position().mean))
                .collect();
            // For each track, the older confirmed track it shadows, if any.
            let shadows: Vec<Option<usize>> = self
                .tracks
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    if !t.confirmed {
                        return None;
                    }
                    positions[..i].iter().position(|(confirmed, p)| {
                        *confirmed && p.distance_m(t.position().mean) < c.duplicate_distance_m
                    })
                })
                .collect();
            let mut merges: Vec<(u64, u64)> = Vec::new();
            for (t, shadow) in self.tracks.iter_mut().zip(&shadows) {
                t.duplicate_since = match shadow {
                    Some(_) => t.duplicate_since.or(Some(now)),
                    None => None,
                };
            }
            for (i, t) in self.tracks.iter().enumerate() {
                if let (Some(since), Some(j)) = (t.duplicate_since, shadows[i])
                    && now.secs_since(since) >= c.duplicate_after_s
                {
                    merges.push((t.id, self.tracks[j].id));
                }
            }
            let before = self.tracks.len();
            self.tracks.retain(|t| {
                t.duplicate_since
                    .is_none_or(|since| now.secs_since(since) < c.duplicate_after_s)
            });
            for (dropped, into) in merges {
                if let Some(t) = self.tracks.iter_mut().find(|t| t.id == into) {
                    t.merged = Some((dropped, now));
                }
            }
            let merged = (before - self.tracks.len()) as u64;
            self.stats.tracks_dropped += merged;
            self.stats.duplicates_dropped += merged;
        }
    }
}

#[cfg(test)]
mod tests;
