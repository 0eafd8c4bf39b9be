//! OpenCV cascade XML (both the old `haarcascade` and the new `cascade` format) on
//! arbitrary text: parsing must never panic, and a cascade that parses must run on a
//! small fixed image (every stage, tree and feature the parser let through is
//! evaluated, with the portable scan and, where the CPU has it, the AVX2 one) without a
//! panic, returning boxes inside the image.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tether_core::GrayImage;
use tether_vision::{Cascade, DetectParams, Detector};

fn image() -> GrayImage {
    // A ramp with a bright square: windows differ, so stages pass and fail.
    let (w, h) = (32, 32);
    let pixels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (8..20).contains(&x) && (6..26).contains(&y) {
                230
            } else {
                ((x * 7 + y * 3) % 256) as u8
            }
        })
        .collect();
    GrayImage::from_raw(w, h, pixels).expect("32x32")
}

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(cascade) = Cascade::from_xml(&text) else {
        return;
    };
    let image = image();
    let params = [
        DetectParams {
            min_neighbors: 0,
            ..DetectParams::default()
        },
        DetectParams::default(),
    ];
    for avx2 in [false, true] {
        let detector = Detector::new(cascade.clone()).with_avx2(avx2);
        for p in &params {
            let boxes = detector
                .detect(&image, p)
                .expect("default params are valid");
            for b in &boxes {
                assert!(b.x >= 0 && b.y >= 0 && b.width > 0 && b.height > 0, "{b:?}");
                assert!(b.x + b.width <= 32 && b.y + b.height <= 32, "{b:?}");
            }
        }
    }
});
