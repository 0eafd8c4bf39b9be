//! Finding the target (design 5.6): the first choice, a restart, and re-acquisition of
//! a lost target.

use super::eligible::Question;
use super::memory::Lost;
use super::{LostStep, Refusal, TargetSelector, Tick, View};
use crate::tracker::Track;
use tether_core::{Point2, Robot, Stamp, wrap_angle_rad};

impl TargetSelector {
    /// One step of `Lost`: the lost track itself back, exactly one candidate
    /// re-acquired, several an ambiguity (the robot waits), none a restart when it is
    /// time. Every track not taken is refused with its reason.
    pub(super) fn step_lost(&mut self, l: &mut Lost, tick: &Tick) -> LostStep {
        let (now, tracks, view) = (tick.now, tick.tracks, tick.view);
        let mut candidates = Vec::new();
        let considered: Vec<&Track> = tracks
            .iter()
            .filter(|t| self.considered(&Question::Reacquire { lost: l }, t, now))
            .collect();
        for t in considered {
            let refusal = if t.id == l.track {
                match self.own_track_refusal(l, t, now, view) {
                    None => return LostStep::Reacquire(t.id),
                    Some(r) => r,
                }
            } else {
                match self.may_be_target(&Question::Reacquire { lost: l }, t, now, view) {
                    Ok(()) => {
                        candidates.push(t.id);
                        continue;
                    }
                    Err(r) => r,
                }
            };
            self.refuse(l, t, refusal);
        }
        match candidates.as_slice() {
            [one] => LostStep::Reacquire(*one),
            [] => self
                .restart(now, l, tracks, view)
                .map_or(LostStep::Stay, LostStep::Restart),
            several => {
                for &id in several {
                    self.refusals_now.push((id, Refusal::Ambiguous));
                }
                if l.ambiguous_sets.insert(several.to_vec()) {
                    self.stats.ambiguous += 1;
                }
                LostStep::Stay
            }
        }
    }

    /// Why the lost target's own track `t` is not taken back (`None`: it is). Not when
    /// led off onto somebody else (that track is theirs now). The tracker kept its
    /// identity: back, if it is still where the target could be (a track that ran off
    /// after something else is not), and shows the person again: a whole person (a pair
    /// of legs, the camera) or two updates since the loss, or one that came out of the
    /// shadow it went into ([`Track::came_out`]; kept only if the next scans confirm
    /// it, see `step_locked`). A coasting track's reach is wide; one false positive in
    /// it (a phantom return, a bystander's leg) must not bring the lock back onto a
    /// track that has lost its person. Nor does the camera
    /// alone bring it back while the laser, in use and seeing the place, has not seen it
    /// since the loss: a false box gates with a track that coasted off as readily as the
    /// person does, and the laser finds a person it can see.
    fn own_track_refusal(&self, l: &Lost, t: &Track, now: Stamp, view: &View) -> Option<Refusal> {
        if l.others.contains_key(&t.id) {
            return Some(Refusal::SomebodyElse);
        }
        if let Some((hits, last_pair)) = l.evidence
            && t.came_out != Some(t.last_update)
            && t.hits < hits + 2
            && t.last_pair <= last_pair
        {
            return Some(Refusal::NoNewEvidence);
        }
        if view.laser_in_use
            && (view.laser_sees)(t.position().mean)
            && t.last_laser.is_none_or(|last| last <= l.from.stamp)
        {
            return Some(Refusal::NotSeenByLaser);
        }
        let p = t.position();
        let sd = p.cov.principal_axes().0.max(0.0).sqrt();
        (!self.reachable_from(&l.from, p.mean, sd, now)).then_some(Refusal::OutOfReach)
    }

    /// Lost for `restart_after_s`: the target taken up again as at the start, by the
    /// one track that has stood alone in the start's window for `restart_dwell_s`.
    pub(super) fn restart(
        &self,
        now: Stamp,
        l: &mut Lost,
        tracks: &[Track],
        view: &View,
    ) -> Option<u64> {
        let c = &self.config;
        if c.restart_after_s <= 0.0 || now.secs_since(l.from.stamp) < c.restart_after_s {
            l.presented = None;
            return None;
        }
        let robot_from_world = view.world_from_robot.inverse();
        let in_front: Vec<&Track> = self
            .eligible_at_start(now, tracks, view)
            .into_iter()
            .filter(|t| self.in_start_window(robot_from_world * t.position().mean))
            .collect();
        let [one] = in_front.as_slice() else {
            l.presented = None;
            return None;
        };
        let from = match l.presented {
            Some((p, from)) if p == one.id => from,
            _ => {
                l.presented = Some((one.id, now));
                now
            }
        };
        if now.secs_since(from) < c.restart_dwell_s {
            return None;
        }
        l.presented = None;
        Some(one.id)
    }

    /// Whether `p` (robot frame) is where the target is chosen at the start: within
    /// `max_select_range_m` and `max_select_bearing_rad` of the heading.
    pub(super) fn in_start_window(&self, p: Point2<Robot>) -> bool {
        p.range_m() <= self.config.max_select_range_m
            && wrap_angle_rad(p.bearing_rad()).abs() <= self.config.max_select_bearing_rad
    }

    /// The tracks that could be chosen at the start ([`Question::Start`]).
    pub(super) fn eligible_at_start<'t>(
        &self,
        now: Stamp,
        tracks: &'t [Track],
        view: &View,
    ) -> Vec<&'t Track> {
        let q = Question::Start;
        tracks
            .iter()
            .filter(|t| self.considered(&q, t, now) && self.may_be_target(&q, t, now, view).is_ok())
            .collect()
    }

    /// The track chosen at the start, if one is: the user's track id, else the
    /// eligible track nearest the user's point, else the eligible track in the start
    /// window nearest the heading.
    pub(super) fn choose(&self, now: Stamp, tracks: &[Track], view: &View) -> Option<u64> {
        let c = &self.config;
        if let Some(id) = c.track_id {
            return tracks.iter().find(|t| t.id == id).map(|t| t.id);
        }
        let robot_from_world = view.world_from_robot.inverse();
        let eligible = self
            .eligible_at_start(now, tracks, view)
            .into_iter()
            .map(|t| (robot_from_world * t.position().mean, t));
        let chosen = match c.near_point_m {
            Some([x, y]) => {
                let point = Point2::<Robot>::new(x, y);
                eligible
                    .map(|(p, t)| (p.distance_m(point), t))
                    .filter(|(d, _)| *d <= c.near_point_radius_m)
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id)))
            }
            None => eligible
                .filter(|(p, _)| self.in_start_window(*p))
                .map(|(p, t)| (wrap_angle_rad(p.bearing_rad()).abs(), t))
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.id.cmp(&b.1.id))),
        };
        chosen.map(|(_, t)| t.id)
    }
}
