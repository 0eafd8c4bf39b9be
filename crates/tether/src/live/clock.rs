//! The live robot's clock: wall-clock time (ns since the Unix epoch, what ROS stamps and
//! MCAP viewers expect) that never jumps.
//!
//! The wall clock is read once at the start; from then on time advances with the
//! monotonic clock. An NTP step during a run therefore neither freezes the pipeline
//! (data that would seem to come from the past) nor fakes a data gap for the watchdog.

use std::time::Instant;

use tether_io::scip::{Clock, SystemClock};

/// Wall-clock time at the start plus monotonic time since.
#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    origin_ns: i64,
    start: Instant,
}

impl MonotonicClock {
    /// A clock starting at the current wall-clock time.
    pub fn new() -> Self {
        MonotonicClock {
            origin_ns: SystemClock.now_ns(),
            start: Instant::now(),
        }
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for MonotonicClock {
    fn now_ns(&self) -> i64 {
        let elapsed = i64::try_from(self.start.elapsed().as_nanos()).unwrap_or(i64::MAX);
        self.origin_ns.saturating_add(elapsed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_at_wall_time_and_never_goes_back() {
        let clock = MonotonicClock::new();
        let wall = SystemClock.now_ns();
        let mut last = clock.now_ns();
        assert!((last - wall).abs() < 1_000_000_000);
        for _ in 0..1000 {
            let now = clock.now_ns();
            assert!(now >= last);
            last = now;
        }
        let copy = clock;
        assert!(copy.now_ns() >= last, "copies share the origin");
    }
}
