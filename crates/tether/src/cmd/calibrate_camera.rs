//! `tether calibrate camera`: estimate the camera tilt (and the box's head margin) from
//! detections of a person standing at known distances, so that the paper's eq. 1
//! (design 3.2) gives the right range, and report the residuals.
//!
//! The samples are a CSV file with a header, one row per observation, either
//!
//! ```text
//! distance_m,x,y,w,h          # a box you measured or detected yourself, px
//! distance_m,image            # an image; tether detects the person (largest box)
//! ```
//!
//! where `distance_m` is the horizontal distance from the lens to the person. Image
//! paths are relative to the CSV file.

use std::path::{Path, PathBuf};

use anyhow::Context;
use tether_core::{CameraModel, PixelBox};
use tether_image::imread_gray;
use tether_vision::calibrate::{CalibrationSample, calibrate_camera};
use tether_vision::monocular::MonocularParams;
use tether_vision::{Cascade, Detector};

use tether::args::resolve_cascade;

/// Options of `tether calibrate camera`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// CSV of samples: `distance_m,x,y,w,h` or `distance_m,image` rows after a header.
    #[arg(long, value_name = "FILE")]
    pub samples: PathBuf,
    /// Camera model TOML (intrinsics and mounting; its tilt is the unknown). Default:
    /// tether's default camera.
    #[arg(long, value_name = "FILE")]
    pub camera: Option<PathBuf>,
    /// Height of the top of the person's head above the floor, m.
    #[arg(long, default_value_t = 1.70, value_name = "M")]
    pub head_height: f64,
    /// Hold the fraction of the box above the head at this value instead of fitting it.
    #[arg(long, value_name = "FRACTION")]
    pub margin: Option<f64>,
    /// Cascade for image samples (default: Debian's haarcascade_upperbody.xml).
    #[arg(long, value_name = "FILE")]
    pub cascade: Option<PathBuf>,
    /// The cascade's search settings for image samples.
    #[command(flatten)]
    pub search: tether::args::DetectOptions,
}

/// One CSV row before detection.
enum Row {
    Box(f64, PixelBox),
    Image(f64, PathBuf),
}

fn parse_rows(path: &Path) -> anyhow::Result<Vec<Row>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() || (rows.is_empty() && line.starts_with("distance")) {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let number = |s: &str| -> anyhow::Result<f64> {
            s.parse::<f64>()
                .with_context(|| format!("{}:{}: `{s}` is not a number", path.display(), n + 1))
        };
        let distance = number(fields[0])?;
        rows.push(match fields.as_slice() {
            [_, x, y, w, h] => Row::Box(
                distance,
                PixelBox {
                    x: number(x)?,
                    y: number(y)?,
                    w: number(w)?,
                    h: number(h)?,
                },
            ),
            [_, image] => Row::Image(distance, dir.join(image)),
            _ => anyhow::bail!(
                "{}:{}: expected `distance_m,x,y,w,h` or `distance_m,image`, got `{line}`",
                path.display(),
                n + 1
            ),
        });
    }
    Ok(rows)
}

fn load_camera(path: Option<&Path>) -> anyhow::Result<CameraModel> {
    let camera = match path {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read {}", p.display()))?;
            toml::from_str::<CameraModel>(&text)
                .with_context(|| format!("{} is not a camera model", p.display()))?
        }
        None => CameraModel::default(),
    };
    camera.validate()?;
    Ok(camera)
}

/// Fits and prints the calibration.
pub fn run(args: Args) -> anyhow::Result<()> {
    let camera = load_camera(args.camera.as_deref())?;
    let rows = parse_rows(&args.samples)?;
    let params = args.search.params()?;
    let mut detector = None;
    let mut samples = Vec::with_capacity(rows.len());
    for row in rows {
        samples.push(match row {
            Row::Box(distance_m, bbox) => CalibrationSample { distance_m, bbox },
            Row::Image(distance_m, image_path) => {
                if detector.is_none() {
                    let cascade = Cascade::load(resolve_cascade(args.cascade.as_deref())?)?;
                    detector = Some(Detector::new(cascade));
                }
                let det = detector.as_ref().context("detector")?;
                let image = imread_gray(&image_path)?;
                let best = det
                    .detect(&image, &params)?
                    .into_iter()
                    .max_by_key(|r| r.area())
                    .with_context(|| format!("no person found in {}", image_path.display()))?;
                CalibrationSample {
                    distance_m,
                    bbox: best.into(),
                }
            }
        });
    }
    let params = MonocularParams {
        head_height_m: args.head_height,
        margin_frac: args.margin.unwrap_or(0.0),
        ..MonocularParams::default()
    };
    let fit = calibrate_camera(&camera, &params, &samples, args.margin.is_none())?;
    tether::outln!(
        "tilt   {:.3} deg +- {:.3} deg  ({:.5} rad)",
        fit.tilt_rad.to_degrees(),
        fit.tilt_sigma_rad.to_degrees(),
        fit.tilt_rad
    )?;
    if fit.margin_fitted {
        tether::outln!(
            "margin {:.4} +- {:.4} of the box height above the head",
            fit.margin_frac,
            fit.margin_sigma
        )?;
    } else {
        tether::outln!("margin {:.4} (held)", fit.margin_frac)?;
    }
    tether::outln!(
        "{:>10} {:>12} {:>12}",
        "distance_m",
        "predicted_m",
        "residual_m"
    )?;
    for (s, r) in samples.iter().zip(&fit.residuals_m) {
        tether::outln!(
            "{:>10.3} {:>12.3} {:>+12.3}",
            s.distance_m,
            s.distance_m + r,
            r
        )?;
    }
    tether::outln!(
        "rms residual {:.3} m over {} samples",
        fit.rms_m,
        samples.len()
    )?;
    let m = &camera.mount;
    tether::outln!(
        "\nFor the robot's config (tether run, ros2, and track, replay --config): in \
         [camera],\n\nmount = {{ x_m = {}, y_m = {}, yaw_rad = {}, height_m = {}, tilt_rad = {:.6} }}\n\n\
         and paste (the box's margin above the head, {}):\n\n[pipeline.vision]\n\
         box_margin_frac = {:.6}",
        m.x_m,
        m.y_m,
        m.yaw_rad,
        m.height_m,
        fit.tilt_rad,
        if fit.margin_fitted { "fitted" } else { "held" },
        fit.margin_frac
    )?;
    Ok(())
}
