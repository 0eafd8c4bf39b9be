//! Training on small synthetic image sets: bad inputs give clear errors (issue 8's list:
//! missing or unreadable images, boxes outside the image, fewer positives than asked for,
//! negatives exhausted, a window too small for any feature), and an interrupted training
//! resumed from its saved state gives the same cascade as an uninterrupted one.

use std::path::{Path, PathBuf};

use tether_cascade::train::{Silent, TrainConfig, TrainState, TrainingData, train};
use tether_cascade::{FeatureMode, TrainError};

/// A fresh folder under the target directory's temporary space.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tether-cascade-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create a temporary folder");
    dir
}

fn write_png(path: &Path, width: usize, height: usize, pixels: &[u8]) {
    let file = std::fs::File::create(path).expect("create the PNG");
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header().expect("PNG header");
    w.write_image_data(pixels).expect("PNG data");
}

/// Textured noise with dark "people" (a head over a body) at the given boxes.
fn scene(
    width: usize,
    height: usize,
    seed: u64,
    people: &[(usize, usize, usize, usize)],
) -> Vec<u8> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut px: Vec<u8> = (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f64, (i / width) as f64);
            let v = 140.0 + 40.0 * (x * 0.21 + seed as f64).sin() * (y * 0.13).cos();
            (v + (rnd() % 50) as f64 - 25.0).clamp(0.0, 255.0) as u8
        })
        .collect();
    for &(bx, by, bw, bh) in people {
        for y in by..by + bh {
            for x in bx..bx + bw {
                let (u, v) = ((x - bx) as f64 / bw as f64, (y - by) as f64 / bh as f64);
                let head = v < 0.25 && (u - 0.5).abs() < 0.18;
                let body = (0.25..0.95).contains(&v) && (u - 0.5).abs() < 0.3;
                if head || body {
                    px[y * width + x] = 30 + (rnd() % 20) as u8;
                }
            }
        }
    }
    px
}

/// Writes `n` scenes of 160x120 with two people each and their info.dat.
fn dataset(dir: &Path, n: usize) -> PathBuf {
    let mut info = String::new();
    for i in 0..n {
        let people = [
            (10 + 7 * (i % 9), 20, 24, 48),
            (100, 30 + 3 * (i % 7), 20, 40),
        ];
        let name = format!("f{i:03}.png");
        write_png(
            &dir.join(&name),
            160,
            120,
            &scene(160, 120, i as u64 + 1, &people),
        );
        info.push_str(&format!("{name} {}", people.len()));
        for (x, y, w, h) in people {
            info.push_str(&format!(" {x} {y} {w} {h}"));
        }
        info.push('\n');
    }
    let path = dir.join("info.dat");
    std::fs::write(&path, info).expect("write info.dat");
    path
}

fn small_config() -> TrainConfig {
    TrainConfig {
        window: Some([10, 20]),
        stages: 2,
        num_pos: Some(60),
        num_neg: 80,
        max_features: 1500,
        mode: FeatureMode::Basic,
        ..TrainConfig::default()
    }
}

#[test]
fn bad_inputs_give_clear_errors() {
    let dir = temp_dir("errors");
    let info = dataset(&dir, 6);

    // A missing image: the error names it and the line that lists it.
    let missing = dir.join("missing.dat");
    std::fs::write(&missing, "f000.png 0\nnope.png 1 1 1 5 5\n").unwrap();
    let e = TrainingData::load(&missing, &[]).unwrap_err();
    let msg = format!("{e}");
    assert!(matches!(e, TrainError::Image { line: 2, .. }), "{msg}");
    assert!(msg.contains("nope.png") && msg.contains(":2"), "{msg}");

    // An unreadable image (not an image at all).
    std::fs::write(dir.join("junk.png"), b"not a png").unwrap();
    let junk = dir.join("junk.dat");
    std::fs::write(&junk, "junk.png 0\n").unwrap();
    assert!(matches!(
        TrainingData::load(&junk, &[]),
        Err(TrainError::Image { .. })
    ));

    // A box outside its image.
    let outside = dir.join("outside.dat");
    std::fs::write(&outside, "f000.png 1 150 100 20 30\n").unwrap();
    let e = TrainingData::load(&outside, &[]).unwrap_err();
    assert!(matches!(e, TrainError::BoxOutside { .. }), "{e}");
    assert!(e.to_string().contains("150 100 20 30"), "{e}");

    // A background folder without images.
    let empty = temp_dir("errors-empty-bg");
    let e = TrainingData::load(&info, &[empty]).unwrap_err();
    assert!(e.to_string().contains("no PNG or JPEG"), "{e}");

    let data = TrainingData::load(&info, &[]).unwrap();

    // More positives than the 12 boxes (24 with mirrors) give.
    let e = train(
        &data,
        &TrainConfig {
            num_pos: Some(100),
            ..small_config()
        },
        None,
        &Silent,
    )
    .unwrap_err();
    assert!(
        matches!(e, TrainError::TooFewPositives { available: 24, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("--num-pos"), "{e}");

    // A window no feature fits.
    let e = train(
        &data,
        &TrainConfig {
            window: Some([2, 2]),
            num_pos: Some(10),
            ..small_config()
        },
        None,
        &Silent,
    )
    .unwrap_err();
    assert!(matches!(e, TrainError::WindowTooSmall { .. }), "{e}");

    // Far more negatives than two tiny images hold: a clear error, not an endless loop.
    let tiny_dir = temp_dir("errors-tiny");
    let mut tiny_info = String::new();
    for i in 0..2 {
        let name = format!("t{i}.png");
        write_png(
            &tiny_dir.join(&name),
            40,
            44,
            &scene(40, 44, i + 7, &[(8, 2, 20, 40)]),
        );
        tiny_info.push_str(&format!("{name} 1 8 2 20 40\n"));
    }
    std::fs::write(tiny_dir.join("info.dat"), tiny_info).unwrap();
    let tiny = TrainingData::load(&tiny_dir.join("info.dat"), &[]).unwrap();
    let e = train(
        &tiny,
        &TrainConfig {
            num_pos: Some(3),
            num_neg: 5_000,
            ..small_config()
        },
        None,
        &Silent,
    )
    .unwrap_err();
    assert!(
        matches!(e, TrainError::NegativesExhausted { stage: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("--bg"), "{e}");

    // Options out of range.
    for bad in [
        TrainConfig {
            min_hit_rate: 1.5,
            ..small_config()
        },
        TrainConfig {
            max_false_alarm: 0.0,
            ..small_config()
        },
        TrainConfig {
            upper: Some(0.0),
            ..small_config()
        },
        TrainConfig {
            stages: 0,
            ..small_config()
        },
    ] {
        assert!(matches!(
            train(&data, &bad, None, &Silent),
            Err(TrainError::BadOption(_))
        ));
    }
}

#[test]
fn a_resumed_training_gives_the_same_cascade() {
    let dir = temp_dir("resume");
    let info = dataset(&dir, 12);
    let data = TrainingData::load(&info, &[]).unwrap();
    let config = TrainConfig {
        num_pos: Some(40),
        ..small_config()
    };
    let whole = train(&data, &config, None, &Silent).unwrap();
    assert_eq!(whole.cascade.stages.len(), 2);
    assert!(whole.reports.iter().all(|r| r.hit_rate >= 0.995));

    // "Interrupted" after one stage: the state holds one stage.
    let state = dir.join("state.json");
    let first = train(
        &data,
        &TrainConfig {
            stages: 1,
            ..config.clone()
        },
        Some(&state),
        &Silent,
    )
    .unwrap();
    assert_eq!(first.cascade.stages.len(), 1);
    assert_eq!(TrainState::load(&state).unwrap(), first);
    // The rerun continues from it.
    let resumed = train(&data, &config, Some(&state), &Silent).unwrap();
    assert_eq!(resumed.cascade, whole.cascade);
    assert_eq!(resumed.reports.len(), 2);

    // Other options: refused, with advice.
    let e = train(
        &data,
        &TrainConfig {
            num_neg: 81,
            ..config.clone()
        },
        Some(&state),
        &Silent,
    )
    .unwrap_err();
    assert!(matches!(e, TrainError::StateMismatch { .. }), "{e}");
    assert!(e.to_string().contains("delete it"), "{e}");
    // A damaged state file.
    std::fs::write(&state, "{not json").unwrap();
    let e = train(&data, &config, Some(&state), &Silent).unwrap_err();
    assert!(matches!(e, TrainError::State { .. }), "{e}");
}
