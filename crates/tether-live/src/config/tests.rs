#![allow(clippy::unwrap_used, reason = "tests fail loudly")]

use super::*;

const MINIMAL: &str = r#"
[robot]
radius_m = 0.2
track_width_m = 0.3
max_speed_mps = 1.0
max_wheel_speed_mps = 1.2
max_accel_mps2 = 1.0

[laser]
serial = "/dev/ttyACM0"
mount = { x_m = 0.1, y_m = 0.0, yaw_rad = 0.0, height_m = 0.3 }

[follow]
follow_distance_m = 1.2
attach_ahead_m = 0.3
distance_omega_radps = 2.0
bearing_omega_radps = 2.5

[base]
kind = "none"

[output]
stdout = true
"#;

fn parse(text: &str) -> Result<RobotConfig, ConfigError> {
    RobotConfig::parse(text, Path::new("robot.toml"))
}

#[test]
fn a_minimal_config_fills_the_pipeline() {
    let c = parse(MINIMAL).unwrap();
    let p = c.pipeline_config().unwrap();
    assert_eq!(p.limits.track_width_m, 0.3);
    assert_eq!(p.limits.max_speed_mps, 1.0);
    assert_eq!(p.safety.robot_radius_m, 0.2);
    assert_eq!(p.follower.follow_distance_m, 1.2);
    assert_eq!(p.laser.mount.x_m, 0.1);
    assert!(!p.fusion.use_vision, "no camera: laser only");
    assert_eq!(
        c.laser_link(),
        LaserLink::Serial {
            path: "/dev/ttyACM0".into(),
            baud: 19_200
        }
    );
    assert!(c.camera.as_ref().and_then(|c| c.frame_input()).is_none());
}

/// Every required key, removed in turn, is named in the error.
#[test]
fn a_missing_key_is_named() {
    for key in [
        "radius_m",
        "track_width_m",
        "max_speed_mps",
        "max_wheel_speed_mps",
        "max_accel_mps2",
        "follow_distance_m",
        "attach_ahead_m",
        "distance_omega_radps",
        "bearing_omega_radps",
        "kind",
        "stdout",
    ] {
        let text: String = MINIMAL
            .lines()
            .filter(|l| !l.starts_with(&format!("{key} =")))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains(&format!("missing field `{key}`")), "{key}: {e}");
    }
    let text = MINIMAL.replace(", height_m = 0.3 }", " }");
    let e = parse(&text).unwrap_err().to_string();
    assert!(e.contains("missing field `height_m`"), "{e}");
    for table in ["[robot]", "[follow]", "[output]"] {
        let name = table.trim_matches(['[', ']']);
        let text = MINIMAL.replace(table, "[unused]");
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains(name), "{table}: {e}");
    }
}

#[test]
fn an_unknown_or_mistyped_key_is_named() {
    let e = parse(&MINIMAL.replace("radius_m = 0.2", "radius_m = 0.2\nwheel_base = 0.3"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `wheel_base`"), "{e}");
    assert!(e.contains("line"), "has a position: {e}");
    let e = parse(&MINIMAL.replace("max_speed_mps = 1.0", "max_speed_mps = \"fast\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("max_speed_mps"), "{e}");
    let e = parse(&MINIMAL.replace("kind = \"none\"", "kind = \"roomba\""))
        .unwrap_err()
        .to_string();
    assert!(e.contains("roomba") && e.contains("create"), "{e}");
}

#[test]
fn a_wrong_value_is_named() {
    let cases = [
        (
            "track_width_m = 0.3",
            "track_width_m = -0.3",
            "robot.track_width_m",
        ),
        (
            "max_accel_mps2 = 1.0",
            "max_accel_mps2 = nan",
            "robot.max_accel_mps2",
        ),
        (
            "serial = \"/dev/ttyACM0\"",
            "serial = \"/dev/ttyACM0\"\ntcp = \"10.0.0.1\"",
            "laser",
        ),
        ("serial = \"/dev/ttyACM0\"", "baud = 115200", "laser"),
        ("kind = \"none\"", "kind = \"create\"", "base.device"),
        (
            "kind = \"none\"",
            "kind = \"create\"\ndevice = \"/dev/ttyUSB0\"",
            "base.baud",
        ),
        (
            "attach_ahead_m = 0.3",
            "attach_ahead_m = 0.0",
            "follow.attach_ahead_m",
        ),
    ];
    for (from, to, field) in cases {
        let e = parse(&MINIMAL.replace(from, to)).unwrap_err();
        assert_eq!(e.field(), Some(field), "{to}: {e}");
        assert!(e.to_string().contains(field), "{e}");
    }
}

#[test]
fn a_base_of_kind_none_ignores_a_device_left_in_place() {
    // Switching a robot's config to "no base" is one line: the device and baud
    // may stay (a warning says they are ignored).
    let c = parse(&MINIMAL.replace(
        "kind = \"none\"",
        "kind = \"none\"\ndevice = \"/dev/ttyUSB0\"\nbaud = 57600",
    ))
    .unwrap();
    assert_eq!(c.base.kind, BaseKind::None);
}

#[test]
fn values_that_switch_safety_off_are_refused_by_name() {
    for (table, key, value, says) in [
        ("pipeline.safety", "laser_timeout_s", "inf", "(0, 1] s"),
        ("pipeline.safety", "laser_timeout_s", "1e9", "(0, 1] s"),
        ("pipeline.safety", "target_timeout_s", "1e9", "(0, 2] s"),
        ("pipeline.safety", "stop_distance_m", "-2.0", "[0.1, 3] m"),
        ("pipeline.safety", "stop_distance_m", "0", "[0.1, 3] m"),
        ("pipeline.limits", "max_reverse_mps", "10", "[0, 0.5] m/s"),
    ] {
        let text = format!("{MINIMAL}\n[{table}]\n{key} = {value}\n");
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains(key) && e.contains(says), "{key} = {value}: {e}");
    }
    let e = parse(&MINIMAL.replace("max_speed_mps = 1.0", "max_speed_mps = 1e300"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("robot.max_speed_mps") && e.contains("1e300") && e.contains("(0, 3] m/s"),
        "{e}"
    );
}

#[test]
fn the_laser_is_tried_again_for_a_bounded_time() {
    assert_eq!(
        parse(MINIMAL).unwrap().laser.reconnect_s,
        DEFAULT_RECONNECT_S
    );
    let mount = "mount = { x_m";
    let with = |value: &str| MINIMAL.replace(mount, &format!("reconnect_s = {value}\n{mount}"));
    assert_eq!(parse(&with("0")).unwrap().laser.reconnect_s, 0.0);
    assert_eq!(parse(&with("2.5")).unwrap().laser.reconnect_s, 2.5);
    for bad in ["-1", "inf", "nan", "1e9"] {
        let e = parse(&with(bad)).unwrap_err();
        assert_eq!(e.field(), Some("laser.reconnect_s"), "{bad}: {e}");
        assert!(e.to_string().contains("[0, 3600] s"), "{bad}: {e}");
    }
}

#[test]
fn pipeline_may_not_repeat_what_the_robot_tables_own() {
    let text = format!("{MINIMAL}\n[pipeline.limits]\ntrack_width_m = 0.5\n");
    let e = parse(&text).unwrap_err();
    assert_eq!(e.field(), Some("pipeline.limits.track_width_m"));
    assert!(e.to_string().contains("robot.track_width_m"), "{e}");
    // Tuning that is not owned elsewhere is welcome.
    let text = format!(
        "{MINIMAL}\n[pipeline.limits]\nmax_turn_radps = 1.0\n[pipeline.safety]\nlaser_timeout_s = 0.5\n"
    );
    let c = parse(&text).unwrap();
    let p = c.pipeline_config().unwrap();
    assert_eq!(p.limits.max_turn_radps, 1.0);
    assert_eq!(p.safety.laser_timeout_s, 0.5);
    assert_eq!(p.limits.track_width_m, 0.3);
    let e = parse(&format!("{MINIMAL}\n[pipeline.limits]\nturbo = 1.0\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `turbo`"), "{e}");
}

#[test]
fn tether_run_refuses_extra_lasers_it_would_never_hear_and_ros2_reads_them() {
    let text = format!("{MINIMAL}\n[[pipeline.extra_lasers]]\nframe_id = \"rear_laser\"\n");
    let e = parse(&text).unwrap_err();
    assert_eq!(e.field(), Some("pipeline.extra_lasers"));
    assert!(e.to_string().contains("[[laser]]"), "{e}");
    // `tether ros2` reads each extra laser from a topic of its own.
    let c = RobotConfig::parse_checked(&text, Path::new("robot.toml"), false).unwrap();
    assert_eq!(
        c.pipeline_config().unwrap().extra_lasers[0].frame_id,
        "rear_laser"
    );
}

#[test]
fn the_example_config_parses() {
    let c = parse(include_str!("../../../../configs/robot.example.toml")).unwrap();
    assert_eq!(c.base.kind, BaseKind::Create);
    assert_eq!(c.base.baud, Some(115_200));
    assert_eq!(
        c.laser_link(),
        LaserLink::Serial {
            path: "/dev/ttyACM0".into(),
            baud: 115_200
        }
    );
    assert!(matches!(
        c.camera.as_ref().and_then(|c| c.frame_input()),
        Some(FrameInput::V4l2 { .. })
    ));
    let p = c.pipeline_config().unwrap();
    assert_eq!(p.limits.track_width_m, 0.235);
    assert_eq!(p.limits.max_reverse_mps, 0.0);
    assert_eq!(p.camera.mount.height_m, 0.65);
    assert!(p.fusion.use_vision);
}

#[test]
fn camera_sources() {
    let camera = r#"
[camera]
folder = "frames"
fps = 15.0
intrinsics = { fx_px = 500.0, fy_px = 500.0, cx_px = 319.5, cy_px = 239.5, width_px = 640, height_px = 480 }
mount = { x_m = 0.05, y_m = 0.0, yaw_rad = 0.0, height_m = 0.65, tilt_rad = 0.3 }
"#;
    let c = parse(&format!("{MINIMAL}{camera}")).unwrap();
    assert_eq!(
        c.camera.as_ref().and_then(|c| c.frame_input()),
        Some(FrameInput::Folder {
            path: "frames".into(),
            fps: 15.0,
            repeat: false
        })
    );
    let p = c.pipeline_config().unwrap();
    assert!(p.fusion.use_vision);
    assert_eq!(p.camera.intrinsics.fx_px, 500.0);
    assert_eq!(p.camera.mount.tilt_rad, 0.3);
    let e = parse(&format!("{MINIMAL}{}", camera.replace("fps = 15.0\n", ""))).unwrap_err();
    assert_eq!(e.field(), Some("camera.fps"));
    let e = parse(&format!(
        "{MINIMAL}{}",
        camera.replace(" tilt_rad = 0.3", "")
    ))
    .unwrap_err()
    .to_string();
    assert!(e.contains("missing field `tilt_rad`"), "{e}");
    let v4l2 = camera.replace("folder = \"frames\"\nfps = 15.0", "v4l2 = \"/dev/video0\"");
    let c = parse(&format!("{MINIMAL}{v4l2}")).unwrap();
    assert_eq!(
        c.camera.as_ref().and_then(|c| c.frame_input()),
        Some(FrameInput::V4l2 {
            device: "/dev/video0".into()
        })
    );
}

/// Values that break naive parsers and checks: non-finite, huge, negative, zero,
/// of the wrong type, unterminated.
const NASTY_VALUES: [&str; 16] = [
    "inf",
    "-inf",
    "nan",
    "1e300",
    "-1e300",
    "0",
    "-0.0",
    "-2",
    "1e9",
    "9223372036854775807",
    "\"\"",
    "\"x\"",
    "[]",
    "{}",
    "true",
    "\"unterminated",
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]

    /// A valid config damaged (values replaced by nasty ones, lines dropped or
    /// doubled, random bytes put in) parses or gives an error, never panics; one that
    /// passes gives its laser link, frame input and pipeline configuration.
    #[test]
    fn damaged_configs_never_panic(
        edits in proptest::collection::vec((proptest::num::usize::ANY, 0usize..NASTY_VALUES.len() + 3, proptest::num::u8::ANY), 1..5),
    ) {
        let mut lines: Vec<String> = MINIMAL.lines().map(str::to_owned).collect();
        lines.push("[camera]".into());
        lines.push("folder = \"frames\"".into());
        lines.push("fps = 10.0".into());
        for (at, what, byte) in edits {
            let at = at % lines.len();
            match what.checked_sub(3) {
                Some(v) => {
                    if let Some((key, _)) = lines[at].split_once('=') {
                        lines[at] = format!("{key}= {}", NASTY_VALUES[v]);
                    }
                }
                None if what == 0 => {
                    lines.remove(at);
                }
                None if what == 1 => {
                    let line = lines[at].clone();
                    lines.insert(at, line);
                }
                None => {
                    let line = &mut lines[at];
                    let cut = (usize::from(byte) % (line.len() + 1)).min(line.len());
                    if line.is_char_boundary(cut) {
                        line.insert(cut, char::from(byte % 128));
                    }
                }
            }
        }
        let text = lines.join("\n");
        if let Ok(config) = parse(&text) {
            let _ = config.laser_link();
            let _ = config.camera.as_ref().and_then(|c| c.frame_input());
            let _ = config.pipeline_config();
        }
    }

    /// Arbitrary text never panics the parser.
    #[test]
    fn arbitrary_text_never_panics(text in "[\\[\\]a-z_=.0-9\"\n {}-]{0,200}") {
        let _ = parse(&text);
    }
}

/// `MINIMAL` with its `[laser]` as the first `[[laser]]` and `rear` (the keys of a
/// second one) after it.
fn two_lasers(rear: &str) -> String {
    MINIMAL
        .replace("[laser]", "[[laser]]")
        .replace("\n[follow]", &format!("\n[[laser]]\n{rear}\n\n[follow]"))
}

#[test]
fn each_laser_table_is_a_scanner_its_scans_told_apart_by_their_frame() {
    let rear = "tcp = \"192.168.0.11:10940\"\nframe_id = \"rear_laser\"\n\
                mount = { x_m = -0.1, y_m = 0.0, yaw_rad = 3.0, height_m = 0.3 }";
    let c = parse(&two_lasers(rear)).unwrap();
    assert_eq!(c.laser.extra().len(), 1);
    assert_eq!(c.laser.first_frame(), "laser");
    assert_eq!(c.laser_link(), parse(MINIMAL).unwrap().laser_link());
    assert_eq!(
        c.laser.extra()[0].link(),
        LaserLink::Tcp {
            address: "192.168.0.11:10940".into()
        }
    );
    let p = c.pipeline_config().unwrap();
    assert_eq!(p.laser.mount.x_m, 0.1);
    assert_eq!(p.extra_lasers.len(), 1);
    assert_eq!(p.extra_lasers[0].frame_id, "rear_laser");
    assert_eq!(p.extra_lasers[0].laser.mount.x_m, -0.1);
    assert_eq!(p.extra_lasers[0].laser.mount.yaw_rad, 3.0);
    // One `[[laser]]` is the same as `[laser]`.
    assert_eq!(
        parse(&MINIMAL.replace("[laser]", "[[laser]]")).unwrap(),
        parse(MINIMAL).unwrap()
    );
}

#[test]
fn a_second_laser_without_a_frame_of_its_own_or_with_a_mistake_is_named() {
    let mount = "mount = { x_m = -0.1, y_m = 0.0, yaw_rad = 3.1, height_m = 0.3 }";
    for (rear, field) in [
        (format!("tcp = \"10.0.0.2\"\n{mount}"), "laser[1].frame_id"),
        (
            format!("tcp = \"10.0.0.2\"\nframe_id = \"laser\"\n{mount}"),
            "laser[1].frame_id",
        ),
        (format!("frame_id = \"rear\"\n{mount}"), "laser[1]"),
        (
            format!("tcp = \"10.0.0.2\"\nbaud = 9600\nframe_id = \"rear\"\n{mount}"),
            "laser[1].baud",
        ),
        (
            "tcp = \"10.0.0.2\"\nframe_id = \"rear\"\n\
             mount = { x_m = -0.1, y_m = 0.0, yaw_rad = 3.1, height_m = -0.3 }"
                .to_owned(),
            "laser[1].mount.height_m",
        ),
    ] {
        let e = parse(&two_lasers(&rear)).unwrap_err();
        assert_eq!(e.field(), Some(field), "{rear}: {e}");
    }
    let e = parse(&two_lasers(&format!(
        "tcp = \"10.0.0.2\"\nframe = \"rear\"\n{mount}"
    )))
    .unwrap_err()
    .to_string();
    assert!(e.contains("unknown field `frame`"), "{e}");
    // No scanner at all: `laser = []` (before the first table, to be a top-level key).
    let without = MINIMAL.replace(
        "[laser]\nserial = \"/dev/ttyACM0\"\n\
         mount = { x_m = 0.1, y_m = 0.0, yaw_rad = 0.0, height_m = 0.3 }\n",
        "",
    );
    let e = parse(&format!("laser = []\n{without}"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("needs a scanner"), "{e}");
}

/// A camera's table at a mount turned by `yaw_rad`, with `extra` keys.
fn camera_table(extra: &str, yaw_rad: f64) -> String {
    format!(
        "[[camera]]\nfolder = \"frames\"\nfps = 10.0\n{extra}\n\
         intrinsics = {{ fx_px = 500.0, fy_px = 500.0, cx_px = 319.5, cy_px = 239.5, \
         width_px = 640, height_px = 480 }}\n\
         mount = {{ x_m = 0.05, y_m = 0.0, yaw_rad = {yaw_rad}, height_m = 0.65, tilt_rad = 0.1 }}\n"
    )
}

#[test]
fn each_camera_table_is_a_camera_its_frames_told_apart_by_their_frame() {
    let front = camera_table("", 0.0);
    let rear = camera_table("frame_id = \"rear_camera\"", 3.1);
    let c = parse(&format!("{MINIMAL}{front}{rear}")).unwrap();
    let cameras = c.camera.as_ref().unwrap();
    assert_eq!(cameras.first_frame(), "camera");
    let keyed: Vec<(String, &str)> = cameras.keyed().map(|(k, f, _)| (k, f)).collect();
    assert_eq!(
        keyed,
        [
            ("camera".to_owned(), "camera"),
            ("camera[1]".to_owned(), "rear_camera")
        ]
    );
    let p = c.pipeline_config().unwrap();
    assert!(p.fusion.use_vision);
    assert_eq!(p.camera.mount.yaw_rad, 0.0);
    assert_eq!(p.extra_cameras.len(), 1);
    assert_eq!(p.extra_cameras[0].frame_id, "rear_camera");
    assert_eq!(p.extra_cameras[0].camera.mount.yaw_rad, 3.1);
    // One `[[camera]]` is the same as `[camera]`.
    assert_eq!(
        parse(&format!("{MINIMAL}{front}")).unwrap(),
        parse(&format!(
            "{MINIMAL}{}",
            front.replace("[[camera]]", "[camera]")
        ))
        .unwrap()
    );
    // Mistakes name the table they are in.
    for (second, field) in [
        (camera_table("", 3.1), "camera[1].frame_id"),
        (
            camera_table("frame_id = \"camera\"", 3.1),
            "camera[1].frame_id",
        ),
        (camera_table("frame_id = \"\"", 3.1), "camera[1].frame_id"),
        (
            camera_table("frame_id = \"rear\"", 3.1).replace("fps = 10.0\n", ""),
            "camera[1].fps",
        ),
        (
            camera_table("frame_id = \"rear\"", 3.1).replace("height_m = 0.65", "height_m = 0"),
            "camera[1].mount.height_m",
        ),
    ] {
        let e = parse(&format!("{MINIMAL}{front}{second}")).unwrap_err();
        assert_eq!(e.field(), Some(field), "{second}: {e}");
    }
    // The first camera may name its frame, but not with nothing.
    let e = parse(&format!(
        "{MINIMAL}{}",
        camera_table("frame_id = \"\"", 0.0)
    ))
    .unwrap_err();
    assert_eq!(e.field(), Some("camera.frame_id"), "{e}");
    // The extra cameras of a robot are its `[[camera]]` tables, not `[pipeline]`'s.
    let e = parse(&format!(
        "{MINIMAL}{front}\n[[pipeline.extra_cameras]]\nframe_id = \"rear_camera\"\n"
    ))
    .unwrap_err();
    assert_eq!(e.field(), Some("pipeline.extra_cameras"), "{e}");
}
