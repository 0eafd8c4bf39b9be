//! tether's JPEG decoder on small fixtures whose OpenCV decode is stored beside them
//! (`tests/data/jpeg/`, written by `make_fixtures.py` with OpenCV 4.14), and damaged
//! versions of them that must never panic.
//!
//! The fixtures cover a baseline 4:2:0 file with restart markers, progressive colour and
//! grey files, progressive files cut in their AC scans and in their second (DC-only
//! known) scan, where libjpeg-turbo smooths the blocks, a cut baseline file, a file whose
//! luma plane is subsampled (upsampled as libjpeg does), an Adobe CMYK file, an
//! Adobe RGB file, and arithmetic-coded copies (`jpegtran -arithmetic`) of the baseline
//! and progressive files, one of them cut.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use tether_image::imread::{apply_orientation, decode_gray as imread_decode};
use tether_image::jpeg::{Warning, decode_gray};

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/jpeg")
}

/// `(name, width, height)` of every fixture.
fn fixtures() -> Vec<(String, usize, usize)> {
    let list = std::fs::read_to_string(data_dir().join("fixtures.txt")).expect("fixtures.txt");
    list.lines()
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (
                f[0].to_string(),
                f[1].parse().expect("width"),
                f[2].parse().expect("height"),
            )
        })
        .collect()
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(data_dir().join(format!("{name}.jpg"))).expect("fixture")
}

#[test]
fn fixtures_equal_opencv() {
    let all = fixtures();
    assert!(all.len() >= 9);
    for (name, w, h) in &all {
        let decoded = decode_gray(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let expected =
            std::fs::read(data_dir().join(format!("{name}.cv2.gray"))).expect("OpenCV decode");
        assert_eq!((decoded.width, decoded.height), (*w, *h), "{name}");
        let differing = decoded
            .pixels
            .iter()
            .zip(&expected)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differing, 0,
            "{name}: {differing} pixels differ from OpenCV's"
        );
        let truncated = name.contains("truncated") || name.contains("dc_only");
        assert_eq!(
            decoded
                .warnings
                .iter()
                .any(|w| matches!(w, Warning::PrematureEnd { .. })),
            truncated,
            "{name}: {:?}",
            decoded.warnings
        );
    }
}

#[test]
fn exif_orientation_is_applied() {
    let plain = fixture("baseline_420_rst2");
    // SOI, then an APP1 "Exif" block: little-endian TIFF, IFD0 with one entry, tag
    // 0x0112 (orientation) = 6 (rotate 90 degrees clockwise).
    let app1 = |orientation: u8| {
        let mut tiff = b"Exif\0\0II*\0\x08\0\0\0\x01\0".to_vec();
        tiff.extend_from_slice(&[
            0x12,
            0x01,
            3,
            0,
            1,
            0,
            0,
            0,
            orientation,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        ]);
        let mut seg = vec![0xff, 0xe1];
        seg.extend_from_slice(&((tiff.len() + 2) as u16).to_be_bytes());
        seg.extend_from_slice(&tiff);
        seg
    };
    // A second Exif block (orientation 3) is ignored, as OpenCV ignores it.
    let mut rotated = plain[..2].to_vec();
    rotated.extend(app1(6));
    rotated.extend(app1(3));
    rotated.extend_from_slice(&plain[2..]);
    let upright = imread_decode(&plain).expect("decode");
    let turned = imread_decode(&rotated).expect("decode");
    assert_eq!((turned.width(), turned.height()), (47, 61));
    assert_eq!(turned.pixels(), apply_orientation(&upright, 6).pixels());
}

/// Width times height declared by the first SOF marker, if any (to keep damaged
/// headers from asking for gigabytes in a test).
fn declared_pixels(data: &[u8]) -> usize {
    data.windows(9)
        .find(|w| w[0] == 0xff && matches!(w[1], 0xc0..=0xc2))
        .map_or(0, |w| {
            usize::from(u16::from_be_bytes([w[5], w[6]]))
                * usize::from(u16::from_be_bytes([w[7], w[8]]))
        })
}

fn check_no_panic(data: &[u8]) {
    if declared_pixels(data) > 1 << 22 {
        return;
    }
    if let Ok(g) = decode_gray(data) {
        assert_eq!(g.pixels.len(), g.width * g.height);
    }
}

#[test]
fn every_truncation_decodes_or_fails_cleanly() {
    for name in ["progressive_420", "baseline_420_rst2", "luma_subsampled"] {
        let data = fixture(name);
        for cut in 0..data.len() {
            check_no_panic(&data[..cut]);
        }
    }
}

/// Cases per property: 600, or `TETHER_FUZZ_CASES` for a longer run.
fn fuzz_cases() -> u32 {
    std::env::var("TETHER_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(600)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fuzz_cases()))]

    /// Random byte changes, insertions, deletions and a cut, anywhere in any fixture.
    #[test]
    fn damaged_files_never_panic(
        which in 0usize..64,
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), 0u8..4), 1..10),
        cut in any::<usize>(),
    ) {
        let all = fixtures();
        let mut data = fixture(&all[which % all.len()].0);
        for (pos, value, kind) in edits {
            let p = pos % data.len().max(1);
            match kind {
                0 | 1 => data[p] = value,
                2 => data.insert(p, value),
                _ => {
                    data.remove(p);
                }
            }
        }
        if cut % 3 == 0 {
            let keep = cut % (data.len() + 1);
            data.truncate(keep);
        }
        check_no_panic(&data);
    }

    /// Damage confined to the entropy-coded data after the first SOS, where a decoder
    /// spends most of its time.
    #[test]
    fn damaged_scan_data_never_panics(
        which in 0usize..64,
        edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..20),
    ) {
        let all = fixtures();
        let mut data = fixture(&all[which % all.len()].0);
        let sos = data.windows(2).position(|w| w == [0xff, 0xda]).unwrap_or(0) + 12;
        for (pos, value) in edits {
            let span = data.len().saturating_sub(sos).max(1);
            let p = sos + pos % span;
            if p < data.len() {
                data[p] = value;
            }
        }
        check_no_panic(&data);
    }
}
