//! The scene of the realism tests: people walking in front of a still laser.

/// A 60 s scenario `name` in one room from `min` to `max`, the robot standing still at
/// the origin with its camera off, and `people` (`[[people]]` tables) walking.
pub fn still_laser_scene(
    name: &str,
    description: &str,
    min: [f64; 2],
    max: [f64; 2],
    people: &str,
) -> String {
    format!(
        r#"
name = "{name}"
description = "{description}"
duration_s = 60.0

[world]
rooms = [{{ min = [{:?}, {:?}], max = [{:?}, {:?}] }}]

[robot]
start = {{ x = 0.0, y = 0.0 }}
driver = "still"

[camera_sim]
enabled = false
{people}"#,
        min[0], min[1], max[0], max[1]
    )
}
