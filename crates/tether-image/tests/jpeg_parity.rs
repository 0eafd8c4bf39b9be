//! tether's JPEG grey decode against `cv2.imread(path, cv2.IMREAD_GRAYSCALE)` (OpenCV
//! 4.x with its libjpeg-turbo), pixel for pixel, including the EXIF orientation:
//!
//! - every JPEG under `../shared/data/images/` and every 10th frame of
//!   `../shared/data/vtest/frames/`;
//! - files OpenCV writes now from two of those images: qualities 10 and 100,
//!   progressive, restart intervals, every sampling factor OpenCV offers, grey,
//!   optimised Huffman tables;
//! - damaged copies of some of them (cut at seeded places, and with seeded byte changes),
//!   where OpenCV and tether must also agree on whether there is an image at all;
//! - arithmetic-coded copies of the shared images that `jpegtran -arithmetic` writes
//!   (sequential, progressive with restart markers, grey), and damaged copies of some.
//!
//! Needs `../shared` and Python with OpenCV 4.x (`pip install
//! opencv-python-headless==4.14.0.94 numpy`), and `jpegtran` (`apt-get install
//! libjpeg-turbo-progs`) for the arithmetic-coded files; without them the test prints
//! why and passes without checking (or without the arithmetic-coded files), unless
//! `TETHER_REQUIRE_SHARED=1`. Run it with
//! `--nocapture` to see the report.
//!
//! One kind of damage is left out on purpose: a `0xFF` byte written into the
//! entropy-coded data next to a stuffed `FF 00`. libjpeg-turbo's fast Huffman path reads
//! `FF FF 00` as a marker, then redoes the MCU with its exact path, and the coefficients
//! the first attempt wrote stay behind; which MCUs take the fast path depends on where
//! the 4096-byte `fread` buffer boundaries fall. tether decodes such an MCU as the exact
//! path does (see `tether_image::jpeg`).

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

use tether_image::imread_gray;

fn jpegs_under(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for p in paths {
        if p.is_dir() {
            jpegs_under(&p, out);
        } else if tether_testkit::is_jpeg(&p) {
            out.push(p);
        }
    }
}

/// Runs a Python snippet; panics with its stderr if it fails.
fn python(script: &str, args: &[&Path]) {
    let mut all = vec![OsStr::new("-c"), OsStr::new(script)];
    all.extend(args.iter().map(|p| p.as_os_str()));
    tether_testkit::python(&all);
}

/// OpenCV writes variants of each source image into `dir`.
const WRITE_VARIANTS: &str = r#"
import sys, cv2
dir = sys.argv[1]
for src in sys.argv[2:]:
    img = cv2.imread(src)
    stem = src.rsplit('/', 1)[-1].rsplit('.', 1)[0]
    crop = img[: img.shape[0] - 3, : img.shape[1] - 5]
    grey = cv2.cvtColor(crop, cv2.COLOR_BGR2GRAY)
    S = cv2.IMWRITE_JPEG_SAMPLING_FACTOR
    variants = {
        'q10': (crop, [cv2.IMWRITE_JPEG_QUALITY, 10]),
        'q100': (crop, [cv2.IMWRITE_JPEG_QUALITY, 100]),
        'progressive': (crop, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
        'progressive_rst7': (crop, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1, cv2.IMWRITE_JPEG_RST_INTERVAL, 7]),
        'rst1': (crop, [cv2.IMWRITE_JPEG_RST_INTERVAL, 1]),
        'rst13': (crop, [cv2.IMWRITE_JPEG_RST_INTERVAL, 13]),
        'optimized': (crop, [cv2.IMWRITE_JPEG_OPTIMIZE, 1]),
        'grey': (grey, []),
        'grey_progressive': (grey, [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
        's411': (crop, [S, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_411]),
        's420_progressive': (crop, [S, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420, cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
        's422': (crop, [S, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_422]),
        's440_progressive': (crop, [S, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_440, cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),
        's444': (crop, [S, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444]),
    }
    for name, (im, params) in variants.items():
        assert cv2.imwrite(f'{dir}/{stem}_{name}.jpg', im, params)
"#;

/// OpenCV's decode of the k-th file into the output folder (the first argument):
/// `k.cv` (raw grey, EXIF orientation applied) and `k.cvsize` ("width height"), or
/// nothing when imread returns None. Nothing is written beside the inputs.
const DECODE: &str = r#"
import sys, cv2
out = sys.argv[1]
for k, p in enumerate(sys.argv[2:]):
    g = cv2.imread(p, cv2.IMREAD_GRAYSCALE)
    if g is not None:
        open(f'{out}/{k}.cv', 'wb').write(g.tobytes())
        open(f'{out}/{k}.cvsize', 'w').write(f'{g.shape[1]} {g.shape[0]}')
"#;

/// Arithmetic-coded copies of `sources` written by `jpegtran` into `dir`, or why there
/// are none.
fn arithmetic_copies(sources: &[PathBuf], dir: &Path) -> Result<Vec<PathBuf>, String> {
    let kinds: [(&str, &[&str]); 3] = [
        ("arith", &["-arithmetic"]),
        (
            "arith_progressive_rst2",
            &["-arithmetic", "-progressive", "-restart", "2"],
        ),
        ("arith_grey", &["-arithmetic", "-grayscale"]),
    ];
    let mut out = Vec::new();
    for src in sources {
        let stem = src
            .file_stem()
            .expect("name")
            .to_string_lossy()
            .into_owned();
        for (kind, flags) in kinds {
            let p = dir.join(format!("{stem}_{kind}.jpg"));
            let run = Command::new("jpegtran")
                .args(flags)
                .args(["-outfile".as_ref(), p.as_os_str(), src.as_os_str()])
                .output()
                .map_err(|e| {
                    format!("jpegtran cannot run ({e}); apt-get install libjpeg-turbo-progs")
                })?;
            if !run.status.success() {
                return Err(format!(
                    "jpegtran failed on {}: {}",
                    src.display(),
                    String::from_utf8_lossy(&run.stderr)
                ));
            }
            out.push(p);
        }
    }
    Ok(out)
}

/// A seeded xorshift generator.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Damaged copies of `src` in `dir`: cut at seeded places, and with seeded byte changes
/// (never to 0xFF; see the module documentation).
fn damage(src: &Path, dir: &Path, seed: u64, out: &mut Vec<PathBuf>) {
    let data = std::fs::read(src).expect("variant");
    let stem = src
        .file_stem()
        .expect("name")
        .to_string_lossy()
        .into_owned();
    let mut rng = Rng(seed | 1);
    for k in 0..6 {
        let cut = 200 + rng.below(data.len() - 200);
        let p = dir.join(format!("{stem}_cut{k}.jpg"));
        std::fs::write(&p, &data[..cut]).expect("write");
        out.push(p);
    }
    for k in 0..10 {
        let mut d = data.clone();
        for _ in 0..1 + rng.below(4) {
            // Mostly in the entropy-coded data, sometimes anywhere.
            let p = if k % 4 == 0 {
                2 + rng.below(d.len() - 2)
            } else {
                d.len() / 4 + rng.below(d.len() * 3 / 4)
            };
            d[p] = rng.below(255) as u8;
        }
        let p = dir.join(format!("{stem}_bytes{k}.jpg"));
        std::fs::write(&p, &d).expect("write");
        out.push(p);
    }
}

#[test]
fn jpeg_gray_equals_opencv() {
    let prerequisite = tether_testkit::shared_missing(&["data/images"])
        .and_then(|()| tether_testkit::python_cv2().map(|_| ()));
    if tether_testkit::or_skip(prerequisite).is_none() {
        return;
    }
    let shared = tether_testkit::shared_dir();

    let mut originals = Vec::new();
    jpegs_under(&shared.join("data/images"), &mut originals);
    let mut frames = Vec::new();
    jpegs_under(&shared.join("data/vtest/frames"), &mut frames);
    let frames: Vec<PathBuf> = frames.into_iter().step_by(10).collect();
    assert!(!originals.is_empty(), "no JPEG under data/images");

    let tmp = tether_testkit::scratch("jpeg-parity");
    let sources: Vec<&Path> = originals
        .iter()
        .filter(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            matches!(name.as_deref(), Some("messi5.jpg" | "fruits.jpg"))
        })
        .map(PathBuf::as_path)
        .collect();
    let mut args = vec![tmp.as_path()];
    args.extend(&sources);
    python(WRITE_VARIANTS, &args);
    let mut variants = Vec::new();
    jpegs_under(&tmp, &mut variants);
    let mut damaged = Vec::new();
    for (i, v) in variants.iter().enumerate() {
        let name = v
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if [
            "progressive",
            "rst13",
            "s411",
            "grey_progressive",
            "s440_progressive",
        ]
        .iter()
        .any(|k| name.ends_with(&format!("_{k}.jpg")))
        {
            damage(v, &tmp, 0x9e37_79b9 + i as u64, &mut damaged);
        }
    }

    let arith_dir = tmp.join("arithmetic");
    std::fs::create_dir_all(&arith_dir).expect("temporary folder");
    let arithmetic = match arithmetic_copies(&originals, &arith_dir) {
        Ok(files) => files,
        Err(why) => {
            assert!(
                !tether_testkit::required(),
                "{why}; TETHER_REQUIRE_SHARED=1 demands the arithmetic-coded files"
            );
            println!("arithmetic-coded files SKIPPED: {why}");
            Vec::new()
        }
    };
    let mut damaged_arithmetic = Vec::new();
    for (i, v) in arithmetic.iter().enumerate() {
        let name = v
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if name.starts_with("messi5_") || name.starts_with("fruits_") {
            damage(v, &tmp, 0x7f4a_7c15 + i as u64, &mut damaged_arithmetic);
        }
    }

    let groups = [
        ("shared images", originals),
        ("vtest frames (every 10th)", frames),
        ("written by OpenCV now", variants),
        ("damaged copies", damaged),
        ("arithmetic-coded by jpegtran", arithmetic),
        ("damaged arithmetic-coded copies", damaged_arithmetic),
    ];
    let decoded = tmp.join("opencv");
    std::fs::create_dir_all(&decoded).expect("temporary folder");
    let mut args = vec![decoded.as_path()];
    args.extend(
        groups
            .iter()
            .flat_map(|(_, files)| files.iter().map(PathBuf::as_path)),
    );
    python(DECODE, &args);

    let mut failures = Vec::new();
    let mut index = 0usize;
    for (group, files) in &groups {
        let (mut pixels, mut differing, mut refused) = (0usize, 0usize, 0usize);
        for file in files {
            let name = file.display().to_string();
            let k = index;
            index += 1;
            let cv = std::fs::read(decoded.join(format!("{k}.cv"))).ok();
            let ours = imread_gray(file);
            match (cv, ours) {
                (None, Err(_)) => refused += 1,
                (None, Ok(_)) => {
                    failures.push(format!("{name}: OpenCV returns None, tether decodes"))
                }
                (Some(_), Err(e)) => {
                    failures.push(format!("{name}: OpenCV decodes, tether fails: {e}"))
                }
                (Some(theirs), Ok(ours)) => {
                    let size = std::fs::read_to_string(decoded.join(format!("{k}.cvsize")))
                        .unwrap_or_default();
                    let ours_size = format!("{} {}", ours.width(), ours.height());
                    if size != ours_size {
                        failures.push(format!("{name}: OpenCV {size}, tether {ours_size}"));
                        continue;
                    }
                    let n = ours
                        .pixels()
                        .iter()
                        .zip(&theirs)
                        .filter(|(a, b)| a != b)
                        .count();
                    pixels += theirs.len();
                    differing += n;
                    if n > 0 {
                        failures.push(format!("{name}: {n} of {} pixels differ", theirs.len()));
                    }
                }
            }
        }
        println!(
            "{group}: {} files, {pixels} pixels compared, {differing} differ; {refused} refused by both",
            files.len()
        );
    }
    let _ = std::fs::remove_dir_all(&tmp);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
