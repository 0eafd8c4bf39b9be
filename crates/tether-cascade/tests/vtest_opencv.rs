//! A cascade trained on real pedestrian video loads in OpenCV 4.x and finds there the
//! same boxes as in tether's detector (issue 8).
//!
//! Trains a small cascade (few stages, few samples, a feature subset) on
//! `../shared/data/vtest/train.txt`, writes the XML, and runs OpenCV's
//! `CascadeClassifier::detectMultiScale` (`../shared/tools/opencv_reference.py`) and
//! tether-vision's detector on a few frames, raw windows (`minNeighbors` 0) and grouped
//! (3). Both read the same pixels: OpenCV decodes the JPEG frames into PNG files first
//! (tether's JPEG decoder differs from libjpeg by a grey level here and there).
//!
//! Needs `../shared` beside the repository and Python with OpenCV 4.x
//! (`pip install opencv-python-headless==4.14.0.94 numpy`); without them the test prints
//! why and passes, unless `TETHER_REQUIRE_SHARED=1` (CI) makes that a failure.

use serde_json::Value;
use tether_cascade::train::{Silent, TrainConfig, TrainingData, train};
use tether_cascade::xml::to_xml;
use tether_image::imread_gray;
use tether_vision::{Cascade, DetectParams, Detector, Rect};

/// Why the test cannot run here, if it cannot.
fn missing_prerequisite() -> Result<(), String> {
    tether_testkit::shared_missing(&["data/vtest/train.txt", "tools/opencv_reference.py"])?;
    tether_testkit::python_cv2().map(|_| ())
}

#[test]
fn opencv_loads_the_trained_cascade_and_finds_the_same_boxes() {
    if tether_testkit::or_skip(missing_prerequisite()).is_none() {
        return;
    }
    let vtest = tether_testkit::shared_dir().join("data/vtest");
    let started = std::time::Instant::now();
    let data = TrainingData::load(&vtest.join("train.txt"), &[]).expect("load train.txt");
    // An unoptimised build trains a smaller cascade to keep `cargo test` short.
    let full = !cfg!(debug_assertions);
    let config = TrainConfig {
        stages: if full { 4 } else { 2 },
        num_pos: Some(if full { 500 } else { 200 }),
        num_neg: if full { 500 } else { 200 },
        max_features: if full { 4000 } else { 1000 },
        ..TrainConfig::default()
    };
    let state = train(&data, &config, None, &Silent).expect("train");
    eprintln!(
        "trained {} stages ({} weak classifiers) in {:.1} s",
        state.cascade.stages.len(),
        state.cascade.weak_count(),
        started.elapsed().as_secs_f64()
    );
    for r in &state.reports {
        assert!(r.hit_rate >= config.min_hit_rate, "{r:?}");
        assert!(r.false_alarm <= config.max_false_alarm, "{r:?}");
    }

    let dir = tether_testkit::scratch("cascade-vtest");
    let xml = dir.join("cascade.xml");
    std::fs::write(&xml, to_xml(&state.cascade, &config.stage_params())).expect("write XML");

    // Frames of the test split, decoded by OpenCV into PNG.
    let frames = [
        "vtest_500.jpg",
        "vtest_560.jpg",
        "vtest_620.jpg",
        "vtest_680.jpg",
    ];
    let mut pngs = Vec::new();
    for f in frames {
        let png = dir.join(f.replace(".jpg", ".png"));
        tether_testkit::python(&[
            "-c",
            "import cv2, sys; cv2.imwrite(sys.argv[2], cv2.imread(sys.argv[1], cv2.IMREAD_GRAYSCALE))",
            &vtest.join("frames").join(f).display().to_string(),
            &png.display().to_string(),
        ]);
        pngs.push(png);
    }
    let detector = Detector::new(Cascade::load(&xml).expect("tether-vision loads the XML"));
    let mut raw_windows = 0;
    for min_neighbors in [0u32, 3] {
        let reference: Value = serde_json::from_str(&tether_testkit::opencv_reference(
            &xml,
            min_neighbors,
            &pngs,
        ))
        .expect("reference JSON");
        let images = reference["images"].as_array().expect("images");
        for (png, image) in pngs.iter().zip(images) {
            let want: Vec<Rect> = image["boxes"]
                .as_array()
                .expect("boxes")
                .iter()
                .map(|b| {
                    let v: Vec<i32> = b
                        .as_array()
                        .expect("box")
                        .iter()
                        .map(|n| n.as_i64().expect("int") as i32)
                        .collect();
                    Rect {
                        x: v[0],
                        y: v[1],
                        width: v[2],
                        height: v[3],
                    }
                })
                .collect();
            let params = DetectParams {
                min_neighbors,
                ..DetectParams::default()
            };
            let mut got = detector
                .detect(&imread_gray(png).expect("read PNG"), &params)
                .expect("detect");
            got.sort();
            assert_eq!(
                got,
                want,
                "{} minNeighbors {min_neighbors}: tether and OpenCV differ",
                png.display()
            );
            if min_neighbors == 0 {
                raw_windows += want.len();
            }
        }
    }
    // The cascade is not trivial: it accepts some windows, not all.
    assert!(raw_windows > 0, "the trained cascade finds nothing");
    let _ = std::fs::remove_dir_all(&dir);
}
