//! Time stamps: signed nanoseconds on a clock that the caller chooses.
//!
//! tether never reads a clock inside an algorithm (design section 1): the simulator, a
//! replayed log or the live driver passes stamps in, so the same input gives the same
//! output.

use serde::{Deserialize, Serialize};

/// Nanoseconds in one second.
pub const NS_PER_S: i64 = 1_000_000_000;

/// A point in time, in nanoseconds since the epoch of whichever clock produced it
/// (simulation start, ROS time, sensor time mapped to host time).
///
/// Serialised as a bare integer, named `stamp_ns` where it appears in files.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(transparent)]
pub struct Stamp(i64);

impl Stamp {
    /// The clock's epoch.
    pub const ZERO: Stamp = Stamp(0);

    /// A stamp `ns` nanoseconds after the epoch.
    pub const fn from_ns(ns: i64) -> Self {
        Stamp(ns)
    }

    /// A stamp from whole seconds and nanoseconds, as ROS `Time` stores it
    /// (`sec`, `nsec`). Returns `None` if the result does not fit in an `i64`.
    pub fn from_sec_nsec(sec: i64, nsec: u32) -> Option<Self> {
        sec.checked_mul(NS_PER_S)?
            .checked_add(i64::from(nsec))
            .map(Stamp)
    }

    /// A stamp `secs` seconds after the epoch, rounded to the nearest nanosecond.
    /// Returns `None` for non-finite or out-of-range values.
    pub fn from_secs_f64(secs: f64) -> Option<Self> {
        let ns = (secs * NS_PER_S as f64).round();
        // i64::MAX as f64 rounds up to 2^63, which does not fit; stay strictly below it.
        if ns.is_finite() && ns >= i64::MIN as f64 && ns < i64::MAX as f64 {
            Some(Stamp(ns as i64))
        } else {
            None
        }
    }

    /// Nanoseconds since the epoch.
    pub const fn ns(self) -> i64 {
        self.0
    }

    /// Seconds since the epoch (loses precision beyond ~104 days of nanoseconds).
    pub fn secs_f64(self) -> f64 {
        self.0 as f64 / NS_PER_S as f64
    }

    /// This stamp moved by `dt_ns` nanoseconds, saturating at the ends of the range.
    pub const fn saturating_add_ns(self, dt_ns: i64) -> Self {
        Stamp(self.0.saturating_add(dt_ns))
    }

    /// Nanoseconds from `earlier` to `self` (negative when `self` is earlier), saturating.
    pub const fn ns_since(self, earlier: Stamp) -> i64 {
        self.0.saturating_sub(earlier.0)
    }

    /// Seconds from `earlier` to `self` (negative when `self` is earlier).
    pub fn secs_since(self, earlier: Stamp) -> f64 {
        self.ns_since(earlier) as f64 / NS_PER_S as f64
    }
}

impl std::fmt::Display for Stamp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sign = if self.0 < 0 { "-" } else { "" };
        let abs = self.0.unsigned_abs();
        let ns_per_s = NS_PER_S as u64;
        write!(f, "{sign}{}.{:09}s", abs / ns_per_s, abs % ns_per_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_trip() {
        let s = Stamp::from_sec_nsec(12, 345_678_901).unwrap();
        assert_eq!(s.ns(), 12_345_678_901);
        assert_eq!(Stamp::from_secs_f64(s.secs_f64()), Some(s));
        assert_eq!(s.to_string(), "12.345678901s");
        assert_eq!(Stamp::from_ns(-1_500_000_000).to_string(), "-1.500000000s");
    }

    #[test]
    fn refuses_unrepresentable_seconds() {
        assert_eq!(Stamp::from_secs_f64(f64::NAN), None);
        assert_eq!(Stamp::from_secs_f64(1e30), None);
        assert_eq!(Stamp::from_sec_nsec(i64::MAX, 0), None);
    }

    #[test]
    fn differences_saturate() {
        let a = Stamp::from_ns(i64::MIN);
        let b = Stamp::from_ns(i64::MAX);
        assert_eq!(b.ns_since(a), i64::MAX);
        assert_eq!(b.saturating_add_ns(5), b);
        assert!((Stamp::from_ns(2_500_000_000).secs_since(Stamp::ZERO) - 2.5).abs() < 1e-12);
    }

    #[test]
    fn serialises_as_integer() {
        let json = serde_json::to_string(&Stamp::from_ns(42)).unwrap();
        assert_eq!(json, "42");
    }
}
