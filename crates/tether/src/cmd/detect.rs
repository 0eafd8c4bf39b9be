//! `tether detect`: run an OpenCV Haar cascade on images, exactly as OpenCV 4.x's
//! `CascadeClassifier::detectMultiScale` does, and print the boxes as JSON in the layout
//! of `opencv_reference.py` (`images[].boxes` as sorted `[x, y, w, h]`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use serde_json::json;
use tether::args::{DetectOptions, resolve_cascade};
use tether_image::imread::imread_gray_warned;
use tether_vision::{Cascade, Detector};

/// Options of `tether detect`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Cascade XML file (OpenCV's traincascade or haartraining layout). Default:
    /// /usr/share/opencv4/haarcascades/haarcascade_upperbody.xml (Debian's opencv-data).
    #[arg(long, value_name = "FILE")]
    pub cascade: Option<PathBuf>,
    /// The cascade's search settings.
    #[command(flatten)]
    pub search: DetectOptions,
    /// Detection threads (0: one per core); the boxes do not depend on it.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub threads: usize,
    /// Also time this many runs per image and report the mean (`ms_per_run`).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub time_runs: usize,
    /// Go on past an image that cannot be read: it is listed in the JSON with its
    /// `error` (and no boxes), counted on stderr, and the exit status is still 0.
    /// Without it the first such image ends the command with an error naming it.
    #[arg(long)]
    pub keep_going: bool,
    /// Also write each image with its boxes drawn (red, 2 px) as `DIR/NAME.png`.
    #[arg(long, value_name = "DIR")]
    pub draw: Option<PathBuf>,
    /// PNG or JPEG images, read as 8-bit grey like cv2.imread(path, IMREAD_GRAYSCALE).
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
}

/// `image` in RGB with each box outlined in red, 2 px wide, as PNG bytes.
pub fn drawn(
    image: &tether_core::GrayImage,
    boxes: &[tether_vision::Rect],
) -> std::io::Result<Vec<u8>> {
    let (w, h) = (image.width(), image.height());
    let mut rgb: Vec<u8> = image.pixels().iter().flat_map(|&g| [g, g, g]).collect();
    let mut paint = |x: i64, y: i64| {
        if (0..w as i64).contains(&x) && (0..h as i64).contains(&y) {
            let at = 3 * (y as usize * w + x as usize);
            rgb[at..at + 3].copy_from_slice(&[230, 20, 20]);
        }
    };
    for b in boxes {
        let (x0, y0) = (i64::from(b.x), i64::from(b.y));
        let (x1, y1) = (x0 + i64::from(b.width) - 1, y0 + i64::from(b.height) - 1);
        for t in 0..2 {
            for x in x0..=x1 {
                paint(x, y0 + t);
                paint(x, y1 - t);
            }
            for y in y0..=y1 {
                paint(x0 + t, y);
                paint(x1 - t, y);
            }
        }
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w as u32, h as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder
        .write_header()
        .and_then(|mut writer| writer.write_image_data(&rgb))
        .map_err(std::io::Error::other)?;
    Ok(out)
}

/// Runs the detector on every image and prints the JSON report.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cascade_path = resolve_cascade(args.cascade.as_deref())?;
    let cascade = Cascade::load(&cascade_path)?;
    let params = args.search.params()?;
    let detector = Detector::new(cascade).with_threads(args.threads)?;
    let mut images = Vec::with_capacity(args.images.len());
    let mut unreadable = 0_usize;
    for path in &args.images {
        let (image, damage) = match imread_gray_warned(path) {
            Ok(read) => read,
            Err(e) if args.keep_going => {
                let e = anyhow::Error::new(e);
                tracing::warn!("{}: {e:#}; skipped (--keep-going)", path.display());
                unreadable += 1;
                images.push(json!({
                    "path": path.display().to_string(),
                    "error": format!("{e:#}"),
                    "boxes": [],
                }));
                continue;
            }
            Err(e) => {
                return Err(anyhow::Error::new(e).context(format!(
                    "{} cannot be read (--keep-going skips such images and goes on)",
                    path.display()
                )));
            }
        };
        // A damaged JPEG decodes anyway, as with OpenCV (grey past a cut): said, and
        // kept in the report.
        for w in &damage {
            tracing::warn!("{}: {w}; decoded anyway, as OpenCV does", path.display());
        }
        let mut boxes = detector
            .detect(&image, &params)
            .with_context(|| format!("detecting in {}", path.display()))?;
        boxes.sort();
        let ms_per_run = if args.time_runs > 0 {
            let start = Instant::now();
            for _ in 0..args.time_runs {
                detector.detect(&image, &params)?;
            }
            Some(start.elapsed().as_secs_f64() * 1e3 / args.time_runs as f64)
        } else {
            None
        };
        tracing::debug!("{}: {} boxes", path.display(), boxes.len());
        if let Some(dir) = &args.draw {
            let name = path
                .file_stem()
                .map_or_else(|| "image".to_string(), |s| s.to_string_lossy().into_owned());
            let out = dir.join(format!("{name}.png"));
            std::fs::create_dir_all(dir)
                .and_then(|()| std::fs::write(&out, drawn(&image, &boxes)?))
                .with_context(|| format!("writing {}", out.display()))?;
        }
        images.push(json!({
            "path": path.display().to_string(),
            "width": image.width(),
            "height": image.height(),
            "boxes": boxes,
            "ms_per_run": ms_per_run,
            "damage": damage,
        }));
    }
    if unreadable > 0 {
        tracing::warn!(
            "{unreadable} of {} images could not be read and have no boxes (their `error` is in the output)",
            args.images.len()
        );
    }
    let report = json!({
        "tether": env!("CARGO_PKG_VERSION"),
        "params": {
            "cascade": cascade_path.display().to_string(),
            "scale_factor": params.scale_factor,
            "min_neighbors": params.min_neighbors,
            "min_size": params.min_size_px,
            "max_size": params.max_size_px,
            "threads": detector.threads(),
        },
        "images": images,
    });
    tether::outln!("{}", serde_json::to_string_pretty(&report)?)?;
    Ok(())
}
