use std::f64::consts::TAU;

use super::*;
use crate::person::{LEG_REFERENCE_HEIGHT_M, leg_girth_scale};

/// `(name, beams, step deg, field of view deg, rate Hz, min m, max m)` as the
/// datasheets give them.
const FIGURES: [(&str, usize, f64, f64, f64, f64, f64); 9] = [
    ("urg_04lx", 682, 0.3516, 239.77, 10.0, 0.02, 5.6),
    ("ust_10lx", 1081, 0.25, 270.25, 40.0, 0.06, 10.0),
    ("utm_30lx", 1081, 0.25, 270.25, 40.0, 0.1, 30.0),
    ("uhg_08lx", 769, 0.3516, 270.35, 15.0, 0.1, 8.0),
    ("sick_tim571", 811, 0.3333, 270.33, 15.0, 0.05, 25.0),
    ("rplidar_a1", 360, 1.0, 360.0, 5.5, 0.15, 12.0),
    ("rplidar_a2", 400, 0.9, 360.0, 10.0, 0.15, 12.0),
    ("lds_01", 360, 1.0, 360.0, 5.0, 0.12, 3.5),
    ("ydlidar_x4", 720, 0.5, 360.0, 7.0, 0.12, 10.0),
];

#[test]
fn every_preset_has_its_datasheet_figures_and_validates() {
    let all = catalogue();
    assert_eq!(all.len(), SCANNER_NAMES.len());
    for (s, (name, beams, step, fov, rate, min, max)) in all.iter().zip(FIGURES) {
        assert_eq!(s.name, name);
        s.laser.validate().unwrap();
        assert_eq!(s.laser.beam_count(), beams, "{name}");
        assert!(
            (s.step_deg() - step).abs() < 1e-3,
            "{name}: {}",
            s.step_deg()
        );
        assert!(
            (s.field_of_view_deg() - fov).abs() < 0.01,
            "{name}: {}",
            s.field_of_view_deg()
        );
        assert!((s.rate_hz() - rate).abs() < 1e-9, "{name}");
        assert_eq!(
            (s.laser.range_min_m, s.laser.range_max_m),
            (min, max),
            "{name}"
        );
        assert!(!s.laser.geometry.clockwise, "{name}: drivers publish CCW");
        assert!(
            s.laser.geometry.angle_min_rad() < 0.0 || fov == 360.0,
            "{name}"
        );
        assert!((0.0..=1.0).contains(&s.sim.object_beam_loss_prob));
        let triangulation = s.ranging == Ranging::Triangulation;
        assert_eq!(s.sim.object_beam_loss_prob > 0.0, triangulation, "{name}");
        assert!(s.sim.long_range_start_m < s.laser.range_max_m, "{name}");
        assert!(!s.source.is_empty());
    }
}

#[test]
fn the_urg_04lx_preset_is_the_simulator_as_it_was() {
    let s = scanner("urg_04lx").unwrap();
    assert_eq!(s.laser, LaserModel::default());
    let d = crate::scenario::LaserSimSpec::default();
    assert_eq!(s.sim.dropout_prob, d.dropout_prob);
    assert_eq!(s.sim.object_beam_loss_prob, 0.0);
    assert_eq!(s.sim.long_range_dropout_prob, d.long_range_dropout_prob);
    assert_eq!(s.sim.long_range_start_m, d.long_range_start_m);
    assert_eq!(s.sim.noise, d.noise);
    assert_eq!(s.laser.mount.height_m, LEG_REFERENCE_HEIGHT_M);
}

#[test]
fn a_360_degree_scan_covers_the_circle_exactly_once() {
    for s in catalogue().iter().filter(|s| s.field_of_view_deg() > 359.0) {
        let g = &s.laser.geometry;
        let n = g.beam_count();
        assert_eq!(n as u32, g.steps_per_rev, "{}", s.name);
        assert!((n as f64 * g.angle_increment_rad() - TAU).abs() < 1e-9);
        // Every direction, folded into [0, 2 pi), once: sorted, a step apart.
        let mut folded: Vec<f64> = (0..n)
            .map(|i| g.beam_angle_rad(i).rem_euclid(TAU))
            .collect();
        folded.sort_by(f64::total_cmp);
        for w in folded.windows(2) {
            assert!(
                (w[1] - w[0] - g.angle_increment_rad()).abs() < 1e-9,
                "{}: {} then {}",
                s.name,
                w[0],
                w[1]
            );
        }
        let wrap = folded[0] + TAU - folded[n - 1];
        assert!((wrap - g.angle_increment_rad()).abs() < 1e-9, "{}", s.name);
    }
}

#[test]
fn an_unknown_name_lists_the_known_ones() {
    let e = scanner("lms200").unwrap_err().to_string();
    assert!(e.contains("`lms200`"), "{e}");
    for name in SCANNER_NAMES {
        assert!(e.contains(name), "{e}");
    }
}

#[test]
fn a_leg_is_narrower_at_the_ankle_and_wider_at_the_thigh() {
    assert_eq!(leg_girth_scale(LEG_REFERENCE_HEIGHT_M), 1.0);
    // Widths of the default legs (radius 0.058-0.072 m at the calf) against the
    // figures of issue 30: 0.08-0.11 m at the shin/ankle, 0.13-0.16 m at the thigh.
    let widths = |h: f64| (0.116 * leg_girth_scale(h), 0.144 * leg_girth_scale(h));
    let (lo, hi) = widths(0.17);
    assert!(lo >= 0.08 && hi <= 0.11, "ankle {lo}-{hi}");
    let (lo, hi) = widths(0.55);
    assert!(lo >= 0.12 && hi <= 0.16, "thigh {lo}-{hi}");
    assert!(leg_girth_scale(0.05) == leg_girth_scale(0.11));
    assert!(leg_girth_scale(1.0) == leg_girth_scale(0.78));
    assert!(leg_girth_scale(0.78) > 1.5);
    // Continuous: no jump between neighbouring heights.
    let mut h = 0.0;
    while h < 1.0 {
        assert!(
            (leg_girth_scale(h + 1e-4) - leg_girth_scale(h)).abs() < 2e-3,
            "{h}"
        );
        h += 1e-3;
    }
}
