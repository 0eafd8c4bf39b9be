//! `tether track --image-topic` over a ROS 1 bag that `rosbags` writes: real scans of
//! leg_tracker's recording with camera frames made of real images, raw and JPEG.
//!
//! Needs `../shared`, Debian's upper-body cascade and python3 with `rosbags`, `numpy` and
//! OpenCV; without them it prints why and skips, unless `TETHER_REQUIRE_SHARED=1` (set in
//! CI) makes that a failure.

#![allow(clippy::unwrap_used, reason = "a test should fail loudly on bad data")]

mod common;

use std::process::Command;

use common::{on_recording, scratch, tether, text};
use tether_testkit::{opencv_cascade, or_skip, python_modules, skip_unless};

const SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/camera_bag.py");

/// Boxes `tether detect` finds in one image.
fn boxes_in(image: &str) -> usize {
    let out = tether(&["detect", image]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    report["images"][0]["boxes"].as_array().unwrap().len()
}

#[test]
fn tracks_a_bag_with_camera_frames_raw_and_compressed() {
    let shared = tether_testkit::shared_dir();
    let source = shared.join("data/laser/leg_tracker/demo_stationary_simple_environment.bag");
    let pngs = [
        shared.join("data/images/people/basketball1.png"),
        shared.join("data/images/people/basketball2.png"),
    ];
    if !skip_unless(
        source.is_file() && pngs.iter().all(|p| p.is_file()),
        &format!("{} is missing its recordings or images", shared.display()),
    ) || or_skip(opencv_cascade("haarcascade_upperbody.xml")).is_none()
        || or_skip(python_modules(
            &["rosbags", "numpy", "cv2"],
            "rosbags numpy opencv-python-headless",
        ))
        .is_none()
    {
        return;
    }
    let dir = scratch("track-camera");
    let n_scans = 12;
    let made = Command::new("python3")
        .arg(SCRIPT)
        .arg(&dir)
        .arg(&source)
        .args(["/scan", &n_scans.to_string()])
        .args(&pngs)
        .output()
        .unwrap();
    assert!(made.status.success(), "{}", text(&made.stderr));
    let made: serde_json::Value = serde_json::from_slice(&made.stdout).unwrap();
    let stamps: Vec<i64> = made["scan_stamps_ns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_i64().unwrap())
        .collect();
    assert_eq!(stamps.len(), n_scans);
    let frames = made["frames"].as_array().unwrap();
    let bag = dir.join("camera.bag");

    for (topic, file_key) in [
        ("/camera/image", "png"),
        ("/camera/image/compressed", "jpg"),
    ] {
        // What the detector finds in the frames' images, one file at a time.
        let expected: usize = frames
            .iter()
            .map(|f| boxes_in(f[file_key].as_str().unwrap()))
            .sum();
        assert!(expected > 0, "the people images should give detections");
        let out_path = dir.join("track.jsonl");
        let out = on_recording("track", &bag, "/scan", &["--image-topic", topic], &out_path);
        let stdout = text(&out.stdout);
        let stderr = text(&out.stderr);
        assert!(out.status.success(), "{stdout}{stderr}");
        assert!(
            stdout.contains(&format!(
                "{n_scans} scans, {} camera frames with {expected} detections",
                frames.len()
            )),
            "{topic}: {stdout}"
        );
        // One line per scan, in bag order, with the scans' own stamps.
        let lines = tether_testkit::json_lines(&std::fs::read_to_string(&out_path).unwrap());
        let got: Vec<i64> = lines
            .iter()
            .map(|l| l["stamp_ns"].as_i64().unwrap())
            .collect();
        assert_eq!(got, stamps, "{topic}");
        // The broken raw frame is skipped with a warning, not fatal.
        if topic == "/camera/image" {
            assert!(
                stderr.contains("skipping the /camera/image message") && stderr.contains("yuv422"),
                "{stderr}"
            );
        }
    }
    // `tether replay` runs the same frames through the same detector.
    let expected: usize = frames
        .iter()
        .map(|f| boxes_in(f["png"].as_str().unwrap()))
        .sum();
    let result = dir.join("replay.mcap");
    let out = on_recording(
        "replay",
        &bag,
        "/scan",
        &["--image-topic", "/camera/image"],
        &result,
    );
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
    assert!(
        stdout.contains(&format!(
            "{n_scans} scans, {} camera frames ({expected} detections)",
            frames.len()
        )),
        "{stdout}"
    );
    assert!(result.with_extension("html").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}
