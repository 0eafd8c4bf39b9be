//! The control timer (design 6): the instants at which the pipeline ticks without data,
//! so that its watchdog stops the robot when every sensor falls silent. The live loop
//! and a replay of a recording take their timer ticks from it alike, which is what
//! makes a replay's commands the live robot's.
//!
//! The instants are the multiples of the period on the clock, `t_k = k * period`: a
//! replay finds the same instants from the recording's first message without knowing
//! when the live run started. Each datum that arrives at time `a` comes after every
//! instant `t_k <= a` (the timer first on a tie), and is processed at time `a`.

use std::time::Duration;

use tether_core::Stamp;

/// The control timer's period on a robot (`tether run`, `tether ros2`) and in a replay:
/// 20 Hz.
pub const CONTROL_PERIOD: Duration = Duration::from_millis(50);

/// More than this far behind (a machine that stalled, a simulated clock that jumped),
/// the timer leaves out the instants it missed instead of ticking through them at once,
/// ns.
pub const MAX_CATCH_UP_NS: i64 = 1_000_000_000;

/// The control timer's instants.
#[derive(Debug, Clone)]
pub struct ControlTimer {
    period_ns: i64,
    next: Stamp,
    skipped: u64,
}

impl ControlTimer {
    /// A timer of `period_ns` (at least 1 ms) whose first instant is the first multiple
    /// of the period at or after `start`.
    pub fn new(start: Stamp, period_ns: i64) -> Self {
        let period_ns = period_ns.max(1_000_000);
        let k = start.ns().div_euclid(period_ns) + i64::from(start.ns().rem_euclid(period_ns) != 0);
        ControlTimer {
            period_ns,
            next: Stamp::from_ns(k.saturating_mul(period_ns)),
            skipped: 0,
        }
    }

    /// The next instant.
    pub fn next(&self) -> Stamp {
        self.next
    }

    /// The period, ns.
    pub fn period_ns(&self) -> i64 {
        self.period_ns
    }

    /// The next instant, if it is due at `now` (at or before it); the timer then moves
    /// on. More than [`MAX_CATCH_UP_NS`] behind, it moves to the last instant at or
    /// before `now`, leaving out (and counting) those between.
    pub fn due(&mut self, now: Stamp) -> Option<Stamp> {
        if self.next > now {
            return None;
        }
        if now.ns_since(self.next) > MAX_CATCH_UP_NS {
            let missed = now.ns_since(self.next) / self.period_ns;
            self.skipped += u64::try_from(missed).unwrap_or(0);
            self.next = self
                .next
                .saturating_add_ns(missed.saturating_mul(self.period_ns));
        }
        let due = self.next;
        self.next = due.saturating_add_ns(self.period_ns);
        Some(due)
    }

    /// Instants left out because the timer was too far behind.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(ms: i64) -> Stamp {
        Stamp::from_ns(ms * 1_000_000)
    }

    #[test]
    fn instants_are_the_multiples_of_the_period() {
        let mut timer = ControlTimer::new(ms(1_012), 50_000_000);
        assert_eq!(timer.next(), ms(1_050));
        assert_eq!(timer.due(ms(1_049)), None);
        assert_eq!(timer.due(ms(1_050)), Some(ms(1_050)), "due on the instant");
        assert_eq!(timer.due(ms(1_120)), Some(ms(1_100)));
        assert_eq!(timer.due(ms(1_120)), None);
        assert_eq!(ControlTimer::new(ms(1_050), 50_000_000).next(), ms(1_050));
    }

    #[test]
    fn a_short_delay_is_caught_up_a_long_one_is_left_out() {
        let mut timer = ControlTimer::new(ms(0), 50_000_000);
        let caught: Vec<_> = std::iter::from_fn(|| timer.due(ms(200))).collect();
        assert_eq!(caught, vec![ms(0), ms(50), ms(100), ms(150), ms(200)]);
        assert_eq!(timer.skipped(), 0);
        let after_stall: Vec<_> = std::iter::from_fn(|| timer.due(ms(5_230))).collect();
        assert_eq!(after_stall, vec![ms(5_200)], "no burst after 5 s");
        assert_eq!(timer.skipped(), 99);
        assert_eq!(timer.next(), ms(5_250));
    }
}
