//! Grey decoding equal to `cv2.imread(path, cv2.IMREAD_GRAYSCALE)` for every kind of PNG
//! (issue 4): 8- and 16-bit colour, alpha, grey with alpha, low-bit grey, palettes,
//! transparency, and files that declare a gamma (`gAMA`, `sRGB`), which libpng converts in
//! linear light.
//!
//! The files are written here (seeded pseudo-random content), read by tether and by
//! Python's OpenCV, and compared pixel for pixel. Needs Python with OpenCV 4.x
//! (`pip install opencv-python-headless==4.14.0.94 numpy`); without it the test prints
//! why and passes without checking. The JPEG decoder is measured by `jpeg_parity` (and
//! by tether-vision's `opencv_parity`).

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use png::{BitDepth, ColorType, ScaledFloat, SrgbRenderingIntent};
use tether_image::imread_gray;

/// One test file: how it is encoded.
struct Variant {
    name: &'static str,
    color: ColorType,
    depth: BitDepth,
    gamma: Option<u32>,
    srgb: bool,
    palette: bool,
    trns: bool,
}

const fn v(name: &'static str, color: ColorType, depth: BitDepth) -> Variant {
    Variant {
        name,
        color,
        depth,
        gamma: None,
        srgb: false,
        palette: false,
        trns: false,
    }
}

fn variants() -> Vec<Variant> {
    vec![
        v("rgb8", ColorType::Rgb, BitDepth::Eight),
        v("rgb16", ColorType::Rgb, BitDepth::Sixteen),
        v("rgba8", ColorType::Rgba, BitDepth::Eight),
        v("rgba16", ColorType::Rgba, BitDepth::Sixteen),
        v("grey8", ColorType::Grayscale, BitDepth::Eight),
        v("grey16", ColorType::Grayscale, BitDepth::Sixteen),
        v("grey1", ColorType::Grayscale, BitDepth::One),
        v("grey2", ColorType::Grayscale, BitDepth::Two),
        v("grey4", ColorType::Grayscale, BitDepth::Four),
        v("greyalpha8", ColorType::GrayscaleAlpha, BitDepth::Eight),
        Variant {
            palette: true,
            ..v("palette8", ColorType::Indexed, BitDepth::Eight)
        },
        Variant {
            palette: true,
            trns: true,
            ..v("palette4_trns", ColorType::Indexed, BitDepth::Four)
        },
        Variant {
            gamma: Some(45_455),
            ..v("rgb8_gamma045", ColorType::Rgb, BitDepth::Eight)
        },
        Variant {
            gamma: Some(220_000),
            ..v("rgba8_gamma22", ColorType::Rgba, BitDepth::Eight)
        },
        Variant {
            gamma: Some(100_000),
            ..v("rgb8_gamma1", ColorType::Rgb, BitDepth::Eight)
        },
        Variant {
            srgb: true,
            ..v("rgb8_srgb", ColorType::Rgb, BitDepth::Eight)
        },
        Variant {
            gamma: Some(45_455),
            ..v("rgb16_gamma045", ColorType::Rgb, BitDepth::Sixteen)
        },
        Variant {
            gamma: Some(45_455),
            palette: true,
            ..v("palette8_gamma045", ColorType::Indexed, BitDepth::Eight)
        },
    ]
}

/// Writes a 61x23 image of the variant with seeded random samples. Colour images get
/// some grey pixels too (libpng passes those through unchanged).
fn write(variant: &Variant, dir: &Path, seed: u64) -> PathBuf {
    let (w, h) = (61u32, 23u32);
    let mut state = seed | 1;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 24) as u8
    };
    let bits = match variant.depth {
        BitDepth::One => 1,
        BitDepth::Two => 2,
        BitDepth::Four => 4,
        BitDepth::Eight => 8,
        BitDepth::Sixteen => 16,
    };
    let samples = variant.color.samples();
    let row_bytes = (w as usize * samples * bits).div_ceil(8);
    let mut data = vec![0u8; row_bytes * h as usize];
    for b in &mut data {
        *b = next();
    }
    // Every fifth pixel grey, except in 16-bit files with a gamma, the one case where
    // tether's grey pixels can be a level off (see `tether_image::imread`).
    let grey_pixels = !(bits == 16 && (variant.gamma.is_some() || variant.srgb));
    if bits >= 8 && grey_pixels && matches!(variant.color, ColorType::Rgb | ColorType::Rgba) {
        let bytes = bits / 8;
        for y in 0..h as usize {
            for x in (0..w as usize).step_by(5) {
                let p = y * row_bytes + x * samples * bytes;
                let first: Vec<u8> = data[p..p + bytes].to_vec();
                for c in 1..3 {
                    data[p + c * bytes..p + (c + 1) * bytes].copy_from_slice(&first);
                }
            }
        }
    }
    let path = dir.join(format!("{}.png", variant.name));
    let file = std::fs::File::create(&path).expect("create the test image");
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    encoder.set_color(variant.color);
    encoder.set_depth(variant.depth);
    if variant.palette {
        let entries = 1usize << bits;
        encoder.set_palette((0..entries * 3).map(|_| next()).collect::<Vec<u8>>());
        if variant.trns {
            encoder.set_trns((0..entries).map(|_| next()).collect::<Vec<u8>>());
        }
    }
    if let Some(g) = variant.gamma {
        encoder.set_source_gamma(ScaledFloat::from_scaled(g));
    }
    if variant.srgb {
        encoder.set_source_srgb(SrgbRenderingIntent::Perceptual);
    }
    let mut writer = encoder.write_header().expect("PNG header");
    writer.write_image_data(&data).expect("PNG data");
    writer.finish().expect("PNG end");
    path
}

#[test]
fn png_grey_equals_opencv() {
    let Some(version) = tether_testkit::or_skip(tether_testkit::python_cv2()) else {
        return;
    };
    let dir = tether_testkit::scratch("image-imread");
    let files: Vec<(String, PathBuf)> = variants()
        .iter()
        .enumerate()
        .map(|(k, v)| (v.name.to_string(), write(v, &dir, 7 + k as u64)))
        .collect();
    // OpenCV's decode of each file, as raw bytes beside it.
    let script = "import sys, cv2\nfor p in sys.argv[1:]:\n    g = cv2.imread(p, cv2.IMREAD_GRAYSCALE)\n    assert g is not None, p\n    open(p + '.cv', 'wb').write(g.tobytes())\n";
    let mut args = vec![OsStr::new("-c"), OsStr::new(script)];
    args.extend(files.iter().map(|(_, p)| p.as_os_str()));
    tether_testkit::python(&args);
    let mut failures = Vec::new();
    for (name, path) in &files {
        let ours = imread_gray(path).unwrap();
        let theirs = std::fs::read(path.with_extension("png.cv")).unwrap();
        let differing = ours
            .pixels()
            .iter()
            .zip(&theirs)
            .filter(|(a, b)| a != b)
            .count();
        println!("{name:<20} {differing} of {} pixels differ", theirs.len());
        if differing > 0 || ours.pixels().len() != theirs.len() {
            failures.push(name.clone());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        failures.is_empty(),
        "OpenCV {version} decodes differently: {failures:?}"
    );
}
