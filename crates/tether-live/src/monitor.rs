//! What a live run says while it follows: the target lost (and why), and a robot that
//! cannot keep up (the target pulls away while the robot drives at its speed limit,
//! the usual sign of a `max_speed_mps` below the person's walking speed).
//!
//! Nothing here reads a clock: the loop passes each tick's stamp.

use std::collections::VecDeque;

use tether_core::Stamp;
use tether_fusion::TargetState;

/// How long the robot must have been at its limit, with the gap growing, s.
pub const PULL_AWAY_WINDOW_S: f64 = 2.0;
/// How much the gap must grow over that window, m.
pub const PULL_AWAY_GROWTH_M: f64 = 0.3;
/// Speeds at or above this share of the limit count as "at the limit".
pub const AT_LIMIT_SHARE: f64 = 0.95;
/// Least time between two warnings about the same thing, s.
pub const WARN_EVERY_S: f64 = 5.0;

/// Watches the ticks of a live run for what the user should hear about.
#[derive(Debug, Clone)]
pub struct FollowMonitor {
    max_speed_mps: f64,
    follow_distance_m: f64,
    /// Recent ticks while locked: stamp, forward speed commanded, range to the target.
    recent: VecDeque<(Stamp, f64, f64)>,
    locked: Option<u64>,
    last_pull_warning: Option<Stamp>,
    /// Warnings given that the target pulled away.
    pub pull_away_warnings: u64,
    /// Losses of the target.
    pub losses: u64,
}

impl FollowMonitor {
    /// A monitor for a robot limited to `max_speed_mps` following at
    /// `follow_distance_m`.
    pub fn new(max_speed_mps: f64, follow_distance_m: f64) -> Self {
        FollowMonitor {
            max_speed_mps,
            follow_distance_m,
            recent: VecDeque::new(),
            locked: None,
            last_pull_warning: None,
            pull_away_warnings: 0,
            losses: 0,
        }
    }

    /// The robot stayed at its speed limit over the whole window and the gap grew:
    /// `Some((gap then, gap now, seconds))`.
    fn pulling_away(&self, now: Stamp) -> Option<(f64, f64, f64)> {
        let &(first_at, _, first_gap) = self.recent.front()?;
        let &(_, _, gap) = self.recent.back()?;
        let span_s = now.secs_since(first_at);
        let at_limit = self
            .recent
            .iter()
            .all(|&(_, v, _)| v >= AT_LIMIT_SHARE * self.max_speed_mps);
        (span_s >= PULL_AWAY_WINDOW_S - 0.1
            && at_limit
            && gap - first_gap > PULL_AWAY_GROWTH_M
            && gap > self.follow_distance_m + 0.5)
            .then_some((first_gap, gap, span_s))
    }

    /// One tick: the commanded forward speed, the range to the target when locked, and
    /// the target's state. Returns what to warn about (usually nothing).
    pub fn observe(
        &mut self,
        stamp: Stamp,
        v_mps: f64,
        range_m: Option<f64>,
        state: &TargetState,
    ) -> Vec<String> {
        let mut said = Vec::new();
        match (state, self.locked) {
            (TargetState::Lost { track, reason, .. }, Some(was)) if *track == was => {
                self.losses += 1;
                let behind = self
                    .pulling_away(stamp)
                    .map(|(_, gap, _)| {
                        format!(
                            "; it was pulling away ({gap:.1} m) with the robot at its speed \
                             limit ({:.2} m/s)",
                            self.max_speed_mps
                        )
                    })
                    .unwrap_or_default();
                said.push(format!(
                    "the target (track {track}) is lost ({}){behind}: the robot stands until \
                     it is found again",
                    reason.name()
                ));
                self.locked = None;
                self.recent.clear();
            }
            (TargetState::Locked { track }, _) => {
                if self.locked != Some(*track) {
                    self.recent.clear();
                }
                self.locked = Some(*track);
            }
            (_, _) => {
                self.locked = None;
                self.recent.clear();
            }
        }
        let (Some(_), Some(range_m)) = (self.locked, range_m) else {
            return said;
        };
        self.recent.push_back((stamp, v_mps, range_m));
        while let Some(&(at, _, _)) = self.recent.front() {
            if stamp.secs_since(at) > PULL_AWAY_WINDOW_S {
                self.recent.pop_front();
            } else {
                break;
            }
        }
        let quiet = self
            .last_pull_warning
            .is_none_or(|at| stamp.secs_since(at) >= WARN_EVERY_S);
        if quiet && let Some((then, now, span_s)) = self.pulling_away(stamp) {
            self.pull_away_warnings += 1;
            self.last_pull_warning = Some(stamp);
            said.push(format!(
                "the robot cannot keep up: at its speed limit ({:.2} m/s) the gap to the \
                 target grew from {then:.1} to {now:.1} m in {span_s:.1} s; raise [robot] \
                 max_speed_mps (and max_wheel_speed_mps) if the base can go faster",
                self.max_speed_mps
            ));
        }
        said
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, reason = "tests fail loudly")]

    use tether_core::{Cov2, Gaussian2, Point2, Vector2};
    use tether_fusion::LossReason;

    use super::*;

    fn at(s: f64) -> Stamp {
        Stamp::from_secs_f64(s).unwrap()
    }

    fn lost(track: u64) -> TargetState {
        TargetState::Lost {
            track,
            reason: LossReason::Unseen,
            since: at(0.0),
            last: Gaussian2::new(Point2::new(0.0, 0.0), Cov2::new(1.0, 0.0, 1.0).unwrap()).unwrap(),
            velocity: Vector2::new(0.0, 0.0),
            velocity_sigma_mps: 0.1,
        }
    }

    #[test]
    fn a_target_walking_away_from_a_robot_at_its_limit_is_said_once_then_the_loss() {
        let mut m = FollowMonitor::new(0.5, 1.2);
        let locked = TargetState::Locked { track: 4 };
        let mut said = Vec::new();
        // The person walks at 1.0 m/s, the robot at 0.5: the gap grows 0.5 m/s.
        for k in 0..60 {
            let t = 0.05 * f64::from(k);
            said.extend(m.observe(at(t), 0.5, Some(1.5 + 0.5 * t), &locked));
        }
        assert_eq!(said.len(), 1, "{said:?}");
        assert!(said[0].contains("cannot keep up") && said[0].contains("0.50 m/s"));
        let said = m.observe(at(3.05), 0.0, None, &lost(4));
        assert_eq!(said.len(), 1, "{said:?}");
        assert!(
            said[0].contains("track 4") && said[0].contains("unseen"),
            "{said:?}"
        );
        assert!(said[0].contains("pulling away"), "{said:?}");
        assert_eq!((m.pull_away_warnings, m.losses), (1, 1));
    }

    #[test]
    fn a_robot_that_keeps_up_or_is_below_its_limit_is_not_warned() {
        let mut m = FollowMonitor::new(1.4, 1.0);
        let locked = TargetState::Locked { track: 1 };
        for k in 0..200 {
            let t = 0.05 * f64::from(k);
            // Below the limit while the gap grows (the robot accelerating)...
            assert!(
                m.observe(at(t), 1.0, Some(1.0 + 0.2 * t), &locked)
                    .is_empty()
            );
        }
        for k in 200..400 {
            let t = 0.05 * f64::from(k);
            // ...and at the limit with a steady gap.
            assert!(m.observe(at(t), 1.4, Some(3.0), &locked).is_empty());
        }
        assert_eq!(m.losses, 0);
        assert!(
            m.observe(at(30.0), 0.0, None, &TargetState::Searching)
                .is_empty()
        );
    }
}
