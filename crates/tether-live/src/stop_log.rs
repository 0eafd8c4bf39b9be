//! Why the robot was held over a run: for each [`StopReason`], how many times a hold
//! began and for how long the robot was held, so that a user whose robot stood still
//! can read why at the end of `tether run` or `tether ros2` (design 6, the safety layer).

use std::collections::BTreeMap;

use tether_control::StopReason;
use tether_core::Stamp;

/// Holds of one reason: how often one began and their total length.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Holds {
    /// Times a hold for this reason began (a tick with the reason after one without).
    pub episodes: u64,
    /// Total time held, s: the sum over held ticks of the time to the next tick.
    pub held_s: f64,
}

/// Keeps the holds of a run, tick by tick.
#[derive(Debug, Clone, Default)]
pub struct StopLog {
    holds: BTreeMap<&'static str, Holds>,
    /// The last tick's stamp and reason.
    last: Option<(Stamp, Option<StopReason>)>,
}

impl StopLog {
    /// An empty log.
    pub fn new() -> Self {
        StopLog::default()
    }

    /// Records a tick at `stamp` held for `reason` (`None`: the robot was free to drive).
    /// The time from the previous tick is counted to the previous tick's reason; a tick
    /// whose stamp went backwards counts no time.
    pub fn record(&mut self, stamp: Stamp, reason: Option<StopReason>) {
        let previous = self.last.replace((stamp, reason));
        if let Some((at, Some(was))) = previous {
            let dt_s = stamp.secs_since(at);
            if dt_s.is_finite() && dt_s > 0.0 {
                self.holds.entry(was.name()).or_default().held_s += dt_s;
            }
        }
        if let Some(now) = reason
            && previous.and_then(|(_, was)| was) != Some(now)
        {
            self.holds.entry(now.name()).or_default().episodes += 1;
        }
    }

    /// The holds of `reason` so far.
    pub fn holds(&self, reason: StopReason) -> Holds {
        self.holds.get(reason.name()).copied().unwrap_or_default()
    }

    /// One line for the log, e.g. `held for: obstacle 3 times (0.9 s), no_target 1 time
    /// (1.5 s)`, or `never held` (reasons by name).
    pub fn one_line(&self) -> String {
        if self.holds.is_empty() {
            return "the robot was never held".into();
        }
        let parts: Vec<String> = self
            .holds
            .iter()
            .map(|(name, h)| {
                let times = if h.episodes == 1 { "time" } else { "times" };
                format!("{name} {} {times} ({:.1} s)", h.episodes, h.held_s)
            })
            .collect();
        format!("the robot was held for: {}", parts.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: f64) -> Stamp {
        Stamp::from_ns((s * 1e9).round() as i64)
    }

    #[test]
    fn holds_are_counted_once_each_and_timed_to_the_next_tick() {
        let mut log = StopLog::new();
        log.record(at(0.0), Some(StopReason::NoTarget));
        log.record(at(0.5), Some(StopReason::NoTarget));
        log.record(at(1.0), None);
        log.record(at(2.0), Some(StopReason::Obstacle));
        log.record(at(2.1), Some(StopReason::Obstacle));
        log.record(at(2.2), None);
        log.record(at(3.0), Some(StopReason::Obstacle));
        log.record(at(3.25), None);
        let obstacle = log.holds(StopReason::Obstacle);
        assert_eq!(obstacle.episodes, 2);
        assert!((obstacle.held_s - 0.45).abs() < 1e-9, "{obstacle:?}");
        let no_target = log.holds(StopReason::NoTarget);
        assert_eq!(no_target.episodes, 1);
        assert!((no_target.held_s - 1.0).abs() < 1e-9, "{no_target:?}");
        assert_eq!(log.holds(StopReason::StaleLaser), Holds::default());
        assert_eq!(
            log.one_line(),
            "the robot was held for: no_target 1 time (1.0 s), obstacle 2 times (0.5 s)"
        );
    }

    #[test]
    fn a_run_never_held_says_so_and_a_stamp_going_back_counts_no_time() {
        let mut log = StopLog::new();
        log.record(at(1.0), None);
        assert_eq!(log.one_line(), "the robot was never held");
        log.record(at(2.0), Some(StopReason::StaleLaser));
        log.record(at(1.5), Some(StopReason::StaleLaser));
        let stale = log.holds(StopReason::StaleLaser);
        assert_eq!(stale.episodes, 1);
        assert_eq!(stale.held_s, 0.0);
    }
}
