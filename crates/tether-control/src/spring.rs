//! The virtual spring follower (design 6, paper section V, corrected).
//!
//! The robot is pulled by a virtual spring attached at `J = (L, 0)`, `L > 0` ahead of the
//! wheel axis, towards the person at `p` (robot frame). With `d = |p - J|` and
//! `phi = atan2(p_y, p_x - L)`:
//!
//! ```text
//! F1 = k1 (d - d0)      along u = (cos phi, sin phi)     (stretch, free length d0)
//! F2 = k2 phi           along n = (-sin phi, cos phi)    (bending)
//! m dv/dt = F1 cos phi - F2 sin phi - k3 (v - v_ref)
//! I dw/dt = L (max(F1, 0) sin phi + F2 |cos phi|) - k4 w
//! ```
//!
//! (design 6 has `F1` in the torque; a compressed spring, `F1 < 0`, would turn the robot
//! away from a person who is close and off to the side, which is exactly the corner
//! case of following. Only a stretched spring turns the robot here; near `phi = 0` the
//! two forms have the same linearisation. Likewise the bending torque takes `|cos phi|`:
//! with the person behind the robot (`|phi| > pi / 2`, seen by a rear scanner, design
//! 5.7) `F2 cos phi` would turn the robot away from them, the long way round, and
//! against the stretched spring, so that a robot whose person walked round it stood
//! backing up instead of turning round; in front of the robot nothing changes.)
//!
//! where `v_ref` is 0 (damping to rest) or, with relative damping, the person's tracked
//! speed along the robot's x axis, which removes the steady lag `k3 V / k1` behind a
//! person walking at `V`.
//!
//! Linearised about rest the distance error obeys `m e'' + k3 e' + k1 e = 0` and the
//! bearing `I phi'' + k4 phi' + (1 + L/d0) L k2 phi = 0`. [`SpringGains::critically_damped`]
//! picks `k1..k4` from natural frequencies so that both loops are critically damped.
//!
//! The paper as printed has no free length (equilibrium at `d = 0`, a collision) and
//! mirrored force directions (positive feedback: it backs away from a person ahead);
//! [`SpringVariant::PaperAsPrinted`] reproduces it for comparison only.

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Which equations to integrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpringVariant {
    /// The corrected model of design 6.
    #[default]
    Corrected,
    /// The equations as printed in the paper: `F1 = k1 d` and both accelerations with
    /// the opposite sign. For comparison only: it is unstable.
    PaperAsPrinted,
}

/// Gains and virtual inertia of the spring.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields)]
pub struct SpringGains {
    /// Stretch stiffness, N/m.
    #[config(range = "> 0")]
    pub k1: f64,
    /// Bending stiffness, N/rad.
    #[config(range = "> 0")]
    pub k2: f64,
    /// Linear damping, N s/m.
    #[config(range = "> 0")]
    pub k3: f64,
    /// Angular damping, N m s/rad.
    #[config(range = "> 0")]
    pub k4: f64,
    /// Virtual mass, kg.
    #[config(range = "> 0")]
    pub mass_kg: f64,
    /// Virtual moment of inertia, kg m^2.
    #[config(range = "> 0")]
    pub inertia_kgm2: f64,
}

impl SpringGains {
    /// Gains that make both linearised loops critically damped: the distance loop with
    /// natural frequency `omega_d` (rad/s) and the bearing loop with `omega_b`, for mass
    /// `m`, inertia `i`, attachment `L` and free length `d0`:
    /// `k1 = m omega_d^2`, `k3 = 2 m omega_d`, `k2 = i omega_b^2 / ((1 + L/d0) L)`,
    /// `k4 = 2 i omega_b`.
    pub fn critically_damped(
        omega_d: f64,
        omega_b: f64,
        mass_kg: f64,
        inertia_kgm2: f64,
        l_m: f64,
        d0_m: f64,
    ) -> Self {
        SpringGains {
            k1: mass_kg * omega_d * omega_d,
            k3: 2.0 * mass_kg * omega_d,
            k2: inertia_kgm2 * omega_b * omega_b / ((1.0 + l_m / d0_m) * l_m),
            k4: 2.0 * inertia_kgm2 * omega_b,
            mass_kg,
            inertia_kgm2,
        }
    }
}

/// Follower settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, tether_core::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct SpringConfig {
    /// Follow distance: the spring's free length, m (user studies prefer 1.2-2.0 m; the
    /// paper's robot kept 0.65-0.8 m).
    #[config(range = "> 0")]
    pub follow_distance_m: f64,
    /// Attachment point ahead of the wheel axis, m.
    #[config(range = "> 0")]
    pub attach_ahead_m: f64,
    /// Natural frequency of the distance loop, rad/s.
    #[config(range = "> 0")]
    pub distance_omega_radps: f64,
    /// Natural frequency of the bearing loop, rad/s.
    #[config(range = "> 0")]
    pub bearing_omega_radps: f64,
    /// Virtual mass, kg.
    #[config(range = "> 0")]
    pub mass_kg: f64,
    /// Virtual inertia, kg m^2.
    #[config(range = "> 0")]
    pub inertia_kgm2: f64,
    /// Damp the speed relative to the person's tracked speed (removes the lag).
    pub relative_damping: bool,
    /// Explicit gains, overriding the ones derived from the frequencies.
    pub gains: Option<SpringGains>,
    /// Which equations.
    pub variant: SpringVariant,
}

impl Default for SpringConfig {
    fn default() -> Self {
        SpringConfig {
            follow_distance_m: 1.0,
            attach_ahead_m: 0.3,
            distance_omega_radps: 4.0,
            bearing_omega_radps: 3.0,
            mass_kg: 1.0,
            inertia_kgm2: 0.2,
            relative_damping: true,
            gains: None,
            variant: SpringVariant::Corrected,
        }
    }
}

/// Why follower settings are unusable.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("follower setting `{field}` = {value} is invalid: {why}")]
pub struct SpringConfigError {
    /// Field.
    pub field: &'static str,
    /// Value.
    pub value: f64,
    /// Requirement.
    pub why: &'static str,
}

impl SpringConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), SpringConfigError> {
        let mut fields = vec![
            ("follow_distance_m", self.follow_distance_m),
            ("attach_ahead_m", self.attach_ahead_m),
            ("distance_omega_radps", self.distance_omega_radps),
            ("bearing_omega_radps", self.bearing_omega_radps),
            ("mass_kg", self.mass_kg),
            ("inertia_kgm2", self.inertia_kgm2),
        ];
        if let Some(g) = &self.gains {
            fields.extend([
                ("gains.k1", g.k1),
                ("gains.k2", g.k2),
                ("gains.k3", g.k3),
                ("gains.k4", g.k4),
                ("gains.mass_kg", g.mass_kg),
                ("gains.inertia_kgm2", g.inertia_kgm2),
            ]);
        }
        for (field, value) in fields {
            if !(value.is_finite() && value > 0.0) {
                return Err(SpringConfigError {
                    field,
                    value,
                    why: "must be a positive number (L > 0: with L = 0 the spring cannot turn the robot)",
                });
            }
        }
        Ok(())
    }

    /// The gains in use.
    pub fn gains(&self) -> SpringGains {
        self.gains.unwrap_or_else(|| {
            SpringGains::critically_damped(
                self.distance_omega_radps,
                self.bearing_omega_radps,
                self.mass_kg,
                self.inertia_kgm2,
                self.attach_ahead_m,
                self.follow_distance_m,
            )
        })
    }
}

/// The spring's internal state: the virtual body's speed and turn rate.
#[derive(Debug, Clone)]
pub struct VirtualSpring {
    config: SpringConfig,
    gains: SpringGains,
    v_mps: f64,
    w_radps: f64,
}

/// The person as the follower sees them, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PersonInRobot {
    /// Position, m.
    pub x_m: f64,
    /// Position, m.
    pub y_m: f64,
    /// Velocity along the robot's x axis (world velocity in robot axes), m/s.
    pub vx_mps: f64,
}

impl VirtualSpring {
    /// A follower at rest.
    pub fn new(config: SpringConfig) -> Result<Self, SpringConfigError> {
        config.validate()?;
        let gains = config.gains();
        Ok(VirtualSpring {
            config,
            gains,
            v_mps: 0.0,
            w_radps: 0.0,
        })
    }

    /// Settings.
    pub fn config(&self) -> &SpringConfig {
        &self.config
    }

    /// Gains in use.
    pub fn gains(&self) -> SpringGains {
        self.gains
    }

    /// The spring's distance `d` and angle `phi` for a person at `p`.
    pub fn geometry(&self, person: &PersonInRobot) -> (f64, f64) {
        let dx = person.x_m - self.config.attach_ahead_m;
        (dx.hypot(person.y_m), person.y_m.atan2(dx))
    }

    /// Integrates the spring by `dt_s` towards `person` and returns the new (v, w),
    /// before any limits.
    pub fn step(&mut self, person: &PersonInRobot, dt_s: f64) -> (f64, f64) {
        if !dt_s.is_finite() || dt_s <= 0.0 {
            return (self.v_mps, self.w_radps);
        }
        let g = self.gains;
        let l = self.config.attach_ahead_m;
        let (d, phi) = self.geometry(person);
        let (s, c) = phi.sin_cos();
        let (f1, sign) = match self.config.variant {
            SpringVariant::Corrected => (g.k1 * (d - self.config.follow_distance_m), 1.0),
            SpringVariant::PaperAsPrinted => (g.k1 * d, -1.0),
        };
        let f2 = g.k2 * phi;
        let v_ref =
            if self.config.relative_damping && self.config.variant == SpringVariant::Corrected {
                person.vx_mps.max(0.0)
            } else {
                0.0
            };
        let force = sign * (f1 * c - f2 * s);
        // A compressed spring (person closer than d0) pushes the robot back but does not
        // turn it away from the person: the turning comes from the stretched spring and
        // the bending spring only. (Without this, at a corner the compression torque
        // cancels the bending torque and the robot stops turning just when the person
        // walks off sideways.) The printed variant keeps the paper's form.
        let f1_turn = match self.config.variant {
            SpringVariant::Corrected => f1.max(0.0),
            SpringVariant::PaperAsPrinted => f1,
        };
        let bend_turn = match self.config.variant {
            SpringVariant::Corrected => c.abs(),
            SpringVariant::PaperAsPrinted => c,
        };
        let torque = sign * l * (f1_turn * s + f2 * bend_turn);
        // Spring forces explicit, damping implicit: unconditionally stable in the
        // damping terms, whatever the control period.
        self.v_mps = (self.v_mps + dt_s * (force + g.k3 * v_ref) / g.mass_kg)
            / (1.0 + dt_s * g.k3 / g.mass_kg);
        self.w_radps =
            (self.w_radps + dt_s * torque / g.inertia_kgm2) / (1.0 + dt_s * g.k4 / g.inertia_kgm2);
        (self.v_mps, self.w_radps)
    }

    /// Tells the spring what the robot actually commands after limits, so that its
    /// internal speed does not wind up beyond what the base can do.
    pub fn sync(&mut self, v_mps: f64, w_radps: f64) {
        if v_mps.is_finite() && w_radps.is_finite() {
            self.v_mps = v_mps;
            self.w_radps = w_radps;
        }
    }

    /// Brings the virtual body to rest (target lost, stale data, obstacle).
    pub fn reset(&mut self) {
        self.v_mps = 0.0;
        self.w_radps = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed loop with a kinematic unicycle: the person walks at `speed` along +x from
    /// `start_x`, `start_y`; returns (time, distance from J, bearing phi, v) samples.
    fn simulate(
        config: SpringConfig,
        start_x: f64,
        start_y: f64,
        speed: f64,
        seconds: f64,
    ) -> Vec<(f64, f64, f64, f64)> {
        let mut spring = VirtualSpring::new(config).unwrap();
        let (mut rx, mut ry, mut rt) = (0.0f64, 0.0f64, 0.0f64);
        let dt = 0.02;
        let mut out = Vec::new();
        for k in 0..(seconds / dt) as usize {
            let t = k as f64 * dt;
            let (px, py) = (start_x + speed * t, start_y);
            // Person in the robot frame.
            let (dx, dy) = (px - rx, py - ry);
            let (s, c) = rt.sin_cos();
            let person = PersonInRobot {
                x_m: c * dx + s * dy,
                y_m: -s * dx + c * dy,
                vx_mps: c * speed,
            };
            let (v, w) = spring.step(&person, dt);
            let (d, phi) = spring.geometry(&person);
            out.push((t, d, phi, v));
            rx += v * dt * rt.cos();
            ry += v * dt * rt.sin();
            rt += w * dt;
        }
        out
    }

    #[test]
    fn settles_at_the_follow_distance_without_overshoot() {
        let config = SpringConfig {
            relative_damping: false,
            ..SpringConfig::default()
        };
        let d0 = config.follow_distance_m;
        let run = simulate(config, 3.0, 0.0, 0.0, 10.0);
        let last = run.last().unwrap();
        assert!((last.1 - d0).abs() < 0.01, "settled at {}", last.1);
        let closest = run.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
        assert!(
            closest > d0 - 0.01,
            "critically damped: no overshoot, closest {closest}"
        );
    }

    #[test]
    fn turns_towards_a_person_on_the_left() {
        let mut spring = VirtualSpring::new(SpringConfig::default()).unwrap();
        let (_, w) = spring.step(
            &PersonInRobot {
                x_m: 2.0,
                y_m: 1.0,
                vx_mps: 0.0,
            },
            0.05,
        );
        assert!(w > 0.0);
        let run = simulate(SpringConfig::default(), 2.5, 1.5, 0.0, 10.0);
        assert!(run.last().unwrap().2.abs() < 0.02, "faces the person");
    }

    #[test]
    fn turns_round_towards_a_person_behind_it() {
        let mut spring = VirtualSpring::new(SpringConfig::default()).unwrap();
        for y_m in [0.3, 1.0] {
            let (_, w) = spring.step(
                &PersonInRobot {
                    x_m: -2.0,
                    y_m,
                    vx_mps: 0.0,
                },
                0.05,
            );
            assert!(w > 0.0, "behind and to the left ({y_m} m): turns left, {w}");
            spring.reset();
        }
        let run = simulate(SpringConfig::default(), -2.5, 0.4, 0.0, 12.0);
        let last = run.last().unwrap();
        assert!(last.2.abs() < 0.05, "faces the person: phi {}", last.2);
        let d0 = SpringConfig::default().follow_distance_m;
        assert!((last.1 - d0).abs() < 0.05, "at d0: {}", last.1);
    }

    #[test]
    fn relative_damping_removes_the_lag_behind_a_walker() {
        let lagging = SpringConfig {
            relative_damping: false,
            ..SpringConfig::default()
        };
        let g = lagging.gains();
        let expected_lag = g.k3 * 1.0 / g.k1;
        let run = simulate(lagging, 1.3, 0.0, 1.0, 20.0);
        let lag = run.last().unwrap().1 - 1.0;
        assert!(
            (lag - expected_lag).abs() < 0.05,
            "lag {lag} vs k3 V / k1 = {expected_lag}"
        );
        let run = simulate(SpringConfig::default(), 1.3, 0.0, 1.0, 20.0);
        let lag = run.last().unwrap().1 - 1.0;
        assert!(lag.abs() < 0.02, "relative damping lag {lag}");
    }

    #[test]
    fn the_equations_as_printed_back_away_from_a_person_ahead() {
        let config = SpringConfig {
            variant: SpringVariant::PaperAsPrinted,
            ..SpringConfig::default()
        };
        let run = simulate(config, 2.0, 0.0, 0.0, 3.0);
        assert!(
            run.last().unwrap().3 < -0.5,
            "v = {}",
            run.last().unwrap().3
        );
        assert!(
            run.last().unwrap().1 > 4.0,
            "runs away: d = {}",
            run.last().unwrap().1
        );
    }

    #[test]
    fn refuses_a_spring_attached_at_the_axle() {
        let config = SpringConfig {
            attach_ahead_m: 0.0,
            ..SpringConfig::default()
        };
        assert!(VirtualSpring::new(config).is_err());
    }
}
