//! On leg_tracker's `demo_stationary_simple_environment.bag` (a static robot, people
//! walking around it, 1,265 scans): scan-matching odometry must stay near the origin.
//! People are excluded as the pipeline will exclude tracked people: here a zone around
//! every leg that tether's laser detector finds (no tracker, so a missed leg is not
//! excluded).
//!
//! Needs `../shared`; without it the test prints why and passes, unless
//! `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

use tether_core::{Point2, Pose2, RangeNoiseModel};
use tether_laser::{DetectorConfig, LegClassifier, LegDetector};
use tether_recording::rosbag::read_scans;
use tether_scanmatch::{
    ExclusionZone, MotionPrior, Quality, ScanMatcher, ScanMatcherConfig, ScanPoints,
};

const BAG: &str = "data/laser/leg_tracker/demo_stationary_simple_environment.bag";

#[derive(Debug)]
struct Run {
    final_m: f64,
    final_yaw_rad: f64,
    max_offset_m: f64,
    max_yaw_rad: f64,
    prior_only: usize,
    excluded_points: usize,
}

fn run(scans: &[tether_msgs::LaserScanMsg], exclude_legs: bool) -> Run {
    let mut detector = LegDetector::learned(
        DetectorConfig::default(),
        RangeNoiseModel::default(),
        LegClassifier::default_model().unwrap(),
    )
    .unwrap();
    let mut matcher = ScanMatcher::new(ScanMatcherConfig::default());
    let mut points = ScanPoints::default();
    let mut r = Run {
        final_m: 0.0,
        final_yaw_rad: 0.0,
        max_offset_m: 0.0,
        max_yaw_rad: 0.0,
        prior_only: 0,
        excluded_points: 0,
    };
    let mut zones = Vec::new();
    for m in scans {
        // The laser frame is the robot frame here: the recording has no mount.
        points.fill_from_scan(&m.scan, Pose2::IDENTITY).unwrap();
        zones.clear();
        if exclude_legs {
            let d = detector.detect(&m.scan);
            zones.extend(d.legs.iter().chain(&d.weak_legs).map(|leg| ExclusionZone {
                center: Point2::new(leg.centre_in_laser.x, leg.centre_in_laser.y),
                radius_m: 0.3,
            }));
        }
        let e = matcher.update(m.scan.stamp, &points, MotionPrior::ConstantVelocity, &zones);
        if matches!(e.quality, Quality::PriorOnly(_)) {
            r.prior_only += 1;
        }
        r.excluded_points += e.excluded_points;
        let p = e.world_from_robot;
        r.max_offset_m = r.max_offset_m.max(p.x.hypot(p.y));
        r.max_yaw_rad = r.max_yaw_rad.max(p.yaw.abs());
        r.final_m = p.x.hypot(p.y);
        r.final_yaw_rad = p.yaw;
    }
    r
}

#[test]
fn a_static_robot_stays_put() {
    let Some(bag) = tether_testkit::shared(BAG) else {
        return;
    };
    let set = read_scans(&bag, "/scan").unwrap();
    assert!(set.scans.len() > 1000, "{} scans", set.scans.len());
    for exclude in [false, true] {
        let r = run(&set.scans, exclude);
        println!(
            "demo_stationary ({} scans, legs {}): final offset {:.4} m, yaw {:.3} deg; max offset {:.4} m, max yaw {:.3} deg; {} points excluded; {} fell back to the prior",
            set.scans.len(),
            if exclude { "excluded" } else { "kept" },
            r.final_m,
            r.final_yaw_rad.to_degrees(),
            r.max_offset_m,
            r.max_yaw_rad.to_degrees(),
            r.excluded_points,
            r.prior_only
        );
        if exclude {
            assert!(r.final_m < 0.03, "{r:?}");
            assert!(r.max_offset_m < 0.05, "{r:?}");
            assert!(r.max_yaw_rad < 1f64.to_radians(), "{r:?}");
            assert_eq!(r.prior_only, 0, "{r:?}");
        }
    }
}
