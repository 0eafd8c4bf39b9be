//! The target of interest: the one person the robot follows.
//!
//! States: `Searching` (no target yet), `Locked` (following a track), `Lost` (the
//! target's track went silent; re-acquisition is possible). The lock is on a track
//! identity, so crossings and short occlusions are handled by the tracker's
//! association. When the target's track goes silent, the selector predicts where the
//! target should be (constant velocity, uncertainty growing with time) and re-locks
//! only onto a track that is consistent with that prediction *and* unambiguous: if two
//! tracks could be the target, it stays `Lost` (and the robot stops) rather than
//! follow a bystander.

use serde::{Deserialize, Serialize};
use tether_core::{Cov2, Gaussian2, Pose2, Robot, Stamp, Vector2, World, wrap_angle_rad};

use crate::tracker::Track;

/// Target selection settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TargetConfig {
    /// Follow this track id instead of choosing (when it exists).
    pub track_id: Option<u64>,
    /// Only people seen by both sensors within this window can be chosen at start, s.
    pub both_sensors_window_s: f64,
    /// Only a person seen by both sensors can be chosen at start (turn off when one
    /// sensor is absent).
    pub require_both_sensors: bool,
    /// Farthest person that can be chosen at start, m.
    pub max_select_range_m: f64,
    /// Largest bearing off the robot's heading for the choice at start, rad.
    pub max_select_bearing_rad: f64,
    /// The target counts as lost when its track has not been updated for this long, s.
    pub lost_after_s: f64,
    /// Growth of the position uncertainty while lost, m/s (a person can change
    /// direction; standard deviation added per second).
    pub lost_sigma_growth_mps: f64,
    /// Gate for re-acquisition (squared Mahalanobis distance).
    pub reacquire_gate: f64,
    /// After this long lost, the prediction stops moving and growing, s.
    pub max_predict_s: f64,
}

impl Default for TargetConfig {
    fn default() -> Self {
        TargetConfig {
            track_id: None,
            both_sensors_window_s: 1.0,
            require_both_sensors: true,
            max_select_range_m: 4.0,
            max_select_bearing_rad: 0.6,
            lost_after_s: 0.4,
            lost_sigma_growth_mps: 0.5,
            reacquire_gate: crate::gate::CHI2_2DOF_99,
            max_predict_s: 3.0,
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
    /// The target's track went silent at `since`; `last` is its last estimate.
    Lost {
        /// The track that was followed.
        track: u64,
        /// When it went silent.
        since: Stamp,
        /// Its last position estimate.
        last: Gaussian2<World>,
        /// Its last velocity.
        velocity: Vector2<World>,
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
}

/// Counts of what the selector did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct TargetStats {
    /// Times the target was lost.
    pub losses: u64,
    /// Times it was re-acquired (same or another track id).
    pub reacquisitions: u64,
    /// Times re-acquisition was refused because two tracks could be the target.
    pub ambiguous: u64,
}

/// Chooses and keeps the target.
#[derive(Debug, Clone)]
pub struct TargetSelector {
    config: TargetConfig,
    state: TargetState,
    stats: TargetStats,
    /// The locked track's last estimate, velocity and update time, kept in case the
    /// tracker drops the track between two calls.
    last_seen: Option<(Gaussian2<World>, Vector2<World>, Stamp)>,
}

impl TargetSelector {
    /// A selector in the `Searching` state.
    pub fn new(config: TargetConfig) -> Self {
        TargetSelector {
            config,
            state: TargetState::Searching,
            stats: TargetStats::default(),
            last_seen: None,
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

    /// The predicted target position `dt` after it was lost.
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
        let dt = now.secs_since(since).clamp(0.0, self.config.max_predict_s);
        let grow = (self.config.lost_sigma_growth_mps * dt).powi(2);
        let mean = last.mean + velocity * dt;
        let cov = Cov2::new(last.cov.xx() + grow, last.cov.xy(), last.cov.yy() + grow)
            .unwrap_or(last.cov);
        Some(Gaussian2 { mean, cov })
    }

    /// Updates the state from the current tracks; `world_from_robot` is the robot's pose
    /// at `now`. Every person is taken to be in the camera's view (see
    /// [`TargetSelector::update_with_view`]).
    pub fn update(
        &mut self,
        now: Stamp,
        tracks: &[Track],
        world_from_robot: Pose2<World, Robot>,
    ) -> TargetState {
        self.update_with_view(now, tracks, world_from_robot, &|_| true)
    }

    /// Like [`TargetSelector::update`], with `camera_sees` telling whether a point is in
    /// the camera's field of view: a lost target that reappears outside it can be
    /// re-acquired by the laser alone, while inside it the camera must vouch too.
    pub fn update_with_view(
        &mut self,
        now: Stamp,
        tracks: &[Track],
        world_from_robot: Pose2<World, Robot>,
        camera_sees: &dyn Fn(tether_core::Point2<World>) -> bool,
    ) -> TargetState {
        let fresh = |t: &Track| now.secs_since(t.last_update) <= self.config.lost_after_s;
        self.state = match self.state {
            TargetState::Searching => self.choose(now, tracks, world_from_robot),
            TargetState::Locked { track } => match tracks.iter().find(|t| t.id == track) {
                Some(t) if fresh(t) => {
                    self.last_seen = Some((t.position(), t.velocity(), t.last_update));
                    TargetState::Locked { track }
                }
                Some(t) => {
                    self.stats.losses += 1;
                    TargetState::Lost {
                        track,
                        since: t.last_update,
                        last: t.position(),
                        velocity: t.velocity(),
                    }
                }
                None => {
                    // Dropped between two calls: fall back on what it was last seen as.
                    self.stats.losses += 1;
                    let (last, velocity, since) = self.last_seen.unwrap_or((
                        Gaussian2 {
                            mean: world_from_robot.translation(),
                            cov: Cov2::IDENTITY,
                        },
                        Vector2::ZERO,
                        now,
                    ));
                    TargetState::Lost {
                        track,
                        since,
                        last,
                        velocity,
                    }
                }
            },
            TargetState::Lost { track, .. } => {
                // While lost, a track only counts if both sensors vouch for it again (when
                // both are in use): a coasting track can latch onto a pillar or a table
                // leg that the camera would never call a person.
                let window = self.config.both_sensors_window_s;
                let vouched = |t: &Track| {
                    !self.config.require_both_sensors
                        || t.seen_by_both(now, window)
                        || !camera_sees(t.position().mean)
                };
                // The same track came back: the tracker kept its identity.
                if tracks
                    .iter()
                    .any(|t| t.id == track && fresh(t) && vouched(t))
                {
                    self.stats.reacquisitions += 1;
                    TargetState::Locked { track }
                } else if let Some(predicted) = self.lost_prediction(now) {
                    let candidates: Vec<&Track> = tracks
                        .iter()
                        .filter(|t| t.confirmed && fresh(t) && vouched(t))
                        .filter(|t| {
                            let p = t.position();
                            let s = predicted.cov.add(&p.cov);
                            s.mahalanobis_sq(
                                p.mean.x - predicted.mean.x,
                                p.mean.y - predicted.mean.y,
                            ) < self.config.reacquire_gate
                        })
                        .collect();
                    match candidates.as_slice() {
                        [one]
                            if one.born >= self.lost_since().unwrap_or(now) || one.id == track =>
                        {
                            self.stats.reacquisitions += 1;
                            TargetState::Locked { track: one.id }
                        }
                        [] | [_] => self.state,
                        _ => {
                            self.stats.ambiguous += 1;
                            self.state
                        }
                    }
                } else {
                    self.state
                }
            }
        };
        self.state
    }

    fn lost_since(&self) -> Option<Stamp> {
        match self.state {
            TargetState::Lost { since, .. } => Some(since),
            _ => None,
        }
    }

    fn choose(
        &self,
        now: Stamp,
        tracks: &[Track],
        world_from_robot: Pose2<World, Robot>,
    ) -> TargetState {
        let c = &self.config;
        if let Some(id) = c.track_id {
            return if tracks.iter().any(|t| t.id == id) {
                TargetState::Locked { track: id }
            } else {
                TargetState::Searching
            };
        }
        let robot_from_world = world_from_robot.inverse();
        tracks
            .iter()
            .filter(|t| t.confirmed && now.secs_since(t.last_update) <= c.lost_after_s)
            .filter(|t| !c.require_both_sensors || t.seen_by_both(now, c.both_sensors_window_s))
            .filter_map(|t| {
                let p = robot_from_world * t.position().mean;
                let bearing = wrap_angle_rad(p.bearing_rad()).abs();
                (p.range_m() <= c.max_select_range_m && bearing <= c.max_select_bearing_rad)
                    .then_some((bearing, t.id))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map_or(TargetState::Searching, |(_, id)| TargetState::Locked {
                track: id,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kalman::CvFilter;
    use tether_core::Point2;

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
        }
    }

    fn at(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    #[test]
    fn chooses_the_person_seen_by_both_sensors_nearest_the_heading() {
        let mut s = TargetSelector::new(TargetConfig::default());
        let tracks = [
            track(1, 2.0, 0.8, 0, true),
            track(2, 2.0, 0.1, 0, false),
            track(3, 3.0, -0.2, 0, true),
        ];
        let state = s.update(at(0), &tracks, Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(3));
    }

    #[test]
    fn lost_target_is_reacquired_only_when_unambiguous() {
        let mut s = TargetSelector::new(TargetConfig::default());
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        // The track goes silent: lost.
        let state = s.update(at(1000), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        // Two new tracks near the prediction: ambiguous, stay lost.
        let mut a = track(7, 2.1, 0.0, 1100, true);
        let mut b = track(8, 1.9, 0.1, 1100, true);
        a.born = at(1050);
        b.born = at(1050);
        let state = s.update(at(1100), &[a.clone(), b], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { .. }));
        assert_eq!(s.stats().ambiguous, 1);
        // One new track near the prediction: re-acquired.
        let state = s.update(at(1200), &[a], Pose2::IDENTITY);
        assert_eq!(state.locked_track(), Some(7));
    }

    #[test]
    fn a_far_bystander_is_never_taken_for_the_target() {
        let mut s = TargetSelector::new(TargetConfig::default());
        s.update(at(0), &[track(1, 2.0, 0.0, 0, true)], Pose2::IDENTITY);
        let mut bystander = track(2, 6.0, 3.0, 900, true);
        bystander.born = at(800);
        s.update(at(900), &[bystander.clone()], Pose2::IDENTITY);
        let state = s.update(at(1500), &[bystander], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
    }

    #[test]
    fn an_old_bystander_near_the_target_does_not_inherit_the_lock() {
        // A person who was already tracked before the loss is someone else.
        let mut s = TargetSelector::new(TargetConfig::default());
        let other = track(2, 2.5, 0.3, 0, true);
        s.update(
            at(0),
            &[track(1, 2.0, 0.0, 0, true), other.clone()],
            Pose2::IDENTITY,
        );
        let mut other_now = other;
        other_now.last_update = at(1000);
        let state = s.update(at(1000), &[other_now.clone()], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
        let state = s.update(at(1100), &[other_now], Pose2::IDENTITY);
        assert!(matches!(state, TargetState::Lost { track: 1, .. }));
    }
}
