//! What the target selector remembers (design 5.6): each state's memory lives inside
//! the state and goes with it, and what is known about every other track (its
//! *notes*) is kept in one place.

use std::collections::{BTreeMap, BTreeSet};

use tether_core::Stamp;

use super::{LossReason, Refusal, SomebodyElse, TargetState};
use crate::tracker::Anchor;

/// The lock and the memory of its state.
#[derive(Debug, Clone, Default)]
pub(super) enum Lock {
    /// No target yet: nothing to remember.
    #[default]
    Searching,
    /// Following a track.
    Locked(Locked),
    /// The target's track went silent or was dropped.
    Lost(Lost),
}

impl Lock {
    /// The public face of the state.
    pub(super) fn state(&self) -> TargetState {
        match self {
            Lock::Searching => TargetState::Searching,
            Lock::Locked(l) => TargetState::Locked { track: l.track },
            Lock::Lost(l) => TargetState::Lost {
                track: l.track,
                reason: l.reason,
                since: l.from.stamp,
                last: l.from.position,
                velocity: l.from.velocity,
                velocity_sigma_mps: l.from.velocity_sigma_mps,
            },
        }
    }

    /// The memory of the company the target kept, in either state that has a target.
    pub(super) fn company_mut(&mut self) -> Option<&mut Company> {
        match self {
            Lock::Searching => None,
            Lock::Locked(l) => Some(&mut l.company),
            Lock::Lost(l) => Some(&mut l.company),
        }
    }
}

/// The company the target keeps: who has been seen beside it, and who its track has
/// run onto. Kept through a loss, and taken up again if the lost track itself comes
/// back (what was seen of the others still holds); a new target starts without it.
#[derive(Debug, Clone, Default)]
pub(super) struct Company {
    /// For each other track, how long it has been updated together with the target,
    /// both as whole people, and apart from it, s.
    pub(super) beside: BTreeMap<u64, f64>,
    /// For each track that is somebody else, how long the target's track has stayed on
    /// it, s.
    pub(super) on_other: BTreeMap<u64, f64>,
}

impl Company {
    /// Whether track `id` has been seen beside the target for `beside_s` (the time is a
    /// sum of scan intervals: five 0.1 s intervals make 0.49999999999999994 s, which
    /// counts as 0.5 s).
    pub(super) fn seen_beside_for(&self, id: u64, beside_s: f64) -> bool {
        self.beside
            .get(&id)
            .is_some_and(|&s| crate::reached_s(s, beside_s))
    }
}

/// The memory of `Locked`.
#[derive(Debug, Clone)]
pub(super) struct Locked {
    /// The followed track.
    pub(super) track: u64,
    /// Its last good estimate, kept in case the tracker drops the track between two
    /// calls.
    pub(super) last_good: Option<Anchor>,
    /// Its good estimate the last time it was alone (no other track within
    /// `encounter_distance_m`): what carries it through a close encounter. A handover
    /// keeps it: the person is the same.
    pub(super) alone: Option<Anchor>,
    /// Who it has been seen with.
    pub(super) company: Company,
    /// Its last update and the update before that.
    pub(super) updates: Option<(Stamp, Option<Stamp>)>,
}

impl Locked {
    /// A new lock on `track`, last seen well at `last_good`.
    pub(super) fn new(track: u64, last_good: Option<Anchor>) -> Self {
        Locked {
            track,
            last_good,
            alone: None,
            company: Company::default(),
            updates: None,
        }
    }

    /// The alone estimate, if it is at most `max_s` old at `now` (and, with `strictly`,
    /// older than `now`: one renewed at this very update says nothing about an
    /// encounter).
    pub(super) fn alone_within(&self, now: Stamp, max_s: f64, strictly: bool) -> Option<Anchor> {
        self.alone
            .filter(|a| now.secs_since(a.stamp) <= max_s && (!strictly || now > a.stamp))
    }
}

/// The memory of `Lost`.
#[derive(Debug, Clone)]
pub(super) struct Lost {
    /// The track that was followed.
    pub(super) track: u64,
    /// Why it was lost.
    pub(super) reason: LossReason,
    /// Its last good estimate, from which where the person can be is bounded.
    pub(super) from: Anchor,
    /// Tracks that are somebody else, judged at the loss (and, when led off, the
    /// target's own track and those it ran onto), and why.
    pub(super) others: BTreeMap<u64, SomebodyElse>,
    /// The lost track's (not weak) updates and its last whole-person evidence at the
    /// loss: coming back, it must show more than that.
    pub(super) evidence: Option<(u32, Option<Stamp>)>,
    /// Refusals already counted in this loss (track, reason).
    pub(super) refused: BTreeSet<(u64, Refusal)>,
    /// Candidate sets already counted as ambiguous in this loss.
    pub(super) ambiguous_sets: BTreeSet<Vec<u64>>,
    /// Lost for `restart_after_s`: the one track standing in front of the robot, and
    /// since when.
    pub(super) presented: Option<(u64, Stamp)>,
    /// The company the lost target kept.
    pub(super) company: Company,
}

/// What is known about one track, whatever the state: where it was born against the
/// target, and whether it has been the target. Forgotten when the tracker drops it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(super) struct Notes {
    /// It has been the target: the same person, whatever the tracker has done since,
    /// until shown otherwise.
    pub(super) former: bool,
    /// Born within `encounter_distance_m` of the locked target, or that near it when it
    /// was locked: perhaps the target itself (taken up by a new track, or its legs
    /// tracked apart).
    pub(super) at_target: bool,
    /// Born apart from the target while it was observed (seen whole a moment before, or
    /// steadily): somebody else if still away from it when it is lost (the target's
    /// track, not the new one, may have been on the wrong thing).
    pub(super) apart: bool,
    /// Born, while the target was unseen, where it could not have been.
    pub(super) elsewhere: bool,
}
