//! A robot with two scanners (design 5.7): a URG-04LX facing forward and one facing
//! back, each with 240 degrees, and a person walking a full circle round the robot. Each
//! scan goes to the laser its `frame_id` names; the people of both go to one tracker in
//! the world frame, so that the person is one track all the way round, passing from one
//! scanner's view to the other's, and the target stays locked on them. With the front
//! scanner alone the person is lost behind the robot. Every scanner must be alive for
//! the robot to drive.

use std::f64::consts::{PI, TAU};

use tether_control::StopReason;
use tether_core::{LaserModel, LaserMount, LaserScan, Point2, Pose2, Robot, Stamp, World};
use tether_fusion::TargetState;
use tether_pipeline::{ExtraLaser, Pipeline, PipelineConfig, Tick};
use tether_sim::rng::SimRng;

/// The robot stands at the world origin facing +x (its odometry says so).
const HERE: Pose2<World, Robot> = Pose2::IDENTITY;
/// The circle the person walks round the robot, m, and their speed, m/s.
const CIRCLE_M: f64 = 1.6;
const SPEED_MPS: f64 = 0.8;

fn front() -> LaserModel {
    LaserModel {
        mount: LaserMount {
            x_m: 0.12,
            y_m: 0.0,
            yaw_rad: 0.0,
            height_m: 0.3,
        },
        ..LaserModel::urg_04lx()
    }
}

fn rear() -> LaserModel {
    LaserModel {
        mount: LaserMount {
            x_m: -0.12,
            y_m: 0.0,
            yaw_rad: PI,
            height_m: 0.3,
        },
        ..LaserModel::urg_04lx()
    }
}

fn config(with_rear: bool) -> PipelineConfig {
    let mut config = PipelineConfig {
        laser: front(),
        ..PipelineConfig::default()
    };
    config.fusion.use_vision = false;
    if with_rear {
        config.extra_lasers.push(ExtraLaser {
            frame_id: "rear_laser".into(),
            laser: rear(),
        });
    }
    config
}

/// Where the person is at `t_s`, robot frame: they start 1.6 m ahead and walk
/// counter-clockwise round the robot; and their two legs (a stride across the path).
fn person_at(t_s: f64) -> (Point2<Robot>, [Point2<Robot>; 2]) {
    let a = SPEED_MPS * t_s / CIRCLE_M;
    let centre = Point2::<Robot>::new(CIRCLE_M * a.cos(), CIRCLE_M * a.sin());
    // Along the path (tangent) and across it.
    let (tx, ty) = (-a.sin(), a.cos());
    let stride = 0.15 * (TAU * t_s).sin();
    let legs = [1.0, -1.0].map(|side: f64| {
        Point2::new(
            centre.x + side * (0.1 * ty + stride * tx),
            centre.y + side * (-0.1 * tx + stride * ty),
        )
    });
    (centre, legs)
}

/// A scan of `model` (frame `frame_id`) at `t_s` of a 10 m x 10 m room round the robot
/// and the person's legs (radius 0.06 m), with 5 mm of range noise.
fn scan(model: &LaserModel, frame_id: &str, t_s: f64, rng: &mut SimRng) -> LaserScan {
    let g = model.geometry;
    let laser_from_robot = model.robot_from_laser().inverse();
    let (_, legs) = person_at(t_s);
    let legs: Vec<Point2<tether_core::Laser>> =
        legs.iter().map(|p| laser_from_robot * *p).collect();
    let walls = laser_from_robot * Point2::<Robot>::ORIGIN;
    let ranges: Vec<f32> = (0..g.beam_count())
        .map(|i| {
            let (s, c) = (g.angle_min_rad() + i as f64 * g.angle_increment_rad()).sin_cos();
            // The room's walls 5 m from the robot's centre, whatever the mount.
            let to_wall = |d: f64, o: f64| {
                if d.abs() > 1e-9 {
                    (5.0 * d.signum() - o) / d
                } else {
                    f64::INFINITY
                }
            };
            let (wx, wy) = (-walls.x, -walls.y);
            let mut r = to_wall(c, -wx).min(to_wall(s, -wy));
            for leg in &legs {
                let proj = c * leg.x + s * leg.y;
                let disc = proj * proj - (leg.x * leg.x + leg.y * leg.y - 0.06 * 0.06);
                if disc >= 0.0 && proj > 0.0 {
                    r = r.min(proj - disc.sqrt());
                }
            }
            let noisy = r + rng.normal(0.0, 0.005);
            if noisy > model.range_max_m {
                f32::INFINITY
            } else {
                noisy as f32
            }
        })
        .collect();
    LaserScan::new(
        Stamp::from_ns((t_s * 1e9).round() as i64),
        frame_id,
        g.angle_min_rad(),
        g.angle_increment_rad(),
        model.range_min_m,
        model.range_max_m,
        ranges,
    )
    .expect("the URG-04LX geometry is valid")
}

/// A walk once round the robot and a quarter more: the front scanner at 10 Hz from
/// t = 0, the rear one (when given) half a period later; the ticks with the person's
/// true place.
fn walk_round(with_rear: bool) -> Vec<(Tick, Point2<Robot>)> {
    let mut pipeline = Pipeline::new(config(with_rear), None).expect("a valid configuration");
    let mut rng = SimRng::stream(7, "two lasers");
    let (front, rear) = (front(), rear());
    let seconds = 1.25 * TAU * CIRCLE_M / SPEED_MPS;
    let mut ticks = Vec::new();
    for k in 0..(seconds * 10.0) as usize {
        let t_s = k as f64 * 0.1;
        let tick = pipeline.on_scan(&scan(&front, "laser", t_s, &mut rng), HERE);
        ticks.push((tick, person_at(t_s).0));
        if with_rear {
            let t_s = t_s + 0.05;
            let tick = pipeline.on_scan(&scan(&rear, "rear_laser", t_s, &mut rng), HERE);
            ticks.push((tick, person_at(t_s).0));
        }
    }
    ticks
}

/// The locked track's id and how far it is from the person, m.
fn locked(tick: &Tick, person: Point2<Robot>) -> Option<(u64, f64)> {
    let id = tick.target.state.locked_track()?;
    let estimate = tick.target.estimate?;
    let person = HERE * person;
    Some((id, estimate.mean.distance_m(person)))
}

#[test]
fn a_person_walking_round_the_robot_is_one_track_seen_by_both_scanners() {
    let ticks = walk_round(true);
    let first_lock = ticks
        .iter()
        .position(|(t, p)| locked(t, *p).is_some())
        .expect("the person is locked on");
    assert!(first_lock < 30, "locked at tick {first_lock}");
    let ids: std::collections::BTreeSet<u64> = ticks[first_lock..]
        .iter()
        .filter_map(|(t, p)| locked(t, *p).map(|(id, _)| id))
        .collect();
    assert_eq!(ids.len(), 1, "the target's track changed: {ids:?}");
    for (k, (tick, person)) in ticks.iter().enumerate().skip(first_lock) {
        let Some((_, off_m)) = locked(tick, *person) else {
            panic!(
                "tick {k} at {:?}: not locked: {:?}",
                tick.stamp, tick.target.state
            );
        };
        assert!(
            off_m < 0.35,
            "tick {k}: the target {off_m:.2} m from the person"
        );
        // Nobody else: one confirmed track.
        let confirmed = tick.tracks.iter().filter(|t| t.confirmed).count();
        assert_eq!(confirmed, 1, "tick {k}: {:?}", tick.tracks);
    }
    // Both scanners saw the person: ahead (front scans) and behind (rear scans).
    let behind = ticks
        .iter()
        .filter(|(t, p)| p.x < -0.5 && !t.laser_people.is_empty())
        .count();
    assert!(
        behind > 30,
        "{behind} ticks saw the person behind the robot"
    );
}

#[test]
fn with_the_front_scanner_alone_the_person_behind_is_lost() {
    let ticks = walk_round(false);
    let ahead_and_locked = ticks
        .iter()
        .filter(|(t, p)| p.x > 1.0 && locked(t, *p).is_some_and(|(_, off)| off < 0.35))
        .count();
    assert!(
        ahead_and_locked > 10,
        "locked on {ahead_and_locked} ticks ahead"
    );
    let behind_and_locked = ticks
        .iter()
        .filter(|(t, p)| {
            p.x < -1.0
                && p.y.abs() < 0.5
                && matches!(t.target.state, TargetState::Locked { .. })
                && locked(t, *p).is_some_and(|(_, off)| off < 0.35)
        })
        .count();
    assert_eq!(behind_and_locked, 0);
}

#[test]
fn every_scanner_must_be_alive_for_the_robot_to_drive() {
    let mut pipeline = Pipeline::new(config(true), None).expect("a valid configuration");
    let mut rng = SimRng::stream(3, "two lasers");
    let front = front();
    // The front scanner alone, the rear one never heard: the laser watchdog holds the
    // robot once the person is locked.
    let mut stops = Vec::new();
    for k in 0..40 {
        let tick = pipeline.on_scan(&scan(&front, "laser", k as f64 * 0.1, &mut rng), HERE);
        stops.push(tick.stop);
    }
    assert_eq!(
        stops.last(),
        Some(&Some(StopReason::StaleLaser)),
        "{stops:?}"
    );
    assert!(stops.iter().all(|s| s.is_some()), "{stops:?}");
}

#[test]
fn two_lasers_may_not_claim_one_frame() {
    let mut config = config(true);
    config.extra_lasers.push(ExtraLaser {
        frame_id: "rear_laser".into(),
        laser: rear(),
    });
    let e = Pipeline::new(config, None).expect_err("a frame named twice");
    assert!(e.to_string().contains("rear_laser"), "{e}");
    let mut config = self::config(true);
    config.extra_lasers[0].frame_id.clear();
    assert!(Pipeline::new(config, None).is_err());
}
