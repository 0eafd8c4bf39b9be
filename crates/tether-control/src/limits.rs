//! Speed, turn-rate, wheel-speed and acceleration limits of a differential base.
//!
//! Saturation scales `(v, w)` together so that the curvature `w / v` (the path the robot
//! drives) is kept; only the pace changes. Wheel speeds are `v +- w b / 2` (design 6).
//! Acceleration limits also scale the change of `(v, w)` by one common factor.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A velocity command, as `geometry_msgs/Twist` on `/cmd_vel` carries it.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Forward speed, m/s.
    pub v_mps: f64,
    /// Turn rate, counter-clockwise, rad/s.
    pub w_radps: f64,
}

impl Twist {
    /// Standing still.
    pub const STOP: Twist = Twist {
        v_mps: 0.0,
        w_radps: 0.0,
    };

    /// Left and right wheel speeds for track width `b`: `v -+ w b / 2`, m/s.
    pub fn wheel_speeds_mps(&self, track_width_m: f64) -> (f64, f64) {
        let half = 0.5 * track_width_m * self.w_radps;
        (self.v_mps - half, self.v_mps + half)
    }
}

/// Limits of the base.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct MotionLimits {
    /// Top forward speed, m/s.
    #[config(range = "> 0, <= 3")]
    pub max_speed_mps: f64,
    /// Top reverse speed, m/s (0: never reverse). The laser does not see behind, so the
    /// pipeline only reverses along the path the robot has just driven.
    pub max_reverse_mps: f64,
    /// Top turn rate, rad/s.
    #[config(range = "> 0, <= 2pi")]
    pub max_turn_radps: f64,
    /// Top speed of either wheel, m/s.
    #[config(range = "> 0, <= 3")]
    pub max_wheel_speed_mps: f64,
    /// Distance between the wheels, m.
    #[config(range = "> 0, <= 2")]
    pub track_width_m: f64,
    /// Largest increase of speed, m/s^2.
    #[config(range = "> 0, <= 10")]
    pub max_accel_mps2: f64,
    /// Largest decrease of speed (braking), m/s^2.
    #[config(range = "> 0, <= 10")]
    pub max_decel_mps2: f64,
    /// Largest change of turn rate, rad/s^2.
    #[config(range = "> 0, <= 100")]
    pub max_angular_accel_radps2: f64,
    /// Largest change of the linear acceleration, m/s^3 (smoothness; emergency stops
    /// ignore it).
    #[config(range = "> 0, <= 1000")]
    pub max_jerk_mps3: f64,
    /// Largest change of the angular acceleration, rad/s^3.
    #[config(range = "> 0, <= 1000")]
    pub max_angular_jerk_radps3: f64,
}

impl Default for MotionLimits {
    fn default() -> Self {
        MotionLimits {
            max_speed_mps: 1.4,
            max_reverse_mps: 0.2,
            max_turn_radps: 1.8,
            max_wheel_speed_mps: 1.6,
            track_width_m: 0.3,
            max_accel_mps2: 1.2,
            max_decel_mps2: 2.5,
            max_angular_accel_radps2: 4.0,
            max_jerk_mps3: 10.0,
            max_angular_jerk_radps3: 30.0,
        }
    }
}

/// Why limits are unusable.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("limit `{field}` = {value:?} is invalid: {why}")]
pub struct LimitsError {
    /// Field.
    pub field: &'static str,
    /// Value.
    pub value: f64,
    /// Requirement.
    pub why: &'static str,
}

impl MotionLimits {
    /// Checks every field against a range that keeps the robot safe: positive (a
    /// limit of 0 or below is no limit), and no larger than a person-following base
    /// can use (a `max_speed_mps` of 1e300 or a `max_reverse_mps` of 10 switches the
    /// limit off; the laser does not see behind, so reversing stays slow).
    pub fn validate(&self) -> Result<(), LimitsError> {
        for (field, value, top, why) in [
            (
                "max_speed_mps",
                self.max_speed_mps,
                3.0,
                "must be in (0, 3] m/s (a person walks at up to 2 m/s)",
            ),
            (
                "max_turn_radps",
                self.max_turn_radps,
                std::f64::consts::TAU,
                "must be in (0, 6.28] rad/s (one turn a second)",
            ),
            (
                "max_wheel_speed_mps",
                self.max_wheel_speed_mps,
                3.0,
                "must be in (0, 3] m/s",
            ),
            (
                "track_width_m",
                self.track_width_m,
                2.0,
                "must be in (0, 2] m",
            ),
            (
                "max_accel_mps2",
                self.max_accel_mps2,
                10.0,
                "must be in (0, 10] m/s^2",
            ),
            (
                "max_decel_mps2",
                self.max_decel_mps2,
                10.0,
                "must be in (0, 10] m/s^2",
            ),
            (
                "max_angular_accel_radps2",
                self.max_angular_accel_radps2,
                100.0,
                "must be in (0, 100] rad/s^2",
            ),
            (
                "max_jerk_mps3",
                self.max_jerk_mps3,
                1000.0,
                "must be in (0, 1000] m/s^3",
            ),
            (
                "max_angular_jerk_radps3",
                self.max_angular_jerk_radps3,
                1000.0,
                "must be in (0, 1000] rad/s^3",
            ),
        ] {
            if !(value.is_finite() && value > 0.0 && value <= top) {
                return Err(LimitsError { field, value, why });
            }
        }
        if !(self.max_reverse_mps.is_finite() && (0.0..=0.5).contains(&self.max_reverse_mps)) {
            return Err(LimitsError {
                field: "max_reverse_mps",
                value: self.max_reverse_mps,
                why: "must be in [0, 0.5] m/s (0: never reverse; the laser does not see behind)",
            });
        }
        Ok(())
    }

    /// Scales `desired` down (keeping its curvature) until speed, turn rate and both
    /// wheel speeds are within limits. Non-finite input gives a stop.
    pub fn saturate(&self, desired: Twist) -> Twist {
        if !(desired.v_mps.is_finite() && desired.w_radps.is_finite()) {
            return Twist::STOP;
        }
        let mut t = desired;
        if t.v_mps < 0.0 && self.max_reverse_mps == 0.0 {
            t.v_mps = 0.0;
        }
        let (l, r) = t.wheel_speeds_mps(self.track_width_m);
        let speed_ratio = if t.v_mps >= 0.0 {
            t.v_mps / self.max_speed_mps
        } else {
            -t.v_mps / self.max_reverse_mps
        };
        let k = [
            1.0,
            speed_ratio,
            t.w_radps.abs() / self.max_turn_radps,
            l.abs() / self.max_wheel_speed_mps,
            r.abs() / self.max_wheel_speed_mps,
        ]
        .into_iter()
        .fold(1.0, f64::max);
        Twist {
            v_mps: t.v_mps / k,
            w_radps: t.w_radps / k,
        }
    }

    /// Limits the change from `previous` to `desired` over `dt_s` (one common factor on
    /// both components). Braking uses the larger deceleration limit.
    pub fn limit_acceleration(&self, previous: Twist, desired: Twist, dt_s: f64) -> Twist {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return previous;
        }
        let dv = desired.v_mps - previous.v_mps;
        let dw = desired.w_radps - previous.w_radps;
        let braking = desired.v_mps.abs() < previous.v_mps.abs();
        let a = if braking {
            self.max_decel_mps2
        } else {
            self.max_accel_mps2
        };
        let k = [
            1.0,
            dv.abs() / (a * dt_s),
            dw.abs() / (self.max_angular_accel_radps2 * dt_s),
        ]
        .into_iter()
        .fold(1.0, f64::max);
        Twist {
            v_mps: previous.v_mps + dv / k,
            w_radps: previous.w_radps + dw / k,
        }
    }

    /// Saturation then acceleration limits.
    pub fn apply(&self, previous: Twist, desired: Twist, dt_s: f64) -> Twist {
        self.saturate(self.limit_acceleration(previous, self.saturate(desired), dt_s))
    }

    /// Saturation, jerk and acceleration limits from the previous motion state, never
    /// stepping past the wanted velocity (design 6, "Limits").
    ///
    /// Per axis, with `e = v_wanted - v`: the acceleration moves toward `e / dt` (there
    /// in one step) by at most `j dt`, then the acceleration limits apply. A step that
    /// would cross the wanted velocity (the acceleration, limited in how fast it may
    /// change, still carrying the command on) ends on it instead, one that starts on it
    /// stays there, and one that would cross zero away from it ends at zero: a stop
    /// never commands the opposite direction, and no command changes sign unless asked
    /// to. With `emergency` the jerk limit is skipped (braking as hard as allowed at
    /// once).
    pub fn apply_smooth(
        &self,
        previous: MotionState,
        desired: Twist,
        dt_s: f64,
        emergency: bool,
    ) -> MotionState {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return previous;
        }
        let target = self.saturate(desired);
        let accel = |v: f64, a: f64, wanted: f64, jerk: f64| {
            let e = wanted - v;
            if emergency {
                return e / dt_s;
            }
            a + (e / dt_s - a).clamp(-jerk * dt_s, jerk * dt_s)
        };
        let av = accel(
            previous.twist.v_mps,
            previous.accel_mps2,
            target.v_mps,
            self.max_jerk_mps3,
        );
        let aw = accel(
            previous.twist.w_radps,
            previous.angular_accel_radps2,
            target.w_radps,
            self.max_angular_jerk_radps3,
        );
        let stepped = Twist {
            v_mps: previous.twist.v_mps + av * dt_s,
            w_radps: previous.twist.w_radps + aw * dt_s,
        };
        let limited = self.saturate(self.limit_acceleration(previous.twist, stepped, dt_s));
        // Never past the wanted velocity: a step that crosses it ends on it, one that
        // starts on it stays there, and one that crosses zero to the side the wanted
        // velocity is not on (the acceleration still carrying it away) ends at zero.
        let no_further = |from: f64, to: f64, wanted: f64| {
            if (wanted - from) * (wanted - to) < 0.0 || from == wanted {
                wanted
            } else if from * to < 0.0 && wanted * to <= 0.0 {
                0.0
            } else {
                to
            }
        };
        let twist = Twist {
            v_mps: no_further(previous.twist.v_mps, limited.v_mps, target.v_mps),
            w_radps: no_further(previous.twist.w_radps, limited.w_radps, target.w_radps),
        };
        MotionState {
            twist,
            accel_mps2: (twist.v_mps - previous.twist.v_mps) / dt_s,
            angular_accel_radps2: (twist.w_radps - previous.twist.w_radps) / dt_s,
        }
    }
}

/// The commanded motion and its rate of change, for jerk limiting.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionState {
    /// The command.
    pub twist: Twist,
    /// Its linear acceleration, m/s^2.
    pub accel_mps2: f64,
    /// Its angular acceleration, rad/s^2.
    pub angular_accel_radps2: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn limits_that_switch_the_limit_off_are_refused() {
        assert_eq!(MotionLimits::default().validate(), Ok(()));
        let refused = |l: MotionLimits| l.validate().map_err(|e| e.field);
        let d = MotionLimits::default;
        assert_eq!(
            refused(MotionLimits {
                max_speed_mps: 1e300,
                ..d()
            }),
            Err("max_speed_mps")
        );
        assert_eq!(
            refused(MotionLimits {
                max_reverse_mps: 10.0,
                ..d()
            }),
            Err("max_reverse_mps")
        );
        assert_eq!(
            refused(MotionLimits {
                max_reverse_mps: -0.1,
                ..d()
            }),
            Err("max_reverse_mps")
        );
        assert_eq!(
            refused(MotionLimits {
                max_turn_radps: f64::INFINITY,
                ..d()
            }),
            Err("max_turn_radps")
        );
        assert_eq!(
            refused(MotionLimits {
                max_reverse_mps: 0.0,
                ..d()
            }),
            Ok(())
        );
    }

    proptest! {
        #[test]
        fn saturation_keeps_curvature_and_respects_every_limit(v in -3.0..3.0f64, w in -5.0..5.0f64) {
            let lim = MotionLimits { max_reverse_mps: 0.3, ..MotionLimits::default() };
            let t = lim.saturate(Twist { v_mps: v, w_radps: w });
            let (l, r) = t.wheel_speeds_mps(lim.track_width_m);
            let eps = 1e-9;
            prop_assert!(t.v_mps <= lim.max_speed_mps + eps && -t.v_mps <= lim.max_reverse_mps + eps);
            prop_assert!(t.w_radps.abs() <= lim.max_turn_radps + eps);
            prop_assert!(l.abs() <= lim.max_wheel_speed_mps + eps && r.abs() <= lim.max_wheel_speed_mps + eps);
            // Same curvature: v * w' == v' * w.
            prop_assert!((t.v_mps * w - v * t.w_radps).abs() < 1e-9);
        }

        #[test]
        fn acceleration_is_bounded(v0 in 0.0..1.4f64, w0 in -1.5..1.5f64, v1 in 0.0..1.4f64, w1 in -1.5..1.5f64) {
            let lim = MotionLimits::default();
            let dt = 0.05;
            let t = lim.limit_acceleration(Twist { v_mps: v0, w_radps: w0 }, Twist { v_mps: v1, w_radps: w1 }, dt);
            prop_assert!((t.v_mps - v0).abs() <= lim.max_decel_mps2 * dt + 1e-9);
            prop_assert!((t.w_radps - w0).abs() <= lim.max_angular_accel_radps2 * dt + 1e-9);
        }
    }

    proptest! {
        /// Issue 32: braking from any motion to any wanted velocity (a stop among them),
        /// smoothly or in an emergency, never steps past it on either axis, and gets
        /// there within 3 s.
        #[test]
        fn a_command_never_steps_past_the_wanted_velocity(
            v0 in -0.2..1.4f64, a0 in -2.5..1.2f64, w0 in -1.8..1.8f64, aw0 in -4.0..4.0f64,
            v1 in prop_oneof![Just(0.0), -0.2..1.4f64], w1 in prop_oneof![Just(0.0), -1.8..1.8f64],
            dt in 0.01..0.2f64, emergency in any::<bool>(),
        ) {
            let lim = MotionLimits::default();
            let wanted = lim.saturate(Twist { v_mps: v1, w_radps: w1 });
            let mut s = MotionState {
                twist: lim.saturate(Twist { v_mps: v0, w_radps: w0 }),
                accel_mps2: a0,
                angular_accel_radps2: aw0,
            };
            let side = |x: f64, goal: f64| (goal - x).signum();
            let (sv, sw) = (side(s.twist.v_mps, wanted.v_mps), side(s.twist.w_radps, wanted.w_radps));
            for _ in 0..(3.0 / dt) as usize {
                s = lim.apply_smooth(s, Twist { v_mps: v1, w_radps: w1 }, dt, emergency);
                let (v, w) = (s.twist.v_mps, s.twist.w_radps);
                prop_assert!(v == wanted.v_mps || side(v, wanted.v_mps) == sv, "v {v} past {}", wanted.v_mps);
                prop_assert!(w == wanted.w_radps || side(w, wanted.w_radps) == sw, "w {w} past {}", wanted.w_radps);
            }
            prop_assert!((s.twist.v_mps - wanted.v_mps).abs() < 1e-6 && (s.twist.w_radps - wanted.w_radps).abs() < 1e-6);
        }
    }

    #[test]
    fn jerk_is_bounded_unless_braking_in_an_emergency() {
        let lim = MotionLimits::default();
        let dt = 0.05;
        let mut s = MotionState::default();
        let go = Twist {
            v_mps: 1.0,
            w_radps: 0.0,
        };
        let mut last_a = 0.0;
        for _ in 0..40 {
            s = lim.apply_smooth(s, go, dt, false);
            // The step that lands on the wanted velocity ends the acceleration faster
            // than the jerk limit would: it never steps past it.
            if s.twist.v_mps != 1.0 {
                assert!((s.accel_mps2 - last_a).abs() <= lim.max_jerk_mps3 * dt + 1e-9);
            }
            last_a = s.accel_mps2;
        }
        assert_eq!(s.twist.v_mps, 1.0);
        let stopped = lim.apply_smooth(s, Twist::STOP, dt, true);
        assert!((stopped.twist.v_mps - (1.0 - lim.max_decel_mps2 * dt)).abs() < 1e-9);
    }

    #[test]
    fn no_reverse_by_default_and_nan_stops() {
        let lim = MotionLimits {
            max_reverse_mps: 0.0,
            ..MotionLimits::default()
        };
        assert_eq!(
            lim.saturate(Twist {
                v_mps: -0.5,
                w_radps: 0.2
            })
            .v_mps,
            0.0
        );
        assert_eq!(
            lim.saturate(Twist {
                v_mps: f64::NAN,
                w_radps: 0.2
            }),
            Twist::STOP
        );
    }
}
