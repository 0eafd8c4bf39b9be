//! Finding the target (design 5.6): the first choice, a restart, and re-acquisition of
//! a lost target.

use super::{Refusal, TargetSelector, TargetState, View};
use crate::tracker::Track;
use tether_core::{Point2, Robot, Stamp, wrap_angle_rad};

impl TargetSelector {
    pub(super) fn reacquire(
        &mut self,
        now: Stamp,
        track: u64,
        since: Stamp,
        tracks: &[Track],
        view: &View,
    ) -> TargetState {
        let lost_after_s = self.config.lost_after_s;
        let fresh = |t: &Track| now.secs_since(t.last_update) <= lost_after_s;
        let mut candidates = Vec::new();
        for t in tracks.iter().filter(|t| t.confirmed && fresh(t)) {
            if t.id == track && self.others_at_loss.contains(&t.id) {
                // Led off onto somebody else: that track is theirs now.
                self.refuse(t.id, Refusal::SomebodyElse);
                continue;
            }
            if t.id == track {
                // The tracker kept its identity: back, if it is still where the target
                // could be (a track that ran off after something else is not), and
                // shows the person again: a whole person (a pair of legs, the camera)
                // or two updates since the loss. A coasting track's reach is wide; one
                // false positive in it (a phantom return, a bystander's leg) must not
                // bring the lock back onto a track that has lost its person.
                if let Some((id, hits, last_pair)) = self.evidence_at_loss
                    && id == track
                    && t.hits < hits + 2
                    && t.last_pair <= last_pair
                {
                    self.refuse(t.id, Refusal::NoNewEvidence);
                    continue;
                }
                // Nor does the camera alone bring it back while the laser, in use and
                // seeing the place, has not seen it since the loss: a false box gates
                // with a track that coasted off as readily as the person does, and
                // the laser finds a person it can see.
                if view.laser_in_use
                    && (view.laser_sees)(t.position().mean)
                    && t.last_laser.is_none_or(|l| l <= since)
                {
                    self.refuse(t.id, Refusal::NotSeenByLaser);
                    continue;
                }
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
            [] => self.restart(now, tracks, view).unwrap_or(self.state),
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

    /// Lost for `restart_after_s`: the target taken up again as at the start, by the
    /// one track that has stood alone in the start's window for `restart_dwell_s`.
    pub(super) fn restart(
        &mut self,
        now: Stamp,
        tracks: &[Track],
        view: &View,
    ) -> Option<TargetState> {
        let c = &self.config;
        let TargetState::Lost { since, .. } = self.state else {
            return None;
        };
        if c.restart_after_s <= 0.0 || now.secs_since(since) < c.restart_after_s {
            self.presented = None;
            return None;
        }
        let robot_from_world = view.world_from_robot.inverse();
        let in_front: Vec<&Track> = self
            .eligible_at_start(now, tracks, view)
            .into_iter()
            .filter(|t| self.in_start_window(robot_from_world * t.position().mean))
            .collect();
        let one = match in_front.as_slice() {
            [t] => *t,
            _ => {
                self.presented = None;
                return None;
            }
        };
        let (id, anchor) = (one.id, one.anchor);
        let from = match self.presented {
            Some((p, from)) if p == id => from,
            _ => {
                self.presented = Some((id, now));
                now
            }
        };
        if now.secs_since(from) < self.config.restart_dwell_s {
            return None;
        }
        self.presented = None;
        self.stats.restarts += 1;
        self.stats.locks += 1;
        self.last_good = Some(anchor);
        Some(TargetState::Locked { track: id })
    }

    /// Whether `p` (robot frame) is where the target is chosen at the start: within
    /// `max_select_range_m` and `max_select_bearing_rad` of the heading.
    pub(super) fn in_start_window(&self, p: Point2<Robot>) -> bool {
        p.range_m() <= self.config.max_select_range_m
            && wrap_angle_rad(p.bearing_rad()).abs() <= self.config.max_select_bearing_rad
    }

    /// The tracks that could be chosen at the start: confirmed, fresh and vouched for
    /// (seen by both sensors, or by the laser as a pair of legs outside static clutter).
    pub(super) fn eligible_at_start<'t>(
        &self,
        now: Stamp,
        tracks: &'t [Track],
        view: &View,
    ) -> Vec<&'t Track> {
        let c = &self.config;
        tracks
            .iter()
            .filter(|t| t.confirmed && now.secs_since(t.last_update) <= c.lost_after_s)
            .filter(|t| {
                if c.require_both_sensors {
                    t.seen_by_both(now, c.both_sensors_window_s)
                } else if view.laser_in_use {
                    // The user stands in front of the robot to start: a pair of legs
                    // outside static clutter, walking or not.
                    self.laser_refusal(t, view, false).is_none()
                } else {
                    true
                }
            })
            .collect()
    }

    pub(super) fn choose(&mut self, now: Stamp, tracks: &[Track], view: &View) -> TargetState {
        let c = &self.config;
        let chosen = if let Some(id) = c.track_id {
            tracks.iter().find(|t| t.id == id)
        } else {
            let robot_from_world = view.world_from_robot.inverse();
            let eligible = self
                .eligible_at_start(now, tracks, view)
                .into_iter()
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
                    .filter(|(p, _)| self.in_start_window(*p))
                    .map(|(p, t)| (wrap_angle_rad(p.bearing_rad()).abs(), t))
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
