//! The laser range finder's model: Hokuyo URG-04LX geometry, range limits, the range
//! noise model bias(r) / sigma(r), and where the scanner sits on the robot (design 2.1).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::frame::{Laser, Robot};
use crate::geometry::Pose2;
use crate::time::NS_PER_S;

/// Why a laser model cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LaserModelError {
    /// The step geometry is inconsistent.
    #[error(
        "laser geometry needs 0 <= first_step <= front_step <= last_step < steps_per_rev, \
         got first {first}, front {front}, last {last}, per revolution {per_rev}"
    )]
    BadGeometry {
        /// First measured step.
        first: u32,
        /// Step pointing forward.
        front: u32,
        /// Last measured step.
        last: u32,
        /// Steps per revolution.
        per_rev: u32,
    },
    /// A numeric field is out of its range.
    #[error("laser field `{field}` = {value} is invalid: {why}")]
    BadValue {
        /// Field name as in the config file.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What it must satisfy.
        why: &'static str,
    },
}

/// The scanner's angular geometry in encoder steps, as SCIP 2.0 `PP` reports it
/// (`ARES`, `AMIN`, `AMAX`, `AFRT`). Defaults are the URG-04LX's: 1024 steps per turn,
/// steps 44..=725 measured, step 384 straight ahead.
///
/// `angle(step) = (step - front_step) * 2 pi / steps_per_rev`.
///
/// A scan lists its beams counter-clockwise from `first_step` to `last_step`, as REP 103
/// and the URG-04LX do; with `clockwise` it lists them from `last_step` down to
/// `first_step` (the same directions in the opposite order), so a `LaserScan` of it has a
/// negative `angle_increment` (a driver that publishes a clockwise-turning scanner's
/// beams in the order they are measured). A 360-degree scanner measures every step:
/// `first_step = 0`, `last_step = steps_per_rev - 1`, so its beams cover the circle
/// exactly once.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct UrgGeometry {
    /// Encoder steps per revolution (`ARES`).
    #[config(range = ">= 1")]
    pub steps_per_rev: u32,
    /// First measured step (`AMIN`).
    pub first_step: u32,
    /// Last measured step (`AMAX`).
    pub last_step: u32,
    /// Step pointing along the sensor's x axis (`AFRT`).
    pub front_step: u32,
    /// Beams listed clockwise (negative angle increment); see the type's comment.
    /// Written to a config only when set.
    #[serde(skip_serializing_if = "is_false")]
    pub clockwise: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Default for UrgGeometry {
    fn default() -> Self {
        UrgGeometry {
            steps_per_rev: 1024,
            first_step: 44,
            last_step: 725,
            front_step: 384,
            clockwise: false,
        }
    }
}

impl UrgGeometry {
    /// Number of beams in a full scan: `last_step - first_step + 1` (682 on the
    /// URG-04LX; datasheets round to "683 steps").
    pub fn beam_count(&self) -> usize {
        (self.last_step.saturating_sub(self.first_step) + 1) as usize
    }

    /// Angle between neighbouring steps, rad.
    pub fn angle_increment_rad(&self) -> f64 {
        std::f64::consts::TAU / f64::from(self.steps_per_rev)
    }

    /// Direction of an encoder step, rad.
    pub fn angle_of_step_rad(&self, step: u32) -> f64 {
        (f64::from(step) - f64::from(self.front_step)) * self.angle_increment_rad()
    }

    /// Direction of the first beam, rad (-2.0862 on the URG-04LX).
    pub fn angle_min_rad(&self) -> f64 {
        self.angle_of_step_rad(self.first_step)
    }

    /// Direction of the last beam, rad (+2.0923 on the URG-04LX).
    pub fn angle_max_rad(&self) -> f64 {
        self.angle_of_step_rad(self.last_step)
    }

    /// Field of view from the first to the last measured step, rad.
    pub fn field_of_view_rad(&self) -> f64 {
        self.angle_max_rad() - self.angle_min_rad()
    }

    /// Direction of beam 0 of a scan, rad: `angle_min_rad`, or `angle_max_rad` when
    /// `clockwise`.
    pub fn first_beam_angle_rad(&self) -> f64 {
        if self.clockwise {
            self.angle_max_rad()
        } else {
            self.angle_min_rad()
        }
    }

    /// Signed angle from one beam of a scan to the next, rad: `angle_increment_rad`,
    /// negated when `clockwise`.
    pub fn beam_increment_rad(&self) -> f64 {
        if self.clockwise {
            -self.angle_increment_rad()
        } else {
            self.angle_increment_rad()
        }
    }

    /// Direction of beam `i` of a scan, rad: `first + i * increment`.
    pub fn beam_angle_rad(&self, i: usize) -> f64 {
        self.first_beam_angle_rad() + i as f64 * self.beam_increment_rad()
    }

    fn validate(&self) -> Result<(), LaserModelError> {
        let ok = self.steps_per_rev > 0
            && self.first_step <= self.front_step
            && self.front_step <= self.last_step
            && self.last_step < self.steps_per_rev;
        if ok {
            Ok(())
        } else {
            Err(LaserModelError::BadGeometry {
                first: self.first_step,
                front: self.front_step,
                last: self.last_step,
                per_rev: self.steps_per_rev,
            })
        }
    }
}

/// A polynomial in range: `c0 + c1 r + c2 r^2 + ...`, coefficients in SI units.
/// Serialised as the list of coefficients, lowest order first.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Polynomial(pub Vec<f64>);

impl Polynomial {
    /// Evaluates at `r` by Horner's rule; the empty polynomial is 0.
    pub fn eval(&self, r: f64) -> f64 {
        self.0.iter().rev().fold(0.0, |acc, c| acc * r + c)
    }

    fn all_finite(&self) -> bool {
        self.0.iter().all(|c| c.is_finite())
    }
}

/// Range error model of the scanner (design 2.1, the paper's Fig. 9):
/// `measured = r + bias(r) + N(0, sigma(r)^2)`.
///
/// Without calibration: `bias = 0`, `sigma(r) = max(0.01 m, 0.01 r)` (the datasheet's
/// +-10 mm to 1 m and +-1 % beyond). `tether calibrate laser` fits both polynomials
/// from samples at known distances and writes them here.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct RangeNoiseModel {
    /// bias(r), m, as a polynomial in the true range (m).
    pub bias_m: Polynomial,
    /// sigma(r), m, as a polynomial in range (m), before the floor is applied.
    pub sigma_m: Polynomial,
    /// Smallest standard deviation ever used, m.
    #[config(range = "> 0")]
    pub sigma_floor_m: f64,
}

impl Default for RangeNoiseModel {
    fn default() -> Self {
        RangeNoiseModel {
            bias_m: Polynomial(Vec::new()),
            sigma_m: Polynomial(vec![0.0, 0.01]),
            sigma_floor_m: 0.01,
        }
    }
}

impl RangeNoiseModel {
    /// Systematic error at range `r_m`, m.
    pub fn bias_m(&self, r_m: f64) -> f64 {
        self.bias_m.eval(r_m)
    }

    /// Standard deviation of the random error at range `r_m`, m:
    /// `max(sigma_floor, sigma(r))`.
    pub fn sigma_m(&self, r_m: f64) -> f64 {
        self.sigma_m.eval(r_m).max(self.sigma_floor_m)
    }

    /// A measured range with the bias removed: `r - bias(r)`. (The bias is a slowly
    /// varying function, so evaluating it at the measured rather than the true range
    /// changes the result by `bias * bias'`, far below the noise.)
    pub fn corrected_m(&self, measured_m: f64) -> f64 {
        measured_m - self.bias_m(measured_m)
    }

    fn validate(&self) -> Result<(), LaserModelError> {
        if !self.bias_m.all_finite() {
            return Err(LaserModelError::BadValue {
                field: "noise.bias_m",
                value: f64::NAN,
                why: "every coefficient must be finite",
            });
        }
        if !self.sigma_m.all_finite() {
            return Err(LaserModelError::BadValue {
                field: "noise.sigma_m",
                value: f64::NAN,
                why: "every coefficient must be finite",
            });
        }
        if !(self.sigma_floor_m.is_finite() && self.sigma_floor_m > 0.0) {
            return Err(LaserModelError::BadValue {
                field: "noise.sigma_floor_m",
                value: self.sigma_floor_m,
                why: "must be a positive number of metres",
            });
        }
        Ok(())
    }
}

/// Where the scanner sits on the robot: the pose of the laser frame in the robot frame
/// and the height of its scan plane above the floor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct LaserMount {
    /// Forward offset from the wheel axis centre, m.
    pub x_m: f64,
    /// Leftward offset, m.
    pub y_m: f64,
    /// Yaw of the scanner's x axis relative to the robot's, rad.
    pub yaw_rad: f64,
    /// Height of the scan plane above the floor, m (the paper: about 0.30 m).
    #[config(range = ">= 0")]
    pub height_m: f64,
}

impl Default for LaserMount {
    fn default() -> Self {
        LaserMount {
            x_m: 0.10,
            y_m: 0.0,
            yaw_rad: 0.0,
            height_m: 0.30,
        }
    }
}

/// A scanner besides a robot's first (`[[extra_lasers]]`, design 5.7): the `frame_id`
/// its scans carry and its model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields)]
pub struct ExtraLaser {
    /// The `frame_id` its scans carry (e.g. `rear_laser`).
    pub frame_id: String,
    /// Its geometry, noise and mount (`[extra_lasers.laser]`, the keys of `[laser]`).
    #[serde(default)]
    pub laser: LaserModel,
}

/// Everything tether needs to know about a 2-D laser scanner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, crate::ConfigDocs)]
#[serde(deny_unknown_fields, default)]
pub struct LaserModel {
    /// Step geometry.
    pub geometry: UrgGeometry,
    /// Shortest valid range, m (URG-04LX: 0.02).
    #[config(range = ">= 0")]
    pub range_min_m: f64,
    /// Longest valid range, m (URG-04LX: 5.6; the paper used the 4 m mode).
    pub range_max_m: f64,
    /// Time of one revolution, s (URG-04LX: 0.1 at 600 rpm).
    #[config(range = ">= 0.001, <= 10")]
    pub scan_period_s: f64,
    /// Range noise.
    pub noise: RangeNoiseModel,
    /// Mounting on the robot.
    pub mount: LaserMount,
}

impl Default for LaserModel {
    fn default() -> Self {
        LaserModel {
            geometry: UrgGeometry::default(),
            range_min_m: 0.02,
            range_max_m: 5.6,
            scan_period_s: 0.1,
            noise: RangeNoiseModel::default(),
            mount: LaserMount::default(),
        }
    }
}

impl LaserModel {
    /// The Hokuyo URG-04LX with its datasheet values and the default mounting.
    pub fn urg_04lx() -> Self {
        Self::default()
    }

    /// Checks every field; call after reading a config.
    pub fn validate(&self) -> Result<(), LaserModelError> {
        self.geometry.validate()?;
        if !(self.range_min_m.is_finite() && self.range_min_m >= 0.0) {
            return Err(LaserModelError::BadValue {
                field: "range_min_m",
                value: self.range_min_m,
                why: "must be >= 0",
            });
        }
        if !(self.range_max_m.is_finite() && self.range_max_m > self.range_min_m) {
            return Err(LaserModelError::BadValue {
                field: "range_max_m",
                value: self.range_max_m,
                why: "must be finite and greater than range_min_m",
            });
        }
        if !(self.scan_period_s.is_finite()
            && self.scan_period_s >= 1e-3
            && self.scan_period_s <= 10.0)
        {
            return Err(LaserModelError::BadValue {
                field: "scan_period_s",
                value: self.scan_period_s,
                why: "must be between 0.001 and 10 s",
            });
        }
        self.noise.validate()?;
        let m = &self.mount;
        for (field, value) in [
            ("mount.x_m", m.x_m),
            ("mount.y_m", m.y_m),
            ("mount.yaw_rad", m.yaw_rad),
            ("mount.height_m", m.height_m),
        ] {
            if !value.is_finite() {
                return Err(LaserModelError::BadValue {
                    field,
                    value,
                    why: "must be finite",
                });
            }
        }
        if m.height_m < 0.0 {
            return Err(LaserModelError::BadValue {
                field: "mount.height_m",
                value: m.height_m,
                why: "must be >= 0 (height above the floor)",
            });
        }
        Ok(())
    }

    /// The laser's pose on the robot.
    pub fn robot_from_laser(&self) -> Pose2<Robot, Laser> {
        Pose2::new(self.mount.x_m, self.mount.y_m, self.mount.yaw_rad)
    }

    /// Scan period in nanoseconds.
    pub fn scan_period_ns(&self) -> i64 {
        (self.scan_period_s * NS_PER_S as f64).round() as i64
    }

    /// Number of beams per scan.
    pub fn beam_count(&self) -> usize {
        self.geometry.beam_count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urg_04lx_geometry_matches_the_datasheet() {
        let g = UrgGeometry::default();
        assert_eq!(g.beam_count(), 682);
        assert!((g.angle_increment_rad() - 0.006_135_92).abs() < 1e-8);
        assert!((g.angle_min_rad() + 2.0862).abs() < 1e-4);
        assert!((g.angle_max_rad() - 2.0923).abs() < 1e-4);
        assert_eq!(g.angle_of_step_rad(384), 0.0);
        assert_eq!(g.first_beam_angle_rad(), g.angle_min_rad());
        assert_eq!(g.beam_increment_rad(), g.angle_increment_rad());
    }

    #[test]
    fn a_clockwise_geometry_lists_the_same_directions_backwards() {
        let ccw = UrgGeometry::default();
        let cw = UrgGeometry {
            clockwise: true,
            ..ccw
        };
        let n = ccw.beam_count();
        assert_eq!(cw.beam_count(), n);
        assert!(cw.beam_increment_rad() < 0.0);
        for i in 0..n {
            assert!((cw.beam_angle_rad(i) - ccw.beam_angle_rad(n - 1 - i)).abs() < 1e-12);
        }
        // Written to a config only when set.
        let text = toml::to_string(&ccw).unwrap();
        assert!(!text.contains("clockwise"), "{text}");
        let back: UrgGeometry = toml::from_str(&toml::to_string(&cw).unwrap()).unwrap();
        assert_eq!(back, cw);
    }

    #[test]
    fn default_noise_is_one_centimetre_or_one_percent() {
        let n = RangeNoiseModel::default();
        assert!((n.sigma_m(0.5) - 0.01).abs() < 1e-12);
        assert!((n.sigma_m(3.0) - 0.03).abs() < 1e-12);
        assert_eq!(n.bias_m(2.0), 0.0);
        assert_eq!(n.corrected_m(2.0), 2.0);
    }

    #[test]
    fn polynomial_evaluates_lowest_order_first() {
        let p = Polynomial(vec![1.0, 2.0, 3.0]);
        assert_eq!(p.eval(2.0), 1.0 + 4.0 + 12.0);
        assert_eq!(Polynomial::default().eval(5.0), 0.0);
    }

    #[test]
    fn reads_a_partial_toml_config() {
        let m: LaserModel = toml::from_str(
            "range_max_m = 4.0\n[noise]\nbias_m = [0.001, 0.002]\n[mount]\nheight_m = 0.35\n",
        )
        .unwrap();
        m.validate().unwrap();
        assert_eq!(m.range_max_m, 4.0);
        assert_eq!(m.mount.height_m, 0.35);
        assert_eq!(m.mount.x_m, LaserMount::default().x_m);
        assert!((m.noise.bias_m(1.0) - 0.003).abs() < 1e-12);
    }

    #[test]
    fn refuses_unknown_keys_and_bad_values() {
        assert!(toml::from_str::<LaserModel>("range_mx_m = 4.0").is_err());
        let mut m = LaserModel::default();
        m.noise.sigma_floor_m = 0.0;
        assert!(m.validate().is_err());
        let mut m = LaserModel::default();
        m.geometry.front_step = 800;
        assert!(matches!(
            m.validate(),
            Err(LaserModelError::BadGeometry { .. })
        ));
    }
}
