//! The catalogue of 2-D laser scanners the simulator can play (design 2.1, issue 30):
//! each scanner's geometry, rate, range limits, range noise, no-return behaviour and a
//! default mount height, from its maker's published figures.
//!
//! Two noise models per scanner, as for the URG-04LX: `laser.noise` is what tether's
//! estimator assumes (the datasheet's accuracy bound taken as one standard deviation, as
//! the URG-04LX's default does with its +-10 mm / 1 %), `sim.noise` is the spread the
//! simulated scanner really makes (the datasheet's repeatability where it gives one,
//! else half the accuracy bound: a +- bound read as about two standard deviations).
//!
//! No-return behaviour, where datasheets are silent (they are, for all of these):
//! - random dropouts `dropout_prob` 0.002 per beam, the URG-04LX's measured figure, for
//!   the time-of-flight scanners; 0.01 for the triangulation ones (their data frames
//!   carry more zero-distance samples; an assumption, not a measurement);
//! - no-returns inside objects `object_beam_loss_prob` 0.25 for the triangulation
//!   scanners (RPLIDAR, LDS-01, YDLIDAR): about one beam in four on dark or oblique
//!   surfaces is the figure issue 30 gives from users' scans of these sensors; 0 for
//!   the time-of-flight ones, whose returns inside a leg are steady on the recordings
//!   tether has (URG-04LX);
//! - long-range flicker: the URG-04LX's measured 45 % extra loss at the end of the
//!   range, growing from 82 % of the longest range (4.6 of 5.6 m), is taken for every
//!   scanner at the same share of its own range.
//!
//! The detector-level failures of `laser_sim.realistic` (weak legs, dark spells,
//! phantoms, foliage) were fitted on URG-04LX recordings (issue 14) and are kept for
//! every scanner: there are no recordings of the others to fit them to.
//!
//! Scan order. A scan's beams are listed counter-clockwise (positive angle increment)
//! for every preset, because that is how each scanner's ROS driver publishes them, even
//! for the ones that turn clockwise (`rotation`): `rplidar_ros` (Slamtec, `node.cpp`,
//! `publish_scan`) sets `angle_min = pi - 360 deg`, `angle_max = pi` and writes the
//! ranges in reverse. A driver that publishes in measuring order is simulated with
//! `[laser.geometry] clockwise = true` (negative increment, the same points).

use serde::Serialize;
use tether_core::{LaserModel, LaserMount, Polynomial, RangeNoiseModel, UrgGeometry};
use thiserror::Error;

/// How the scanner measures range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ranging {
    /// Phase or pulse time of flight (Hokuyo, SICK).
    TimeOfFlight,
    /// Laser triangulation (the low-cost 360-degree scanners).
    Triangulation,
}

/// Which way the scanner's head turns, seen from above.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Rotation {
    /// Counter-clockwise (the Hokuyo SCIP scanners; REP 103's positive angle).
    CounterClockwise,
    /// Clockwise (the RPLIDAR's angles grow clockwise).
    Clockwise,
}

/// The simulator-only figures of a scanner: its true noise and its no-returns (the
/// fields of `laser_sim` it sets; see the module comment for where each comes from).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScannerSim {
    /// Probability that any beam returns nothing.
    pub dropout_prob: f64,
    /// Probability that a beam hitting anything returns nothing.
    pub object_beam_loss_prob: f64,
    /// Extra probability of no return at the longest range.
    pub long_range_dropout_prob: f64,
    /// Range where the long-range flicker begins, m.
    pub long_range_start_m: f64,
    /// The range error the simulated scanner makes.
    pub noise: RangeNoiseModel,
}

/// One scanner of the catalogue.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scanner {
    /// Name on the command line and in scenario files (`rplidar_a1`).
    pub name: &'static str,
    /// Maker and model as sold.
    pub model: &'static str,
    /// How it measures range.
    pub ranging: Ranging,
    /// Which way its head turns.
    pub rotation: Rotation,
    /// Geometry, range limits, scan period, the estimator's noise, default mount.
    pub laser: LaserModel,
    /// True noise and no-returns.
    pub sim: ScannerSim,
    /// Where the figures come from.
    pub source: &'static str,
}

/// A name the catalogue does not hold.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("no scanner named `{name}`; the known scanners are: {known}")]
pub struct UnknownScanner {
    /// The name asked for.
    pub name: String,
    /// The catalogue's names, comma-separated.
    pub known: String,
}

impl Scanner {
    /// Angular step, degrees.
    pub fn step_deg(&self) -> f64 {
        self.laser.geometry.angle_increment_rad().to_degrees()
    }

    /// Field of view, degrees (the span from the first beam's direction to the last's
    /// plus one step: 360 for a full turn).
    pub fn field_of_view_deg(&self) -> f64 {
        let g = &self.laser.geometry;
        (g.field_of_view_rad() + g.angle_increment_rad()).to_degrees()
    }

    /// Scans per second.
    pub fn rate_hz(&self) -> f64 {
        1.0 / self.laser.scan_period_s
    }
}

/// The names of the catalogue, in the order `tether scanners` lists them.
pub const SCANNER_NAMES: &[&str] = &[
    "urg_04lx",
    "ust_10lx",
    "utm_30lx",
    "uhg_08lx",
    "sick_tim571",
    "rplidar_a1",
    "rplidar_a2",
    "lds_01",
    "ydlidar_x4",
];

/// Every scanner of the catalogue, in [`SCANNER_NAMES`] order.
pub fn catalogue() -> Vec<Scanner> {
    SCANNER_NAMES
        .iter()
        .filter_map(|n| scanner(n).ok())
        .collect()
}

/// The scanner named `name`, or an error listing the known names.
pub fn scanner(name: &str) -> Result<Scanner, UnknownScanner> {
    Ok(match name {
        "urg_04lx" => urg_04lx(),
        "ust_10lx" => ust_10lx(),
        "utm_30lx" => utm_30lx(),
        "uhg_08lx" => uhg_08lx(),
        "sick_tim571" => sick_tim571(),
        "rplidar_a1" => rplidar_a1(),
        "rplidar_a2" => rplidar_a2(),
        "lds_01" => lds_01(),
        "ydlidar_x4" => ydlidar_x4(),
        _ => {
            return Err(UnknownScanner {
                name: name.to_owned(),
                known: SCANNER_NAMES.join(", "),
            });
        }
    })
}

/// `sigma(r) = max(floor, c0 + c1 r)`, m.
fn noise(c0_m: f64, c1: f64, floor_m: f64) -> RangeNoiseModel {
    RangeNoiseModel {
        bias_m: Polynomial(Vec::new()),
        sigma_m: Polynomial(vec![c0_m, c1]),
        sigma_floor_m: floor_m,
    }
}

/// A scanner's laser model from its step geometry and figures.
#[allow(
    clippy::too_many_arguments,
    reason = "one row of the catalogue's table"
)]
fn model(
    steps_per_rev: u32,
    first_step: u32,
    last_step: u32,
    front_step: u32,
    range_m: (f64, f64),
    rate_hz: f64,
    estimator_noise: RangeNoiseModel,
    height_m: f64,
) -> LaserModel {
    LaserModel {
        geometry: UrgGeometry {
            steps_per_rev,
            first_step,
            last_step,
            front_step,
            clockwise: false,
        },
        range_min_m: range_m.0,
        range_max_m: range_m.1,
        scan_period_s: 1.0 / rate_hz,
        noise: estimator_noise,
        mount: LaserMount {
            height_m,
            ..LaserMount::default()
        },
    }
}

/// The no-returns of a time-of-flight (`object_loss = 0`, dropouts 0.002) or a
/// triangulation scanner (`object_loss = 0.25`, dropouts 0.01), flicker from 82 % of
/// `range_max_m`.
fn no_returns(ranging: Ranging, range_max_m: f64, noise: RangeNoiseModel) -> ScannerSim {
    let (dropout_prob, object_beam_loss_prob) = match ranging {
        Ranging::TimeOfFlight => (0.002, 0.0),
        Ranging::Triangulation => (0.01, 0.25),
    };
    ScannerSim {
        dropout_prob,
        object_beam_loss_prob,
        long_range_dropout_prob: 0.45,
        long_range_start_m: range_max_m * (4.6 / 5.6),
        noise,
    }
}

/// Hokuyo URG-04LX: exactly what the simulator did before the catalogue (the defaults of
/// `[laser]` and `[laser_sim]`). Hokuyo, SCIP 2.0 specification C-42-03320B, `PP` of
/// the URG-04LX: 1024 steps a turn, steps 44-725 (240 deg, 682 beams), front 384,
/// 0.02-5.6 m, 600 rpm (10 Hz); URG-04LX specification: accuracy +-10 mm to 1 m, 1 %
/// beyond. The simulated spread (6-7 mm) and the no-returns were measured on the real
/// recordings (issue 14). Mounted at shin height, 0.30 m (the paper's robot).
pub fn urg_04lx() -> Scanner {
    let sim = crate::scenario::LaserSimSpec::default();
    Scanner {
        name: "urg_04lx",
        model: "Hokuyo URG-04LX",
        ranging: Ranging::TimeOfFlight,
        rotation: Rotation::CounterClockwise,
        laser: LaserModel::urg_04lx(),
        sim: ScannerSim {
            dropout_prob: sim.dropout_prob,
            object_beam_loss_prob: sim.object_beam_loss_prob,
            long_range_dropout_prob: sim.long_range_dropout_prob,
            long_range_start_m: sim.long_range_start_m,
            noise: sim.noise,
        },
        source: "Hokuyo SCIP 2.0 spec C-42-03320B (PP); URG-04LX specification",
    }
}

/// Hokuyo UST-10LX: 270 deg at 0.25 deg (1440 steps a turn, steps 0-1080, front 540:
/// 1081 beams), 25 ms a scan (40 Hz), 0.06-10 m guaranteed, accuracy +-40 mm (Hokuyo,
/// UST-10LX specification sheet). Mounted at 0.30 m (an assumption: shin height, as
/// the URG-04LX it replaces).
pub fn ust_10lx() -> Scanner {
    let r = Ranging::TimeOfFlight;
    Scanner {
        name: "ust_10lx",
        model: "Hokuyo UST-10LX",
        ranging: r,
        rotation: Rotation::CounterClockwise,
        laser: model(
            1440,
            0,
            1080,
            540,
            (0.06, 10.0),
            40.0,
            noise(0.04, 0.0, 0.04),
            0.30,
        ),
        sim: no_returns(r, 10.0, noise(0.02, 0.0, 0.02)),
        source: "Hokuyo UST-10LX specification sheet",
    }
}

/// Hokuyo UTM-30LX: 1440 steps a turn, steps 0-1080, front 540 (270 deg, 1081 beams;
/// Hokuyo SCIP 2.0 specification C-42-03320B, table 2), 25 ms a scan (40 Hz), 0.1-30 m,
/// accuracy +-30 mm to 10 m and +-50 mm to 30 m (UTM-30LX specification): sigma
/// `0.02 + 0.001 r`, at least 0.03 m. Mounted at 0.40 m (an assumption: the top plate
/// of a research base, knee height).
pub fn utm_30lx() -> Scanner {
    let r = Ranging::TimeOfFlight;
    Scanner {
        name: "utm_30lx",
        model: "Hokuyo UTM-30LX",
        ranging: r,
        rotation: Rotation::CounterClockwise,
        laser: model(
            1440,
            0,
            1080,
            540,
            (0.1, 30.0),
            40.0,
            noise(0.02, 0.001, 0.03),
            0.40,
        ),
        sim: no_returns(r, 30.0, noise(0.01, 0.0005, 0.015)),
        source: "Hokuyo SCIP 2.0 spec C-42-03320B table 2; UTM-30LX specification",
    }
}

/// Hokuyo UHG-08LX: 1024 steps a turn, steps 0-768, front 384 (270.35 deg, 769 beams;
/// Hokuyo SCIP 2.0 specification C-42-03320B, table 2), 67 ms a scan (15 Hz), 0.1-8 m,
/// accuracy +-30 mm to 1 m and +-3 % beyond (UHG-08LX specification). Mounted at 0.30 m
/// (an assumption).
pub fn uhg_08lx() -> Scanner {
    let r = Ranging::TimeOfFlight;
    Scanner {
        name: "uhg_08lx",
        model: "Hokuyo UHG-08LX",
        ranging: r,
        rotation: Rotation::CounterClockwise,
        laser: model(
            1024,
            0,
            768,
            384,
            (0.1, 8.0),
            15.0,
            noise(0.0, 0.03, 0.03),
            0.30,
        ),
        sim: no_returns(r, 8.0, noise(0.0, 0.015, 0.015)),
        source: "Hokuyo SCIP 2.0 spec C-42-03320B table 2; UHG-08LX specification",
    }
}

/// SICK TiM571: 270 deg at 0.33 deg (1080 steps a turn, steps 135-945, front 540: 811
/// beams), 15 Hz, 0.05-25 m, statistical error 20 mm (1 sigma) and systematic +-60 mm
/// (SICK, TiM55x/56x/57x technical information 8015883 and online data sheet).
/// Mounted at 0.35 m (an assumption).
pub fn sick_tim571() -> Scanner {
    let r = Ranging::TimeOfFlight;
    Scanner {
        name: "sick_tim571",
        model: "SICK TiM571",
        ranging: r,
        rotation: Rotation::CounterClockwise,
        laser: model(
            1080,
            135,
            945,
            540,
            (0.05, 25.0),
            15.0,
            noise(0.06, 0.0, 0.06),
            0.35,
        ),
        sim: no_returns(r, 25.0, noise(0.02, 0.0, 0.02)),
        source: "SICK TiM55x/56x/57x technical information 8015883; TiM571 data sheet",
    }
}

/// Slamtec RPLIDAR A1 (A1M8): 360 deg, 1 deg at the typical 5.5 Hz (360 samples a
/// scan), 0.15-12 m, resolution under 1 % of the distance (Slamtec, RPLIDAR A1
/// datasheet LD108 rev. 2-3, "Measurement performance"). Turns clockwise. Mounted at
/// 0.20 m (an assumption: on top of a small base, just above the ankle).
pub fn rplidar_a1() -> Scanner {
    let r = Ranging::Triangulation;
    Scanner {
        name: "rplidar_a1",
        model: "Slamtec RPLIDAR A1 (A1M8)",
        ranging: r,
        rotation: Rotation::Clockwise,
        laser: model(
            360,
            0,
            359,
            180,
            (0.15, 12.0),
            5.5,
            noise(0.0, 0.01, 0.005),
            0.20,
        ),
        sim: no_returns(r, 12.0, noise(0.0, 0.005, 0.003)),
        source: "Slamtec RPLIDAR A1 datasheet LD108 (A1M8)",
    }
}

/// Slamtec RPLIDAR A2 (A2M8): 360 deg, 0.9 deg at the typical 10 Hz (4000 samples/s in
/// the standard mode: 400 a scan), 0.15-12 m, accuracy 1 % of the distance to 3 m
/// (Slamtec, RPLIDAR A2 datasheet, "Measurement performance"). Turns clockwise.
/// Mounted at 0.50 m (an assumption: on top of a taller base, at thigh height).
pub fn rplidar_a2() -> Scanner {
    let r = Ranging::Triangulation;
    Scanner {
        name: "rplidar_a2",
        model: "Slamtec RPLIDAR A2 (A2M8)",
        ranging: r,
        rotation: Rotation::Clockwise,
        laser: model(
            400,
            0,
            399,
            200,
            (0.15, 12.0),
            10.0,
            noise(0.0, 0.01, 0.005),
            0.50,
        ),
        sim: no_returns(r, 12.0, noise(0.0, 0.005, 0.003)),
        source: "Slamtec RPLIDAR A2 datasheet (A2M8)",
    }
}

/// ROBOTIS / Hitachi-LG LDS-01 (HLS-LFCD2): 360 deg at 1 deg (360 beams from 0 deg, as
/// `hls_lfcd_lds_driver` publishes them), 300 rpm (5 Hz), 0.12-3.5 m, accuracy +-15 mm
/// to 0.5 m and +-5 % beyond, precision +-10 mm and +-3.5 % (ROBOTIS e-Manual, LDS-01
/// specifications). Mounted at 0.17 m, the top of a TurtleBot3 Burger (192 mm tall,
/// ROBOTIS e-Manual), at the ankle.
pub fn lds_01() -> Scanner {
    let r = Ranging::Triangulation;
    Scanner {
        name: "lds_01",
        model: "ROBOTIS LDS-01 (HLS-LFCD2)",
        ranging: r,
        rotation: Rotation::CounterClockwise,
        laser: model(
            360,
            0,
            359,
            0,
            (0.12, 3.5),
            5.0,
            noise(0.0, 0.05, 0.015),
            0.17,
        ),
        sim: no_returns(r, 3.5, noise(0.0, 0.0175, 0.005)),
        source: "ROBOTIS e-Manual, LDS-01 specifications",
    }
}

/// YDLIDAR X4: 360 deg, 5000 samples/s at a typical 7 Hz (0.5 deg: 720 a scan),
/// 0.12-10 m, relative accuracy about 2 % of the distance taken as the bound (EAI,
/// YDLIDAR X4 data sheet V1.1, "Performance parameter"). Turns clockwise. Mounted at
/// 0.25 m (an assumption: on top of a small base, mid-shin).
pub fn ydlidar_x4() -> Scanner {
    let r = Ranging::Triangulation;
    Scanner {
        name: "ydlidar_x4",
        model: "EAI YDLIDAR X4",
        ranging: r,
        rotation: Rotation::Clockwise,
        laser: model(
            720,
            0,
            719,
            360,
            (0.12, 10.0),
            7.0,
            noise(0.0, 0.02, 0.01),
            0.25,
        ),
        sim: no_returns(r, 10.0, noise(0.0, 0.01, 0.005)),
        source: "EAI YDLIDAR X4 data sheet V1.1",
    }
}

#[cfg(test)]
mod tests;
