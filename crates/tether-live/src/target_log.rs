//! What happened to the target over a run: when it was locked, lost (and why), taken up
//! again, and which candidates were refused while it was lost (and why). `track`,
//! `replay`, `run` and the simulator's report all keep one, so every output says the
//! same thing in the same words (the names of [`TargetState::name`],
//! [`LossReason::name`] and [`Refusal::name`]).

use std::collections::BTreeSet;

use serde::Serialize;
use tether_core::Stamp;
use tether_fusion::{LossReason, Refusal, SomebodyElse, TargetState, TargetStats, Transition};
use tether_pipeline::Tick;

/// One change of the target's state, or a first refusal of a candidate during a loss.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetEvent {
    /// Time since the first recorded tick, s.
    pub t_s: f64,
    /// What happened.
    #[serde(flatten)]
    pub kind: EventKind,
}

/// What a [`TargetEvent`] says.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum EventKind {
    /// A target was chosen (from searching).
    Locked {
        /// Its track.
        track: u64,
    },
    /// The target was lost.
    Lost {
        /// The track that was followed.
        track: u64,
        /// Why.
        reason: LossReason,
    },
    /// The lost target was taken up again.
    Reacquired {
        /// The track followed now (the old id, or a new track on the same person).
        track: u64,
        /// How long it was lost, s.
        after_s: f64,
        /// How (`back`, `reacquired`, `restarted`), when the log was given it.
        #[serde(skip_serializing_if = "Option::is_none")]
        how: Option<Transition>,
    },
    /// The target moved from one track to another without being lost: the tracker
    /// had given its person's observations to another track (its track went astray,
    /// or the person was tracked twice).
    HandedOver {
        /// The track followed until then.
        from: u64,
        /// The track followed now.
        track: u64,
        /// How (`coasting_handover`, `encounter_handover`), when the log was given it.
        #[serde(skip_serializing_if = "Option::is_none")]
        how: Option<Transition>,
    },
    /// The lost target's search was given up (a user's track id that vanished).
    Searching,
    /// A track was refused as the lost target (the first time for this track and
    /// reason during this loss).
    Refused {
        /// The refused track.
        track: u64,
        /// Why.
        refusal: Refusal,
        /// For `somebody_else`, why it is somebody else, when the log was given it.
        #[serde(skip_serializing_if = "Option::is_none")]
        because: Option<SomebodyElse>,
    },
}

/// Time spent in each state and what the selector counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct TargetSummary {
    /// Time locked on a target, s.
    pub locked_s: f64,
    /// Time with the target lost, s.
    pub lost_s: f64,
    /// Time searching before any target was chosen (or after giving up), s.
    pub searching_s: f64,
    /// Longest single loss, s.
    pub longest_loss_s: f64,
    /// Ticks in each state.
    pub locked_ticks: u64,
    /// Ticks lost.
    pub lost_ticks: u64,
    /// Ticks searching.
    pub searching_ticks: u64,
    /// The selector's counters (locks, losses by reason, re-acquisitions, refusals).
    #[serde(flatten)]
    pub counts: TargetStats,
}

/// Keeps the target's timeline over a run.
#[derive(Debug, Clone, Default)]
pub struct TargetLog {
    start: Option<Stamp>,
    last: Option<(Stamp, TargetState)>,
    lost_since: Option<Stamp>,
    refused: BTreeSet<(u64, Refusal)>,
    events: Vec<TargetEvent>,
    summary: TargetSummary,
}

impl TargetLog {
    /// An empty log.
    pub fn new() -> Self {
        TargetLog::default()
    }

    /// Records a pipeline tick: its state, refusals, transition and why each track
    /// refused as somebody else is (see [`Self::record`]).
    pub fn record_tick(&mut self, tick: &Tick) {
        self.record_detail(
            tick.stamp,
            &tick.target.state,
            &tick.refusals,
            tick.transition,
            &tick.somebody_else,
        );
    }

    /// Records one tick's state and refusals (ticks must come in stamp order; a tick
    /// whose stamp went backwards only updates the state).
    pub fn record(&mut self, stamp: Stamp, state: &TargetState, refusals: &[(u64, Refusal)]) {
        self.record_detail(stamp, state, refusals, None, &[]);
    }

    /// [`Self::record`] with the tick's transition and why each track refused as
    /// somebody else is.
    fn record_detail(
        &mut self,
        stamp: Stamp,
        state: &TargetState,
        refusals: &[(u64, Refusal)],
        how: Option<Transition>,
        somebody_else: &[(u64, SomebodyElse)],
    ) {
        let start = *self.start.get_or_insert(stamp);
        let t_s = stamp.secs_since(start);
        if let Some((prev_stamp, prev)) = &self.last {
            let dt_s = stamp.secs_since(*prev_stamp).max(0.0);
            match prev {
                TargetState::Locked { .. } => self.summary.locked_s += dt_s,
                TargetState::Lost { .. } => self.summary.lost_s += dt_s,
                TargetState::Searching => self.summary.searching_s += dt_s,
            }
        }
        match state {
            TargetState::Locked { .. } => self.summary.locked_ticks += 1,
            TargetState::Lost { .. } => self.summary.lost_ticks += 1,
            TargetState::Searching => self.summary.searching_ticks += 1,
        }
        let prev = self.last.map(|(_, s)| s).unwrap_or(TargetState::Searching);
        let event = match (prev, *state) {
            (TargetState::Searching, TargetState::Locked { track }) => {
                Some(EventKind::Locked { track })
            }
            (TargetState::Locked { .. }, TargetState::Lost { track, reason, .. })
            | (TargetState::Searching, TargetState::Lost { track, reason, .. }) => {
                self.lost_since = Some(stamp);
                self.refused.clear();
                Some(EventKind::Lost { track, reason })
            }
            (TargetState::Lost { .. }, TargetState::Locked { track }) => {
                let after_s = self.end_loss(stamp);
                Some(EventKind::Reacquired {
                    track,
                    after_s,
                    how,
                })
            }
            (TargetState::Lost { .. }, TargetState::Searching) => {
                self.end_loss(stamp);
                Some(EventKind::Searching)
            }
            (TargetState::Locked { track: a }, TargetState::Locked { track: b }) if a != b => {
                Some(EventKind::HandedOver {
                    from: a,
                    track: b,
                    how,
                })
            }
            _ => None,
        };
        if let Some(kind) = event {
            self.events.push(TargetEvent { t_s, kind });
        }
        if let TargetState::Lost { .. } = state {
            for &(track, refusal) in refusals {
                if self.refused.insert((track, refusal)) {
                    self.events.push(TargetEvent {
                        t_s,
                        kind: EventKind::Refused {
                            track,
                            refusal,
                            because: somebody_else
                                .iter()
                                .find(|(t, _)| *t == track)
                                .map(|&(_, b)| b),
                        },
                    });
                }
            }
        }
        self.last = Some((stamp, *state));
    }

    fn end_loss(&mut self, stamp: Stamp) -> f64 {
        let after_s = self
            .lost_since
            .take()
            .map_or(0.0, |since| stamp.secs_since(since).max(0.0));
        self.summary.longest_loss_s = self.summary.longest_loss_s.max(after_s);
        self.refused.clear();
        after_s
    }

    /// The events so far, in time order.
    pub fn events(&self) -> &[TargetEvent] {
        &self.events
    }

    /// The summary, with the selector's counters.
    pub fn summary(&self, counts: TargetStats) -> TargetSummary {
        let mut s = self.summary;
        if let (Some(since), Some((now, _))) = (self.lost_since, self.last) {
            s.longest_loss_s = s.longest_loss_s.max(now.secs_since(since).max(0.0));
        }
        s.counts = counts;
        s
    }

    /// The selector's counters as far as the events tell them (for a run whose
    /// selector is gone: the simulator's log). Ambiguity counts each refused track.
    pub fn counts_from_events(&self) -> TargetStats {
        let mut c = TargetStats::default();
        let mut lost_track = None;
        for e in &self.events {
            match e.kind {
                EventKind::Locked { .. } => c.locks += 1,
                EventKind::Lost { track, reason } => {
                    lost_track = Some(track);
                    c.count_loss(reason);
                }
                EventKind::Reacquired { track, .. } => {
                    c.reacquisitions += 1;
                    c.reacquired_same_track += u64::from(lost_track == Some(track));
                }
                EventKind::HandedOver { .. } => c.handovers += 1,
                EventKind::Searching => {}
                EventKind::Refused { refusal, .. } => c.count_refusal(refusal),
            }
        }
        c
    }

    /// One line for a command's closing message.
    pub fn one_line(&self, counts: TargetStats) -> String {
        let s = self.summary(counts);
        let mut reasons = Vec::new();
        for (name, n) in [
            (LossReason::Unseen.name(), s.counts.lost_unseen),
            (LossReason::LeftView.name(), s.counts.lost_left_view),
            (LossReason::SensorGap.name(), s.counts.lost_sensor_gap),
            (LossReason::TrackDropped.name(), s.counts.lost_track_dropped),
            (LossReason::LedOff.name(), s.counts.lost_led_off),
        ] {
            if n > 0 {
                reasons.push(format!("{n} {name}"));
            }
        }
        let reasons = if reasons.is_empty() {
            String::new()
        } else {
            format!(" ({})", reasons.join(", "))
        };
        let restarts = if s.counts.restarts > 0 {
            format!(
                ", {} taken up again as at the start after a long loss",
                s.counts.restarts
            )
        } else {
            String::new()
        };
        format!(
            "target locked {:.1} s, lost {:.1} s in {} losses{reasons}, {} re-acquired, \
             {} ambiguous, {} handed over between tracks{restarts}",
            s.locked_s,
            s.lost_s,
            s.counts.losses,
            s.counts.reacquisitions,
            s.counts.ambiguous,
            s.counts.handovers
        )
    }

    /// How long the log covers, from its first tick to its last, s.
    pub fn span_s(&self) -> f64 {
        self.last
            .zip(self.start)
            .map_or(0.0, |((now, _), start)| now.secs_since(start))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tether_core::{Cov2, Gaussian2, Point2, Vector2, World};

    fn at(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    fn lost(track: u64, reason: LossReason) -> TargetState {
        TargetState::Lost {
            track,
            reason,
            since: at(0),
            last: Gaussian2::<World>::new(Point2::new(1.0, 0.0), Cov2::isotropic(0.01).unwrap())
                .unwrap(),
            velocity: Vector2::ZERO,
            velocity_sigma_mps: 0.1,
        }
    }

    #[test]
    fn the_timeline_says_when_and_why() {
        let mut log = TargetLog::new();
        log.record(at(0), &TargetState::Searching, &[]);
        log.record(at(100), &TargetState::Locked { track: 3 }, &[]);
        log.record(at(1100), &lost(3, LossReason::Unseen), &[]);
        let refusals = [(5, Refusal::NotWalking)];
        log.record(at(1200), &lost(3, LossReason::Unseen), &refusals);
        log.record(at(1300), &lost(3, LossReason::Unseen), &refusals);
        log.record(at(1600), &TargetState::Locked { track: 5 }, &[]);
        log.record(at(2600), &TargetState::Locked { track: 5 }, &[]);
        let kinds: Vec<&EventKind> = log.events().iter().map(|e| &e.kind).collect();
        assert_eq!(
            kinds,
            [
                &EventKind::Locked { track: 3 },
                &EventKind::Lost {
                    track: 3,
                    reason: LossReason::Unseen
                },
                &EventKind::Refused {
                    track: 5,
                    refusal: Refusal::NotWalking,
                    because: None
                },
                &EventKind::Reacquired {
                    track: 5,
                    after_s: 0.5,
                    how: None
                },
            ]
        );
        let s = log.summary(TargetStats::default());
        assert!((s.locked_s - 2.0).abs() < 1e-9, "{s:?}");
        assert!((s.lost_s - 0.5).abs() < 1e-9);
        assert!((s.searching_s - 0.1).abs() < 1e-9);
        assert!((s.longest_loss_s - 0.5).abs() < 1e-9);
        assert_eq!((s.locked_ticks, s.lost_ticks, s.searching_ticks), (3, 3, 1));
        let counts = log.counts_from_events();
        assert_eq!((counts.locks, counts.losses, counts.lost_unseen), (1, 1, 1));
        assert_eq!(
            (counts.reacquisitions, counts.reacquired_same_track),
            (1, 0)
        );
        assert_eq!(counts.refused_not_walking, 1);
        assert!((log.span_s() - 2.6).abs() < 1e-9);
    }

    #[test]
    fn a_tick_s_transition_and_why_somebody_else_go_into_the_events() {
        let mut log = TargetLog::new();
        let locked = |track| TargetState::Locked { track };
        log.record(at(0), &locked(3), &[]);
        let handover = Some(Transition::EncounterHandover);
        log.record_detail(at(100), &locked(4), &[], handover, &[]);
        log.record(at(1200), &lost(4, LossReason::Unseen), &[]);
        let refusals = [(7, Refusal::SomebodyElse), (8, Refusal::NotWalking)];
        let why = [(7, SomebodyElse::SeenBeside)];
        log.record_detail(
            at(1300),
            &lost(4, LossReason::Unseen),
            &refusals,
            None,
            &why,
        );
        let back = Some(Transition::Back);
        log.record_detail(at(1400), &locked(4), &[], back, &[]);
        let kinds: Vec<&EventKind> = log.events().iter().map(|e| &e.kind).collect();
        assert_eq!(
            kinds[1],
            &EventKind::HandedOver {
                from: 3,
                track: 4,
                how: handover
            }
        );
        assert_eq!(
            kinds[3..],
            [
                &EventKind::Refused {
                    track: 7,
                    refusal: Refusal::SomebodyElse,
                    because: Some(SomebodyElse::SeenBeside)
                },
                &EventKind::Refused {
                    track: 8,
                    refusal: Refusal::NotWalking,
                    because: None
                },
                &EventKind::Reacquired {
                    track: 4,
                    after_s: 0.2,
                    how: back
                },
            ]
        );
    }

    #[test]
    fn a_loss_still_open_counts_as_the_longest() {
        let mut log = TargetLog::new();
        log.record(at(0), &TargetState::Locked { track: 1 }, &[]);
        log.record(at(1000), &lost(1, LossReason::SensorGap), &[]);
        log.record(at(4000), &lost(1, LossReason::SensorGap), &[]);
        assert!((log.summary(TargetStats::default()).longest_loss_s - 3.0).abs() < 1e-9);
        assert!(log.one_line(TargetStats::default()).contains("lost 3.0 s"));
    }
}
