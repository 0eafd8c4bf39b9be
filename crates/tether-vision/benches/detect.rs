//! Speed of the Haar cascade detector against OpenCV (issue 4): 640x480 images,
//! `haarcascade_upperbody.xml`, scale factor 1.1, minNeighbors 3.
//!
//! `cargo bench -p tether-vision --bench detect` first prints a comparison measured in
//! this run: tether on 1 and 2 threads (AVX2 when the CPU has it), tether on one thread
//! with the portable SSE2 scan, and OpenCV 4.x single-threaded (through
//! `../shared/tools/opencv_reference.py --time-runs`), best of several runs each, and the
//! ratio; then divan's own statistics for tether (reading the images is measured by
//! `tether-image`'s `decode` bench). Set `TETHER_BENCH_NO_OPENCV=1` to skip OpenCV. Needs
//! `../shared/data/images` and Debian's `opencv-data`; without them it says so and
//! measures nothing.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::LazyLock;
use std::time::Instant;

use tether_core::GrayImage;
use tether_image::imread_gray;
use tether_vision::{Cascade, DetectParams, Detector};

const CASCADE: &str = "/usr/share/opencv4/haarcascades/haarcascade_upperbody.xml";
/// The 640x480 images of `../shared/data/images`.
const IMAGES: [&str; 4] = [
    "people/basketball1.png",
    "people/basketball2.png",
    "no_people/aero3.jpg",
    "no_people/board.jpg",
];
/// Timed runs per measurement (the best is kept: the machine is shared).
const RUNS: usize = 10;

fn shared() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

struct Setup {
    detector_1: Detector,
    detector_2: Detector,
    /// One thread, the portable SSE2 scan even where the CPU has AVX2.
    detector_sse2: Detector,
    images: Vec<(String, GrayImage)>,
}

static SETUP: LazyLock<Option<Setup>> = LazyLock::new(|| {
    let dir = shared().join("data/images");
    if !dir.is_dir() || !Path::new(CASCADE).is_file() {
        println!(
            "SKIPPED: needs {} (beside the repository) and {CASCADE} (apt-get install opencv-data)",
            dir.display()
        );
        return None;
    }
    let cascade = Cascade::load(CASCADE).expect("load the cascade");
    let images = IMAGES
        .iter()
        .map(|name| {
            (
                name.to_string(),
                imread_gray(dir.join(name)).expect("read the image"),
            )
        })
        .collect();
    Some(Setup {
        detector_1: Detector::new(cascade.clone()),
        detector_sse2: Detector::new(cascade.clone()).with_avx2(false),
        detector_2: Detector::new(cascade).with_threads(2).expect("two threads"),
        images,
    })
});

fn params() -> DetectParams {
    DetectParams {
        scale_factor: 1.1,
        min_neighbors: 3,
        ..DetectParams::default()
    }
}

fn best_ms(detector: &Detector, image: &GrayImage) -> f64 {
    let p = params();
    (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            divan::black_box(detector.detect(image, &p).expect("detect"));
            t.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

/// OpenCV's time per image, ms, from the reference script: it reports the mean of its
/// `--time-runs`, so it is run three times with `RUNS / 3` timed runs and the best mean is
/// kept.
fn opencv_ms(paths: &[PathBuf]) -> Option<Vec<f64>> {
    let script = shared().join("tools/opencv_reference.py");
    let mut best = vec![f64::INFINITY; paths.len()];
    for _ in 0..3 {
        let out = Command::new("python3")
            .arg(&script)
            .args([
                "--cascade",
                CASCADE,
                "--scale-factor",
                "1.1",
                "--min-neighbors",
                "3",
            ])
            .args([
                "--threads",
                "1",
                "--time-runs",
                &(RUNS / 3).max(1).to_string(),
            ])
            .args(paths)
            .output()
            .ok()?;
        if !out.status.success() {
            println!(
                "OpenCV not measured: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            );
            return None;
        }
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).ok()?;
        for (b, image) in best.iter_mut().zip(json["images"].as_array()?) {
            *b = b.min(image["ms_per_run"].as_f64()?);
        }
    }
    Some(best)
}

fn compare_with_opencv(setup: &Setup) {
    let dir = shared().join("data/images");
    let paths: Vec<PathBuf> = IMAGES.iter().map(|n| dir.join(n)).collect();
    let opencv = if std::env::var_os("TETHER_BENCH_NO_OPENCV").is_some() {
        None
    } else {
        opencv_ms(&paths)
    };
    println!(
        "upperbody, 640x480, scale 1.1, minNeighbors 3 (best of {RUNS} runs, ms); x1 and x2 use \
         AVX2: {}; x1 SSE2 is the portable scan",
        setup.detector_1.uses_avx2()
    );
    println!(
        "{:<26} {:>10} {:>10} {:>10} {:>10} {:>9} {:>9} {:>9}",
        "image",
        "tether x1",
        "tether x2",
        "x1 SSE2",
        "OpenCV x1",
        "ratio x1",
        "ratio x2",
        "SSE2 x1"
    );
    let mut sums = [0.0; 4];
    for (k, (name, image)) in setup.images.iter().enumerate() {
        let t1 = best_ms(&setup.detector_1, image);
        let t2 = best_ms(&setup.detector_2, image);
        let ts = best_ms(&setup.detector_sse2, image);
        let cv = opencv.as_ref().map(|o| o[k]);
        for (sum, t) in sums.iter_mut().zip([t1, t2, ts, cv.unwrap_or(0.0)]) {
            *sum += t;
        }
        print_row(name, [t1, t2, ts], cv);
    }
    if opencv.is_some() {
        print_row("total", [sums[0], sums[1], sums[2]], Some(sums[3]));
    }
}

/// One line of the comparison: tether's times (x1, x2, x1 SSE2), OpenCV's and the ratios.
fn print_row(name: &str, [t1, t2, ts]: [f64; 3], cv: Option<f64>) {
    match cv {
        Some(cv) => println!(
            "{name:<26} {t1:>10.1} {t2:>10.1} {ts:>10.1} {cv:>10.1} {:>8.1}x {:>8.1}x {:>8.1}x",
            cv / t1,
            cv / t2,
            cv / ts
        ),
        None => println!(
            "{name:<26} {t1:>10.1} {t2:>10.1} {ts:>10.1} {:>10} {:>9} {:>9} {:>9}",
            "-", "-", "-", "-"
        ),
    }
}

fn main() {
    if let Some(setup) = SETUP.as_ref() {
        compare_with_opencv(setup);
    }
    divan::main();
}

/// One detection (upperbody, minNeighbors 3) on each 640x480 image.
#[divan::bench(args = IMAGES, consts = [1, 2], sample_count = 10)]
fn detect_640x480<const THREADS: usize>(bencher: divan::Bencher, name: &str) {
    let Some(setup) = SETUP.as_ref() else {
        return;
    };
    let detector = if THREADS == 1 {
        &setup.detector_1
    } else {
        &setup.detector_2
    };
    let image = &setup
        .images
        .iter()
        .find(|(n, _)| n == name)
        .expect("image")
        .1;
    let p = params();
    bencher.bench(|| detector.detect(image, &p).expect("detect"));
}

/// The image pyramid alone: every level's resize of a 640x480 image.
#[divan::bench(sample_count = 20)]
fn pyramid_resize_640x480(bencher: divan::Bencher) {
    let Some(setup) = SETUP.as_ref() else {
        return;
    };
    let image = &setup.images[0].1;
    let levels = tether_vision::detect::pyramid(640, 480, 22, 18, &params()).expect("pyramid");
    bencher.bench(|| {
        for l in &levels {
            divan::black_box(tether_vision::resize::resize_linear(
                image.pixels(),
                640,
                480,
                l.width,
                l.height,
            ));
        }
    });
}
