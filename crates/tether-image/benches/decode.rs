//! Speed of reading image files to grey: the two 640x480 JPEG files of
//! `../shared/data/images` through tether's own decoder (`tether_image::jpeg`), bytes to
//! grey pixels, as `cv2.imread(path, IMREAD_GRAYSCALE)` decodes them.
//!
//! `cargo bench -p tether-image --bench decode`. Needs `../shared/data/images`; without
//! it the benchmark measures nothing.

use std::path::{Path, PathBuf};

fn shared() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

fn main() {
    divan::main();
}

/// Reading a 640x480 JPEG file's bytes to grey (`imread` without the file system).
#[divan::bench(args = ["no_people/aero3.jpg", "no_people/board.jpg"], sample_count = 50)]
fn imread_jpeg_640x480(bencher: divan::Bencher, name: &str) {
    let Ok(bytes) = std::fs::read(shared().join("data/images").join(name)) else {
        return;
    };
    bencher.bench(|| tether_image::imread::decode_gray(&bytes).expect("decode"));
}
