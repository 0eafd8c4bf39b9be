use super::*;

#[test]
fn every_builtin_parses_and_validates() {
    for name in BUILTIN_NAMES {
        let s = Scenario::builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&s.name, name);
        assert!(s.people.iter().any(|p| p.target), "{name} has a target");
    }
    assert!(matches!(
        Scenario::builtin("nope"),
        Err(ScenarioError::UnknownBuiltin(_))
    ));
}

const BASE: &str = r#"
name = "t"
description = "test"
duration_s = 5.0

[world]
rooms = [{ min = [0.0, 0.0], max = [10.0, 5.0] }]

[[world.pillars]]
center = [5.0, 4.0]
radius_m = 0.3

[robot]
start = { x = 1.0, y = 2.5 }

[[people]]
name = "target"
target = true
path = [[2.0, 2.5], [8.0, 2.5]]
"#;

fn err_of(src: &str) -> String {
    match Scenario::from_toml_str(src, "bad.toml") {
        Ok(_) => panic!("accepted:\n{src}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn base_is_valid() {
    Scenario::from_toml_str(BASE, "base.toml").unwrap();
}

#[test]
fn unknown_key_names_file_line_and_field() {
    let src = BASE.replace("radius_m = 0.3", "radius_m = 0.3\nradius_cm = 30");
    let e = err_of(&src);
    assert!(e.starts_with("bad.toml:12:1:"), "{e}");
    assert!(e.contains("unknown field `radius_cm`"), "{e}");
}

#[test]
fn negative_radius_names_file_line_and_field() {
    let src = BASE.replace("radius_m = 0.3", "radius_m = -0.3");
    let e = err_of(&src);
    assert!(
        e.starts_with("bad.toml:11:12: field `world.pillars[0].radius_m`"),
        "{e}"
    );
}

#[test]
fn missing_field_names_file_line_and_field() {
    let src = BASE.replace("path = [[2.0, 2.5], [8.0, 2.5]]\n", "");
    let e = err_of(&src);
    assert!(e.starts_with("bad.toml:"), "{e}");
    assert!(e.contains("missing field `path`"), "{e}");
    // The error points at the [[people]] table.
    assert!(e.starts_with("bad.toml:16:1:"), "{e}");
}

#[test]
fn a_world_of_absurd_size_is_refused() {
    // A room of 1e15 m once took 60 s and 6.9 GB drawing its grid.
    let src = BASE.replace("max = [10.0, 5.0]", "max = [1e15, 5.0]");
    let e = err_of(&src);
    assert!(e.contains("field `world.rooms[0]`"), "{e}");
    assert!(e.contains("within 10000 m of the origin"), "{e}");
}

#[test]
fn path_outside_walls_names_the_waypoint() {
    let src = BASE.replace("[8.0, 2.5]]", "[8.0, 2.5], [12.0, 2.5]]");
    let e = err_of(&src);
    assert!(e.contains("field `people[0].path[2]`"), "{e}");
    assert!(e.contains("outside the walls"), "{e}");
    assert!(e.starts_with("bad.toml:19:33:"), "{e}");
}

#[test]
fn path_through_a_wall_is_refused() {
    let src = BASE.replace(
            "rooms = [{ min = [0.0, 0.0], max = [10.0, 5.0] }]",
            "rooms = [{ min = [0.0, 0.0], max = [10.0, 5.0] }]\nwalls = [{ from = [5.0, 0.0], to = [5.0, 3.0] }]",
        );
    let e = err_of(&src);
    assert!(e.contains("goes through the wall"), "{e}");
}

#[test]
fn path_into_a_pillar_is_refused() {
    let src = BASE.replace("[8.0, 2.5]]", "[8.0, 2.5], [5.0, 3.8]]");
    assert!(err_of(&src).contains("runs into the pillar"));
}

#[test]
fn wrong_type_points_at_the_line() {
    let src = BASE.replace("duration_s = 5.0", "duration_s = \"long\"");
    let e = err_of(&src);
    assert!(
        e.starts_with("bad.toml:4:14: field `duration_s`: invalid type"),
        "{e}"
    );
}

#[test]
fn sensor_models_are_checked() {
    let src = format!("{BASE}\n[laser.noise]\nsigma_floor_m = -1.0\n");
    let e = err_of(&src);
    assert!(e.contains("field `laser.noise.sigma_floor_m`"), "{e}");
    let src = format!("{BASE}\n[camera_sim]\nrate_hz = 0.0\n");
    assert!(err_of(&src).contains("field `camera_sim.rate_hz`"));
}

#[test]
fn extra_cameras_name_their_frames_alone_and_are_checked() {
    let rear = "[[extra_cameras]]\nframe_id = \"rear_camera\"\ncamera = { mount = { x_m = -0.1, \
                yaw_rad = 3.14159 } }\n";
    let ok = Scenario::from_toml_str(&format!("{BASE}\n{rear}"), "ok.toml").unwrap();
    assert_eq!(ok.extra_cameras[0].frame_id, "rear_camera");
    let e = err_of(&format!("{BASE}\n{rear}\n{rear}"));
    assert!(e.contains("field `extra_cameras[1].frame_id`"), "{e}");
    let e = err_of(&format!(
        "{BASE}\n{}",
        rear.replace("rear_camera", "camera")
    ));
    assert!(e.contains("field `extra_cameras[0].frame_id`"), "{e}");
    let bad = rear.replace("x_m = -0.1", "tilt_rad = 2.0");
    let e = err_of(&format!("{BASE}\n{bad}"));
    assert!(
        e.contains("field `extra_cameras[0].camera.mount.tilt_rad`"),
        "{e}"
    );
    let e = err_of(&format!("{BASE}\n[[extra_lasers]]\nframe_id = \"laser\"\n"));
    assert!(e.contains("field `extra_lasers[0].frame_id`"), "{e}");
}

/// The byte ranges of the numbers in a TOML text (runs of digits, signs, points
/// and exponents that start with a digit or a minus).
fn number_spans(src: &str) -> Vec<std::ops::Range<usize>> {
    let b = src.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        // Not inside a name such as `x1` or `leg_0`.
        let after_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !after_word {
            let start = i;
            i += 1;
            while i < b.len() && (b[i].is_ascii_digit() || b"-+.eE".contains(&b[i])) {
                i += 1;
            }
            spans.push(start..i);
        } else {
            i += 1;
        }
    }
    spans
}

/// Numbers that break naive geometry: huge (a room of 1e15 m once drew its SVG grid
/// for 60 s and 6.9 GB), at the cap, non-finite, zero, tiny, negative.
const NASTY_NUMBERS: [&str; 14] = [
    "1e15",
    "-1e15",
    "1e308",
    "inf",
    "-inf",
    "nan",
    "0",
    "-0.0",
    "1e-300",
    "10000.0",
    "-10000.0",
    "9999.5",
    "-1",
    "4294967296",
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(96))]

    /// A valid scenario with some of its numbers replaced by nasty ones parses or is
    /// refused, never panics; one that passes builds its world, draws an SVG map no
    /// bigger than its input justifies and simulates its first events.
    #[test]
    fn damaged_scenarios_never_panic_and_draw_bounded_maps(
        office in proptest::bool::ANY,
        edits in proptest::collection::vec((proptest::num::usize::ANY, 0usize..NASTY_NUMBERS.len()), 1..4),
    ) {
        let mut src = if office {
            Scenario::builtin_toml("office").unwrap().to_owned()
        } else {
            BASE.to_owned()
        };
        for (which, value) in edits {
            let spans = number_spans(&src);
            let span = spans[which % spans.len()].clone();
            src.replace_range(span, NASTY_NUMBERS[value]);
        }
        let Ok(scenario) = Scenario::from_toml_str(&src, "damaged.toml") else {
            return Ok(());
        };
        proptest::prop_assert!(scenario.validate().is_empty());
        let mut sim = crate::sim::Simulation::new(&scenario, 0).unwrap();
        let extent: Vec<_> = scenario
            .people
            .iter()
            .flat_map(|p| p.path.iter().map(|&xy| point(xy)))
            .collect();
        let svg = crate::svg::MapSvg::new(&scenario, sim.world(), extent, 60.0).finish();
        proptest::prop_assert!(svg.len() < 1_000_000 + 2_000 * src.len(), "{} bytes", svg.len());
        for _ in 0..3 {
            sim.advance();
        }
    }

    /// Arbitrary text never panics the parser.
    #[test]
    fn arbitrary_text_never_panics(text in "[\\[\\]a-z_=.0-9\"\n {},-]{0,200}") {
        let _ = Scenario::from_toml_str(&text, "random.toml");
    }
}
