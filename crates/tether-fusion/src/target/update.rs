//! The bookkeeping of an update of the target selector (design 5.6), before its
//! transition: the memory of who is who brought up to date, and the notes on the tracks
//! seen for the first time.

use tether_core::{Gaussian2, Stamp, World};

use super::memory::{Lock, Locked};
use super::{BIRTH_SIGMA_M, SEEN_WHOLE_S, STEADY_GAP_S, TargetSelector};
use crate::tracker::{Anchor, Track};

impl TargetSelector {
    /// The track the tracker dropped as a second track on the locked target's person
    /// since the last update, when it was somebody else (its last anchor): the target's
    /// track may have come onto them (a bystander crossing close behind the target
    /// while it was partly hidden), and it is checked as a track led off.
    pub(super) fn merged_somebody_else(&self, lock: &Lock, tracks: &[Track]) -> Option<Anchor> {
        let Lock::Locked(l) = lock else {
            return None;
        };
        tracks
            .iter()
            .find(|t| t.id == l.track)
            .and_then(|t| t.merged)
            .filter(|&(u, when)| {
                self.last_now.is_none_or(|last| when > last)
                    && l.company.seen_beside_for(u, self.config.beside_s)
            })
            .and_then(|(u, _)| self.last_anchors.get(&u).copied())
    }

    /// Forgets what is remembered about tracks the tracker no longer has.
    pub(super) fn forget_gone(&mut self, lock: &mut Lock, tracks: &[Track]) {
        let alive = |id: &u64| tracks.iter().any(|t| t.id == *id);
        self.notes.retain(|id, _| alive(id));
        if let Some(company) = lock.company_mut() {
            company.beside.retain(|id, _| alive(id));
        }
    }

    /// Whether `u` was somebody else already when the target was last seen at `a`: a
    /// track older than that observation, not born at the target nor ever the target,
    /// and not where the target was last seen.
    pub(super) fn there_before(&self, u: &Track, a: &Anchor) -> bool {
        let notes = self.notes_of(u.id);
        u.born <= a.stamp
            && !notes.at_target
            && !notes.former
            && u.position().mean.distance_m(a.position.mean) > self.config.encounter_distance_m
    }

    /// The locked target's position when it was observed now and seen whole a moment
    /// ago or observed steadily (not a coasting track that took a stray return); keeps
    /// the times of its last two updates.
    fn target_seen_now(now: Stamp, l: &mut Locked, tracks: &[Track]) -> Option<Gaussian2<World>> {
        let Some(t) = tracks.iter().find(|t| t.id == l.track) else {
            l.updates = None;
            return None;
        };
        let previous_update = match l.updates {
            Some((last, previous)) => {
                if t.last_update > last {
                    Some(last)
                } else {
                    previous
                }
            }
            None => None,
        };
        l.updates = Some((t.last_update, previous_update));
        let seen = t.last_update == now
            && (t
                .last_pair
                .is_some_and(|p| now.secs_since(p) <= SEEN_WHOLE_S)
                || previous_update.is_some_and(|p| now.secs_since(p) <= STEADY_GAP_S));
        seen.then(|| t.position())
    }

    /// While the target is unseen (its track coasting, or lost), where it was last
    /// seen well, from which where it can be is bounded.
    fn unseen_from(&self, now: Stamp, lock: &Lock, tracks: &[Track]) -> Option<Anchor> {
        match lock {
            Lock::Locked(l) => tracks
                .iter()
                .find(|t| t.id == l.track)
                .filter(|t| t.last_update < now)
                .map(|t| self.good_anchor(t)),
            Lock::Lost(l) => Some(l.from),
            Lock::Searching => None,
        }
    }

    /// Notes on the tracks seen for the first time: born at the locked target
    /// (`at_target`); born now apart from a target observed now, a second person even
    /// before the two have been seen apart for `beside_s` (`apart`: a bystander found
    /// while the target walks into an occlusion); born while the target is unseen,
    /// outside where it can be (`elsewhere`: a bystander stepping out from behind the
    /// pillar the target walked behind).
    pub(super) fn judge_new_tracks(&mut self, lock: &mut Lock, now: Stamp, tracks: &[Track]) {
        let (target_here, target_seen_now) = match lock {
            Lock::Locked(l) => (
                tracks
                    .iter()
                    .find(|t| t.id == l.track)
                    .map(|t| t.position().mean),
                Self::target_seen_now(now, l, tracks),
            ),
            _ => (None, None),
        };
        let unseen_from = self.unseen_from(now, lock, tracks);
        let sd = |g: &Gaussian2<World>| g.cov.principal_axes().0.max(0.0).sqrt();
        for t in tracks {
            if self.notes.contains_key(&t.id) {
                continue;
            }
            let mut notes = super::Notes {
                at_target: target_here.is_some_and(|p| {
                    p.distance_m(t.birth_position) <= self.config.encounter_distance_m
                }),
                ..Default::default()
            };
            // Apart beyond doubt: by more than `encounter_distance_m` and three
            // standard deviations of each (a camera-born track's monocular range is
            // loose far away).
            notes.apart = t.born == now
                && target_seen_now.is_some_and(|p| {
                    p.mean.distance_m(t.birth_position)
                        > self.config.encounter_distance_m + 3.0 * (sd(&p) + sd(&t.position()))
                });
            notes.elsewhere = unseen_from.is_some_and(|a| {
                t.born > a.stamp
                    && !self.reachable_from(&a, t.birth_position, BIRTH_SIGMA_M, t.born)
            });
            self.notes.insert(t.id, notes);
        }
    }
}
