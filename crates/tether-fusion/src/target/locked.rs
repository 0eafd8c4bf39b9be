//! The `Locked` state's update (design 5.6): kept, handed over to the track that took up
//! a coasting target, lost as led off onto somebody else, carried through a close
//! encounter, or lost when the track is gone or silent.

use super::eligible::Question;
use super::memory::{Company, Locked, Lost};
use super::{LockedStep, LossReason, SomebodyElse, TargetSelector, Tick, Transition, View};
use crate::tracker::{Anchor, Track};
use tether_core::Stamp;

impl TargetSelector {
    /// One step of `Locked` (`merged_somebody_else`: see
    /// [`Self::merged_somebody_else`]).
    pub(super) fn step_locked(
        &mut self,
        l: &mut Locked,
        tick: &Tick,
        merged_somebody_else: Option<Anchor>,
    ) -> LockedStep {
        let (now, tracks, view) = (tick.now, tick.tracks, tick.view);
        let max_s = self.config.encounter_max_s;
        let found = tracks.iter().find(|t| t.id == l.track);
        match found {
            Some(t) if now.secs_since(t.last_update) <= self.silent_limit_s(t) => {
                l.last_good = Some(self.good_anchor(t));
                if t.last_pair == Some(now) {
                    self.count_beside(&mut l.company, t, tracks, now, tick.dt);
                }
                if let Some(u) = self.coasting_handover(now, l, t, tracks, view) {
                    LockedStep::HandOver(u, Transition::CoastingHandover)
                } else if self.led_off(l, t, tracks, now, tick.dt, merged_somebody_else) {
                    let from = l.alone_within(now, max_s, false).or(l.last_good);
                    LockedStep::Lose(LossReason::LedOff, from)
                } else {
                    match self.through_encounter(now, l, t, tracks, view) {
                        Some(u) => LockedStep::HandOver(u, Transition::EncounterHandover),
                        None => LockedStep::Stay,
                    }
                }
            }
            found => {
                // Lost in company: the target's track may have been led off before it
                // went silent; the region starts from where it was alone.
                let from = match (l.alone_within(now, max_s, false), found) {
                    (Some(a), Some(f))
                        if f.anchor.stamp > a.stamp
                            && self.off_prediction_sigma(&a, f, f.anchor.stamp)
                                > self.config.handover_within_sigma =>
                    {
                        Some(a)
                    }
                    _ => found.map(|t| self.good_anchor(t)).or(l.last_good),
                };
                LockedStep::Lose(self.loss_reason(found, from, view), from)
            }
        }
    }

    /// How long the target's track `t` may go without an update before the target is
    /// lost: `lost_after_s`; but a track last updated by a person coming out of the
    /// shadow it went into ([`Track::came_out`]), which took the target back on that
    /// one update, must be confirmed within `handover_coast_s`: one leg at a shadow's
    /// edge may be a phantom, and the person, seen by the next scans, is there.
    fn silent_limit_s(&self, t: &Track) -> f64 {
        if t.came_out == Some(t.last_update) {
            self.config.handover_coast_s
        } else {
            self.config.lost_after_s
        }
    }

    /// Why a target whose track is `found` (`None`: dropped) and was last seen well at
    /// `from` is lost.
    fn loss_reason(&self, found: Option<&Track>, from: Option<Anchor>, view: &View) -> LossReason {
        if view.sensor_gap {
            LossReason::SensorGap
        } else if found.is_none() {
            LossReason::TrackDropped
        } else if from.is_some_and(|a| {
            // Heading out of view: where it would be a few tenths of a second on.
            !(view.laser_sees)(a.position.mean + a.velocity * 0.5)
        }) {
            LossReason::LeftView
        } else {
            LossReason::Unseen
        }
    }

    /// The memory of the loss of `l` for `reason`, searched for from `from`: who is
    /// somebody else from now on. A track seen beside the target, apart from it, for
    /// long enough (`beside_s`), or one already there before the target's last
    /// observation, not born at the target, and away from where the target was last
    /// seen; or one born apart from the observed target and still away. A track born
    /// at the target, or standing where it was lost, may be the target itself, taken
    /// up by a new track while the old one coasted or was led off. Led off, the
    /// target's own track and those it ran onto are somebody else too.
    pub(super) fn lost(
        &self,
        l: Locked,
        reason: LossReason,
        from: Anchor,
        tracks: &[Track],
    ) -> Lost {
        let away = |t: &Track| {
            t.position().mean.distance_m(from.position.mean) > self.config.encounter_distance_m
        };
        let beside_s = self.config.beside_s;
        let mut others: std::collections::BTreeMap<u64, SomebodyElse> = tracks
            .iter()
            .filter(|t| t.confirmed && t.id != l.track)
            .filter_map(|t| {
                let why = if l.company.seen_beside_for(t.id, beside_s) {
                    SomebodyElse::SeenBeside
                } else if self.notes_of(t.id).apart && away(t) {
                    SomebodyElse::BornApart
                } else if self.there_before(t, &from) {
                    SomebodyElse::ThereBefore
                } else {
                    return None;
                };
                Some((t.id, why))
            })
            .collect();
        let mut company = l.company;
        if reason == LossReason::LedOff {
            others.insert(l.track, SomebodyElse::LedOff);
            for &id in company.on_other.keys() {
                others.insert(id, SomebodyElse::LedOff);
            }
            company.on_other.clear();
        }
        Lost {
            track: l.track,
            reason,
            from,
            others,
            evidence: tracks
                .iter()
                .find(|t| t.id == l.track)
                .map(|t| (t.hits, t.last_pair)),
            refused: Default::default(),
            ambiguous_sets: Default::default(),
            presented: None,
            company,
        }
    }

    /// The locked target `t`, carried through close encounters: while another track is
    /// within `encounter_distance_m`, the target's motion from when it was last alone
    /// is the reference; a target track that leaves it far behind while exactly one
    /// other track (a person the laser vouches for, not somebody else) follows it hands
    /// the target over to that track (returned).
    fn through_encounter(
        &self,
        now: Stamp,
        l: &mut Locked,
        t: &Track,
        tracks: &[Track],
        view: &View,
    ) -> Option<u64> {
        let c = &self.config;
        let here = t.position().mean;
        let fresh = |u: &Track| now.secs_since(u.last_update) <= c.lost_after_s;
        let company = tracks.iter().any(|u| {
            u.id != t.id && fresh(u) && u.position().mean.distance_m(here) < c.encounter_distance_m
        });
        if !company {
            if t.last_update == now {
                l.alone = Some(self.good_anchor(t));
            }
            return None;
        }
        let a = l.alone_within(now, c.encounter_max_s, true)?;
        let d_target = self.off_motion_sq(&a, t, now);
        // The candidates are the company: a swap of identities happens between tracks
        // that meet, and a track away from the target that only fits the reference's
        // extrapolation is not one (the target may have turned where it was hidden).
        let q = Question::Encounter {
            target: t,
            locked: l,
        };
        let mut others: Vec<(f64, &Track)> = tracks
            .iter()
            .filter(|u| self.considered(&q, u, now) && self.where_target_can_be(&q, u, now))
            .map(|u| (self.off_motion_sq(&a, u, now), u))
            .collect();
        others.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.id.cmp(&y.1.id)));
        let margin = c.handover_margin;
        match others.as_slice() {
            [(d, u), rest @ ..]
                if *d <= c.handover_within_sigma.powi(2)
                    && d_target - d >= margin
                    && rest.first().is_none_or(|(d2, _)| d2 - d >= margin)
                    && self.may_be_target(&q, u, now, view).is_ok() =>
            {
                Some(u.id)
            }
            _ => None,
        }
    }

    /// Adds `dt_s` to every other confirmed track seen now as a whole person, apart from
    /// the target (called when the target itself was seen now as a whole person: a pair
    /// of legs, or by the camera, so that a target led off by clutter does not make the
    /// person it left somebody else).
    fn count_beside(
        &self,
        company: &mut Company,
        target: &Track,
        tracks: &[Track],
        now: Stamp,
        dt_s: f64,
    ) {
        let here = target.position().mean;
        for u in tracks {
            if u.id != target.id
                && u.confirmed
                && u.last_pair == Some(now)
                && u.position().mean.distance_m(here) > self.config.beside_distance_m
            {
                *company.beside.entry(u.id).or_insert(0.0) += dt_s;
            }
        }
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
        &self,
        l: &mut Locked,
        t: &Track,
        tracks: &[Track],
        now: Stamp,
        dt_s: f64,
        merged: Option<Anchor>,
    ) -> bool {
        let c = &self.config;
        let alone = l.alone_within(now, c.encounter_max_s, true);
        if let Some(other) = merged {
            let d_other = self.off_motion_sq(&other, t, now);
            if alone.is_some_and(|a| d_other < self.off_motion_sq(&a, t, now)) {
                return true;
            }
        }
        let on_course = alone
            .is_some_and(|a| self.off_motion_sq(&a, t, now) <= c.handover_within_sigma.powi(2));
        if on_course {
            l.company.on_other.clear();
            return false;
        }
        let here = t.position().mean;
        let fresh = |u: &Track| now.secs_since(u.last_update) <= c.lost_after_s;
        let on: Vec<u64> = tracks
            .iter()
            .filter(|u| u.id != t.id && u.confirmed && fresh(u))
            .filter(|u| u.position().mean.distance_m(here) < c.led_off_distance_m)
            .filter(|u| l.company.seen_beside_for(u.id, c.beside_s))
            .map(|u| u.id)
            .collect();
        l.company.on_other.retain(|id, _| on.contains(id));
        let mut led = false;
        for id in on {
            let s = l.company.on_other.entry(id).or_insert(0.0);
            *s += dt_s;
            led |= crate::reached_s(*s, c.led_off_after_s);
        }
        led
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
        l: &Locked,
        t: &Track,
        tracks: &[Track],
        view: &View,
    ) -> Option<u64> {
        let c = &self.config;
        if now.secs_since(t.last_update) <= c.handover_coast_s {
            return None;
        }
        // In company, the target's own last observation may already be dragged off by
        // the person it met: the reference is its motion when it was last alone, and
        // the candidates are every track that continues it.
        let alone = l.alone_within(now, c.encounter_max_s, true);
        // Where the target was last seen whole: a track that coasts on single legs may
        // be running off after somebody else's.
        let good = self.good_anchor(t);
        let q = Question::Coasting {
            target: t,
            locked: l,
            alone,
            good,
        };
        let candidates: Vec<&Track> = tracks
            .iter()
            .filter(|u| self.considered(&q, u, now) && self.may_be_target(&q, u, now, view).is_ok())
            .collect();
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
            [(d, u), (d2, _), ..] if d2 - d >= c.handover_margin => Some(*u),
            _ => None,
        }
    }
}
