//! A robot with a second camera looking back (`[[extra_cameras]]`, design 5.7): the
//! simulator makes its frames, the driver hands them to the pipeline under their frame,
//! and the pipeline reads each box through that camera's own model, so that the people
//! behind the robot come out behind it, where they are.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_core::ExtraCamera;
use tether_eval::closed_loop;
use tether_sim::{Scenario, SensorData};

/// One vision person of a frame: from the rear camera, behind the robot, and how far
/// from the nearest true person, m.
#[derive(Debug, Clone, Copy)]
struct Seen {
    rear_camera: bool,
    behind: bool,
    error_m: f64,
}

/// Every vision person of `all_round` (seed 1), with a rear camera when `rear`, the
/// robot turned round at its start (the person walks off behind it) and too slow to turn
/// back: the person is only ever behind it.
fn seen(rear: bool) -> Vec<Seen> {
    let mut scenario = Scenario::resolve("all_round").unwrap().0;
    scenario.robot.start.yaw_rad = std::f64::consts::PI;
    scenario.robot.max_wheel_speed_mps = 0.001;
    if rear {
        let mut camera = scenario.camera;
        camera.mount.x_m = -0.1;
        camera.mount.yaw_rad = std::f64::consts::PI;
        scenario.extra_cameras.push(ExtraCamera {
            frame_id: "rear_camera".into(),
            camera,
        });
    }
    let (fused, _) = closed_loop::variants(&scenario);
    let mut seen = Vec::new();
    closed_loop::run_observed(&scenario, 1, &fused, &[], &[], &mut |event, tick| {
        if let (SensorData::Camera(frame), Some(tick)) = (&event.data, tick) {
            let robot_from_world = event.truth.world_from_robot.inverse();
            for person in &tick.vision_people {
                let error_m = event
                    .truth
                    .people
                    .iter()
                    .map(|p| p.position.distance_m(person.mean))
                    .fold(f64::INFINITY, f64::min);
                seen.push(Seen {
                    rear_camera: frame.frame_id == "rear_camera",
                    behind: (robot_from_world * person.mean).x < 0.0,
                    error_m,
                });
            }
        }
        Ok(())
    })
    .unwrap();
    seen
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

#[test]
fn a_rear_camera_sees_the_people_behind_the_robot_where_they_are() {
    let with_rear = seen(true);
    let (rear, front): (Vec<Seen>, Vec<Seen>) = with_rear.iter().partition(|s| s.rear_camera);
    let behind = rear.iter().filter(|s| s.behind).count();
    let near = |seen: &[Seen]| seen.iter().filter(|s| s.error_m < 0.5).count();
    let rear_error_m = median(rear.iter().map(|s| s.error_m).collect());
    eprintln!(
        "rear camera: {} people seen, {behind} behind the robot, {} within 0.5 m of a person, \
         median error {rear_error_m:.2} m; front camera: {} seen, {} within 0.5 m",
        rear.len(),
        near(&rear),
        front.len(),
        near(&front)
    );
    assert!(near(&rear) >= 50, "{} of the rear camera's", near(&rear));
    assert_eq!(
        behind,
        rear.len(),
        "the rear camera's people in front of the robot"
    );
    assert!(rear_error_m < 0.5, "median error {rear_error_m:.2} m");
    assert!(front.iter().all(|s| !s.behind));
    // The front camera alone, looking away, never sees the person.
    let alone = seen(false);
    assert!(alone.iter().all(|s| !s.rear_camera && !s.behind));
    assert_eq!(near(&alone), 0);
}
