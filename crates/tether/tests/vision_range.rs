//! Fed with the simulator's camera model, the vision-only range error grows with
//! distance as design 3.2 predicts (issue 4), and the covariance the monocular model gives
//! predicts it.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly")]

use tether_pipeline::vision::{VisionConfig, person_from_box};
use tether_sim::{Scenario, SensorData, Simulation};

/// A still robot watching a person walk straight away from 1 m to 6.5 m.
const SCENE: &str = r#"
name = "walk_away"
description = "a person walks away from a still camera"
duration_s = 9.0

[world]
rooms = [{ min = [-1.0, -3.0], max = [9.0, 3.0] }]

[robot]
start = { x = 0.0, y = 0.0 }
driver = "still"

[camera_sim]
false_positives_per_frame = 0.0

[[people]]
name = "walker"
target = true
path = [[1.2, 0.2], [6.8, 0.2]]
speed_mps = 0.8
"#;

#[test]
fn range_error_grows_with_distance_as_predicted() {
    // (distance bin, squared error, predicted variance along the ray)
    let mut bins: Vec<(f64, f64, usize)> = vec![(0.0, 0.0, 0); 6];
    for seed in 0..20 {
        let scenario = Scenario::from_toml_str(SCENE, "walk_away").unwrap();
        let mut sim = Simulation::new(&scenario, seed).unwrap();
        while let Some(event) = sim.advance() {
            let SensorData::Camera(frame) = &event.data else {
                continue;
            };
            let target = event.truth.target().unwrap();
            let robot_from_world = event.truth.world_from_robot.inverse();
            let truth = robot_from_world * target.position;
            for b in &frame.boxes {
                let Some(g) = person_from_box(&scenario.camera, &VisionConfig::default(), b) else {
                    continue;
                };
                if g.mean.distance_m(truth) > 1.5 {
                    continue;
                }
                let bin = truth.range_m().floor() as usize;
                if let Some(entry) = bins.get_mut(bin) {
                    let (major, _, _) = g.cov.principal_axes();
                    entry.0 += (g.mean.x - truth.x).powi(2);
                    entry.1 += major;
                    entry.2 += 1;
                }
            }
        }
    }
    let mut last = 0.0;
    for (k, (se, var, n)) in bins.iter().enumerate().filter(|(_, b)| b.2 > 30) {
        let rmse = (se / *n as f64).sqrt();
        let predicted = (var / *n as f64).sqrt();
        println!(
            "{k}-{} m: {n} boxes, range RMSE {rmse:.3} m, predicted sigma {predicted:.3} m",
            k + 1
        );
        assert!(rmse > last, "error grows with distance");
        assert!(
            rmse < 2.0 * predicted && rmse > 0.4 * predicted,
            "covariance predicts the error"
        );
        last = rmse;
    }
    assert!(
        last > 0.2,
        "at 5-6 m the range error is tens of centimetres"
    );
}
