//! "May this track be the target?" (design 11.4): one answer for the four times it is
//! asked, as one table.
//!
//! | check | start | encounter | coasting | re-acquisition | refusal |
//! |---|---|---|---|---|---|
//! | considered | confirmed, fresh | confirmed, updated now | confirmed, updated now | confirmed, fresh | (none: not a candidate) |
//! | where the target can be | anywhere | within `encounter_distance_m` of the target's track | near the target's last observations, reachable from its walk | reachable from its last good estimate | `out_of_reach` |
//! | not somebody else | not asked | seen beside it | seen beside it, born elsewhere, there before its last observation | somebody else at the loss, born elsewhere | `somebody_else` |
//! | both sensors | required (fused) | not asked | suffice | required where the camera sees (fused) | `camera_does_not_vouch` |
//! | the laser vouches | standing | standing | standing | walking | `static_clutter`, `not_seen_by_laser`, `no_leg_pair`, `few_leg_pairs`, `weak_legs`, `not_walking` |
//!
//! Why they differ:
//! - *Start*: the user presents themselves to the robot, in front of it, where the
//!   camera sees, and may stand still to do it; nobody is excluded yet.
//! - *Encounter*: the track is right beside the target and carries on its walk better
//!   than the target's own track by a margin: motion says who it is. Only a track seen
//!   apart from the target is excluded, because a track born in the encounter may be the
//!   target's own legs tracked apart; the camera is not asked, because its boxes mix
//!   when two people meet.
//! - *Coasting*: the target's track has gone without observation for a moment and
//!   another track has the person's observations. It must stand where the target was
//!   last seen and be reachable from its walk; a track that was already there,
//!   elsewhere, when the target was last observed is somebody else. Both sensors
//!   seeing it suffice; else a standing pair of legs, as at the start.
//! - *Re-acquisition*: anyone within a region that grows with the time lost. The
//!   exclusions were settled at the loss; where the camera does not see, a post or a
//!   bush must not be taken, so the laser must have seen the track walk.

use super::memory::{Locked, Lost};
use super::{Refusal, SomebodyElse, TargetSelector, View};
use crate::tracker::{Anchor, Track};
use tether_core::{Point2, Stamp, World};

/// Why "may this track be the target?" is asked, with what the answer depends on.
pub(super) enum Question<'a> {
    /// Choosing the target at the start (or at a restart).
    Start,
    /// Handing the locked target over during a close encounter.
    Encounter {
        /// The target's track.
        target: &'a Track,
        /// The lock.
        locked: &'a Locked,
    },
    /// Handing over a coasting target to the track that took up its person.
    Coasting {
        /// The target's track.
        target: &'a Track,
        /// The lock.
        locked: &'a Locked,
        /// Its good estimate when it was last alone, if recent.
        alone: Option<Anchor>,
        /// Its last good estimate.
        good: Anchor,
    },
    /// Taking up a lost target again.
    Reacquire {
        /// The loss.
        lost: &'a Lost,
    },
}

/// How both sensors' word counts for a question.
#[derive(Clone, Copy, PartialEq)]
enum Both {
    /// Required everywhere (when `require_both_sensors`).
    Required,
    /// Required where the camera sees (when `require_both_sensors`).
    WhereCameraSees,
    /// Enough on its own; without the laser, required where the camera sees.
    Suffices,
    /// Not asked.
    NotAsked,
}

impl TargetSelector {
    /// Whether `u` is considered at all for `q` (no refusal: it is not a candidate).
    pub(super) fn considered(&self, q: &Question, u: &Track, now: Stamp) -> bool {
        let fresh = now.secs_since(u.last_update) <= self.config.lost_after_s;
        u.confirmed
            && match q {
                Question::Start | Question::Reacquire { .. } => fresh,
                Question::Encounter { target, .. } | Question::Coasting { target, .. } => {
                    u.id != target.id && u.last_update == now
                }
            }
    }

    /// Whether track `u` may be the target for `q`; if not, why (the checks of the
    /// module's table, in order). `u` must be [considered](Self::considered).
    pub(super) fn may_be_target(
        &self,
        q: &Question,
        u: &Track,
        now: Stamp,
        view: &View,
    ) -> Result<(), Refusal> {
        if !self.where_target_can_be(q, u, now) {
            return Err(Refusal::OutOfReach);
        }
        if self.somebody_else(q, u).is_some() {
            return Err(Refusal::SomebodyElse);
        }
        let (both, walking) = match q {
            Question::Start => (Both::Required, false),
            Question::Encounter { .. } => (Both::NotAsked, false),
            Question::Coasting { .. } => (Both::Suffices, false),
            Question::Reacquire { .. } => (Both::WhereCameraSees, true),
        };
        self.vouched(u, now, view, both, walking)
    }

    /// The second row of the table.
    pub(super) fn where_target_can_be(&self, q: &Question, u: &Track, now: Stamp) -> bool {
        let p = u.position();
        let sd = p.cov.principal_axes().0.max(0.0).sqrt();
        let r = self.config.encounter_distance_m;
        match q {
            Question::Start => true,
            Question::Encounter { target, .. } => p.mean.distance_m(target.position().mean) < r,
            Question::Coasting {
                target,
                alone,
                good,
                ..
            } => {
                // Near where the target was last seen, or where its motion from when
                // it was alone would have taken it; and where it could have gone.
                let near = |q: Point2<World>| {
                    q.distance_m(target.anchor.position.mean) <= r
                        || q.distance_m(good.position.mean) <= r
                        || alone.is_some_and(|al| {
                            q.distance_m(al.position.mean + al.velocity * now.secs_since(al.stamp))
                                <= r
                        })
                };
                near(p.mean) && self.reachable_from(&alone.unwrap_or(*good), p.mean, sd, now)
            }
            Question::Reacquire { lost } => self.reachable_from(&lost.from, p.mean, sd, now),
        }
    }

    /// The third row of the table: why `u` is somebody else, if it is.
    pub(super) fn somebody_else(&self, q: &Question, u: &Track) -> Option<SomebodyElse> {
        let beside = |l: &Locked| {
            l.company
                .seen_beside_for(u.id, self.config.beside_s)
                .then_some(SomebodyElse::SeenBeside)
        };
        let elsewhere = || {
            self.notes_of(u.id)
                .elsewhere
                .then_some(SomebodyElse::BornElsewhere)
        };
        match q {
            Question::Start => None,
            Question::Encounter { locked, .. } => beside(locked),
            Question::Coasting { target, locked, .. } => {
                beside(locked).or_else(elsewhere).or_else(|| {
                    self.there_before(u, &target.anchor)
                        .then_some(SomebodyElse::ThereBefore)
                })
            }
            Question::Reacquire { lost } => lost.others.get(&u.id).copied().or_else(elsewhere),
        }
    }

    /// The last two rows of the table: whether the sensors vouch for `u` as a person,
    /// both sensors as `both` says, the laser for a person standing or `walking`.
    fn vouched(
        &self,
        u: &Track,
        now: Stamp,
        view: &View,
        both: Both,
        walking: bool,
    ) -> Result<(), Refusal> {
        let c = &self.config;
        let seen_by_both = u.seen_by_both(now, c.both_sensors_window_s);
        if both == Both::Suffices && seen_by_both {
            return Ok(());
        }
        let camera_sees = || (view.camera_sees)(u.position().mean);
        let camera_asks = c.require_both_sensors
            && match both {
                Both::Required => true,
                Both::WhereCameraSees => camera_sees(),
                Both::Suffices => !view.laser_in_use && camera_sees(),
                Both::NotAsked => false,
            };
        if camera_asks {
            return if seen_by_both {
                Ok(())
            } else {
                Err(Refusal::CameraDoesNotVouch)
            };
        }
        if !view.laser_in_use {
            return Ok(());
        }
        self.laser_refusal(u, view, walking).map_or(Ok(()), Err)
    }

    /// Why the laser alone does not vouch that `t` is a person (`walking`: it must also
    /// have walked), checked in this order: static clutter; no pair of legs because no
    /// leg at all (a track of the camera alone); too few pairs; (walking) pairs in too
    /// small a share of its updates, mostly weak legs, not walked.
    fn laser_refusal(&self, t: &Track, view: &View, walking: bool) -> Option<Refusal> {
        let c = &self.config;
        let min_pairs = if walking {
            c.min_leg_pairs
        } else {
            c.min_leg_pairs_standing
        };
        if (view.in_clutter)(t.position().mean) {
            Some(Refusal::StaticClutter)
        } else if t.pair_hits < min_pairs && t.last_laser.is_none() {
            Some(Refusal::NotSeenByLaser)
        } else if t.pair_hits < min_pairs {
            Some(Refusal::NoLegPair)
        } else if !walking {
            None
        } else if f64::from(t.pair_hits) < c.min_pair_share * f64::from(t.hits) {
            Some(if t.last_laser.is_none() {
                Refusal::NotSeenByLaser
            } else {
                Refusal::FewLegPairs
            })
        } else if f64::from(t.weak_hits) > c.max_weak_share * f64::from(t.hits + t.weak_hits) {
            Some(Refusal::WeakLegs)
        } else if t.walked_m < c.min_walked_m {
            Some(Refusal::NotWalking)
        } else {
            None
        }
    }

    /// Records that track `t` was refused for `refusal` in the loss `l` (counted once per
    /// track, reason and loss), and, for `somebody_else`, why.
    pub(super) fn refuse(&mut self, l: &mut Lost, t: &Track, refusal: Refusal) {
        let track = t.id;
        self.refusals_now.push((track, refusal));
        if refusal == Refusal::SomebodyElse
            && let Some(why) = self.somebody_else(&Question::Reacquire { lost: l }, t)
        {
            self.somebody_else_now.push((track, why));
        }
        if l.refused.insert((track, refusal)) {
            self.stats.count_refusal(refusal);
        }
    }
}
