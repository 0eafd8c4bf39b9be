//! Parity with OpenCV 4.x `CascadeClassifier::detectMultiScale` (issue 4, design 3.1).
//!
//! For every cascade of [`CASCADES`] (Debian's `opencv-data`, one of them in the old
//! haartraining layout), every image under `../shared/data/images/` and `minNeighbors`
//! 0 (raw windows) and 3, the boxes of OpenCV (computed now by
//! `../shared/tools/opencv_reference.py`) and of tether must be identical.
//!
//! tether reads every file itself (`imread_gray`, PNG and JPEG), and its pixels must
//! equal `cv2.imread(path, cv2.IMREAD_GRAYSCALE)`'s (written to a temporary PNG by
//! OpenCV for the comparison); OpenCV's boxes come from the original files. So the test
//! checks the whole path from file to boxes, decoding included.
//!
//! Needs `../shared` (beside the repository), the cascades in
//! `/usr/share/opencv4/haarcascades/` (`apt-get install opencv-data`) and Python with
//! OpenCV 4.x (`pip install opencv-python-headless==4.14.0.94 numpy`); without them the
//! test prints why and passes without checking. CI has all three.
//!
//! Run it optimised, `cargo test --release -p tether-vision --test opencv_parity -- --nocapture`,
//! to see the report; an unoptimised build checks a subset only (see [`FULL`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use tether_core::GrayImage;
use tether_image::imread_gray;
use tether_vision::detect::group_and_clip;
use tether_vision::{Cascade, DetectParams, Detector, Rect};

/// The cascades of the issue, plus the one old-layout cascade Debian ships.
const CASCADES: [&str; 9] = [
    "haarcascade_upperbody.xml",
    "haarcascade_fullbody.xml",
    "haarcascade_lowerbody.xml",
    "haarcascade_frontalface_default.xml",
    "haarcascade_frontalface_alt.xml",
    "haarcascade_frontalface_alt2.xml",
    "haarcascade_frontalface_alt_tree.xml",
    "haarcascade_profileface.xml",
    "haarcascade_licence_plate_rus_16stages.xml",
];

const CASCADE_DIR: &str = "/usr/share/opencv4/haarcascades";

#[derive(Debug, Deserialize)]
struct Reference {
    opencv: String,
    images: Vec<ReferenceImage>,
}

#[derive(Debug, Deserialize)]
struct ReferenceImage {
    path: String,
    width: usize,
    height: usize,
    boxes: Vec<[i32; 4]>,
}

/// Why the test cannot run here, if it cannot.
fn missing_prerequisite() -> Result<(), String> {
    tether_testkit::shared_missing(&["data/images", "tools/opencv_reference.py"])?;
    if let Some(c) = CASCADES
        .iter()
        .find(|c| !Path::new(CASCADE_DIR).join(c).is_file())
    {
        return Err(format!(
            "{CASCADE_DIR}/{c} is absent (apt-get install opencv-data)"
        ));
    }
    tether_testkit::python_cv2().map(|_| ())
}

fn images() -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in ["people", "no_people"] {
        let dir = tether_testkit::shared_dir().join("data/images").join(sub);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("list the images").path())
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        out.extend(files);
    }
    out
}

/// Runs the reference script.
fn opencv_reference(cascade: &Path, min_neighbors: u32, images: &[PathBuf]) -> Reference {
    serde_json::from_str(&tether_testkit::opencv_reference(
        cascade,
        min_neighbors,
        images,
    ))
    .expect("opencv_reference.py JSON")
}

/// OpenCV's grey decode of each file, written as PNG into `dir` (for the JPEG files).
fn opencv_decoded_as_png(files: &[PathBuf], dir: &Path) -> Vec<PathBuf> {
    let outs: Vec<PathBuf> = files
        .iter()
        .enumerate()
        .map(|(i, f)| {
            dir.join(format!(
                "{i}_{}.png",
                f.file_stem().expect("an image file name").to_string_lossy()
            ))
        })
        .collect();
    let pairs: Vec<String> = files
        .iter()
        .zip(&outs)
        .map(|(f, o)| {
            format!(
                "({:?}, {:?})",
                f.display().to_string(),
                o.display().to_string()
            )
        })
        .collect();
    let script = format!(
        "import cv2\nfor src, dst in [{}]:\n    g = cv2.imread(src, cv2.IMREAD_GRAYSCALE)\n    assert g is not None, src\n    assert cv2.imwrite(dst, g), dst\n",
        pairs.join(", ")
    );
    tether_testkit::python(&["-c", &script]);
    outs
}

fn sorted(mut v: Vec<Rect>) -> Vec<[i32; 4]> {
    v.sort();
    v.into_iter().map(Into::into).collect()
}

/// Boxes in one list and not the other (multiset difference both ways).
fn difference(a: &[[i32; 4]], b: &[[i32; 4]]) -> (Vec<[i32; 4]>, Vec<[i32; 4]>) {
    let count = |v: &[[i32; 4]]| {
        let mut m = BTreeMap::new();
        for r in v {
            *m.entry(*r).or_insert(0i32) += 1;
        }
        m
    };
    let (ca, cb) = (count(a), count(b));
    let mut only_a = Vec::new();
    let mut only_b = Vec::new();
    for (r, n) in &ca {
        for _ in 0..(n - cb.get(r).copied().unwrap_or(0)).max(0) {
            only_a.push(*r);
        }
    }
    for (r, n) in &cb {
        for _ in 0..(n - ca.get(r).copied().unwrap_or(0)).max(0) {
            only_b.push(*r);
        }
    }
    (only_a, only_b)
}

/// Optimised builds compare everything; unoptimised test builds (about 100 times slower
/// here) compare two cascades, one of each layout, on the two smallest images, and say so.
const FULL: bool = !cfg!(debug_assertions);

#[test]
fn same_boxes_as_opencv() {
    if tether_testkit::or_skip(missing_prerequisite()).is_none() {
        return;
    }
    let mut files = images();
    assert!(!files.is_empty());
    let cascades: Vec<&str> = if FULL {
        CASCADES.to_vec()
    } else {
        files.retain(|f| {
            let name = f
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            name == "messi5.jpg" || name == "smarties.png"
        });
        println!(
            "unoptimised build: comparing {} cascades on {} images only; run \
             `cargo test --release -p tether-vision --test opencv_parity` for all of them",
            2,
            files.len()
        );
        vec![CASCADES[0], CASCADES[8]]
    };
    let tmp = tether_testkit::scratch("vision-parity");
    let opencv_png = opencv_decoded_as_png(&files, &tmp);

    // The pixels the detector sees: tether's own decode, which must equal OpenCV's.
    let mut pixels: Vec<GrayImage> = Vec::new();
    println!("decoding (tether vs cv2.imread IMREAD_GRAYSCALE):");
    for (file, reference_png) in files.iter().zip(&opencv_png) {
        let opencv = imread_gray(reference_png).expect("decode OpenCV's PNG");
        let own = imread_gray(file).expect("tether decodes the file");
        assert_eq!(
            (own.width(), own.height()),
            (opencv.width(), opencv.height()),
            "{}",
            file.display()
        );
        let differing = own
            .pixels()
            .iter()
            .zip(opencv.pixels())
            .filter(|(a, b)| a != b)
            .count();
        println!(
            "  {:<40} {} of {} pixels differ",
            file.file_name().unwrap().to_string_lossy(),
            differing,
            own.pixels().len()
        );
        assert_eq!(
            differing,
            0,
            "the decode must equal OpenCV's: {}",
            file.display()
        );
        pixels.push(own);
    }

    let mut total_boxes = 0usize;
    let mut jpeg_boxes = 0usize;
    let mut mismatches = Vec::new();
    for name in cascades {
        let path = Path::new(CASCADE_DIR).join(name);
        let cascade = Cascade::load(&path).unwrap_or_else(|e| panic!("{e}"));
        // The portable SSE2 scan must find the same raw windows as the default one (AVX2
        // where the CPU has it).
        let portable = Detector::new(cascade.clone()).with_avx2(false);
        let detector = Detector::new(cascade).with_threads(2).unwrap();
        let references: Vec<(u32, Reference)> = [0u32, 3]
            .iter()
            .map(|&mn| (mn, opencv_reference(&path, mn, &files)))
            .collect();
        // One scan per image serves both minNeighbors values: they differ only in the
        // grouping.
        let params = DetectParams {
            min_neighbors: 0,
            ..DetectParams::default()
        };
        let raw: Vec<Vec<Rect>> = pixels
            .iter()
            .map(|image| detector.detect_raw(image, &params).unwrap())
            .collect();
        for (image, raw) in pixels.iter().zip(&raw) {
            assert_eq!(
                &portable.detect_raw(image, &params).unwrap(),
                raw,
                "{name}: the SSE2 and AVX2 scans differ"
            );
        }
        for (mn, reference) in &references {
            assert!(
                reference.opencv.starts_with('4'),
                "OpenCV {}",
                reference.opencv
            );
            for (k, theirs) in reference.images.iter().enumerate() {
                let (image, file) = (&pixels[k], &files[k]);
                assert_eq!(
                    (image.width(), image.height()),
                    (theirs.width, theirs.height),
                    "{}",
                    theirs.path
                );
                let ours = sorted(group_and_clip(&raw[k], *mn, image.width(), image.height()));
                total_boxes += theirs.boxes.len();
                if tether_testkit::is_jpeg(file) {
                    jpeg_boxes += theirs.boxes.len();
                }
                let (only_ours, only_theirs) = difference(&ours, &theirs.boxes);
                if !only_ours.is_empty() || !only_theirs.is_empty() {
                    mismatches.push(format!(
                        "{name} minNeighbors {mn} {}: tether only {only_ours:?}, OpenCV only {only_theirs:?}",
                        file.display()
                    ));
                }
            }
        }
        println!("{name}: compared");
    }
    println!(
        "{total_boxes} OpenCV boxes compared ({jpeg_boxes} on the JPEG files), {} mismatching \
         image/cascade/minNeighbors runs",
        mismatches.len()
    );
    for m in &mismatches {
        println!("  MISMATCH {m}");
    }
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(
        mismatches.is_empty(),
        "{} runs differ from OpenCV",
        mismatches.len()
    );
}
