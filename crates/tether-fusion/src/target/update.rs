//! One update of the target selector (design 5.6): the memory of who is who brought up to
//! date, verdicts on the tracks seen for the first time, and the transition from
//! `Locked`.

use tether_core::{Gaussian2, Stamp, World};

use super::{BIRTH_SIGMA_M, SEEN_WHOLE_S, STEADY_GAP_S, TargetSelector, TargetState, View};
use crate::tracker::{Anchor, Track};

impl TargetSelector {
    /// The track the tracker dropped as a second track on the locked target's person
    /// since the last update, when it was somebody else (its last anchor): the target's
    /// track may have come onto them (a bystander crossing close behind the target
    /// while it was partly hidden), and it is checked as a track led off.
    pub(super) fn merged_somebody_else(&self, tracks: &[Track]) -> Option<Anchor> {
        let TargetState::Locked { track } = self.state else {
            return None;
        };
        tracks
            .iter()
            .find(|t| t.id == track)
            .and_then(|t| t.merged)
            .filter(|&(u, when)| {
                self.last_now.is_none_or(|l| when > l) && self.seen_beside_long_enough(u)
            })
            .and_then(|(u, _)| self.last_anchors.get(&u).copied())
    }

    /// Forgets what is remembered about tracks the tracker no longer has.
    pub(super) fn forget_gone(&mut self, tracks: &[Track]) {
        let alive = |id: &u64| tracks.iter().any(|t| t.id == *id);
        self.beside.retain(|id, _| alive(id));
        self.seen.retain(alive);
        self.former.retain(alive);
        self.born_at_target.retain(alive);
        self.born_elsewhere.retain(alive);
        self.born_apart.retain(alive);
    }

    /// The locked target's position when it was observed now and seen whole a moment
    /// ago or observed steadily (not a coasting track that took a stray return); keeps
    /// the times of its last two updates.
    pub(super) fn target_seen_now(
        &mut self,
        now: Stamp,
        tracks: &[Track],
    ) -> Option<Gaussian2<World>> {
        let locked = match self.state {
            TargetState::Locked { track } => tracks.iter().find(|t| t.id == track),
            _ => None,
        };
        let previous_update = match (locked, self.target_updates) {
            (Some(t), Some((id, last, previous))) if id == t.id => {
                if t.last_update > last {
                    Some(last)
                } else {
                    previous
                }
            }
            _ => None,
        };
        self.target_updates = locked.map(|t| (t.id, t.last_update, previous_update));
        locked
            .filter(|t| {
                t.last_update == now
                    && (t
                        .last_pair
                        .is_some_and(|p| now.secs_since(p) <= SEEN_WHOLE_S)
                        || previous_update.is_some_and(|p| now.secs_since(p) <= STEADY_GAP_S))
            })
            .map(|t| t.position())
    }

    /// While the target is unseen (its track coasting, or lost), where it was last
    /// seen well, from which where it can be is bounded.
    pub(super) fn unseen_from(&self, now: Stamp, tracks: &[Track]) -> Option<Anchor> {
        match self.state {
            TargetState::Locked { track } => tracks
                .iter()
                .find(|t| t.id == track)
                .filter(|t| t.last_update < now)
                .map(|t| self.good_anchor(t)),
            TargetState::Lost {
                since,
                last,
                velocity,
                velocity_sigma_mps,
                ..
            } => Some(Anchor {
                stamp: since,
                position: last,
                velocity,
                velocity_sigma_mps,
            }),
            TargetState::Searching => None,
        }
    }

    /// Verdicts on the tracks seen for the first time: born at the locked target
    /// (`born_at_target`); born now apart from a target observed now, a second person
    /// even before the two have been seen apart for `beside_s` (`born_apart`: a
    /// bystander found while the target walks into an occlusion); born while the target
    /// is unseen, outside where it can be (`born_elsewhere`: a bystander stepping out
    /// from behind the pillar the target walked behind).
    pub(super) fn judge_new_tracks(&mut self, now: Stamp, tracks: &[Track]) {
        let target_here = match self.state {
            TargetState::Locked { track } => tracks
                .iter()
                .find(|t| t.id == track)
                .map(|t| t.position().mean),
            _ => None,
        };
        let target_seen_now = self.target_seen_now(now, tracks);
        let unseen_from = self.unseen_from(now, tracks);
        for t in tracks {
            if !self.seen.insert(t.id) {
                continue;
            }
            if target_here
                .is_some_and(|p| p.distance_m(t.birth_position) <= self.config.encounter_distance_m)
            {
                self.born_at_target.insert(t.id);
            }
            // Apart beyond doubt: by more than `encounter_distance_m` and three
            // standard deviations of each (a camera-born track's monocular range is
            // loose far away).
            let sd = |g: &Gaussian2<World>| g.cov.principal_axes().0.max(0.0).sqrt();
            if t.born == now
                && target_seen_now.is_some_and(|p| {
                    p.mean.distance_m(t.birth_position)
                        > self.config.encounter_distance_m + 3.0 * (sd(&p) + sd(&t.position()))
                })
            {
                self.born_apart.insert(t.id);
            }
            if let Some(a) = unseen_from
                && t.born > a.stamp
                && !self.reachable_from(&a, t.birth_position, BIRTH_SIGMA_M, t.born)
            {
                self.born_elsewhere.insert(t.id);
            }
        }
    }

    /// One transition from `Locked { track }`: kept, handed over to the track that
    /// continues a coasting target, lost as led off, through an encounter, or lost when
    /// the track is gone or silent.
    pub(super) fn step_locked(
        &mut self,
        now: Stamp,
        track: u64,
        tracks: &[Track],
        view: &View,
        dt: f64,
        merged_somebody_else: Option<Anchor>,
    ) -> TargetState {
        let found = tracks.iter().find(|t| t.id == track);
        // Read where it is used: the steps before may renew it.
        let alone = |s: &Self| {
            s.alone
                .filter(|a| now.secs_since(a.stamp) <= s.config.encounter_max_s)
        };
        match found {
            Some(t) if now.secs_since(t.last_update) <= self.config.lost_after_s => {
                self.last_good = Some(self.good_anchor(t));
                if t.last_pair == Some(now) {
                    self.count_beside(t, tracks, now, dt);
                }
                if let Some(u) = self.coasting_handover(now, t, tracks, view) {
                    self.stats.handovers += 1;
                    self.last_good = tracks.iter().find(|k| k.id == u).map(|k| k.anchor);
                    TargetState::Locked { track: u }
                } else if self.led_off(t, tracks, now, dt, merged_somebody_else) {
                    self.last_good = alone(self).or(self.last_good);
                    self.lose_led_off(track, tracks)
                } else {
                    self.through_encounter(now, t, tracks, view)
                }
            }
            found => {
                // Lost in company: the target's track may have been led off before it
                // went silent; the region starts from where it was alone.
                if let (Some(a), Some(f)) = (alone(self), found)
                    && f.anchor.stamp > a.stamp
                    && self.off_prediction_sigma(&a, f, f.anchor.stamp)
                        > self.config.handover_within_sigma
                {
                    self.lose(track, found, Some(a), tracks, view)
                } else {
                    let anchor = found.map(|t| self.good_anchor(t)).or(self.last_good);
                    self.lose(track, found, anchor, tracks, view)
                }
            }
        }
    }

    /// After the transition: a locked track is remembered as a former target and the
    /// refusals of the search are cleared; a new target starts a fresh "beside" memory,
    /// with the tracks already near it counted as born at it (they may be the same
    /// person, their legs tracked apart). When not locked, the alone estimate goes.
    pub(super) fn after_transition(&mut self, tracks: &[Track]) {
        let TargetState::Locked { track } = self.state else {
            self.alone = None;
            return;
        };
        self.former.insert(track);
        self.refused.clear();
        self.ambiguous_sets.clear();
        if self.beside_of == Some(track) {
            return;
        }
        self.beside.clear();
        self.beside_of = Some(track);
        if let Some(here) = tracks
            .iter()
            .find(|t| t.id == track)
            .map(|t| t.position().mean)
        {
            for t in tracks {
                if t.id != track
                    && t.position().mean.distance_m(here) <= self.config.encounter_distance_m
                {
                    self.born_at_target.insert(t.id);
                }
            }
        }
    }
}
