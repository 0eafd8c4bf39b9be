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
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionBounds {
    /// Highest speed of a person, m/s.
    pub max_speed_mps: f64,
    /// Highest sustained acceleration of a person, m/s^2.
    pub max_accel_mps2: f64,
    /// The region a coasting track takes observations from grows by at most this
    /// beyond its estimate's own uncertainty, m: a track silent for long is more
    /// likely lost than far away.
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
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackerConfig {
    /// Association gate on the innovation's squared Mahalanobis distance.
    pub gate: Gate,
    /// Spectral density of the white-noise acceleration, m^2/s^3 (how briskly people
    /// change velocity).
    pub accel_noise: f64,
    /// Velocity uncertainty of a new track, m/s.
    pub initial_speed_sigma_mps: f64,
    /// Updates that confirm a tentative track.
    pub confirm_hits: u32,
    /// A tentative track not updated for this long is dropped, s.
    pub tentative_timeout_s: f64,
    /// A confirmed track not updated for this long is dropped, s.
    pub max_coast_s: f64,
    /// A return hides what lies more than this behind it ([`crate::Shadow`]), m.
    pub shadow_margin_m: f64,
    /// A track whose position standard deviation exceeds this is dropped, m.
    pub max_position_sigma_m: f64,
    /// Observations with a position standard deviation above this are ignored, m.
    pub max_observation_sigma_m: f64,
    /// How laser (and fused) observations update tracks.
    pub laser_update: UpdateRule,
    /// How vision observations update tracks that lack recent laser support.
    pub vision_update: UpdateRule,
    /// A track updated by the laser within this long takes only the bearing of a
    /// vision observation, s (0: always the full position).
    pub laser_support_s: f64,
    /// A camera observation updates no track that another confirmed track is closer to
    /// than this, m (0: no such rule). Two people closer than about a body width (0.5 m)
    /// overlap in the image: the box, and the range the monocular model reads from it,
    /// may be either one's or both merged, and giving it to the wrong track at a crossing
    /// drags that track onto the other person; the laser, which resolves their legs,
    /// updates them alone until they part.
    pub vision_min_separation_m: f64,
    /// What people can do: the physical gate of every track.
    pub motion: MotionBounds,
    /// No new track starts closer than this to a confirmed track, m: two people's
    /// centres are never closer than about a body width, so what is found there is the
    /// tracked person's other leg, or a false positive at their feet (0: no rule).
    pub spawn_separation_m: f64,
    /// Two confirmed tracks closer than this for `duplicate_after_s` are one person
    /// tracked twice (its legs seen apart): the younger is dropped, m (0: no rule).
    pub duplicate_distance_m: f64,
    /// How long two tracks must stay within `duplicate_distance_m` to be one person, s
    /// (two people passing close by stay that close for a moment only).
    pub duplicate_after_s: f64,
    /// A weak observation (a leg the classifier barely accepts) updates only a
    /// confirmed track updated within `weak_keepalive_s`, or whose prediction is within
    /// `weak_max_offset_m` of it: it keeps a track going through a dark spell, but a
    /// track that has been coasting does not jump to it, since a coasting track's reach
    /// covers a leg-like bush or a bystander's leg as readily as its person's, s.
    pub weak_keepalive_s: f64,
    /// See `weak_keepalive_s`, m.
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
    pub coast_lone_leg_after_s: f64,
    /// See `coast_lone_leg_after_s`, m (0: no such rule).
    pub coast_lone_leg_offset_m: f64,
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
            ("vision_min_separation_m", self.vision_min_separation_m),
            ("spawn_separation_m", self.spawn_separation_m),
            ("duplicate_distance_m", self.duplicate_distance_m),
            ("duplicate_after_s", self.duplicate_after_s),
            ("weak_keepalive_s", self.weak_keepalive_s),
            ("weak_max_offset_m", self.weak_max_offset_m),
            ("coast_lone_leg_after_s", self.coast_lone_leg_after_s),
            ("coast_lone_leg_offset_m", self.coast_lone_leg_offset_m),
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
mod tests {
    use super::*;
    use tether_core::Cov2;

    fn obs(x: f64, y: f64, source: Source) -> Observation {
        Observation {
            source,
            estimate: Gaussian2::new(Point2::new(x, y), Cov2::isotropic(0.05).unwrap()).unwrap(),
            may_spawn: true,
            bearing: None,
            leg_pair: source != Source::Vision,
            weak: false,
            from_shadow: false,
        }
    }

    fn at(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    #[test]
    fn two_walkers_keep_their_identities_through_a_crossing() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        let mut ids = None;
        for k in 0..60 {
            let t = k as f64 * 0.1;
            // A walks +x along y = 0, B walks +y along x = 3: they cross at t = 3 s.
            let a = obs(t, 0.0, Source::Laser);
            let b = obs(3.0, t - 3.0, Source::Laser);
            let r = tr.process(at(100 * k), &[a, b]);
            if k == 10 {
                ids = Some((r.track_of[0].unwrap(), r.track_of[1].unwrap()));
            }
            if let Some((ia, ib)) = ids {
                assert_eq!(r.track_of, vec![Some(ia), Some(ib)], "at t = {t}");
            }
        }
        assert_eq!(tr.tracks().len(), 2);
        assert!(tr.tracks().iter().all(|t| t.confirmed));
        let a = tr.track(ids.unwrap().0).unwrap();
        assert!((a.velocity().x - 1.0).abs() < 0.1);
    }

    #[test]
    fn a_tentative_track_that_comes_onto_a_confirmed_one_goes() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        // A person standing at (1, 0), confirmed; a phantom track starts 0.6 m from them
        // and takes a return 0.35 m from them, where no track would have started.
        for k in 0..5 {
            tr.process(at(100 * k), &[obs(1.0, 0.0, Source::Laser)]);
        }
        let person = tr.tracks()[0].id;
        let r = tr.process(
            at(500),
            &[obs(1.0, 0.0, Source::Laser), obs(1.0, 0.6, Source::Laser)],
        );
        let phantom = r.track_of[1].unwrap();
        tr.process(at(600), &[obs(1.0, 0.0, Source::Laser)]);
        let r = tr.process(
            at(700),
            &[obs(1.0, 0.0, Source::Laser), obs(1.0, 0.35, Source::Laser)],
        );
        assert_eq!(r.track_of, vec![Some(person), Some(phantom)]);
        let t = tr.track(phantom).unwrap();
        assert!(!t.confirmed && t.position().mean.distance_m(Point2::new(1.0, 0.0)) < 0.45);
        let before = tr.stats().tracks_dropped;
        // Tracks are pruned as the next batch comes in.
        tr.process(at(800), &[obs(1.0, 0.0, Source::Laser)]);
        assert!(tr.track(phantom).is_none());
        assert_eq!(tr.stats().tracks_dropped, before + 1);
        assert_eq!(tr.tracks().len(), 1);
    }

    #[test]
    fn a_track_dropped_as_a_duplicate_is_recorded_on_the_one_it_merged_into() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        // One person at x = 1 walking +y; from 0.5 s a second track starts 0.6 m
        // beside it (out of its gate) and comes within 0.3 m of it, walking with it
        // (the person's legs tracked apart).
        let mut second = None;
        for k in 0..30 {
            let y = k as f64 * 0.1;
            let mut o = vec![obs(1.0, y, Source::Laser)];
            if k >= 5 {
                let dx = if k < 10 { 0.6 } else { 0.3 };
                o.push(obs(1.0 + dx, y, Source::Laser));
            }
            let r = tr.process(at(100 * k), &o);
            if k == 5 {
                second = r.track_of[1];
            }
        }
        let second = second.unwrap();
        assert!(tr.track(second).is_none(), "the duplicate is dropped");
        assert_eq!(tr.stats().duplicates_dropped, 1);
        let first = &tr.tracks()[0];
        assert!(
            matches!(first.merged, Some((id, _)) if id == second),
            "{:?}",
            first.merged
        );
    }

    #[test]
    fn camera_leaves_people_closer_than_a_body_width_to_the_laser() {
        // Two confirmed tracks, `gap` apart; a camera observation on the first.
        let hits_after_camera = |gap: f64| {
            let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
            for k in 0..5 {
                tr.process(
                    at(100 * k),
                    &[obs(2.0, 0.0, Source::Laser), obs(2.0, gap, Source::Laser)],
                );
            }
            let before = tr.stats().ambiguous_observations;
            let r = tr.process(at(550), &[obs(2.0, -0.05, Source::Vision)]);
            (
                r.track_of[0].is_some(),
                tr.stats().ambiguous_observations - before,
            )
        };
        assert_eq!(
            hits_after_camera(0.4),
            (false, 1),
            "too close: left to the laser"
        );
        assert_eq!(
            hits_after_camera(1.0),
            (true, 0),
            "apart: the camera updates"
        );
        let c = TrackerConfig {
            vision_min_separation_m: -0.5,
            ..TrackerConfig::default()
        };
        assert!(c.validate().is_err());
    }

    #[test]
    fn tentative_noise_dies_and_confirmed_tracks_coast() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        tr.process(at(0), &[obs(5.0, 5.0, Source::Laser)]);
        assert_eq!(tr.tracks().len(), 1);
        assert!(!tr.tracks()[0].confirmed);
        tr.process(at(1000), &[]);
        assert!(tr.tracks().is_empty(), "a single false alarm is forgotten");
        for k in 0..5 {
            tr.process(at(1100 + 100 * k), &[obs(1.0, 1.0, Source::Laser)]);
        }
        assert!(tr.tracks()[0].confirmed);
        tr.process(at(2500), &[]);
        assert_eq!(tr.tracks().len(), 1, "coasts through a short gap");
        tr.process(at(4000), &[]);
        assert!(tr.tracks().is_empty(), "dropped after max_coast_s");
    }

    #[test]
    fn out_of_order_and_bad_observations_are_counted_not_used() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        tr.process(at(1000), &[obs(1.0, 1.0, Source::Laser)]);
        let r = tr.process(at(900), &[obs(1.0, 1.0, Source::Laser)]);
        assert!(!r.accepted);
        assert_eq!(tr.stats().out_of_order_batches, 1);
        let mut wide = obs(1.0, 1.0, Source::Vision);
        wide.estimate.cov = Cov2::isotropic(50.0).unwrap();
        tr.process(at(1100), &[wide]);
        assert_eq!(tr.stats().rejected_observations, 1);
        assert_eq!(tr.tracks().len(), 1);
        assert_eq!(tr.tracks()[0].hits, 1);
    }

    #[test]
    fn fused_and_single_sensor_observations_mark_their_sensors() {
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        tr.process(at(0), &[obs(2.0, 0.0, Source::Laser)]);
        tr.process(at(50), &[obs(2.0, 0.0, Source::Vision)]);
        let t = &tr.tracks()[0];
        assert!(t.seen_by_both(at(50), 0.5));
        assert!(!t.seen_by_both(at(2000), 0.5));
    }

    #[test]
    fn refuses_bad_settings() {
        let c = TrackerConfig {
            accel_noise: -1.0,
            ..TrackerConfig::default()
        };
        assert!(Tracker::new(c).is_err());
        let c = TrackerConfig {
            confirm_hits: 0,
            ..TrackerConfig::default()
        };
        assert!(Tracker::new(c).is_err());
    }

    #[test]
    fn a_weak_leg_keeps_a_track_but_does_not_pull_a_coasting_one_across() {
        let g =
            |x: f64| Gaussian2::new(Point2::new(x, 0.0), Cov2::isotropic(0.01).unwrap()).unwrap();
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        for ms in [0, 100, 200, 300] {
            tr.process(at(ms), &[Observation::laser(g(2.0), true, false)]);
        }
        assert!(tr.tracks()[0].confirmed);
        // Silent for 0.5 s: a strong observation 0.8 m on is taken (a person can be
        // there), a weak one is not (a leg-like bush is as likely)...
        let mut strong = tr.clone();
        let r = strong.process(at(800), &[Observation::laser(g(2.8), true, false)]);
        assert!(r.track_of[0].is_some(), "{r:?}");
        let r = tr.process(at(800), &[Observation::weak_laser(g(2.8))]);
        assert_eq!(r.track_of, vec![None]);
        // ...but a weak leg where the track is predicted keeps it going.
        let r = tr.process(at(900), &[Observation::weak_laser(g(2.1))]);
        assert!(r.track_of[0].is_some(), "{r:?}");
        assert_eq!(tr.tracks()[0].weak_hits, 1);
    }

    #[test]
    fn a_coasting_track_is_taken_far_off_only_by_a_whole_person() {
        let g =
            |x: f64| Gaussian2::new(Point2::new(x, 0.0), Cov2::isotropic(0.04).unwrap()).unwrap();
        let mut tr = Tracker::new(TrackerConfig::default()).unwrap();
        for ms in [0, 100, 200, 300] {
            tr.process(at(ms), &[Observation::laser(g(2.0), true, false)]);
        }
        let id = tr.tracks()[0].id;
        // Unseen for 0.5 s, then something 0.65 m from where the track stands, within
        // its reach: a pair of legs or the laser and camera together take the track
        // there...
        let lone = Observation::laser(g(2.65), false, true);
        let pair = Observation::laser(g(2.65), true, false);
        let camera = Observation::vision(g(2.65), false, None);
        let fused = Observation {
            source: Source::Fused,
            ..camera
        };
        for (o, taken) in [
            (&pair, true),
            (&fused, true),
            (&lone, false),
            (&camera, false),
        ] {
            let mut t = tr.clone();
            let r = t.process(at(800), std::slice::from_ref(o));
            assert_eq!(r.track_of[0] == Some(id), taken, "{o:?}: {r:?}");
        }
        // ...and a lone leg near the prediction updates it as before.
        let mut t = tr.clone();
        let r = t.process(at(800), &[Observation::laser(g(2.3), false, true)]);
        assert_eq!(r.track_of[0], Some(id));
        // Off by the rule: the far lone leg is taken as before.
        let mut t = Tracker::new(TrackerConfig {
            coast_lone_leg_offset_m: 0.0,
            ..TrackerConfig::default()
        })
        .unwrap();
        for ms in [0, 100, 200, 300] {
            t.process(at(ms), &[Observation::laser(g(2.0), true, false)]);
        }
        let r = t.process(at(800), std::slice::from_ref(&lone));
        assert_eq!(r.track_of[0], Some(t.tracks()[0].id));
        // A far lone leg that does not take the track starts a tentative one instead
        // of vanishing.
        let mut t = tr.clone();
        t.process(at(800), &[lone]);
        assert!(
            t.tracks().iter().any(|u| u.id != id && !u.confirmed),
            "{:?}",
            t.tracks()
        );
        // Camera-only tracking (the laser never on the track) keeps taking the camera.
        let mut cam = Tracker::new(TrackerConfig::default()).unwrap();
        for ms in [0, 100, 200, 300] {
            cam.process(at(ms), &[Observation::vision(g(2.0), true, None)]);
        }
        let r = cam.process(at(800), &[Observation::vision(g(2.65), true, None)]);
        assert_eq!(r.track_of[0], Some(cam.tracks()[0].id));
    }
}
