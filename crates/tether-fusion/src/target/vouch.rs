//! Whether a track may be the target (design 11.4): the refusals of a lost target's
//! candidates, and what the sensors must have seen of a track to vouch for it.

use super::memory::Lost;
use super::{Refusal, TargetSelector, View};
use crate::tracker::Track;
use tether_core::Stamp;

impl TargetSelector {
    /// Why `t` cannot be the target lost in `l`, if it cannot (`None`: a candidate).
    pub(super) fn refusal(&self, l: &Lost, t: &Track, now: Stamp, view: &View) -> Option<Refusal> {
        let p = t.position();
        let sd = p.cov.principal_axes().0.max(0.0).sqrt();
        if !self.reachable_from(&l.from, p.mean, sd, now) {
            return Some(Refusal::OutOfReach);
        }
        if l.others.contains(&t.id) || self.notes_of(t.id).elsewhere {
            return Some(Refusal::SomebodyElse);
        }
        self.vouching_refusal(t, now, view)
    }

    /// Why the sensors do not vouch for `t` as the target taken up again.
    pub(super) fn vouching_refusal(&self, t: &Track, now: Stamp, view: &View) -> Option<Refusal> {
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

    /// Why the laser alone does not vouch that `t` is a person (`walking`: it must also
    /// have walked).
    pub(super) fn laser_refusal(&self, t: &Track, view: &View, walking: bool) -> Option<Refusal> {
        let c = &self.config;
        let min_pairs = if walking {
            c.min_leg_pairs
        } else {
            c.min_leg_pairs_standing
        };
        let few_pairs = t.pair_hits < min_pairs
            || (walking
                && (f64::from(t.pair_hits) < c.min_pair_share * f64::from(t.hits)
                    || f64::from(t.weak_hits)
                        > c.max_weak_share * f64::from(t.hits + t.weak_hits)));
        if (view.in_clutter)(t.position().mean) {
            Some(Refusal::StaticClutter)
        } else if few_pairs {
            // No pair of legs because no leg at all: a track of the camera alone.
            Some(if t.last_laser.is_none() {
                Refusal::NotSeenByLaser
            } else {
                Refusal::NoLegPair
            })
        } else if walking && t.walked_m < c.min_walked_m {
            Some(Refusal::NotWalking)
        } else {
            None
        }
    }

    /// Records that `track` was refused for `refusal` in the loss `l` (counted once per
    /// track, reason and loss).
    pub(super) fn refuse(&mut self, l: &mut Lost, track: u64, refusal: Refusal) {
        self.refusals_now.push((track, refusal));
        if l.refused.insert((track, refusal)) {
            self.stats.count_refusal(refusal);
        }
    }
}
