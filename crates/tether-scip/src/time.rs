//! Mapping the sensor's clock to the host's (manual C-42-03320B, section 8.6 `TM`).
//!
//! The sensor stamps each scan with its own millisecond counter, 24 bits wide (it wraps
//! every 2^24 ms = 4 h 39 min 37 s). `TM0` puts it in adjust mode, each `TM1` returns
//! the counter, `TM2` ends the mode. With the host's clock read just before sending
//! `TM1` (`t0`) and just after the reply (`t1`), the counter value `s` was taken at
//! about `(t0 + t1) / 2`; the round trip with the smallest `t1 - t0` bounds that best,
//! giving `host = sensor + offset`.
//!
//! Then, while scans stream, two clocks that tick at slightly different rates drift
//! apart (100 ppm is 0.36 s an hour). Each scan's arrival time is its true time plus a
//! transmission delay that is never below some floor; the smallest `arrival - sensor`
//! over a window of scans therefore follows the offset. [`TimeSync::observe`] learns
//! that floor over the first window and then moves the offset by the change of the
//! windowed minimum, and never lets a mapped stamp lie after the scan's arrival.
//!
//! Everything here takes times as numbers; nothing reads a clock.

/// Period of the sensor's 24-bit millisecond counter, ms.
pub const SENSOR_CLOCK_PERIOD_MS: i64 = 1 << 24;

const NS_PER_MS: i64 = 1_000_000;

/// One `TM1` exchange: host time before sending, the sensor's counter, host time after
/// the reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RoundTrip {
    /// Host time just before the request was written, ns.
    pub host_sent_ns: i64,
    /// The sensor's counter, ms (24 bits).
    pub sensor_ms: u32,
    /// Host time just after the reply was read, ns.
    pub host_received_ns: i64,
}

/// The mapping from sensor time to host time, kept up to date with scan arrivals.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeSync {
    /// `host_ns = unwrapped_sensor_ms * 1e6 + offset_ns`.
    offset_ns: i64,
    /// Scans per window of the drift tracker.
    window: usize,
    /// `arrival - mapped` of the scans of the current window.
    lags_ns: Vec<i64>,
    /// Smallest lag of the first full window (the transmission floor).
    floor_ns: Option<i64>,
    /// Times a stamp would have been later than its arrival and the offset was moved.
    causality_corrections: u64,
}

/// Default drift-tracking window: 50 scans (5 s of a URG-04LX).
pub const DEFAULT_WINDOW: usize = 50;

impl TimeSync {
    /// A mapping with a known offset (`host_ns = sensor_ms * 1e6 + offset_ns`).
    pub fn with_offset(offset_ns: i64) -> Self {
        TimeSync {
            offset_ns,
            window: DEFAULT_WINDOW,
            lags_ns: Vec::with_capacity(DEFAULT_WINDOW),
            floor_ns: None,
            causality_corrections: 0,
        }
    }

    /// The mapping from `TM1` exchanges: the one with the shortest round trip, its
    /// counter taken at the midpoint. `None` without any exchange (or with exchanges
    /// whose reply came before the request, which a working clock cannot produce).
    pub fn from_round_trips(trips: &[RoundTrip]) -> Option<Self> {
        let best = trips
            .iter()
            .filter(|t| t.host_received_ns >= t.host_sent_ns)
            .min_by_key(|t| t.host_received_ns - t.host_sent_ns)?;
        let mid_ns = best.host_sent_ns + (best.host_received_ns - best.host_sent_ns) / 2;
        Some(Self::with_offset(
            mid_ns - i64::from(best.sensor_ms) * NS_PER_MS,
        ))
    }

    /// Sets the number of scans per drift-tracking window (at least 1).
    pub fn set_window(&mut self, scans: usize) {
        self.window = scans.max(1);
        self.lags_ns.clear();
    }

    /// Current offset, ns.
    pub fn offset_ns(&self) -> i64 {
        self.offset_ns
    }

    /// How often a stamp would have been later than its arrival.
    pub fn causality_corrections(&self) -> u64 {
        self.causality_corrections
    }

    /// The host time of a counter value, unwrapped to the turn of the 24-bit counter
    /// nearest to `host_hint_ns` (the arrival time of the data, or any host time within
    /// 2 h of it).
    pub fn to_host_ns(&self, sensor_ms: u32, host_hint_ns: i64) -> i64 {
        let raw = i64::from(sensor_ms) % SENSOR_CLOCK_PERIOD_MS;
        // The unwrapped counter the hint corresponds to.
        let hint_ms = host_hint_ns
            .saturating_sub(self.offset_ns)
            .div_euclid(NS_PER_MS);
        let turns = (hint_ms - raw + SENSOR_CLOCK_PERIOD_MS / 2).div_euclid(SENSOR_CLOCK_PERIOD_MS);
        let unwrapped_ms = raw + turns * SENSOR_CLOCK_PERIOD_MS;
        unwrapped_ms
            .saturating_mul(NS_PER_MS)
            .saturating_add(self.offset_ns)
    }

    /// Learns from a scan stamped `sensor_ms` that arrived at `host_received_ns`, and
    /// returns the scan's host time (ns) under the updated mapping.
    pub fn observe(&mut self, sensor_ms: u32, host_received_ns: i64) -> i64 {
        let mapped = self.to_host_ns(sensor_ms, host_received_ns);
        let lag = host_received_ns.saturating_sub(mapped);
        if lag < 0 {
            // The scan would have been made after it arrived: the sensor's clock has
            // run ahead of the mapping.
            self.offset_ns = self.offset_ns.saturating_add(lag);
            self.causality_corrections += 1;
            if let Some(floor) = self.floor_ns.as_mut() {
                *floor = (*floor + lag).max(0);
            }
        }
        self.lags_ns.push(lag.max(0));
        if self.lags_ns.len() >= self.window {
            let min = self.lags_ns.iter().copied().min().unwrap_or(0);
            match self.floor_ns {
                None => self.floor_ns = Some(min),
                Some(floor) => self.offset_ns = self.offset_ns.saturating_add(min - floor),
            }
            self.lags_ns.clear();
        }
        self.to_host_ns(sensor_ms, host_received_ns)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_shortest_round_trip() {
        let trips = [
            RoundTrip {
                host_sent_ns: 1_000_000_000,
                sensor_ms: 500,
                host_received_ns: 1_040_000_000,
            },
            RoundTrip {
                host_sent_ns: 2_000_000_000,
                sensor_ms: 1_502,
                host_received_ns: 2_004_000_000,
            },
        ];
        let sync = TimeSync::from_round_trips(&trips).unwrap();
        // Midpoint 2.002 s for 1.502 s of sensor time.
        assert_eq!(sync.offset_ns(), 500_000_000);
        assert_eq!(sync.to_host_ns(1_502, 2_010_000_000), 2_002_000_000);
        assert!(TimeSync::from_round_trips(&[]).is_none());
    }

    #[test]
    fn unwraps_the_24_bit_counter() {
        let sync = TimeSync::with_offset(0);
        let period_ns = SENSOR_CLOCK_PERIOD_MS * NS_PER_MS;
        // Just after the third wrap, the counter reads 10 ms.
        let host = 3 * period_ns + 10 * NS_PER_MS;
        assert_eq!(sync.to_host_ns(10, host + 30 * NS_PER_MS), host);
        // Just before a wrap, seen just after it.
        let host = 3 * period_ns - 5 * NS_PER_MS;
        assert_eq!(
            sync.to_host_ns((SENSOR_CLOCK_PERIOD_MS - 5) as u32, host + 20 * NS_PER_MS),
            host
        );
    }

    /// Scans every 100 ms for two hours from a sensor whose clock runs `ppm` fast or
    /// slow, arriving 20 ms + up to 6 ms of jitter after they were made (a fixed
    /// pseudo-random sequence); every mapped stamp stays within 3 ms of the truth.
    fn follows_drift(ppm: f64) {
        let true_offset_ns = -7_000_000_000i64;
        let mut sync = TimeSync::with_offset(true_offset_ns);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut worst = 0i64;
        for k in 0..72_000i64 {
            let true_ns = k * 100_000_000 + 1_000_000_000;
            let sensor_ms =
                ((true_ns - true_offset_ns) as f64 * (1.0 + ppm * 1e-6) / 1e6).floor() as i64;
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let jitter_ns = (state % 6_000_000) as i64;
            let arrival = true_ns + 20_000_000 + jitter_ns;
            let mapped = sync.observe((sensor_ms % SENSOR_CLOCK_PERIOD_MS) as u32, arrival);
            worst = worst.max((mapped - true_ns).abs());
        }
        assert!(worst < 3_000_000, "{ppm} ppm: worst error {worst} ns");
    }

    #[test]
    fn follows_a_fast_sensor_clock() {
        follows_drift(100.0);
    }

    #[test]
    fn follows_a_slow_sensor_clock() {
        follows_drift(-100.0);
    }
}
