//! `tether run` with two cameras (`[[camera]]`, design 5.7): one looking ahead and one
//! looking back, each a folder of real photographs of people
//! (`../shared/data/images/people`), beside the emulated laser. Each camera's boxes go
//! through its own model, so the people the rear camera sees are behind the robot and
//! those the front one sees ahead of it; each camera records on a topic of its own, and
//! a replay given both topics reads every frame again through the same models.
//!
//! Needs `../shared` and Debian's upper-body cascade; without them it prints why and
//! skips, unless `TETHER_REQUIRE_SHARED=1` (set in CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::path::Path;
use std::time::Duration;

use common::run::{following, json};
use common::{scratch, tether, text};
use tether_core::{Point2, Pose2, Robot, World};
use tether_msgs::{CompressedImageMsg, OdometryMsg, PoseArrayMsg};
use tether_recording::mcap::McapFile;
use tether_testkit::{opencv_cascade, or_skip, skip_unless};

const FRONT_TOPIC: &str = "/camera/image_raw/compressed";
const REAR_TOPIC: &str = "/rear_camera/image_raw/compressed";

/// A `[[camera]]` table of a 640 x 480 camera reading `frames` at 10 fps, turned by
/// `yaw_rad`, with `extra` keys.
fn camera_table(frames: &Path, cascade: &Path, yaw_rad: f64, extra: &str) -> String {
    format!(
        r#"
[[camera]]
folder = "{}"
fps = 10.0
cascade = "{}"
{extra}
intrinsics = {{ fx_px = 460.0, fy_px = 460.0, cx_px = 319.5, cy_px = 239.5, width_px = 640, height_px = 480 }}
mount = {{ x_m = 0.0, y_m = 0.0, yaw_rad = {yaw_rad}, height_m = 0.65, tilt_rad = 0.2 }}
"#,
        frames.display(),
        cascade.display()
    )
}

/// `count` copies of the photograph `image` in a new folder `name` of `dir`.
fn folder_of(dir: &Path, name: &str, image: &Path, count: usize) -> std::path::PathBuf {
    let folder = dir.join(name);
    std::fs::create_dir_all(&folder).unwrap();
    for k in 0..count {
        std::fs::copy(image, folder.join(format!("frame{k}.png"))).unwrap();
    }
    folder
}

/// The forward coordinate, in the robot's frame, of each person seen in `results`'
/// `/tether/vision_people`, split by the camera that took the frame they came from:
/// (front, rear). A run writes each camera tick's people after the frame (on
/// `REAR_TOPIC` or not), so that the `k`-th people message is of the `k`-th frame. The
/// frames and the robot's poses are those of the live run's `recording`.
fn seen_ahead_m(recording: &Path, results: &Path) -> (Vec<f64>, Vec<f64>) {
    let file = McapFile::open(recording).unwrap();
    let (mut rear_frames, mut poses) = (Vec::new(), Vec::new());
    for m in file.messages() {
        let m = m.unwrap();
        match m.topic() {
            REAR_TOPIC => {
                let frame: CompressedImageMsg = m.decode().unwrap();
                assert_eq!(frame.header.frame_id, "rear_camera");
                rear_frames.push(true);
            }
            FRONT_TOPIC => rear_frames.push(false),
            "/odom" => {
                let odom: OdometryMsg = m.decode().unwrap();
                let world_from_robot: Pose2<World, Robot> = odom.pose.pose2();
                poses.push((odom.header.stamp.ns(), world_from_robot));
            }
            _ => {}
        }
    }
    let (mut front, mut rear) = (Vec::new(), Vec::new());
    let results = McapFile::open(results).unwrap();
    let people = results.decoded::<PoseArrayMsg>(&["/tether/vision_people"]);
    for (m, is_rear) in people.zip(rear_frames) {
        let m = m.unwrap().message;
        let stamp = m.header.stamp.ns();
        let (_, world_from_robot) = poses.iter().find(|(t, _)| *t == stamp).unwrap();
        let robot_from_world = world_from_robot.inverse();
        let ahead = m
            .positions_2d::<World>()
            .into_iter()
            .map(|p: Point2<World>| (robot_from_world * p).x);
        match is_rear {
            true => rear.extend(ahead),
            false => front.extend(ahead),
        }
    }
    (front, rear)
}

#[test]
fn two_cameras_each_read_through_its_own_model_recorded_and_replayed() {
    let shared = tether_testkit::shared_dir().join("data/images/people");
    let (ahead_image, behind_image) = (
        shared.join("basketball1.png"),
        shared.join("basketball2.png"),
    );
    if !skip_unless(
        ahead_image.is_file() && behind_image.is_file(),
        &format!("{} is missing its images", shared.display()),
    ) {
        return;
    }
    let Some(cascade) = or_skip(opencv_cascade("haarcascade_upperbody.xml")) else {
        return;
    };
    let dir = scratch("live-two-cameras");
    // The rear camera's folder ends first, the front one's later.
    let front = folder_of(&dir, "front", &ahead_image, 8);
    let rear = folder_of(&dir, "rear", &behind_image, 3);
    let tables = format!(
        "{}{}",
        camera_table(&front, &cascade, 0.0, ""),
        camera_table(
            &rear,
            &cascade,
            std::f64::consts::PI,
            "frame_id = \"rear_camera\""
        )
    );
    let (_emu, mut run, lines) = following(&dir, &tables, &["--duration", "3"]);
    let status = run.wait_or_fail(
        Duration::from_secs(60),
        "tether run did not end within 60 s",
    );
    let stderr = run.stderr();
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("11 camera frames"), "{stderr}");
    assert!(
        stderr.contains("camera \"rear_camera\": its frames ended; the other cameras"),
        "{stderr}"
    );
    assert!(
        stderr.contains("camera \"camera\": its frames ended; laser only"),
        "{stderr}"
    );
    let camera_ticks = lines
        .lock()
        .unwrap()
        .iter()
        .filter(|l| json(l)["input"] == "camera")
        .count();
    assert_eq!(camera_ticks, 11);

    // Each camera on its own topic, its frames' headers naming it.
    let recording = dir.join("run.mcap");
    let file = McapFile::open(&recording).unwrap();
    assert_eq!(file.message_count(FRONT_TOPIC), 8);
    assert_eq!(file.message_count(REAR_TOPIC), 3);
    // The people of the rear camera's frames are behind the robot, the front one's
    // ahead of it: each box went through its own camera's model.
    let (ahead, behind) = seen_ahead_m(&recording, &recording);
    assert!(
        !ahead.is_empty() && !behind.is_empty(),
        "{ahead:?} {behind:?}"
    );
    assert!(ahead.iter().all(|x| *x > 1.0), "{ahead:?}");
    assert!(behind.iter().all(|x| *x < -1.0), "{behind:?}");

    // The replay reads both topics, each frame through the model its header names.
    let replayed = dir.join("replayed.mcap");
    let out = tether(&[
        "replay",
        recording.to_str().unwrap(),
        "--config",
        dir.join("robot.toml").to_str().unwrap(),
        "--ego-motion",
        "commands",
        "--image-topic",
        FRONT_TOPIC,
        "--image-topic",
        REAR_TOPIC,
        "--cascade",
        cascade.to_str().unwrap(),
        "--out",
        replayed.to_str().unwrap(),
    ]);
    let said = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert!(out.status.success(), "{said}");
    assert!(said.contains(" 11 camera frames"), "{said}");
    // The replay steers by the live run's commands: the same people, where the live
    // run saw them.
    assert_eq!(seen_ahead_m(&recording, &replayed), (ahead, behind));
}
