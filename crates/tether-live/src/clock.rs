//! The live robot's clock: wall-clock time (ns since the Unix epoch, what ROS stamps and
//! MCAP viewers expect) that never jumps, or a simulator's time (ROS 2 `/clock`,
//! `use_sim_time`).
//!
//! The wall clock is read once at the start; from then on time advances with the
//! monotonic clock. An NTP step during a run therefore neither freezes the pipeline
//! (data that would seem to come from the past) nor fakes a data gap for the watchdog.

use std::sync::Arc;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::time::Instant;

use tether_scip::{Clock, SystemClock};

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

/// Simulated time: the newest `/clock` a simulator published, shared by the threads
/// that stamp data. It only goes forward: a clock message older than the newest is
/// counted and ignored (a restarted simulator needs a restarted node, as in ROS).
#[derive(Debug, Clone, Default)]
pub struct SimClock {
    now_ns: Arc<AtomicI64>,
    backward: Arc<AtomicU64>,
}

impl SimClock {
    /// A clock that has not started (0 until the first [`SimClock::set`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the time to `ns`; `false` (and counted) when that is before the time now.
    pub fn set(&self, ns: i64) -> bool {
        let before = self.now_ns.fetch_max(ns, Ordering::AcqRel);
        if ns < before {
            self.backward.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        true
    }

    /// Whether a time has been set.
    pub fn started(&self) -> bool {
        self.now_ns.load(Ordering::Acquire) > 0
    }

    /// Clock messages that went back in time and were ignored.
    pub fn backward_jumps(&self) -> u64 {
        self.backward.load(Ordering::Relaxed)
    }
}

impl Clock for SimClock {
    fn now_ns(&self) -> i64 {
        self.now_ns.load(Ordering::Acquire)
    }
}

/// The clock a live run uses: the host's, or a simulator's.
#[derive(Debug, Clone)]
pub enum LiveClock {
    /// [`MonotonicClock`].
    Host(MonotonicClock),
    /// [`SimClock`].
    Sim(SimClock),
}

impl Clock for LiveClock {
    fn now_ns(&self) -> i64 {
        match self {
            LiveClock::Host(c) => c.now_ns(),
            LiveClock::Sim(c) => c.now_ns(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sim_time_only_goes_forward_and_is_shared() {
        let clock = SimClock::new();
        assert!(!clock.started());
        assert_eq!(clock.now_ns(), 0);
        let live = LiveClock::Sim(clock.clone());
        assert!(clock.set(5_000_000_000));
        assert!(clock.started());
        assert_eq!(live.now_ns(), 5_000_000_000);
        assert!(!clock.set(4_000_000_000));
        assert_eq!(live.now_ns(), 5_000_000_000);
        assert_eq!(clock.backward_jumps(), 1);
        assert!(clock.set(5_000_000_000), "the same time again is no jump");
        assert!(clock.set(6_000_000_000));
        assert_eq!(live.now_ns(), 6_000_000_000);
    }

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
